"""Does a healthy reference at a second load give the accelerometer the pit's size? (issue 6, a test of an idea)

Run: ``python experiments/two_load_reference.py [--fraction 0.5] [--workers 2]``; the last line is JSON.

Why
---
Read against a healthy reference of the same machine, the accelerometer's severity stays at 85-86 %
(``experiments/RESULTS.md``, "Reading against a healthy reference"), while the transmission error reaches
96-98 %. The difference is the housing path: the residual (record less reference) is the pit's excitation
through an unknown path, and the scale it is read against, the reference's own level, is mostly the gear's
profile error (11-21 um of transmission error against a 2-3 um stiffness ripple at these loads,
``experiments/severity_identifiability.py``), whose size and phase are random: so the ratio of the two says
how large the pit is against the profile error, not against the gear.

A pit's excitation is a loss of stiffness *under load*: quasi-statically the transmission error it adds is
``F (1/k_pitted - 1/k)``, proportional to the load ``F``. The profile error's is a displacement, independent
of the load. So the difference of two healthy recordings of the same machine at loads ``F1`` and ``F2``
cancels the profile error (the system is linear in the excitation) and leaves ``(F1 - F2)`` times the
healthy gear's stiffness ripple response, through the same path; at a mesh harmonic both the pit's
sidebands and that ripple pass the path's gain there. The ratio

    (residual near mesh harmonic m / F1) / (|ref(F1) - ref(F2)| at m / (F1 - F2))

is then the pit's compliance change over the healthy ripple, set by the gear alone: a path-free,
gain-free measure of the pit's size. A condition-monitoring baseline recorded at two loads (a commissioning
run, load-binned baselines) gives it.

What this script does
---------------------
1. For every record of ``default_pitch_ref`` (both draws, with the healthy parts), simulates its healthy
   twin again at ``--fraction`` of its torque (another noise seed; everything else as drawn) and stores the
   accelerometer channel in ``experiments/out/models/reference/second_load/<part>.npy`` (resumable per shard).
2. Computes the two-load features per record (:func:`two_load_features`).
3. Gradient boosting on the referenced feature table of ``experiments/reference_check.py --baselines``
   (cached there) with and without the two-load features, the protocol's split (2038 training records,
   362 test records), severity and teeth accuracy; and on the two-load features + speed + load alone.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

DATA = ROOT / "experiments" / "out" / "models" / "data"
OUT = ROOT / "experiments" / "out" / "models" / "reference"
PARTS = ("default_pitch_ref", "default_pitch_ref_healthy", "default_pitch_ref_second_draw",
         "default_pitch_ref_healthy_second_draw")
CHANNEL = "acc_pinion_loa_m_s2"
#: mesh-harmonic regions read separately (1..N_REGIONS)
N_REGIONS = 4
#: another noise stream than the reference's
SEED_SALT = 0x2_10AD


def _simulate_shard(args) -> tuple[int, np.ndarray]:
    part, indices, fraction = args
    from threadpoolctl import threadpool_limits

    from datagen.dataset import read_metadata
    from datagen.generate import build_case, simulate_batch
    from datagen.sampling import draw_sample, healthy_twin
    from datagen.sweep import sweep_from_dict

    sweep = sweep_from_dict(read_metadata(DATA / part)["config"])
    with threadpool_limits(1):
        cases = []
        for i in indices:
            twin = healthy_twin(sweep, draw_sample(sweep, int(i)))
            twin = dataclasses.replace(twin, torque_nm=twin.torque_nm * fraction,
                                       simulation_seed=(twin.simulation_seed ^ SEED_SALT) % 2**31)
            cases.append(build_case(sweep, twin, None))
        sig = simulate_batch(cases)
    return indices[0], np.stack([s.channels[CHANNEL] for s in sig]).astype(np.float32)


def second_load(part: str, fraction: float, workers: int) -> np.ndarray:
    """The second-load healthy records of every sample of ``part``, in the dataset's index order."""
    from datagen.dataset import load_index

    index = load_index(DATA / part).reset_index(drop=True)["sample_index"].to_numpy()
    path = OUT / "second_load" / f"{part}_{fraction:g}.npy"
    if path.is_file():
        return np.load(path)
    shard_dir = OUT / "second_load" / f"{part}_{fraction:g}_shards"
    shard_dir.mkdir(parents=True, exist_ok=True)
    chunks = [index[i:i + 16] for i in range(0, index.size, 16)]
    todo = [c for c in chunks if not (shard_dir / f"{c[0]}.npy").is_file()]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as ex:
        for k, (first, x) in enumerate(ex.map(_simulate_shard, [(part, c, fraction) for c in todo])):
            tmp = shard_dir / f"{first}.part.npy"
            np.save(tmp, x)
            tmp.replace(shard_dir / f"{first}.npy")
            print(f"  {part}: {k + 1}/{len(todo)} shards, {time.perf_counter() - t0:.0f} s", flush=True)
    out = np.concatenate([np.load(shard_dir / f"{c[0]}.npy") for c in chunks])
    tmp = path.with_suffix(".part.npy")
    np.save(tmp, out)
    tmp.replace(path)
    return out


