"""``gearpit generate SWEEP.toml --out DIR``: a labelled dataset from a sweep file (resumable).

The sweep file is checked completely before anything is written. Runs on a
local process pool (``--workers``, default 1), or on a Dask cluster
(``--dask ADDRESS``, or ``--dask-local N`` for a LocalCluster of N workers);
any of them gives the same bytes. Started again on the same ``--out``, a killed
run computes only the missing shards. Stopped by Ctrl-C or SIGTERM, it stops its
workers, keeps the shards written so far and says how many there are (exit 130
or 143). Samples whose simulation is physically implausible
(:mod:`datagen.plausibility`) are kept, flagged in the index column
``simulation_warnings`` and counted in one line at the end. User effects (``--plugin FILE.py``, or
``plugins = [...]`` in the sweep's ``[sweep]`` table) join the registry before the sweep is read, in every worker
too; a plugin file that changed since the run began is refused on resume (the fingerprint holds its contents).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("generate", help="generate a labelled dataset from a sweep TOML (resumable)",
                       description=__doc__)
    p.add_argument("sweep", type=Path, metavar="SWEEP.toml", help="sweep file (see datagen.sweep)")
    p.add_argument("--out", type=Path, required=True, help="dataset directory (created, or resumed)")
    p.add_argument("--workers", type=int, default=1, help="local worker processes (default 1)")
    p.add_argument("--dask", metavar="ADDRESS", default=None, help="run on the Dask scheduler at ADDRESS")
    p.add_argument("--dask-local", metavar="N", type=int, default=None,
                   help="run on a Dask LocalCluster of N single-threaded worker processes")
    p.add_argument("--max-shards", type=int, default=None, help="stop after N shards (resume later)")
    p.add_argument("--plugin", type=Path, action="append", default=[], metavar="FILE.py",
                   help="a user effect file (repeatable), as the sweep's [sweep] plugins list; its effects can be "
                        "[effects.NAME] tables of the sweep; the dataset records each file's sha256")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.set_defaults(func=run)


def run(args) -> int:
    from datagen.generate import generate
    from datagen.sweep import load_sweep
    from gearpit.errors import require

    require(args.max_shards is None or args.max_shards >= 1, "--max-shards", args.max_shards, "an integer >= 1")
    sweep = load_sweep(args.sweep, plugins=tuple(args.plugin))
    try:
        report = generate(sweep, args.out, workers=args.workers, dask_address=args.dask,
                          dask_local_workers=args.dask_local, progress=not args.quiet, max_shards=args.max_shards)
    except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM: what is kept, for the line gearpit.cli prints
        from datagen.dataset import finished_shards

        exc.note = f"{len(finished_shards(args.out))} of {sweep.n_shards} shards written; rerun the same command to resume"
        raise
    summary = {"out": str(report.out), "n_samples": report.n_samples, "n_shards": report.n_shards,
               "computed_shards": report.computed, "skipped_shards": report.skipped,
               "complete": report.computed + report.skipped == report.n_shards, "seconds": round(report.seconds, 3),
               "flagged_samples": report.flagged, "warnings": report.warnings}
    if args.json:
        print(json.dumps(summary))
    else:
        state = "complete" if summary["complete"] else "incomplete (run again to resume)"
        print(f"{report.out}: {report.n_samples} samples in {report.n_shards} shards, {report.computed} computed now, "
              f"{report.skipped} earlier; {state}; {report.seconds:.1f} s")
    if report.flagged:
        from datagen.generate import WARNINGS_COLUMN

        counts = ", ".join(f"{code} {n}" for code, n in report.warnings.items())
        print(f"gearpit generate: warning: {report.flagged} of the {report.computed_samples} samples computed now "
              f"are physically implausible ({counts}); the index column {WARNINGS_COLUMN} names them, and "
              "`gearpit simulate` of such a case says why", file=sys.stderr)
    return 0
