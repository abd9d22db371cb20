"""The runs the classifier protocols of experiments/ are made of: the datasets and their feature tables (generated
once, then read from ``experiments/out/models/``), the CNN variants, one CNN run and the three feature-table
baselines, each trained with fixed seeds, scored and saved (metrics.json/.md and confusion.png under the run's
directory). The protocols themselves: ``eval_protocol.py``, ``sensor_protocol.py`` and the checks built on them.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from models.augment import AugmentConfig  # noqa: E402
from models.baselines import KINDS, feature_config_for, feature_table, fit_baseline  # noqa: E402
from models.data import SignalSet, concat  # noqa: E402
from models.evaluate import evaluate, write_report  # noqa: E402
from models.plots import plot_confusions  # noqa: E402
from models.representation_spec import RepresentationSpec  # noqa: E402
from models.sources import load_dataset  # noqa: E402
from models.train import TrainConfig, stratified_split, train_cnn  # noqa: E402

SWEEPS = ROOT / "experiments" / "models_sweeps"
OUT = ROOT / "experiments" / "out" / "models"
SEED = 0
#: wall-time budget per CNN run (s), far above what any run needs on 2 cores
MAX_SECONDS = 4 * 3600.0

REPRESENTATIONS = {
    "raw": RepresentationSpec(kind="raw", n_samples=8192),
    "envelope": RepresentationSpec(kind="envelope", n_samples=8192),
    "tsa": RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024),
    "order": RepresentationSpec(kind="order", n_revs=8, max_order=100.0),
}
#: CNN variants: name -> (representation, side inputs, see models/operating.py). ``tsa_op``: the TSA with
#: the known speed and load; ``tsa_level``: also the record's RMS in m/s^2, i.e. a model tied to the
#: sensor calibration and transmission path it was trained with
OPERATING = ("speed_rpm", "torque_nm")
VARIANTS = {**{k: (v, ()) for k, v in REPRESENTATIONS.items()},
            "tsa_op": (REPRESENTATIONS["tsa"], OPERATING),
            "tsa_level": (REPRESENTATIONS["tsa"], OPERATING + ("signal_rms",))}
#: variants that may be "the CNN": not the calibration-bound one (it cannot transfer to another sensor
#: path; it is reported beside the chosen CNN)
CHOOSABLE = tuple(v for v in VARIANTS if "signal_rms" not in VARIANTS[v][1])
CALIBRATED = "tsa_level"
#: CNN runs of an earlier results.json that ``--reuse`` may take instead of training again:
#: "<run directory under OUT>#<variant>" -> stored result (see stored_runs)
REUSE: dict = {}
#: the mesh-order spectrum, which needs no sampling rate: the CNN of a variant name not among the variants
#: (:func:`cnn_run`, e.g. ``mesh_order``) and the input of eval_protocol.real_data's baseline
MESH_ORDER = RepresentationSpec(kind="mesh_order", n_mesh_periods=256, max_order=4.0)


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", flush=True)


# ------------------------------------------------------------------ data


def dataset(name: str, data_dir: Path, channel: str | None = None, stiffness: dict | None = None) -> SignalSet:
    """Damaged + healthy records of sweep ``name`` (generated once, then read); ``channel``: a stored
    channel other than the first (experiments/sensor_protocol.py); ``stiffness``: a ``[stiffness]`` table that
    replaces the sweep's mesh record (experiments/record_check.py)."""
    from datagen.dataset import read_metadata
    from datagen.generate import generate
    from datagen.sweep import sweep_from_dict
    from gearpit.tomlio import read_toml

    parts = []
    for part in (name, f"{name}_healthy"):
        out = data_dir / part
        meta_ok = (out / "index.parquet").is_file()
        if not meta_ok:
            doc = dict(read_toml(SWEEPS / f"{part}.toml"))
            if stiffness is not None:
                doc["stiffness"] = stiffness
            log(f"generating {part}" + ("" if stiffness is None else f" with [stiffness] {stiffness}"))
            generate(sweep_from_dict(doc), out, progress=False)
        read_metadata(out)
        parts.append(load_dataset(out, channel=channel))
    d = concat(parts)
    return SignalSet(d.signals, d.fs_hz, d.pair, d.labels, source=f"{name} (+{name}_healthy)", channel=d.channel,
                     reference=d.reference)