def two_load_features(signals, reference, reference2, shaft_hz, torque_nm, fraction, fs_hz, z_pinion):
    """Per record: log10 of the residual's level over the load-difference ripple, in total and per
    mesh-harmonic region (module docstring), ``(n, 1 + N_REGIONS)``; and the names."""
    from models.reference_features import RESIDUAL_SPEC
    from models.tsa import _difference_mask, _tsa_comb, align_comb

    spec = RESIDUAL_SPEC
    n = signals.shape[0]
    out = np.full((n, 1 + N_REGIONS), np.nan)
    for i in range(n):
        fr = float(shaft_hz[i])
        c, c0, c2 = (_tsa_comb(np.asarray(x[i], float) - np.mean(x[i]), spec, fs_hz, fr, (0.0,), z_pinion)[0]
                     for x in (signals, reference, reference2))
        res = c - align_comb(c, c0)[0]
        ripple = c0 - align_comb(c0, c2)[0]
        K = c.size - 1
        top = min(K, int(0.45 * fs_hz / fr))           # orders the sensor's band holds
        keep = _difference_mask(K + 1, z_pinion)
        keep[top + 1:] = False
        f1 = float(torque_nm[i])
        df = f1 * (1.0 - fraction)
        harm = np.arange(1, top // z_pinion + 1) * z_pinion
        rip = np.abs(ripple[harm]) / df                   # per newton metre of pinion torque
        r_all = np.sqrt(np.sum(np.abs(res[keep]) ** 2)) / f1
        out[i, 0] = np.log10(r_all / max(np.sqrt(np.sum(rip ** 2)), 1e-300) + 1e-300)
        orders = np.arange(K + 1)
        for m in range(1, N_REGIONS + 1):
            if m > harm.size:
                continue
            sel = keep & (np.abs(orders - m * z_pinion) <= z_pinion // 2)
            r_m = np.sqrt(np.sum(np.abs(res[sel]) ** 2)) / f1
            out[i, m] = np.log10(r_m / max(rip[m - 1], 1e-300) + 1e-300)
    names = ["two_load:all"] + [f"two_load:h{m}" for m in range(1, N_REGIONS + 1)]
    return out, names


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fraction", type=float, default=0.5, help="second load as a fraction of the record's")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--split", default="in_domain", choices=["in_domain", "speed", "load"],
                    help="the sensor protocol's splits (speed / load: train below 1200 rpm / 50 N m, test at or above)")
    args = ap.parse_args(argv)
    assert 0.0 < args.fraction < 1.0, "--fraction must lie in (0, 1)"
    from classifier_runs import SEED, strata
    from models.sources import load_dataset
    from models.data import concat
    from models.train import stratified_split
    from sklearn.ensemble import HistGradientBoostingClassifier, RandomForestClassifier

    t0 = time.perf_counter()
    sets, feats = {}, {}
    for part in PARTS:
        d = load_dataset(DATA / part, channel=CHANNEL)
        cache = OUT / "second_load" / f"{part}_{args.fraction:g}_features.npy"
        if cache.is_file():
            f = np.load(cache)
        else:
            r2 = second_load(part, args.fraction, args.workers)
            f = two_load_features(d.signals, d.reference, r2, d.shaft_hz(), d.labels["torque_nm"].to_numpy(),
                                  args.fraction, d.fs_hz, int(d.pair.z_pinion))[0]
            np.save(cache, f)
        sets[part], feats[part] = d, f
        print(f"{part}: {len(d)} records, features {time.perf_counter() - t0:.0f} s", flush=True)
    draw1 = concat([sets[PARTS[0]], sets[PARTS[1]]])
    draw2 = concat([sets[PARTS[2]], sets[PARTS[3]]])
    f1 = np.vstack([feats[PARTS[0]], feats[PARTS[1]]])
    f2 = np.vstack([feats[PARTS[2]], feats[PARTS[3]]])
    tab1 = np.load(OUT / "features" / "acc_draw1.npz")
    tab2 = np.load(OUT / "features" / "acc_draw2.npz")
    tnames = [str(v) for v in tab1["names"]]
    assert tab1["x"].shape[0] == len(draw1) and tab2["x"].shape[0] == len(draw2), "cached tables' records"
    if args.split == "in_domain":
        tr, te = stratified_split(strata(draw1), 0.3, SEED)
        tr2 = np.arange(len(draw2))
    else:
        from sensor_protocol_design import draw_training_rows, splits

        tr, te, _ = splits(draw1, inner=True)[args.split]
        tr2 = draw_training_rows(args.split, draw2)

    def xy(x1, x2):
        return np.vstack([x1[tr], x2[tr2]]), x1[te]

    lab_tr = {k: np.concatenate([draw1.labels[k].to_numpy()[tr], draw2.labels[k].to_numpy()[tr2]])
              for k in ("severity_class", "teeth_class")}
    lab_te = {k: draw1.labels[k].to_numpy()[te] for k in lab_tr}
    op = lambda d: np.log10(d.labels[["speed_rpm", "torque_nm"]].to_numpy(float))      # noqa: E731
    sets_x = {
        "referenced table": xy(tab1["x"], tab2["x"]),
        "referenced table + two-load": xy(np.hstack([tab1["x"], f1]), np.hstack([tab2["x"], f2])),
        "residual scalars (rms_over_own, rms_over_ref) + speed, load": xy(
            np.hstack([tab1["x"][:, [tnames.index("residual:rms_over_own"), tnames.index("residual:rms_over_ref")]],
                       op(draw1)]),
            np.hstack([tab2["x"][:, [tnames.index("residual:rms_over_own"), tnames.index("residual:rms_over_ref")]],
                       op(draw2)])),
        "two-load + speed, load": xy(np.hstack([f1, op(draw1)]), np.hstack([f2, op(draw2)])),
    }
    res = {"fraction": args.fraction, "split": args.split, "n_train": int(len(tr) + len(tr2)), "n_test": int(len(te)), "runs": {}}
    models = {"gb": lambda s: HistGradientBoostingClassifier(random_state=s, max_iter=300, learning_rate=0.05),
              "rf": lambda s: RandomForestClassifier(n_estimators=300, random_state=s, n_jobs=2)}
    print("| inputs | model | severity % | teeth % |\n|---|---|---|---|")
    for name, (xtr, xte) in sets_x.items():
        for mname, make in models.items():
            acc = {}
            for task in ("severity_class", "teeth_class"):
                clf = make(0).fit(np.nan_to_num(xtr, nan=-9.0), lab_tr[task])
                acc[task] = float(np.mean(clf.predict(np.nan_to_num(xte, nan=-9.0)) == lab_te[task]))
            res["runs"][f"{name} [{mname}]"] = acc
            print(f"| {name} | {mname} | {100 * acc['severity_class']:.1f} | {100 * acc['teeth_class']:.1f} |",
                  flush=True)
    pitted = lab_te["severity_class"] != "healthy"
    fte = f1[te]
    for cls in ("minor", "moderate", "severe"):
        s = lab_te["severity_class"] == cls
        q = np.nanpercentile(fte[s, 0], [5, 50, 95])
        res.setdefault("two_load_all_percentiles", {})[cls] = [round(float(v), 3) for v in q]
        print(f"two_load:all, {cls}: 5/50/95 % {q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f}")
    res["n_pitted_test"] = int(pitted.sum())
    res["seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
