"""How identifiable is the severity label of the default dataset? (issue 6, step 1)

Run: ``python experiments/severity_identifiability.py`` (about 2 min; needs the datasets of
``experiments/eval_protocol.py``). Writes ``experiments/out/models/identifiability/identifiability.json``
and ``per_record.csv``.

The severity label is the pitted *area* fraction of the worst tooth. What the vibration can see is the
loss of mesh stiffness while a pitted tooth meshes. For every pitted record the pit map is regenerated from
the stored sweep (:func:`datagen.dataset.regenerate_pit_map`) and the mesh stiffness over one pinion
revolution computed with and without the pits (:func:`datagen.stiffness.mesh_stiffness`, the simulator's
own stiffness). Per pitted tooth ``m`` (engagement ``m`` of the pinion):

- ``deficit``: integral of the stiffness drop of its tooth pair over its mesh, in mesh cycles times the
  mean healthy mesh stiffness (a tooth whose pair lost all stiffness for one whole mesh cycle: 1);
- ``peak``: the largest drop of the total mesh stiffness, as a fraction of the mean;
- ``te_um``: the largest change of the static transmission error ``F / k`` it causes at the record's load
  (F = torque / pinion base radius), micrometres; divided by the torque it is the pit's *peak* excitation
  per unit load, which (unlike the deficit, an integral over the mesh) a reader of the impulse height sees.

The record's stiffness-level severity is the worst tooth's value (the label is the worst tooth's area).
Questions answered:

1. Do the classes overlap at the stiffness level? Per class, the 5-95 % range of the worst deficit; the
   accuracy of the best ordered thresholds on it (fitted on all records: an upper bound for any rule that
   sees only this number); and a gradient-boosting classifier (5-fold cross-validated) on per-record
   stiffness descriptors (worst/sum deficit and peak of the sorted teeth, number of pitted teeth) = what a
   perfect stiffness estimate would give.
2. How large are the manufacturing errors' transmission errors next to a pit's? Profile form/slope
   deviations (the same on every tooth) and the cumulative pitch deviation (once per revolution) from the
   ISO 1328 grade of each record, against the pit's ``te_um``.
3. What does the *signal* lose? From the chosen representation (TSA and its difference signal, scaled by
   the TSA's standard deviation, as the CNN sees it) three scalars per record: log RMS and log peak of the
   difference signal and its kurtosis. Gradient boosting (5-fold cross-validated) on them, then with the
   known operating point (speed, load) and the number of pitted teeth, then with each true nuisance
   parameter added one at a time, then with the record's absolute RMS (m/s^2): which nuisance costs what.
   And the absolute level across sensor paths: trained on ``nopath`` records, tested on ``default``.
4. Where do the CNN's errors lie? For the in-domain test predictions of the chosen CNN
   (``experiments/out/models/in_domain_default/cnn_<rep>/test/predictions.csv``), how many of the severity
   errors are records whose worst deficit lies outside their class's 5-95 % range or inside the
   neighbouring class's.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from datagen.dataset import load_index, read_metadata, regenerate_pit_map  # noqa: E402
from datagen.effects.accuracy_grade import gear_tolerances  # noqa: E402
from datagen.stiffness import mesh_stiffness  # noqa: E402
from datagen.sweep import sweep_from_dict  # noqa: E402

DATA = ROOT / "experiments" / "out" / "models" / "data"
OUT = ROOT / "experiments" / "out" / "models" / "identifiability"
CLASSES = ("minor", "moderate", "severe")
PPC = 64


def tooth_stiffness_loss(pair, pit_map, torque_nm: float) -> dict[int, dict]:
    """deficit, peak and te_um of every pitted pinion tooth (module docstring)."""
    healthy = mesh_stiffness(pair, positions_per_cycle=PPC)
    pitted = mesh_stiffness(pair, pits=pit_map, positions_per_cycle=PPC)
    k_mean = healthy.mean_n_per_m
    drop_slots = healthy.k_slots_n_per_m - pitted.k_slots_n_per_m       # (positions, slots)
    force_n = torque_nm / pair.base_radius_m("pinion")
    te_drop = force_n / pitted.k_n_per_m - force_n / healthy.k_n_per_m   # (positions,) m
    out = {}
    for m in pit_map.pitted_teeth:
        on = pitted.engagement == m
        d = np.where(on, drop_slots, 0.0)
        per_pos = d.sum(axis=1)
        touched = per_pos > 0
        out[int(m)] = {"deficit": float(per_pos.sum() / PPC / k_mean),
                       "peak": float(per_pos.max() / k_mean),
                       "te_um": float(te_drop[touched].max() * 1e6) if touched.any() else 0.0}
    return out


def best_ordered_thresholds(value: np.ndarray, cls: np.ndarray) -> tuple[float, list[float]]:
    """Highest accuracy of ``class = number of thresholds below value`` over all ordered threshold sets
    (dynamic programming over the sorted values); ``cls`` in 0..K-1."""
    order = np.argsort(value)
    v, c = value[order], cls[order]
    n, k = v.size, int(c.max()) + 1
    # hits[j][i] = records among the first i sorted values with class j
    hits = np.vstack([np.concatenate([[0], np.cumsum(c == j)]) for j in range(k)])
    # best[j][i]: best hits with the first i records assigned to classes 0..j (monotone)
    best = np.full((k, n + 1), -1.0)
    arg = np.zeros((k, n + 1), dtype=int)
    best[0] = hits[0]
    for j in range(1, k):
        for i in range(n + 1):
            cand = best[j - 1, :i + 1] + (hits[j, i] - hits[j, :i + 1])
            arg[j, i] = int(np.argmax(cand))
            best[j, i] = cand[arg[j, i]]
    cuts, i = [], n
    for j in range(k - 1, 0, -1):
        i = arg[j, i]
        cuts.append(float(v[i - 1] + v[min(i, n - 1)]) / 2 if 0 < i < n else float("nan"))
    return float(best[k - 1, n] / n), cuts[::-1]


def record_table(name: str) -> pd.DataFrame:
    path = DATA / name
    meta = read_metadata(path)
    sweep = sweep_from_dict(meta["config"])
    idx = load_index(path).reset_index(drop=True)
    rows = []
    for r in idx.itertuples():
        if r.severity <= 0:
            continue
        pair = sweep.pair(r.pair)
        per_tooth = tooth_stiffness_loss(pair, regenerate_pit_map(path, int(r.sample_index)), float(r.torque_nm))
        d = sorted((v["deficit"] for v in per_tooth.values()), reverse=True) + [0.0] * 4
        p = sorted((v["peak"] for v in per_tooth.values()), reverse=True) + [0.0] * 4
        worst_area_tooth = int(np.asarray(r.pitted_teeth)[int(np.argmax(r.severity_by_tooth))])
        tol_p = gear_tolerances(pair, "pinion", float(r.pitch_error_grade))
        tol_pr = [gear_tolerances(pair, w, float(r.profile_error_grade)) for w in ("pinion", "wheel")]
        rows.append({
            "sample_index": int(r.sample_index), "severity": float(r.severity), "severity_class": r.severity_class,
            "n_pitted_teeth": int(r.n_pitted_teeth), "shape": r.shape, "pit_depth_m": float(r.pit_depth_m),
            "pit_aspect_w_to_s": float(r.pit_aspect_w_to_s), "speed_rpm": float(r.speed_rpm),
            "torque_nm": float(r.torque_nm),
            "deficit_worst": d[0], "deficit_2": d[1], "deficit_3": d[2], "deficit_sum": float(sum(d)),
            "peak_worst": p[0], "peak_2": p[1], "deficit_of_largest_area_tooth": per_tooth[worst_area_tooth]["deficit"],
            "te_pit_um": max(v["te_um"] for v in per_tooth.values()),
            # manufacturing errors along the line of action (um): pitch F_p range over the revolution and the
            # largest step between adjacent teeth; profile form range + slope (both gears, same on every tooth)
            "pitch_Fp_um": tol_p.cumulative_pitch_m * math.cos(pair.pressure_angle_t_rad) * 1e6,
            "pitch_step_um": tol_p.cumulative_pitch_m * math.cos(pair.pressure_angle_t_rad) * 1e6
                             * math.sin(math.pi / pair.pinion.teeth),
            "profile_um": sum(t.profile_form_m + abs(t.profile_slope_m) for t in tol_pr) * 1e6,
        })
    return pd.DataFrame(rows)


def stiffness_ceiling(t: pd.DataFrame, seed: int = 0) -> float:
    """5-fold cross-validated accuracy of gradient boosting on the stiffness descriptors (3 classes)."""
    from sklearn.ensemble import GradientBoostingClassifier
    from sklearn.model_selection import StratifiedKFold, cross_val_score

    cols = ["deficit_worst", "deficit_2", "deficit_3", "deficit_sum", "peak_worst", "peak_2", "n_pitted_teeth"]
    y = t["severity_class"].map({c: i for i, c in enumerate(CLASSES)}).to_numpy()
    g = GradientBoostingClassifier(n_estimators=150, max_depth=3, random_state=seed)
    cv = StratifiedKFold(5, shuffle=True, random_state=seed)
    return float(cross_val_score(g, t[cols].to_numpy(), y, cv=cv).mean())


NUISANCES = ("profile_error_grade", "profile_error_phase_rad", "pitch_error_grade",
             "transmission_path_housing_frequency_hz", "transmission_path_housing_damping_ratio", "snr_db",
             "drive_train_mesh_damping_ratio", "pit_depth_m")


def _signal_scalars(data):
    """log RMS, log peak and kurtosis of the TSA difference signal (in TSA standard deviations), and the
    log of the record's absolute RMS, for every pitted record of ``data``."""
    from classifier_runs import REPRESENTATIONS

    from models.representations import represent

    m = (data.labels["severity"] > 0).to_numpy()
    x = represent(data.signals[m], REPRESENTATIONS["tsa"], fs_hz=data.fs_hz, shaft_hz=data.shaft_hz()[m],
                  z_pinion=data.pair.z_pinion, starts=0.5)[:, 1].astype(float)
    r = np.sqrt((x ** 2).mean(axis=1))
    f = np.column_stack([np.log(r), np.log(np.abs(x).max(axis=1)), (x ** 4).mean(axis=1) / r ** 4])
    sig = data.signals[m].astype(float)
    level = np.log(np.sqrt(((sig - sig.mean(axis=1, keepdims=True)) ** 2).mean(axis=1)))
    return f, level, data.labels[m].reset_index(drop=True)


