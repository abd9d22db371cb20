"""``gearpit stiffness``: mesh stiffness of a preset or TOML pair, healthy or pitted -> CSV, PNG, JSON."""
from __future__ import annotations

import argparse
import dataclasses
import hashlib
import inspect
import json
import sys
from pathlib import Path

import numpy as np

from datagen.geometry import PRESETS, preset
from datagen.pair_file import load_pair
from datagen.pit_stiffness import PIT_MODELS
from datagen.pitshapes import require_depth
from datagen.stiffness import mesh_stiffness, resolve_n_slices
from datagen.stiffness_limits import require_n_slices, require_record_fits
from gearpit.atomic import atomic_path
from gearpit.errors import InputError, require
from gearpit.tomlio import check_keys, read_toml


def register(sub) -> None:
    p = sub.add_parser("stiffness", help="time-varying mesh stiffness over a revolution (CSV, PNG, JSON)",
                       description=__doc__)
    src = p.add_mutually_exclusive_group()
    src.add_argument("--preset", default="spur-gds",
                     help=f"preset pair (default spur-gds): {', '.join(sorted(PRESETS))}")
    src.add_argument("--pair", type=Path, help="gear pair TOML ([pair] table, units in key names)")
    p.add_argument("--pits", type=Path, help="TOML with a [pits] table (shape, teeth, severity, depth_mm, seed)")
    p.add_argument("--mask", type=Path, help="pit mask PNG of one tooth (painted: white = pit, or 16-bit depth in um)")
    p.add_argument("--photo", type=Path,
                   help="photo of one flank, the pit mask is extracted from it: rows along the profile (start of "
                        "active profile at the top, tip at the bottom), columns across the face width; crop and turn "
                        "it with --photo-crop / --photo-rot90")
    p.add_argument("--photo-crop", default="none",
                   help="the flank's region in the photo: none (the whole photo), auto (the bright flank's bounding "
                        "box) or top,bottom,left,right in photo pixels (half-open)")
    p.add_argument("--photo-rot90", type=int, default=0,
                   help="quarter turns counter-clockwise after cropping (1 for a photo taken with the face vertical)")
    p.add_argument("--photo-any-aspect", action="store_true",
                   help="accept a photo whose height/width is far from the flank's (refused by default: a photo "
                        "turned a quarter)")
    p.add_argument("--tooth", type=int, default=None, help="tooth that --mask/--photo applies to (default 0)")
    p.add_argument("--depth-mm", type=float, default=None,
                   help="pit depth for --photo / binary --mask (mm, 0.001 .. 5; default 0.2)")
    p.add_argument("--gear", choices=["pinion", "wheel"], default="pinion", help="gear that carries the pits")
    p.add_argument("--grid", default="219x1000", help="flank grid ROWSxCOLS (profile x face), default 219x1000")
    p.add_argument("--positions-per-cycle", type=int, default=64)
    p.add_argument("--n-slices", type=int, default=None)
    p.add_argument("--pit-model", choices=PIT_MODELS, default="no_contact")
    p.add_argument("--out", type=Path, default=Path("gearpit_out/stiffness"), help="output directory")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.set_defaults(func=run)


def parse_grid(text: str) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise InputError("--grid", text, "ROWSxCOLS with two integers, e.g. 219x1000") from None
    require(rows >= 2 and cols >= 2, "--grid", text, "at least 2x2 pixels")
    return rows, cols


#: the pit map of a pitted run, written beside summary.json (datagen.pitio NPZ)
PIT_MAP_FILE = "pits.npz"
#: pit depth of a --photo or binary --mask pit map when --depth-mm is not given (mm)
DEFAULT_DEPTH_MM = 0.2


