"""The real-data protocol again, trained on a simulated gearbox with the recordings' own tooth counts.

The real-data row of experiments/RESULTS.md trains on the default dataset (29/100 teeth, pitting) and is at
chance on the SpectraQuest recordings; one stated limit was that the real gear's tooth count was unknown, so the
shaft-order sidebands of a local fault sit at other mesh orders. experiments/real_data_pair.py reads the count
from the recordings: a 32/80 stage. Here the simulator makes that stage (``experiments/models_sweeps/
sq_matched*.toml``: 32/80 spur pair near the recordings' speed, damaged on the 32-tooth gear by 25-50 % of one
flank, every unknown of the gearbox drawn), and the same two models as the protocol (the mesh-order CNN,
healthy vs damaged; a logistic regression on the same representation) are trained on it and tested on the
recordings (each channel; 8192-sample records; the records' pair set to 32/80, so no pair mismatch).

Printed: the held-out synthetic accuracy (20 %, stratified: can the models see the simulated damage at all?),
then per channel the accuracy, macro-F1 and the fraction called damaged on the recordings (60 healthy and 55
broken-tooth records: "always healthy" scores 52.2 %). Last line JSON.

Run: ``python experiments/real_data_matched.py [--data-dir DIR]`` (~5 min on 2 cores: generation ~1 min, the
CNN ~2-4 min).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "experiments")]

from classifier_runs import MESH_ORDER, OUT, cnn_run, dataset, log  # noqa: E402
from models.data import PairInfo  # noqa: E402
from models.train import stratified_split  # noqa: E402

REAL = ROOT.parent / "shared" / "data" / "spectraquest_gfd"
PAIR = PairInfo("sq-32-80", 32, 80)


def main(argv=None) -> int:
    from sklearn.linear_model import LogisticRegression
    from sklearn.metrics import f1_score

    from models.representations import represent
    from models.unknown_rate import load_unknown_rate_csv

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, default=OUT / "data")
    args = ap.parse_args(argv)
    sim = dataset("sq_matched", args.data_dir).as_binary()
    files = sorted(REAL.glob("*30hz*.csv"))
    tests = {ch: dataclasses.replace(load_unknown_rate_csv(files, channel=ch, record_samples=8192), pair=PAIR)
             for ch in ("a1", "a2", "a3", "a4")}
    y_sim = (sim.labels["severity_class"].astype(str) != "healthy").to_numpy().astype(int)
    tr, te = stratified_split(y_sim, 0.2, 0)
    log(f"synthetic: {len(sim)} records ({y_sim.sum()} damaged); real: {len(tests['a1'])} records per channel")

    where = OUT / "real_matched"
    cnn = cnn_run(sim.subset(tr), {"synthetic_test": sim.subset(te), **tests}, "mesh_order", where / "cnn",
                  task="binary")

    def rep(d):
        return represent(d.signals, MESH_ORDER, fs_hz=d.fs_hz, mesh_cps=d.mesh_cps(), starts=0.5).reshape(len(d), -1)

    x_sim = rep(sim)
    lr = LogisticRegression(C=0.1, max_iter=5000).fit(x_sim[tr], y_sim[tr])
    res = {"n_synthetic": len(sim), "cnn": {}, "logreg": {}}
    res["logreg"]["synthetic_test"] = {"accuracy": float(np.mean(lr.predict(x_sim[te]) == y_sim[te]))}
    res["cnn"]["synthetic_test"] = {"accuracy": cnn["synthetic_test"]["accuracy"]}
    print(f"\nheld-out synthetic: CNN {100 * cnn['synthetic_test']['accuracy']:.1f} %, logreg "
          f"{100 * res['logreg']['synthetic_test']['accuracy']:.1f} %\n")
    print("| channel | CNN acc. % | CNN macro-F1 % | CNN called damaged % | logreg acc. % | logreg macro-F1 % | "
          "logreg called damaged % |")
    print("|---|---|---|---|---|---|---|")
    for ch, d in tests.items():
        y = (d.labels["severity_class"] != "healthy").to_numpy().astype(int)
        conf = np.asarray(json.loads((where / "cnn" / ch / "metrics.json").read_text())["severity_class"]["confusion"])
        called = float(conf[:, 1].sum() / conf.sum())
        p = lr.predict(rep(d))
        res["cnn"][ch] = {"accuracy": cnn[ch]["accuracy"], "macro_f1": cnn[ch]["macro_f1"], "called_damaged": called}
        res["logreg"][ch] = {"accuracy": float(np.mean(p == y)), "macro_f1": float(f1_score(y, p, average="macro")),
                             "called_damaged": float(p.mean())}
        c, g = res["cnn"][ch], res["logreg"][ch]
        print(f"| {ch} | {100 * c['accuracy']:.1f} | {100 * c['macro_f1']:.1f} | {100 * c['called_damaged']:.1f} | "
              f"{100 * g['accuracy']:.1f} | {100 * g['macro_f1']:.1f} | {100 * g['called_damaged']:.1f} |")
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