def signal_level(seed: int = 0) -> dict:
    """Question 3 of the module docstring."""
    from classifier_runs import OUT as MODELS_OUT, dataset
    from sklearn.ensemble import GradientBoostingClassifier
    from sklearn.model_selection import StratifiedKFold, cross_val_score

    data = dataset("default", MODELS_OUT / "data")
    f, level, lab = _signal_scalars(data)
    y = lab["severity_class"].map({c: i for i, c in enumerate(CLASSES)}).to_numpy()
    op = np.column_stack([np.log(lab["torque_nm"]), np.log(lab["speed_rpm"]), lab["n_pitted_teeth"]])
    cv = StratifiedKFold(5, shuffle=True, random_state=seed)

    def score(x):
        g = GradientBoostingClassifier(n_estimators=150, max_depth=3, random_state=seed)
        return float(cross_val_score(g, x, y, cv=cv).mean())

    out = {"difference_signal_scalars": score(f), "+ speed, load, n_teeth": score(np.column_stack([f, op]))}
    for c in NUISANCES:
        out[f"+ speed, load, n_teeth, {c}"] = score(np.column_stack([f, op, lab[c].to_numpy(dtype=float)]))
    nuis = lab[list(NUISANCES)].to_numpy(dtype=float)
    out["+ speed, load, n_teeth, all nuisances"] = score(np.column_stack([f, op, nuis]))
    out["+ speed, load, n_teeth, absolute RMS"] = score(np.column_stack([f, op, level]))
    out["+ speed, load, n_teeth, absolute RMS, all nuisances"] = score(np.column_stack([f, op, level, nuis]))
    # the absolute level does not carry across sensor paths: train on nopath, test on default
    nop = dataset("nopath", MODELS_OUT / "data")
    fn, level_n, lab_n = _signal_scalars(nop)
    yn = lab_n["severity_class"].map({c: i for i, c in enumerate(CLASSES)}).to_numpy()
    op_n = np.column_stack([np.log(lab_n["torque_nm"]), np.log(lab_n["speed_rpm"]), lab_n["n_pitted_teeth"]])
    cross = {}
    for name, a, b in (("relative only", np.column_stack([fn, op_n]), np.column_stack([f, op])),
                       ("with absolute RMS", np.column_stack([fn, op_n, level_n]), np.column_stack([f, op, level]))):
        g = GradientBoostingClassifier(n_estimators=150, max_depth=3, random_state=seed).fit(a, yn)
        cross[name] = float(np.mean(g.predict(b) == y))
    out["nopath_to_default"] = cross
    out["log10_rms_median"] = {"default": float(np.median(level) / np.log(10)),
                               "nopath": float(np.median(level_n) / np.log(10))}
    return out


