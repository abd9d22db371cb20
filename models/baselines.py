"""Feature-table baselines: logistic regression, random forest, gradient boosting.

Each baseline is three scikit-learn estimators on the feature table of
:mod:`features.table` (one per task: severity class, pitted-teeth class,
severity regression):

============  ==========================================  ======================================
``kind``      classifiers                                 severity regressor
============  ==========================================  ======================================
``logreg``    standardise + multinomial logistic reg.     standardise + ridge
``rf``        random forest (200 trees)                   random forest (200 trees)
``gb``        gradient boosting (150 stages, depth 3)     gradient boosting (150 stages, depth 3)
============  ==========================================  ======================================

Missing feature values (NaN) are replaced by the training medians.

**Novelty.** Each baseline also keeps a novelty model of its standardised feature table
(:mod:`models.novelty`, fitted on 80 % of the training records and scaled by the
other 20 %), so a record unlike the training records gets a warning as with the CNN.

**No pickling.** After fitting, every estimator is exported to plain arrays
(:attr:`FeatureClassifier.arrays`): scaler means and scales, linear
coefficients, and for the tree ensembles one node table per ensemble
(``left``, ``right``, ``feature``, ``threshold``, ``value``, tree offsets) plus
the boosting start value. Prediction always runs on these arrays (a vectorised
tree walk), so a model loaded from ``arrays.npz`` predicts exactly what the
fitted estimators predicted; :func:`fit_baseline` checks this on the training
table before returning.

References
----------
.. [1] Breiman, L. (2001). Random forests. Machine Learning 45, 5-32.
.. [2] Friedman, J. H. (2001). Greedy function approximation: a gradient boosting
   machine. Annals of Statistics 29(5), 1189-1232.
.. [3] Pedregosa, F. et al. (2011). Scikit-learn: machine learning in Python.
   JMLR 12, 2825-2830.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearpit.errors import require
from models.data import TEETH_CLASSES, SignalSet
from models.novelty import MIN_HELD_OUT, NoveltyModel, fit_novelty, join_warnings, novelty_warning
from models.spec import ModelSpec, Predictions, bounded_severity, check_input, training_ranges

KINDS: tuple[str, ...] = ("logreg", "rf", "gb")
TASK_KEYS: tuple[str, ...] = ("sev", "teeth", "reg")


def feature_config_for(data: SignalSet, *, hht_method: str = "none", envelope_band: str = "full",
                       reference: bool = False) -> dict:
    """The :class:`features.table.FeatureConfig` fields used for ``data`` (as a dict).

    Up to 3 mesh harmonics, as many as stay (with 3 sidebands) below the Nyquist
    frequency at the fastest speed of ``data``; HHT features off by default (the
    EMD costs ~1 s per record). ``reference``: the table also reads every record
    against its healthy reference (:mod:`models.reference_features`; ``data``
    must have references, and so must every record the model predicts).
    """
    from features.table import FeatureConfig

    fr = data.shaft_hz()
    require(fr is not None, "speed_rpm", None, "the pinion speed of every record (the features need it)")
    fast = float(np.max(fr))
    n_h = int(min(3, np.floor((data.fs_hz / 2 - 3 * fast) / (data.pair.z_pinion * fast))))
    require(n_h >= 1, "speed_rpm", round(fast * 60, 1), "a speed whose mesh frequency lies below the Nyquist frequency")
    require(not reference or data.reference is not None, "reference", None,
            "a healthy reference of every record (a dataset generated with [sweep] healthy_reference = true, or "
            "the sidecar key 'reference')")
    cfg = FeatureConfig(fs_hz=float(data.fs_hz), z_pinion=int(data.pair.z_pinion), z_wheel=int(data.pair.z_wheel),
                        hht_method=hht_method, envelope_band=envelope_band, n_mesh_harmonics=n_h).to_dict()
    return {**cfg, "reference": True} if reference else cfg


def feature_table(data: SignalSet, config: dict, *, n_jobs: int = 1) -> tuple[np.ndarray, list[str]]:
    """Feature matrix ``(n_records, n_features)`` of ``data`` and the column names (with ``config["reference"]``
    also the columns of :mod:`models.reference_features`)."""
    from features.table import FeatureConfig, extract_features

    reference = bool(config.get("reference", False))
    cfg = FeatureConfig.from_dict({**{k: v for k, v in config.items() if k != "reference"}, "fs_hz": float(data.fs_hz)})
    fr = data.shaft_hz()
    require(fr is not None, "speed_rpm", None, "the pinion speed of every record (the features need it)")
    require(not reference or data.reference is not None, "reference", None,
            "a healthy reference of every record (the baseline reads each record against one)")
    table = extract_features(data.signals, cfg, fr_pinion_hz=fr, n_jobs=n_jobs)
    x, names = table.to_numpy(dtype=float), list(table.columns)
    if not reference:
        return x, names
    from models.reference_features import with_reference_columns

    x_ref = extract_features(data.reference, cfg, fr_pinion_hz=fr, n_jobs=n_jobs).to_numpy(dtype=float)
    return with_reference_columns(data, x, x_ref, names)


# ---------------------------------------------------------------- export of fitted estimators


def _export_trees(trees, prefix: str, normalise: bool) -> dict[str, np.ndarray]:
    left, right, feat, thr, val, offs = [], [], [], [], [], [0]
    for t in trees:
        tr = t.tree_
        v = tr.value[:, 0, :].astype(float)
        if normalise:
            v = v / v.sum(axis=1, keepdims=True)
        base = offs[-1]
        lc = tr.children_left.astype(np.int64)
        rc = tr.children_right.astype(np.int64)
        left.append(np.where(lc >= 0, lc + base, -1))
        right.append(np.where(rc >= 0, rc + base, -1))
        feat.append(tr.feature.astype(np.int64))
        thr.append(tr.threshold.astype(float))
        val.append(v)
        offs.append(base + tr.node_count)
    return {f"{prefix}_left": np.concatenate(left), f"{prefix}_right": np.concatenate(right),
            f"{prefix}_feature": np.concatenate(feat), f"{prefix}_threshold": np.concatenate(thr),
            f"{prefix}_value": np.concatenate(val), f"{prefix}_offsets": np.asarray(offs, dtype=np.int64)}


def _walk(arrays: dict, prefix: str, x: np.ndarray) -> np.ndarray:
    """Leaf values ``(n_trees, n_records, n_values)`` of every tree for every record."""
    left, right = arrays[f"{prefix}_left"], arrays[f"{prefix}_right"]
    feat, thr, val = arrays[f"{prefix}_feature"], arrays[f"{prefix}_threshold"], arrays[f"{prefix}_value"]
    roots = arrays[f"{prefix}_offsets"][:-1]
    n = x.shape[0]
    node = np.repeat(roots[:, None], n, axis=1)  # (n_trees, n_records)
    rows = np.broadcast_to(np.arange(n)[None, :], node.shape)
    while True:
        inner = left[node] >= 0
        if not inner.any():
            break
        go_left = x[rows, np.where(inner, feat[node], 0)] <= thr[node]
        node = np.where(inner, np.where(go_left, left[node], right[node]), node)
    return val[node]


def _softmax(z: np.ndarray) -> np.ndarray:
    z = z - z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


def _export(kind: str, task: str, est, x0: np.ndarray) -> dict[str, np.ndarray]:
    """Plain arrays of a fitted estimator (``x0``: one training row, for the boosting start value)."""
    p = task
    if kind == "logreg":
        scaler, lin = est.named_steps["scale"], est.named_steps["model"]
        out = {f"{p}_mean": scaler.mean_.astype(float), f"{p}_scale": scaler.scale_.astype(float),
               f"{p}_coef": np.atleast_2d(lin.coef_).astype(float), f"{p}_intercept": np.atleast_1d(lin.intercept_).astype(float)}
    elif kind == "rf":
        out = _export_trees(est.estimators_, p, normalise=task != "reg")
    else:
        stages = est.estimators_  # (n_stages, K)
        out = {}
        for k in range(stages.shape[1]):
            out.update(_export_trees(stages[:, k], f"{p}{k}", normalise=False))
        out[f"{p}_n_outputs"] = np.array([stages.shape[1]])
        out[f"{p}_learning_rate"] = np.array([float(est.learning_rate)])
        raw0 = (np.atleast_1d(est.decision_function(x0[None, :])[0]) if task != "reg"
                else np.atleast_1d(est.predict(x0[None, :])[0]))
        trees0 = np.array([_walk(out, f"{p}{k}", x0[None, :]).sum() for k in range(stages.shape[1])])
        out[f"{p}_init"] = (raw0 - est.learning_rate * trees0).astype(float)
    if task != "reg":
        out[f"{p}_classes"] = np.asarray(est.classes_, dtype=np.int64)
    return out


def _raw_output(kind: str, task: str, arrays: dict, x: np.ndarray) -> np.ndarray:
    """Probabilities over ``{task}_classes`` (classifiers) or the prediction (regressor)."""
    p = task
    if kind == "logreg":
        z = (x - arrays[f"{p}_mean"]) / arrays[f"{p}_scale"] @ arrays[f"{p}_coef"].T + arrays[f"{p}_intercept"]
        if task == "reg":
            return z[:, 0] if z.ndim == 2 else z
        if z.shape[1] == 1:
            q = 1.0 / (1.0 + np.exp(-z[:, 0]))
            return np.stack([1 - q, q], axis=1)
        return _softmax(z)
    if kind == "rf":
        v = _walk(arrays, p, x).mean(axis=0)
        return v[:, 0] if task == "reg" else v
    k_out = int(arrays[f"{p}_n_outputs"][0])
    lr = float(arrays[f"{p}_learning_rate"][0])
    raw = np.stack([_walk(arrays, f"{p}{k}", x)[:, :, 0].sum(axis=0) for k in range(k_out)], axis=1)
    raw = arrays[f"{p}_init"][None, :] + lr * raw
    if task == "reg":
        return raw[:, 0]
    if k_out == 1:
        q = 1.0 / (1.0 + np.exp(-raw[:, 0]))
        return np.stack([1 - q, q], axis=1)
    return _softmax(raw)


def _estimators(kind: str, seed: int):
    from sklearn.ensemble import (GradientBoostingClassifier, GradientBoostingRegressor, RandomForestClassifier,
                                  RandomForestRegressor)
    from sklearn.linear_model import LogisticRegression, Ridge
    from sklearn.pipeline import Pipeline
    from sklearn.preprocessing import StandardScaler

    if kind == "logreg":
        def clf():
            return Pipeline([("scale", StandardScaler()), ("model", LogisticRegression(C=1.0, max_iter=5000))])
        reg = Pipeline([("scale", StandardScaler()), ("model", Ridge(alpha=1.0))])
    elif kind == "rf":
        def clf():
            return RandomForestClassifier(n_estimators=200, random_state=seed, n_jobs=1)
        reg = RandomForestRegressor(n_estimators=200, random_state=seed, n_jobs=1)
    else:
        def clf():
            return GradientBoostingClassifier(n_estimators=150, max_depth=3, learning_rate=0.1, random_state=seed)
        reg = GradientBoostingRegressor(n_estimators=150, max_depth=3, learning_rate=0.1, random_state=seed)
    return clf(), clf(), reg


@dataclass
class FeatureClassifier:
    """A fitted baseline as plain arrays, with its :class:`~models.spec.ModelSpec`.

    ``spec.representation`` holds the feature configuration and the feature names.
    """

    spec: ModelSpec
    arrays: dict

    def predict_features(self, x: np.ndarray, warnings: list[str] | None = None) -> Predictions:
        """Predictions from a feature matrix (columns as in ``spec.representation["feature_names"]``)."""
        x = np.asarray(x, dtype=float)
        names = self.spec.representation["feature_names"]
        require(x.ndim == 2 and x.shape[1] == len(names), "features", x.shape, f"(n, {len(names)})")
        x = np.where(np.isfinite(x), x, self.arrays["impute"][None, :])
        kind = self.spec.model_type
        n = x.shape[0]
        out = {}
        for task, n_cls in (("sev", len(self.spec.severity_classes)), ("teeth", len(self.spec.teeth_classes))):
            full = np.zeros((n, n_cls))
            if f"{task}_constant" in self.arrays:
                full[:, int(self.arrays[f"{task}_constant"][0])] = 1.0
            else:
                full[:, self.arrays[f"{task}_classes"]] = _raw_output(kind, task, self.arrays, x)
            out[task] = full
        sev, sev_notes = bounded_severity(_raw_output(kind, "reg", self.arrays, x), self.spec.severity_scale)
        warnings = join_warnings(warnings if warnings is not None else [""] * n, sev_notes)
        nov, batch = None, None
        if NOVELTY_PREFIX + "means" in self.arrays:
            model = self.novelty_model()
            nov = model.novelty((x - self.arrays[NOVELTY_PREFIX + "center"]) / self.arrays[NOVELTY_PREFIX + "scale"])
            warnings = join_warnings(warnings, [novelty_warning(v, model.quantile) for v in nov])
            batch = model.batch_shift(nov)
        return Predictions(list(self.spec.severity_classes), list(self.spec.teeth_classes), out["sev"], out["teeth"],
                           sev, warnings, nov, batch)

    def novelty_model(self) -> NoveltyModel | None:
        """The novelty model of the standardised feature table (:mod:`models.novelty`), None if not fitted."""
        a = {k[len(NOVELTY_PREFIX):]: v for k, v in self.arrays.items() if k.startswith(NOVELTY_PREFIX)}
        return NoveltyModel.from_arrays(a) if "means" in a else None

    def predict(self, data: SignalSet, *, features: np.ndarray | None = None, allow_mismatch: bool = False,
                n_jobs: int = 1) -> Predictions:
        """Predictions for the records of ``data`` (feature table computed unless given)."""
        warnings = check_input(self.spec, data, allow_mismatch=allow_mismatch)
        if features is None:
            cfg = {k: v for k, v in self.spec.representation.items() if k != "feature_names"}
            features, _ = feature_table(data, cfg, n_jobs=n_jobs)
        return self.predict_features(features, warnings)


def trainable(data: SignalSet, task: str) -> SignalSet:
    """``data`` with the classes of ``task`` (``binary``: healthy / damaged); refused before any work when it lacks
    the labels or holds fewer than two classes (a baseline cannot be fitted on one)."""
    require(data.has_labels() and data.has_teeth_labels(), "labels", list(data.labels.columns),
            "severity_class and teeth labels")
    if task == "binary":
        data = data.as_binary()
    classes = data.severity_class_names()
    require(len(classes) >= 2, "severity_class", classes, "at least two classes in the training data"
            + (" (--task binary needs healthy and damaged records)" if task == "binary" else ""))
    return data


def fit_baseline(data: SignalSet, kind: str, *, features: np.ndarray, feature_names: list[str], feature_config: dict,
                 task: str = "multi", seed: int = 0) -> FeatureClassifier:
    """Fit one baseline on a feature table; return it exported to arrays (checked against scikit-learn).

    Parameters
    ----------
    data : SignalSet
        Labelled records (labels only are used; the features are given).
    kind : {"logreg", "rf", "gb"}
    features : ndarray, shape (n_records, n_features)
    feature_names : list of str
    feature_config : dict
        The :class:`features.table.FeatureConfig` fields that made the table.
    task : {"multi", "binary"}
    seed : int
    """
    require(kind in KINDS, "kind", kind, "one of: " + ", ".join(KINDS))
    x = np.asarray(features, dtype=float)
    require(x.shape == (len(data), len(feature_names)), "features", x.shape, f"({len(data)}, {len(feature_names)})")
    data = trainable(data, task)
    classes = data.severity_class_names()
    lut = {c: i for i, c in enumerate(classes)}
    y_sev = np.array([lut[c] for c in data.labels["severity_class"].astype(str)], dtype=np.int64)
    t_lut = {c: i for i, c in enumerate(TEETH_CLASSES)}
    y_teeth = np.array([t_lut[c] for c in data.teeth_classes()], dtype=np.int64)
    sev = data.labels["severity"].to_numpy(dtype=float) if "severity" in data.labels else np.zeros(len(data))
    impute = np.nanmedian(np.where(np.isfinite(x), x, np.nan), axis=0)
    impute = np.where(np.isfinite(impute), impute, 0.0)
    xi = np.where(np.isfinite(x), x, impute[None, :])

    arrays: dict[str, np.ndarray] = {"impute": impute}
    clf_sev, clf_teeth, reg = _estimators(kind, seed)
    fitted = {}
    for task_key, est, y in (("sev", clf_sev, y_sev), ("teeth", clf_teeth, y_teeth), ("reg", reg, sev)):
        if task_key != "reg" and np.unique(y).size == 1:
            arrays[f"{task_key}_constant"] = np.unique(y)  # one class seen: always predicted
            fitted[task_key] = None
            continue
        est.fit(xi, y)
        fitted[task_key] = est
        arrays.update(_export(kind, task_key, est, xi[0]))

    arrays.update(_fit_feature_novelty(xi, y_sev, seed))
    n_held_out = int(round(NOVELTY_HELD_OUT * len(data)))

    spec = ModelSpec(model_type=kind, task=task, fs_hz=float(data.fs_hz), n_samples=data.n_samples, pair=data.pair,
                     representation={**feature_config, "feature_names": list(feature_names)},
                     severity_classes=classes, teeth_classes=list(TEETH_CLASSES),
                     severity_scale=float(sev.max()) if sev.max() > 0 else 1.0, channel=data.channel,
                     ranges=training_ranges(data.labels), train_config={"kind": kind, "seed": seed, "task": task},
                     training={"n_train": len(data), "source": data.source,
                               "novelty": FeatureClassifier(None, arrays).novelty_model().summary()
                               if NOVELTY_PREFIX + "means" in arrays else
                               f"not fitted: {n_held_out} held-out records, fewer than {MIN_HELD_OUT}"})
    model = FeatureClassifier(spec, arrays)
    # the exported arrays must reproduce scikit-learn's predictions
    check = model.predict_features(x[: min(64, len(x))])
    ref = fitted["sev"].predict_proba(xi[: min(64, len(x))])
    got = check.severity_proba[:, arrays["sev_classes"]]
    require(np.allclose(got, ref, atol=1e-9), "export", float(np.abs(got - ref).max()),
            "exported baseline equal to scikit-learn (internal error)")
    return model


#: prefix of the novelty model's arrays among a baseline's arrays
NOVELTY_PREFIX = "novelty_"
#: share of the training records held out to scale the novelty (:mod:`models.novelty`)
NOVELTY_HELD_OUT = 0.2


def _fit_feature_novelty(x: np.ndarray, y: np.ndarray, seed: int) -> dict[str, np.ndarray]:
    """The novelty model of a baseline (:mod:`models.novelty`) on its imputed feature table ``x``, standardised
    by the training records' mean and standard deviation: fitted on a seeded random 80 % of them, scaled by the
    other 20 %. Empty (no warning) when that 20 % is fewer than :data:`models.novelty.MIN_HELD_OUT` records."""
    n = x.shape[0]
    k = int(round(NOVELTY_HELD_OUT * n))
    if k < MIN_HELD_OUT:
        return {}
    center = x.mean(axis=0)
    scale = x.std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    z = (x - center) / scale
    order = np.random.default_rng([int(seed), 17]).permutation(n)
    model = fit_novelty(z[order[k:]], y[order[k:]], z[order[:k]])
    return {NOVELTY_PREFIX + "center": center, NOVELTY_PREFIX + "scale": scale,
            **{NOVELTY_PREFIX + key: np.asarray(v) for key, v in model.to_arrays().items()}}
