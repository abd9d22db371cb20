"""Does a higher sampling rate lift the accelerometer's severity accuracy? The in-domain protocol's ``tsa_op`` CNN
on the default dataset made at another sampling rate.

experiments/RESULTS.md ("Why one rig still stops near 90 %") puts the accelerometer's severity ceiling on the
pit's dip being short (0.1-1 ms) against the 12.8 kHz records and the 2-5 kHz housing mode, and names "a
representation that resolves the dip's duration at higher sampling rates" as an untried way out. This script
regenerates ``experiments/models_sweeps/default*.toml`` with only ``fs_hz`` changed (and only the accelerometer
stored; its noise is drawn first, so at 12.8 kHz the records are the protocol's bytes), splits it as the protocol
does (70/30, stratified, split seed 0), trains ``tsa_op`` (training seed 0) with the TSA on ``--samples-per-rev``
points per revolution and prints the held-out severity and teeth accuracy.

Run: ``python experiments/sampling_rate_check.py --fs 25600 --samples-per-rev 1024 2048`` (generation ~1.5 min
with 2 workers, each CNN 4-5 min on an idle core). The last line is JSON. Datasets and reports go under
``experiments/out/models/sampling_rate/``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import classifier_runs as cr  # noqa: E402  (experiments/classifier_runs.py)

OUT = ROOT / "experiments" / "out" / "models" / "sampling_rate"


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fs", type=float, default=25600.0, help="sampling rate of the regenerated dataset, Hz")
    ap.add_argument("--samples-per-rev", type=int, nargs="+", default=[1024, 2048],
                    help="TSA points per pinion revolution (the protocol uses 1024)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    from gearpit.errors import require
    from models.representation_spec import RepresentationSpec

    require(4000.0 <= args.fs <= 200000.0, "--fs", args.fs, "4000-200000 Hz")
    for n in args.samples_per_rev:
        require(64 <= n <= 16384, "--samples-per-rev", n, "64-16384")
    data_dir = OUT / f"fs{int(args.fs)}"
    cr.OUT = OUT
    train, test = cr.edited_default_split(
        data_dir, lambda doc: {**doc, "sweep": dict(doc["sweep"], fs_hz=args.fs)}, args.workers, f"{args.fs:g} Hz")
    rows = {}
    for n in args.samples_per_rev:
        variants = {"tsa_op": (RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=n), cr.OPERATING)}
        r = cr.cnn_run(train, {"test": test}, "tsa_op", data_dir / f"tsa_op_{n}", variants=variants)
        rows[n] = {"severity_accuracy": r["test"]["accuracy"], "teeth_accuracy": r["test"]["teeth_accuracy"],
                   "severity_mae": r["test"]["severity_mae"], "epochs": r["epochs"], "train_seconds": r["train_seconds"]}
    print("\n| fs (Hz) | TSA points per revolution | severity acc. % | teeth acc. % | epochs | training (s) |")
    print("|---|---|---|---|---|---|")
    for n, r in rows.items():
        print(f"| {args.fs:g} | {n} | {100 * r['severity_accuracy']:.1f} | {100 * r['teeth_accuracy']:.1f} | "
              f"{r['epochs']} | {r['train_seconds']:.0f} |")
    out = {"fs_hz": args.fs, "n_train": len(train), "n_test": len(test), "runs": rows}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