def cnn_errors(t: pd.DataFrame, ranges: dict, rep: str) -> dict:
    f = ROOT / "experiments" / "out" / "models" / "in_domain_default" / f"cnn_{rep}" / "test" / "predictions.csv"
    if not f.is_file():
        return {"skipped": f"no {f}"}
    p = pd.read_csv(f)
    p = p[p["severity_class"] != "healthy"].merge(t[["sample_index", "deficit_worst"]], on="sample_index")
    wrong = p[p["pred_severity_class"] != p["severity_class"]]
    atypical = [not (ranges[c][0] <= d <= ranges[c][1])
                for c, d in zip(wrong["severity_class"], wrong["deficit_worst"])]
    atypical_all = [not (ranges[c][0] <= d <= ranges[c][1]) for c, d in zip(p["severity_class"], p["deficit_worst"])]
    # does the wrong prediction follow the deficit? (predicted class's range contains the deficit)
    follows = [pc in ranges and ranges[pc][0] <= d <= ranges[pc][1]
               for pc, d in zip(wrong["pred_severity_class"], wrong["deficit_worst"])]
    return {"representation": rep, "n_pitted_test": int(len(p)), "n_wrong": int(len(wrong)),
            "wrong_outside_own_5_95": int(np.sum(atypical)), "all_outside_own_5_95": int(np.sum(atypical_all)),
            "wrong_inside_predicted_class_5_95": int(np.sum(follows))}