def file_sha256(path: Path) -> str:
    """SHA-256 (hex) of a file's bytes, so that a summary names exactly the input it was computed from."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def photo_options() -> dict:
    """The extraction options ``--photo`` uses: every keyword of :func:`datagen.photo.pit_map_from_image` the
    command does not set itself, at its default (passed explicitly, so the summary records what ran)."""
    from datagen.photo import pit_map_from_image

    own = {"gear", "tooth", "depth_m", "crop", "rot90", "check_aspect"}
    return {name: prm.default for name, prm in inspect.signature(pit_map_from_image).parameters.items()
            if prm.kind is inspect.Parameter.KEYWORD_ONLY and name not in own}


def parse_photo_crop(text: str):
    """``--photo-crop``: None (``none``), ``"auto"``, or (top, bottom, left, right) photo pixels."""
    t = str(text).strip().lower()
    if t in ("none", ""):
        return None
    if t == "auto":
        return "auto"
    parts = t.split(",")
    ok = len(parts) == 4 and all(p.strip().isdigit() for p in parts)
    require(ok, "--photo-crop", text, "none, auto, or top,bottom,left,right in photo pixels (integers >= 0)")
    top, bottom, left, right = (int(p) for p in parts)
    require(bottom > top and right > left, "--photo-crop", text, "bottom > top and right > left")
    return (top, bottom, left, right)


def build_pits(args, pair):
    """The pit map the arguments describe (None for a healthy pair) and its provenance (what summary.json
    records to rebuild it: the source file, its SHA-256 and its contents or the options used); validates
    everything first."""
    given = [a for a in ("pits", "mask", "photo") if getattr(args, a) is not None]
    require(len(given) <= 1, "--pits/--mask/--photo", given, "at most one pit source")
    for flag, value, default in (("--photo-crop", args.photo_crop, "none"), ("--photo-rot90", args.photo_rot90, 0),
                                 ("--photo-any-aspect", args.photo_any_aspect, False)):
        require(value == default or given[:1] == ["photo"], flag, value, "only with --photo")
    for flag, value in (("--tooth", args.tooth), ("--depth-mm", args.depth_mm)):
        require(value is None or given[:1] in (["mask"], ["photo"]), flag, value,
                "only with --mask or --photo (a --pits file states its own teeth and depth_mm)")
    args.tooth = 0 if args.tooth is None else args.tooth
    args.depth_mm = DEFAULT_DEPTH_MM if args.depth_mm is None else args.depth_mm
    if not given:
        return None, None
    rows, cols = parse_grid(args.grid)
    grid = pair.flank_grid(args.gear, rows, cols)
    require(0 <= args.tooth < pair._gear(args.gear).teeth, "--tooth", args.tooth,
            f"a tooth index in [0, {pair._gear(args.gear).teeth - 1}]")
    require_depth("--depth-mm", args.depth_mm, "mm")
    source = getattr(args, given[0])
    prov = {"source": given[0], "file": str(source), "gear": args.gear, "grid": f"{rows}x{cols}"}
    if args.pits is not None:
        from datagen.pits import PitSpec

        doc = read_toml(args.pits)
        check_keys(doc, {"pits"}, "", required={"pits"})
        spec = PitSpec.from_dict(doc["pits"])
        prov.update(sha256=file_sha256(args.pits), table=doc["pits"], spec=dataclasses.asdict(spec))
        return spec.build(grid, args.gear), prov
    prov.update(tooth=args.tooth, depth_mm=args.depth_mm)
    if args.mask is not None:
        from datagen.pitio import load_mask_png

        pits = load_mask_png(args.mask, grid, gear=args.gear, tooth=args.tooth, depth_m=args.depth_mm * 1e-3)
        prov.update(sha256=file_sha256(args.mask))
        return pits, prov
    from datagen.photo import pit_map_from_image

    options = {"crop": parse_photo_crop(args.photo_crop), "rot90": args.photo_rot90,
               "check_aspect": not args.photo_any_aspect, **photo_options()}
    import warnings

    from datagen.photo import PhotoWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PhotoWarning)
        pits = pit_map_from_image(args.photo, grid, gear=args.gear, tooth=args.tooth, depth_m=args.depth_mm * 1e-3,
                                  **options)
    said = [str(w.message) for w in caught if issubclass(w.category, PhotoWarning)]
    for text in said:                       # one line each, as every other warning of the CLI
        print(f"warning: {text}", file=sys.stderr)
    prov.update(sha256=file_sha256(args.photo), extraction=options, warnings=said)
    return pits, prov


def write_stiffness_csv(ms, path: Path) -> None:
    cols = [np.degrees(ms.angle_rad), ms.x_cycles, ms.k_n_per_m]
    head = ["pinion_angle_deg", "mesh_position_cycles", "k_total_n_per_m"]
    for s in range(ms.n_slots):
        cols += [ms.k_slots_n_per_m[:, s], ms.engagement[:, s]]
        head += [f"k_slot{s}_n_per_m", f"engagement_slot{s}"]
    with atomic_path(path) as tmp:
        np.savetxt(tmp, np.column_stack(cols), delimiter=",", header=",".join(head), comments="", fmt="%.9g")


def run(args: argparse.Namespace) -> int:
    pair = load_pair(args.pair) if args.pair else preset(args.preset)
    if args.n_slices is not None:
        require_n_slices(pair, args.n_slices, "--n-slices")
    pits, provenance = build_pits(args, pair)
    require(args.positions_per_cycle >= 4, "--positions-per-cycle", args.positions_per_cycle, "an integer >= 4")
    n_slices = resolve_n_slices(pair, () if pits is None else (pits,), args.n_slices)
    require_record_fits(pair, args.positions_per_cycle, n_slices,
                        None if pits is None else {pits.gear: len(pits.pitted_teeth)}, "--positions-per-cycle",
                        records=1 if pits is None else 2)    # a pitted record is drawn beside the healthy one
    ms = mesh_stiffness(pair, pits=pits, positions_per_cycle=args.positions_per_cycle, n_slices=args.n_slices,
                        pit_model=args.pit_model)
    from datagen.stiffness_plot import plot_stiffness

    args.out.mkdir(parents=True, exist_ok=True)
    write_stiffness_csv(ms, args.out / "stiffness.csv")
    curves = {"pitted" if pits is not None else "healthy": ms}
    if pits is not None:
        curves = {"healthy": mesh_stiffness(pair, positions_per_cycle=args.positions_per_cycle,
                                            n_slices=ms.n_slices), **curves}
    with atomic_path(args.out / "stiffness.png") as tmp:
        plot_stiffness(curves, tmp, title=f"{pair.name}: mesh stiffness over one revolution")
    summary = ms.summary()
    if pits is not None:
        from datagen.pitio import save_npz

        summary["severity_by_tooth"] = {str(t): s for t, s in pits.severities().items()}
        save_npz(pits, args.out / PIT_MAP_FILE)   # the map itself (a photo's mask), read back with load_npz
        summary["pits"] = {**provenance, "pit_map_file": PIT_MAP_FILE}
    with atomic_path(args.out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2, default=str))   # default: a TOML date, shown as text
    if args.json:
        print(json.dumps(summary, default=str))
    return 0
