"""``gearpit simulate``: run one case file -> signals (CSV + NPZ with metadata), optional PNG.

The files of a run are written together (:func:`gearpit.atomic.atomic_set`):
into a hidden folder first, renamed into place only once all are written, and
an earlier ``STEM.png`` that this run does not redraw (no ``--png``) is removed
with them, so ``--out`` never mixes two runs. Stopped (Ctrl-C, SIGTERM), the run
leaves the folder as it was; the temporaries of a killed run (SIGKILL) are
removed by the next run of the same case into the same folder.

A record that is no physical gear pair's (a mesh that pulls without a
contact-loss law, an unconverged solution, a load beyond the teeth's strength:
:mod:`datagen.plausibility`) is still written, with one warning per finding on
stderr and in the JSON's ``warnings``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gearpit.atomic import atomic_set, remove_leftovers


def register(sub) -> None:
    p = sub.add_parser("simulate", help="simulate a case file (CSV, NPZ, optional PNG)", description=__doc__)
    p.add_argument("case", type=Path, help="case TOML (see datagen.simulate)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    p.add_argument("--png", action="store_true", help="also draw time signal, spectrum and envelope spectrum")
    p.add_argument("--channel", default="acc_pinion_loa_m_s2", help="channel drawn in the PNG")
    p.add_argument("--channels", default=None, metavar="NAME[,NAME...]",
                   help="write only these channels (only they are made and decimated; default: all)")
    p.add_argument("--plugin", type=Path, action="append", default=[],
                   help="Python file registering user effects (repeatable)")
    p.add_argument("--effect", action="append", default=[], metavar="NAME:KEY=VALUE,...",
                   help="add an effect (repeatable), e.g. noise:snr_db=30")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from datagen.effects import EffectSpec, load_plugin
    from datagen.simulate import Case, simulate
    from gearpit.errors import InputError

    for plugin in args.plugin:
        load_plugin(plugin)
    case = Case.from_toml(args.case)          # validates everything before any work
    if args.effect:
        from dataclasses import replace

        case = replace(case, effects=case.effects + tuple(EffectSpec.from_string(e) for e in args.effect))
    wanted = None
    if args.channels is not None:
        wanted = [c.strip() for c in args.channels.split(",") if c.strip()]
        if not wanted:
            raise InputError("--channels", args.channels, "one or more channel names separated by commas")
        for c in wanted:
            if c not in _channels(case):
                raise InputError("--channels", c, f"one of: {', '.join(_channels(case))}")
    if args.png and args.channel not in (wanted or _channels(case)):
        raise InputError("--channel", args.channel, f"one of: {', '.join(wanted or _channels(case))}")
    sig = simulate([case], channels=wanted)[0]
    if wanted is not None:          # what the output hooks read besides (a bearing force under a housing path) is dropped
        from dataclasses import replace as _replace

        sig = _replace(sig, channels={c: sig.channels[c] for c in wanted})
    args.out.mkdir(parents=True, exist_ok=True)
    stem = args.case.stem
    files = {ext: args.out / f"{stem}.{ext}" for ext in ("csv", "npz", "json", "png")}
    remove_leftovers(files.values())
    written = [files[e] for e in ("csv", "npz", "json")] + ([files["png"]] if args.png else [])
    stale = [] if args.png else [files["png"]]
    with atomic_set(written, stale=stale) as tmp:
        sig.save_csv(tmp[files["csv"]])
        sig.save_npz(tmp[files["npz"]])
        tmp[files["json"]].write_text(json.dumps(sig.metadata, indent=2))
        if args.png:
            from datagen.signals_plot import plot_signals

            plot_signals(sig, tmp[files["png"]], channel=args.channel, title=f"{stem}: {args.channel}")
    print(f"wrote {args.out / stem}.{{csv,npz,json{',png' if args.png else ''}}}: "
          f"{sig.n_samples} samples at {sig.fs_hz:g} Hz, {len(sig.channels)} channels")
    for w in sig.metadata["warnings"]:       # also in the JSON and the NPZ metadata ("warnings")
        print(f"gearpit simulate: warning: {w['message']} [{w['code']}]", file=sys.stderr)
    return 0


def _channels(case) -> list[str]:
    from datagen.output_channels import channel_names

    names = channel_names(8 if case.pair.is_helical else 6)
    return [c for c in names if not c.startswith("_")] + ["tacho_pinion", "tacho_wheel"]
