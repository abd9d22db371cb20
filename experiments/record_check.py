"""Does the simulator's mesh record change what the classifiers learn? The default dataset of the classifiers
(``experiments/models_sweeps/default*.toml``) made twice, on the former record (64 point-sampled positions per
mesh cycle, the record of every dataset in experiments/RESULTS.md) and on the current default (positions chosen
by the output band, box edges; README, "Dynamics"), with the same seeds, draws and split; on each the in-domain
protocol of eval_protocol.py for the chosen CNN (``tsa_op``) and the three feature-table baselines.

Run: ``python experiments/record_check.py`` (about 40 min on 2 cores; datasets and feature tables are cached in
``experiments/out/record_check/``). Prints a Markdown table; the last line is JSON.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import classifier_runs as cr  # noqa: E402  (experiments/classifier_runs.py)
from models.train import stratified_split  # noqa: E402

OUT = ROOT / "experiments" / "out" / "record_check"
#: the two records: name -> [stiffness] table of the sweep
RECORDS = {"former (64 point-sampled)": {"positions_per_cycle": 64, "edges": "point"},
           "band (default)": {"positions_per_cycle": "auto", "edges": "box"}}


def _slug(record: str) -> str:
    return record.split()[0]


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=1, help="processes for the feature tables")
    ap.add_argument("--variant", default="tsa_op", help="the CNN variant (experiments/classifier_runs.VARIANTS)")
    args = ap.parse_args(argv)
    cr.OUT = OUT            # the runs' reports and the feature caches go under OUT
    t0 = time.perf_counter()
    rows = {}
    for record in RECORDS:
        data = cr.dataset("default", OUT / _slug(record), stiffness=RECORDS[record])
        x, names, cfg = cr.features(f"default_{_slug(record)}", data, args.jobs)
        tr, te = stratified_split(cr.strata(data), 0.3, cr.SEED)
        train, test = data.subset(tr), data.subset(te)
        where = OUT / _slug(record) / "in_domain"
        cnn = cr.cnn_run(train, {"test": test}, args.variant, where / f"cnn_{args.variant}")
        base = cr.baseline_runs(train, x[tr], {"test": (test, x[te])}, names, cfg, where)
        rows[record] = {"cnn": cnn["test"], "cnn_epochs": cnn["epochs"], "cnn_seconds": cnn["train_seconds"],
                        "baseline": base["best"], **{k: base[k]["test"] for k in cr.KINDS}}
    print(f"\n| record | CNN ({args.variant}) severity / teeth acc. % | " + " | ".join(
        f"{k} severity / teeth acc. %" for k in cr.KINDS) + " | best baseline (chosen on validation) |")
    print("|---" * (3 + len(cr.KINDS)) + "|")
    for record, r in rows.items():
        cells = [f"{100 * r['cnn']['accuracy']:.1f} / {100 * r['cnn']['teeth_accuracy']:.1f}"]
        cells += [f"{100 * r[k]['accuracy']:.1f} / {100 * r[k]['teeth_accuracy']:.1f}" for k in cr.KINDS]
        print(f"| {record} | " + " | ".join(cells) + f" | {r['baseline']} |")
    out = {"records": rows, "seconds": round(time.perf_counter() - t0, 1)}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