def cnn_errors_by(rep: str, column: str) -> dict:
    """Severity error rate of the pitted test records per tercile of ``column``, and the share of the
    errors that call the pit milder than it is."""
    f = ROOT / "experiments" / "out" / "models" / "in_domain_default" / f"cnn_{rep}" / "test" / "predictions.csv"
    if not f.is_file():
        return {"skipped": f"no {f}"}
    p = pd.read_csv(f)
    p = p[p["severity_class"] != "healthy"].copy()
    order = {"healthy": 0, **{c: i + 1 for i, c in enumerate(CLASSES)}}
    p["step"] = p["pred_severity_class"].map(order) - p["severity_class"].map(order)
    out = {}
    for q, g in p.groupby(pd.qcut(p[column], 3), observed=True):
        out[f"{q.left:.0f}-{q.right:.0f}"] = {"error_rate": float((g["step"] != 0).mean()),
                                             "too_mild": float((g["step"] < 0).mean())}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", default="default")
    ap.add_argument("--rep", default=None, help="CNN representation whose test errors to inspect (default: chosen)")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    t = record_table(args.dataset)
    t.to_csv(OUT / f"per_record_{args.dataset}.csv", index=False)
    y = t["severity_class"].map({c: i for i, c in enumerate(CLASSES)}).to_numpy()
    res: dict = {"dataset": args.dataset, "n_pitted": int(len(t))}
    ranges = {}
    for c in CLASSES:
        s = t[t["severity_class"] == c]
        q = np.percentile(s["deficit_worst"], [0, 5, 50, 95, 100])
        ranges[c] = (float(q[1]), float(q[3]))
        res[f"deficit_worst_{c}"] = {"min": q[0], "p5": q[1], "median": q[2], "p95": q[3], "max": q[4],
                                     "area_range": [float(s["severity"].min()), float(s["severity"].max())]}
    # the peak static transmission-error change per unit load: what a reader of the pit's peak sees (te ~ F)
    t["te_pit_um_per_nm"] = t["te_pit_um"] / t["torque_nm"]
    for col in ("deficit_worst", "peak_worst", "deficit_of_largest_area_tooth", "te_pit_um_per_nm"):
        acc, cuts = best_ordered_thresholds(t[col].to_numpy(), y)
        res[f"best_thresholds_{col}"] = {"accuracy": acc, "cuts": cuts}
    res["largest_area_tooth_is_largest_deficit_tooth"] = float(np.mean(
        np.isclose(t["deficit_of_largest_area_tooth"], t["deficit_worst"])))
    rho = pd.Series(t["severity"]).corr(t["deficit_worst"], method="spearman")
    res["spearman_area_vs_deficit"] = float(rho)
    res["gb_on_stiffness_descriptors_cv5"] = stiffness_ceiling(t)
    # transmission errors: pit vs manufacturing errors (um)
    res["te_um"] = {k: {"p5": float(np.percentile(t[k], 5)), "median": float(t[k].median()),
                        "p95": float(np.percentile(t[k], 95))}
                    for k in ("te_pit_um", "pitch_Fp_um", "pitch_step_um", "profile_um")}
    res["te_pit_um_by_class"] = {c: float(t.loc[t["severity_class"] == c, "te_pit_um"].median()) for c in CLASSES}
    # what explains the deficit within a class: Spearman with the pit's nuisance parameters
    res["within_class_spearman_deficit_vs"] = {
        k: float(np.mean([t[t.severity_class == c]["deficit_worst"].corr(t[t.severity_class == c][k], method="spearman")
                          for c in CLASSES]))
        for k in ("severity", "pit_depth_m", "pit_aspect_w_to_s", "n_pitted_teeth")}
    res["by_shape_median_deficit"] = {f"{c}/{s}": float(g["deficit_worst"].median())
                                      for (c, s), g in t.groupby(["severity_class", "shape"])}
    rep = args.rep
    if rep is None:
        rj = ROOT / "experiments" / "out" / "models" / "results.json"
        rep = json.loads(rj.read_text()).get("in_domain", {}).get("cnn_choice", "tsa") if rj.is_file() else "tsa"
    res["cnn_errors"] = cnn_errors(t, ranges, rep)
    res["cnn_errors_by_torque_tercile"] = cnn_errors_by(rep, "torque_nm")
    res["signal_level_gb_cv5"] = signal_level()
    (OUT / f"identifiability_{args.dataset}.json").write_text(json.dumps(res, indent=1, default=float))
    print(json.dumps(res, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
