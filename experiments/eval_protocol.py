"""Evaluation protocol of the classifiers (issue 6) -> experiments/RESULTS.md.

Run: ``python experiments/eval_protocol.py`` (about 30-60 min on 2 shared cores, most of it
dataset generation and feature tables, which are cached in ``experiments/out/models/``).

Protocols
---------
1. in-domain: the default dataset (``experiments/models_sweeps/default*.toml``), stratified 70/30
   split; the CNN on every input representation (raw, envelope, tsa, order) and the three
   feature-table baselines; the CNN representation is chosen on the validation split inside
   the training data, the best baseline on an internal 80/20 split of the training data.
   Repeated on the harder, domain-randomised sweep (``randomised*.toml``).
2. cross-condition: the default dataset split by speed (train < 1200 rpm, test >= 1200 rpm) and
   by load (train < 50 N m, test >= 50 N m).
3. cross-physics: trained on ``nopath*.toml`` (no housing transmission path), tested on the
   default test split (with it).
4. real data: healthy vs damaged, trained on the whole default dataset (``mesh_order``
   representation, which needs no sampling rate), tested on the SpectraQuest recordings in
   ../shared/data/spectraquest_gfd (each channel a1..a4, records of 8192 samples); plus a
   real-to-real check (leave one load out) of how separable those recordings are at all.

Every number comes from fixed seeds; every run writes metrics.json/.md and confusion.png under
``experiments/out/models/<protocol>/<run>/``; ``results.json`` collects them.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from models.augment import AugmentConfig  # noqa: E402
from models.baselines import KINDS, feature_config_for, feature_table, fit_baseline  # noqa: E402
from models.data import SignalSet, concat  # noqa: E402
from models.evaluate import evaluate, report_markdown, write_report  # noqa: E402
from models.plots import plot_confusions  # noqa: E402
from models.representations import RepresentationSpec  # noqa: E402
from models.sources import load_dataset  # noqa: E402
from models.train import TrainConfig, stratified_split, train_cnn  # noqa: E402

SWEEPS = ROOT / "experiments" / "models_sweeps"
OUT = ROOT / "experiments" / "out" / "models"
REAL = ROOT.parent / "shared" / "data" / "spectraquest_gfd"
RESULTS_MD = ROOT / "experiments" / "RESULTS.md"
SEED = 0

REPRESENTATIONS = {
    "raw": RepresentationSpec(kind="raw", n_samples=8192),
    "envelope": RepresentationSpec(kind="envelope", n_samples=8192),
    "tsa": RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024),
    "order": RepresentationSpec(kind="order", n_revs=8, max_order=100.0),
}
MESH_ORDER = RepresentationSpec(kind="mesh_order", n_mesh_periods=256, max_order=4.0)


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", flush=True)


# ------------------------------------------------------------------ data


def dataset(name: str, data_dir: Path) -> SignalSet:
    """Damaged + healthy records of sweep ``name`` (generated once, then read)."""
    from datagen.dataset import read_metadata
    from datagen.generate import generate
    from datagen.sweep import load_sweep

    parts = []
    for part in (name, f"{name}_healthy"):
        out = data_dir / part
        meta_ok = (out / "index.parquet").is_file()
        if not meta_ok:
            log(f"generating {part}")
            generate(load_sweep(SWEEPS / f"{part}.toml"), out, progress=False)
        read_metadata(out)
        parts.append(load_dataset(out))
    d = concat(parts)
    return SignalSet(d.signals, d.fs_hz, d.pair, d.labels, source=f"{name} (+{name}_healthy)", channel=d.channel)


def features(name: str, data: SignalSet, jobs: int) -> tuple[np.ndarray, list[str], dict]:
    """Feature table of a dataset (cached as npz next to the data)."""
    cfg = feature_config_for(data)
    cache = OUT / "features" / f"{name}.npz"
    if cache.is_file():
        z = np.load(cache, allow_pickle=False)
        if z["x"].shape[0] == len(data):
            return z["x"], [str(s) for s in z["names"]], cfg
    log(f"feature table of {name} ({len(data)} records)")
    x, names = feature_table(data, cfg, n_jobs=jobs)
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, x=x, names=np.asarray(names))
    return x, names, cfg


def strata(data: SignalSet) -> np.ndarray:
    return (data.labels["severity_class"].astype(str) + "/" + data.teeth_classes().astype(str)).to_numpy()


# ------------------------------------------------------------------ runs


def summary(metrics: dict, extra: dict | None = None) -> dict:
    s = {"accuracy": metrics["severity_class"]["accuracy"], "macro_f1": metrics["severity_class"]["macro_f1"],
         "n_test": metrics["n_records"]}
    if "teeth" in metrics:
        s.update({"teeth_accuracy": metrics["teeth"]["accuracy"], "teeth_macro_f1": metrics["teeth"]["macro_f1"]})
    if "severity_mae" in metrics:
        s["severity_mae"] = metrics["severity_mae"]
    s.update(extra or {})
    return s


def save_run(path: Path, metrics: dict, pred, data: SignalSet, title: str) -> None:
    write_report(metrics, pred, data, path, title=title)
    plot_confusions(metrics, path / "confusion.png")


def cnn_run(train: SignalSet, tests: dict[str, SignalSet], rep: RepresentationSpec, where: Path, *,
            task: str = "multi", augment: AugmentConfig | None = None, allow_mismatch: bool = False) -> dict:
    cfg = TrainConfig(representation=rep, task=task, augment=augment or AugmentConfig(), seed=SEED)
    t0 = time.perf_counter()
    model = train_cnn(train, cfg)
    secs = time.perf_counter() - t0
    tr = model.spec.training
    out = {"train_seconds": round(secs, 1), "epochs": tr["epochs_run"], "val_accuracy": tr["val_accuracy"],
           "val_teeth_accuracy": tr["val_teeth_accuracy"], "n_train": tr["n_train"] + tr["n_val"]}
    for name, test in tests.items():
        pred = model.predict(test, allow_mismatch=allow_mismatch)
        m = evaluate(test, pred)
        save_run(where / name, m, pred, test, f"CNN ({rep.kind}) on {name}")
        out[name] = summary(m)
    log(f"  CNN {rep.kind}: " + ", ".join(f"{k} acc {v['accuracy']:.3f}" for k, v in out.items() if isinstance(v, dict))
        + f" ({secs:.0f} s)")
    return out


def baseline_runs(train: SignalSet, x_train: np.ndarray, tests: dict[str, tuple[SignalSet, np.ndarray]], names, cfg,
                  where: Path, *, select: bool = True) -> dict:
    """All three baselines; ``best`` chosen on an internal 80/20 split of the training data."""
    out: dict = {}
    if select:
        tr, va = stratified_split(strata(train), 0.2, SEED)
        score = {}
        for kind in KINDS:
            m = fit_baseline(train.subset(tr), kind, features=x_train[tr], feature_names=names, feature_config=cfg,
                             seed=SEED)
            mm = evaluate(train.subset(va), m.predict_features(x_train[va]))
            score[kind] = (mm["severity_class"]["accuracy"] + mm["teeth"]["accuracy"]) / 2
        out["best"] = max(score, key=score.get)
        out["selection_scores"] = score
    for kind in KINDS:
        model = fit_baseline(train, kind, features=x_train, feature_names=names, feature_config=cfg, seed=SEED)
        res = {}
        for name, (test, x_test) in tests.items():
            pred = model.predict_features(x_test)
            m = evaluate(test, pred)
            save_run(where / kind / name, m, pred, test, f"{kind} on {name}")
            res[name] = summary(m)
        out[kind] = res
        log(f"  {kind}: " + ", ".join(f"{k} acc {v['accuracy']:.3f}" for k, v in res.items()))
    return out


# ------------------------------------------------------------------ protocols


def in_domain(name: str, data: SignalSet, x: np.ndarray, names, cfg, reps: list[str]) -> dict:
    log(f"in-domain on {name}")
    tr, te = stratified_split(strata(data), 0.3, SEED)
    train, test = data.subset(tr), data.subset(te)
    where = OUT / f"in_domain_{name}"
    res = {"n_train": int(tr.size), "n_test": int(te.size), "cnn": {}}
    for r in reps:
        res["cnn"][r] = cnn_run(train, {"test": test}, REPRESENTATIONS[r], where / f"cnn_{r}")
    res["cnn_choice"] = max(res["cnn"], key=lambda r: res["cnn"][r]["val_accuracy"] + res["cnn"][r]["val_teeth_accuracy"])
    res["baselines"] = baseline_runs(train, x[tr], {"test": (test, x[te])}, names, cfg, where)
    return res


def augmentation_ablation(data: SignalSet, rep: str) -> dict:
    log(f"augmentation ablation ({rep})")
    tr, te = stratified_split(strata(data), 0.3, SEED)
    train, test = data.subset(tr), data.subset(te)
    where = OUT / "augmentation"
    strong = AugmentConfig(noise_probability=0.5, snr_db_range=(5.0, 30.0), speed_error=0.01)
    return {"none": cnn_run(train, {"test": test}, REPRESENTATIONS[rep], where / "none", augment=AugmentConfig.none()),
            "strong": cnn_run(train, {"test": test}, REPRESENTATIONS[rep], where / "strong", augment=strong)}


def cross_condition(data: SignalSet, x: np.ndarray, names, cfg, reps: list[str]) -> dict:
    res = {}
    lab = data.labels
    for split, col, edge, unit in (("speed", "speed_rpm", 1200.0, "rpm"), ("load", "torque_nm", 50.0, "N m")):
        log(f"cross-condition: {split}")
        lo = np.nonzero(lab[col].to_numpy() < edge)[0]
        hi = np.nonzero(lab[col].to_numpy() >= edge)[0]
        train, test = data.subset(lo), data.subset(hi)
        where = OUT / f"cross_{split}"
        r = {"rule": f"train {col} < {edge:g} {unit}, test >= {edge:g} {unit}", "n_train": int(lo.size),
             "n_test": int(hi.size), "cnn": {}}
        for rep in reps:
            r["cnn"][rep] = cnn_run(train, {"test": test}, REPRESENTATIONS[rep], where / f"cnn_{rep}")
        r["baselines"] = baseline_runs(train, x[lo], {"test": (test, x[hi])}, names, cfg, where)
        res[split] = r
    return res


def cross_physics(nopath: SignalSet, x_np: np.ndarray, default: SignalSet, x_d: np.ndarray, names, cfg,
                  reps: list[str]) -> dict:
    log("cross-physics: train without transmission path, test with it")
    _, te = stratified_split(strata(default), 0.3, SEED)
    test = default.subset(te)
    where = OUT / "cross_physics"
    r = {"rule": "train on nopath (no housing transmission path), test on the default test split (with it)",
         "n_train": len(nopath), "n_test": int(te.size), "cnn": {}}
    for rep in reps:
        r["cnn"][rep] = cnn_run(nopath, {"test": test}, REPRESENTATIONS[rep], where / f"cnn_{rep}")
    r["baselines"] = baseline_runs(nopath, x_np, {"test": (test, x_d[te])}, names, cfg, where)
    return r


def real_data(default: SignalSet) -> dict:
    from sklearn.linear_model import LogisticRegression

    from models.representations import represent
    from models.unknown_rate import load_unknown_rate_csv

    log("real data: healthy vs damaged, synthetic -> SpectraQuest")
    files = sorted(REAL.glob("*30hz*.csv"))
    if not files:
        return {"skipped": f"no files in {REAL}"}
    where = OUT / "real"
    tests = {ch: load_unknown_rate_csv(files, channel=ch, record_samples=8192) for ch in ("a1", "a2", "a3", "a4")}
    res = {"files": [f.name for f in files], "n_records_per_channel": len(tests["a1"]),
           "mesh_cps": tests["a1"].labels.groupby("file")["mesh_cps"].first().round(5).to_dict()}
    res["cnn"] = cnn_run(default, tests, MESH_ORDER, where / "cnn_mesh_order", task="binary", allow_mismatch=True)

    # baseline: logistic regression on the same mesh-order representation (the feature table needs fs)
    def rep_of(d: SignalSet) -> np.ndarray:
        return represent(d.signals, MESH_ORDER, fs_hz=d.fs_hz, mesh_cps=d.mesh_cps(), starts=0.5).reshape(len(d), -1)

    xs = rep_of(default)
    ys = (default.labels["severity_class"].astype(str) != "healthy").to_numpy().astype(int)
    lr = LogisticRegression(C=0.1, max_iter=5000).fit(xs, ys)
    res["logreg_mesh_order"] = {}
    res["real_to_real"] = {}
    for ch, d in tests.items():
        xr = rep_of(d)
        yr = (d.labels["severity_class"] != "healthy").to_numpy().astype(int)
        res["logreg_mesh_order"][ch] = {"accuracy": float(np.mean(lr.predict(xr) == yr)),
                                        "predicted_damaged_fraction": float(lr.predict(xr).mean())}
        # how separable are the recordings themselves? leave one load out, logistic regression
        loads = d.labels["load_percent"].to_numpy()
        hits = []
        for ld in np.unique(loads):
            m = loads == ld
            clf = LogisticRegression(C=0.1, max_iter=5000).fit(xr[~m], yr[~m])
            hits.append(clf.predict(xr[m]) == yr[m])
        res["real_to_real"][ch] = float(np.mean(np.concatenate(hits)))
    cnn_pred_frac = {}
    for ch in tests:
        p = json.loads((where / "cnn_mesh_order" / ch / "metrics.json").read_text())
        conf = np.asarray(p["severity_class"]["confusion"])
        cnn_pred_frac[ch] = float(conf[:, 1].sum() / conf.sum())
    res["cnn_predicted_damaged_fraction"] = cnn_pred_frac
    log("  logreg(mesh-order): " + ", ".join(f"{k} {v['accuracy']:.3f}" for k, v in res["logreg_mesh_order"].items()))
    log("  real-to-real: " + ", ".join(f"{k} {v:.3f}" for k, v in res["real_to_real"].items()))
    return res


# ------------------------------------------------------------------ tables


def _pct(v) -> str:
    return "-" if v is None else f"{100 * v:.1f}"


def _row(label: str, s: dict) -> str:
    mae = s.get("severity_mae")
    mae = "-" if mae is None else f"{mae:.3f}"
    return (f"| {label} | {_pct(s.get('accuracy'))} | {_pct(s.get('macro_f1'))} | {_pct(s.get('teeth_accuracy'))} | "
            f"{_pct(s.get('teeth_macro_f1'))} | {mae} |")


HEAD = ("| model | severity acc. % | severity macro-F1 % | teeth acc. % | teeth macro-F1 % | severity MAE |\n"
        "|---|---|---|---|---|---|")


def _protocol_rows(r: dict, choice: str, label: str) -> list[str]:
    b = r["baselines"]
    best = b.get("best") or max(KINDS, key=lambda k: b[k]["test"]["accuracy"])
    return [_row(f"{label}: CNN ({choice})", r["cnn"][choice]["test"]),
            _row(f"{label}: best baseline ({best})", b[best]["test"])]


def results_tables(res: dict) -> str:
    """Markdown tables of ``results.json`` (inserted into RESULTS.md)."""
    out = []
    ind = res.get("in_domain")
    choice = ind["cnn_choice"] if ind else "tsa"
    if ind:
        out += ["### Headline: every protocol, the CNN and the best baseline", "", HEAD]
        out += _protocol_rows(ind, choice, "in-domain (default)")
        if "randomised" in res:
            rr = res["randomised"]
            ch = choice if choice in rr["cnn"] else rr["cnn_choice"]
            out += _protocol_rows(rr, ch, "in-domain (randomised sweep)")
        for split, r in res.get("cross_condition", {}).items():
            out += _protocol_rows(r, choice, f"cross-condition ({split}: {r['rule']})")
        if "cross_physics" in res:
            out += _protocol_rows(res["cross_physics"], choice, "cross-physics (no path -> path)")
        if "real" in res and "cnn" in res["real"]:
            rl = res["real"]
            for ch in ("a1", "a2", "a3", "a4"):
                out.append(f"| real data, channel {ch}: CNN (mesh_order, binary) | {_pct(rl['cnn'][ch]['accuracy'])} | "
                           f"{_pct(rl['cnn'][ch]['macro_f1'])} | n/a | n/a | n/a |")
                out.append(f"| real data, channel {ch}: logreg on mesh-order spectrum | "
                           f"{_pct(rl['logreg_mesh_order'][ch]['accuracy'])} | - | n/a | n/a | n/a |")
        out += ["", f"CNN representation chosen on the validation split: **{choice}**; best baseline chosen on an "
                "internal 80/20 split of the training data. Accuracy and macro-F1 in %, severity MAE in pitted "
                "fraction of the flank.", ""]
        out += ["### In-domain (default dataset): every input representation and baseline", "",
                f"{ind['n_train']} training records (of which 20 % validation for early stopping), "
                f"{ind['n_test']} test records.", "",
                "| model | val. acc. % | val. teeth acc. % | test severity acc. % | test macro-F1 % | test teeth acc. % | "
                "test severity MAE | epochs | train s |", "|---|---|---|---|---|---|---|---|---|"]
        for rep, r in ind["cnn"].items():
            t = r["test"]
            out.append(f"| CNN {rep} | {_pct(r['val_accuracy'])} | {_pct(r['val_teeth_accuracy'])} | {_pct(t['accuracy'])} | "
                       f"{_pct(t['macro_f1'])} | {_pct(t.get('teeth_accuracy'))} | {t.get('severity_mae', 0):.3f} | "
                       f"{r['epochs']} | {r['train_seconds']} |")
        for kind in KINDS:
            t = ind["baselines"][kind]["test"]
            out.append(f"| {kind} (feature table) | - | - | {_pct(t['accuracy'])} | {_pct(t['macro_f1'])} | "
                       f"{_pct(t.get('teeth_accuracy'))} | {t.get('severity_mae', 0):.3f} | - | - |")
        out.append("")
    if "augmentation" in res:
        a = res["augmentation"]
        out += [f"### Augmentation ablation (CNN {choice}, default dataset, same split)", "", HEAD]
        if ind:
            out.append(_row("default (light: 25 % of records + noise at 20-40 dB, 0.2 % speed error)",
                            ind["cnn"][choice]["test"]))
        out.append(_row("none (no crop, gain, noise, speed error or polarity)", a["none"]["test"]))
        out.append(_row("strong (50 % + noise at 5-30 dB, 1 % speed error)", a["strong"]["test"]))
        out.append("")
    sections = [("cross_condition", "Cross-condition")]
    for key, title in sections:
        for split, r in res.get(key, {}).items():
            out += [f"### {title}: {split} ({r['rule']}; {r['n_train']} train, {r['n_test']} test)", "", HEAD]
            out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
            out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "cross_physics" in res:
        r = res["cross_physics"]
        out += [f"### Cross-physics ({r['rule']}; {r['n_train']} train, {r['n_test']} test)", "", HEAD]
        out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
        out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "randomised" in res:
        r = res["randomised"]
        out += [f"### In-domain on the randomised sweep ({r['n_train']} train, {r['n_test']} test)", "", HEAD]
        out += [_row(f"CNN {rep}", v["test"]) for rep, v in r["cnn"].items()]
        out += [_row(kind, r["baselines"][kind]["test"]) for kind in KINDS] + [""]
    if "real" in res and "cnn" in res["real"]:
        rl = res["real"]
        out += ["### Real data (SpectraQuest, healthy vs broken tooth; trained on synthetic healthy vs pitted)", "",
                f"{rl['n_records_per_channel']} records of 8192 samples per channel from {len(rl['files'])} files. "
                "Estimated mesh frequency per file (cycles/sample): "
                + ", ".join(f"{k} {v}" for k, v in rl["mesh_cps"].items()) + ".", "",
                "| channel | CNN acc. % | CNN macro-F1 % | CNN: fraction called damaged | logreg (mesh-order) acc. % | "
                "logreg: fraction called damaged | real-to-real (leave one load out) acc. % |",
                "|---|---|---|---|---|---|---|"]
        for ch in ("a1", "a2", "a3", "a4"):
            c, lg = rl["cnn"][ch], rl["logreg_mesh_order"][ch]
            out.append(f"| {ch} | {_pct(c['accuracy'])} | {_pct(c['macro_f1'])} | "
                       f"{_pct(rl['cnn_predicted_damaged_fraction'][ch])} | {_pct(lg['accuracy'])} | "
                       f"{_pct(lg['predicted_damaged_fraction'])} | {_pct(rl['real_to_real'][ch])} |")
        out.append("")
    return "\n".join(out) + "\n"


BEGIN, END = "<!-- tables:begin (written by experiments/eval_protocol.py) -->", "<!-- tables:end -->"


def insert_tables(path: Path, tables: str) -> None:
    """Replace the text between the table markers of ``path`` (append the markers if missing)."""
    text = path.read_text() if path.is_file() else "# Classifier results\n\n"
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        tail = rest.split(END, 1)[1]
    else:
        head, tail = text + "\n", "\n"
    path.write_text(head + BEGIN + "\n\n" + tables + "\n" + END + tail)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, default=OUT / "data", help="where the generated datasets live")
    ap.add_argument("--jobs", type=int, default=1, help="processes for the feature tables")
    ap.add_argument("--only", nargs="*", default=None,
                    help="protocols to run (in_domain randomised augmentation cross_condition cross_physics real)")
    args = ap.parse_args(argv)
    import torch

    torch.set_num_threads(1)
    OUT.mkdir(parents=True, exist_ok=True)
    results_path = OUT / "results.json"
    results = json.loads(results_path.read_text()) if results_path.is_file() else {}
    todo = args.only or ["in_domain", "randomised", "augmentation", "cross_condition", "cross_physics", "real"]
    t0 = time.perf_counter()
    default = dataset("default", args.data_dir)
    x_d, names, cfg = features("default", default, args.jobs)
    if "in_domain" in todo:
        results["in_domain"] = in_domain("default", default, x_d, names, cfg, list(REPRESENTATIONS))
    choice = results.get("in_domain", {}).get("cnn_choice", "tsa")
    reps = sorted({choice, "order"})
    if "randomised" in todo:
        rnd = dataset("randomised", args.data_dir)
        x_r, names_r, cfg_r = features("randomised", rnd, args.jobs)
        results["randomised"] = in_domain("randomised", rnd, x_r, names_r, cfg_r, reps)
    if "augmentation" in todo:
        results["augmentation"] = augmentation_ablation(default, choice)
    if "cross_condition" in todo:
        results["cross_condition"] = cross_condition(default, x_d, names, cfg, reps)
    if "cross_physics" in todo:
        nopath = dataset("nopath", args.data_dir)
        x_n, _, _ = features("nopath", nopath, args.jobs)
        results["cross_physics"] = cross_physics(nopath, x_n, default, x_d, names, cfg, reps)
    if "real" in todo:
        results["real"] = real_data(default)
    results["seconds_total_last_run"] = round(time.perf_counter() - t0, 1)
    results_path.write_text(json.dumps(results, indent=1))
    tables = results_tables(results)
    (OUT / "results_tables.md").write_text(tables)
    insert_tables(RESULTS_MD, tables)
    log(f"wrote {results_path} and the tables of {RESULTS_MD}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