def edited_default_split(data_dir: Path, edit, workers: int, label: str, *,
                         channels: tuple = ("acc_pinion_loa_m_s2",), channel: str | None = None
                         ) -> tuple[SignalSet, SignalSet]:
    """The default dataset (``default`` + ``default_healthy`` sweeps) generated once into ``data_dir`` with each
    sweep document passed through ``edit(doc) -> doc`` and only ``channels`` stored (default the accelerometer),
    split as the in-domain protocol splits it (70/30, stratified, split seed :data:`SEED`): ``(train, test)`` of
    ``channel`` (default the first stored). The experiments that ask what one change of the data does to the
    protocol's CNN (``sampling_rate_check.py``, ``nuisance_ceiling_check.py``, ``path_inverse_check.py``)."""
    from datagen.generate import generate
    from datagen.sweep import sweep_from_dict
    from gearpit.tomlio import read_toml

    for part in ("default", "default_healthy"):
        if not (data_dir / part / "index.parquet").is_file():
            doc = edit(dict(read_toml(SWEEPS / f"{part}.toml")))
            doc["sweep"] = dict(doc["sweep"], channels=list(channels))
            t0 = time.perf_counter()
            generate(sweep_from_dict(doc), data_dir / part, workers=workers, progress=False)
            log(f"{label}: generated {part} in {time.perf_counter() - t0:.0f} s")
    data = dataset("default", data_dir, channel=channel)
    tr, te = stratified_split(strata(data), 0.3, SEED)
    return data.subset(tr), data.subset(te)


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
    if "novelty" in metrics:      # the records flagged as unlike the training records (models/novelty.py)
        s["novelty"] = metrics["novelty"]
    s.update(extra or {})
    return s


def save_run(path: Path, metrics: dict, pred, data: SignalSet, title: str) -> None:
    write_report(metrics, pred, data, path, title=title)
    plot_confusions(metrics, path / "confusion.png")


def cnn_run(train: SignalSet, tests: dict[str, SignalSet], variant: str, where: Path, *,
            task: str = "multi", augment: AugmentConfig | None = None, allow_mismatch: bool = False,
            variants: dict | None = None, seed: int = SEED) -> dict:
    """Train the CNN ``variant`` (of ``variants``, default :data:`VARIANTS`: name -> (representation, side
    inputs); an unknown name is the mesh-order CNN) on ``train`` with training seed ``seed``, evaluate it on each
    of ``tests``."""
    variants = VARIANTS if variants is None else variants
    rep, operating = variants[variant] if variant in variants else (MESH_ORDER, ())
    # the epoch limit and early stopping end every run, not the wall-time budget: on a loaded machine the
    # default 900 s budget cut the 2 s one-rig runs short, which made the numbers depend on the load
    cfg = TrainConfig(representation=rep, task=task, augment=augment or AugmentConfig(), seed=seed,
                      operating_inputs=operating, max_seconds=MAX_SECONDS)
    key = f"{where.relative_to(OUT)}#{variant}"
    old = REUSE.get(key)
    # a run stored before the config was recorded comes from the code without side inputs (models/ unchanged
    # otherwise): it stands for the same configuration only if this one has no side inputs
    same = old is not None and (old["config"] == cfg.to_dict() if "config" in old else not operating)
    if same and old.get("n_train") == len(train) and all(n in old for n in tests):
        log(f"  CNN {variant}: reusing the stored run {key} (same configuration and training records)")
        return {**old, "config": cfg.to_dict()}
    t0 = time.perf_counter()
    model = train_cnn(train, cfg)
    secs = time.perf_counter() - t0
    tr = model.spec.training
    out = {"variant": variant, "train_seconds": round(secs, 1), "epochs": tr["epochs_run"],
           "val_accuracy": tr["val_accuracy"],
           "val_teeth_accuracy": tr["val_teeth_accuracy"], "n_train": tr["n_train"] + tr["n_val"],
           "n_parameters": tr["n_parameters"], "config": cfg.to_dict()}
    for name, test in tests.items():
        pred = model.predict(test, allow_mismatch=allow_mismatch)
        m = evaluate(test, pred)
        save_run(where / name, m, pred, test, f"CNN ({variant}) on {name}")
        out[name] = summary(m)
    log(f"  CNN {variant}: " + ", ".join(f"{k} acc {out[k]['accuracy']:.3f}" for k in tests)
        + f" ({secs:.0f} s)")
    return out


def stored_runs(results: dict) -> dict:
    """Every CNN run of a results.json, keyed as :data:`REUSE`."""
    runs = {}
    choice = results.get("in_domain", {}).get("cnn_choice", "tsa")
    for proto, sub in (("in_domain", "in_domain_default"), ("randomised", "in_domain_randomised"),
                       ("cross_physics", "cross_physics")):
        for v, r in results.get(proto, {}).get("cnn", {}).items():
            runs[f"{sub}/cnn_{v}#{v}"] = r
    for split, rr in results.get("cross_condition", {}).items():
        for v, r in rr.get("cnn", {}).items():
            runs[f"cross_{split}/cnn_{v}#{v}"] = r
    for k, r in results.get("augmentation", {}).items():
        runs[f"augmentation/{k}#{r.get('variant', choice)}"] = r
    for k, r in results.get("learning_curve", {}).items():
        runs[f"learning_curve/{k}#{r.get('variant', choice)}"] = r
    return runs


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
