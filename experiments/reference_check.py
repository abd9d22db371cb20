"""Classifiers read against a healthy reference of the same machine: in-domain, on another simulator, on real data.

Run: ``python experiments/reference_check.py [--records N] [--seed S] [--skip PART ...] [--variants V ...]
[--channel dte_m] [--more] [--split speed|load] [--train-seed S]
[--baselines]``. The last line is JSON.

Every classifier of ``experiments/eval_protocol.py`` reads a record alone, and two things defeat it that a
record alone cannot settle (``experiments/RESULTS.md``): a healthy gear's own random tooth-to-tooth spacing
errors look like pitting (``default_pitch``: 68 / 67 % in-domain on the accelerometer), and another simulator's
gear looks pitted to a model trained on ours (30 / 31 %). A user who monitors a machine has what removes both:
a recording of the same machine before the fault. ``reference = true`` (:mod:`models.representations`) reads
the log ratio of the record's order spectrum to the reference's, in which the machine's own spacing errors,
eccentricity, sensor gain and housing path cancel.

Parts (each on the housing accelerometer ``acc_pinion_loa_m_s2``):

1. **in-domain**: ``experiments/models_sweeps/default_pitch_ref{,_healthy}.toml`` (``default_pitch`` with each
   sample's healthy twin, ``[sweep] healthy_reference = true``); the protocol's stratified 70/30 split; the
   order-spectrum CNN read against the reference (``order_ref``) beside the same CNN on the record alone
   (``order``), same records, same split, same training settings.
2. **another simulator**: the records of ``experiments/foreign_classifier_check.py`` (``tests/foreign_rig.py``:
   ISO 6336 stiffness, 3-DOF model, RK4; random-walk pitch errors of 5-15 um), each with its healthy twin (the
   same rig without pits, other noise) as the sidecar's ``reference``, read through the user's path
   (:func:`models.sources.load_measurements`, speed from the tachometer).
3. **real data**: SpectraQuest (``../shared/data/spectraquest_gfd``, healthy vs broken tooth, 30 Hz, loads 0-90 %;
   sampling rate undocumented, so the mesh-order CNN ``mesh_order_ref``, binary, trained on part 1's data with
   pitted = damaged). Reference of a record at load L: a record of the *healthy* file at load L. The healthy file's
   first half gives the references, its second half the healthy test records; the broken file's records are
   all test records. Limit: the healthy test records and their references come from the same run, the broken
   ones from another run, so a run-to-run change of the rig (remounting, temperature) would also read as damage;
   the recordings do not say whether one happened.

``--baselines``: the feature-table baselines too (:mod:`models.reference_features`: each column's change since
the reference and the TSA residual's indicators), beside the same baselines on the record's own columns.

Run: about 20 min on 2 cores with the default variants (datasets of part 1, 2 x 1200 records with twins: 2 min;
the foreign records: 2 min; five CNN trainings of 1-3 min). ``--channel dte_m --more --variants te_ref_res te_diff``:
the transmission error, trained on 2038 records (a second draw of the sweep, 2 min more), 12 min; ``--split
speed|load``: the sensor protocol's cross-condition splits.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "experiments"))

from models.representation_spec import RepresentationSpec  # noqa: E402

OUT = ROOT / "experiments" / "out" / "models" / "reference"
TRAIN = "default_pitch_ref"
ORDER = RepresentationSpec(kind="order", n_revs=8, max_order=100.0)
TE_TSA = RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024, lowpass_mesh_orders=1.25,
                            remove_shaft_1x=True)
TSA_REF = RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024, reference=True)
VARIANTS = {"order_ref": (RepresentationSpec(kind="order", n_revs=8, max_order=100.0, reference=True), ()),
            "order": (ORDER, ()),
            "tsa_ref_op": (TSA_REF, ("speed_rpm", "torque_nm")),
            "tsa_op": (RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024), ("speed_rpm", "torque_nm")),
            # the transmission error (--channel dte_m): tsa_te_diff of experiments/train_te_encoders.toml, and the
            # same TSA read against the reference with the load and the record's level in metres
            "te_diff": (TE_TSA, ("torque_nm", "signal_rms_no1x", "tsa_diff_rms", "tooth_profile")),
            "te_ref": (dataclasses.replace(TE_TSA, reference=True), ("torque_nm", "signal_rms_no1x")),
            # and with the residual's level in metres and its pitted-teeth profile (models/operating.py)
            "te_ref_res": (dataclasses.replace(TE_TSA, reference=True),
                           ("torque_nm", "signal_rms_no1x", "residual_rms", "residual_profile")),
            "tsa_ref_res": (TSA_REF, ("speed_rpm", "torque_nm", "residual_profile")),
            # the TSA and its residual whitened by the reference's mesh harmonics (models.tsa.mesh_whitening)
            "tsa_ref_w_op": (dataclasses.replace(TSA_REF, whiten=True), ("speed_rpm", "torque_nm"))}
MESH_ORDER_REF = {"mesh_order_ref": (RepresentationSpec(kind="mesh_order", n_mesh_periods=256, max_order=4.0,
                                                        reference=True), ())}
REAL = ROOT.parent / "shared" / "data" / "spectraquest_gfd"


def real_with_references(channel: str):
    """SpectraQuest records of one channel with references (module docstring, part 3), or None without the data."""
    from models.data import SignalSet, concat
    from models.unknown_rate import load_unknown_rate_csv

    files = sorted(REAL.glob("*30hz*.csv"))
    if not files:
        return None
    d = load_unknown_rate_csv(files, channel=channel, record_samples=8192)
    lab = d.labels
    parts = []
    for load in sorted(lab["load_percent"].unique()):
        h = np.nonzero((lab["load_percent"] == load).to_numpy() & (lab["severity_class"] == "healthy").to_numpy())[0]
        b = np.nonzero((lab["load_percent"] == load).to_numpy() & (lab["severity_class"] != "healthy").to_numpy())[0]
        half = h.size // 2
        refs, tests = h[:half], h[half:]
        for idx in (tests, b):
            part = d.subset(idx)
            ref = d.signals[refs[np.arange(idx.size) % refs.size]]
            parts.append(SignalSet(part.signals, part.fs_hz, part.pair, part.labels, part.source, part.channel,
                                   reference=np.asarray(ref)))
    return concat(parts)


def cached_table(data, cfg: dict, path: Path, jobs: int) -> tuple[np.ndarray, list[str]]:
    """Feature table of ``data`` (:func:`models.baselines.feature_table`), kept in ``path`` for reruns."""
    from models.baselines import feature_table

    if path.is_file():
        z = np.load(path, allow_pickle=False)
        if z["x"].shape[0] == len(data):
            return z["x"], [str(v) for v in z["names"]]
    x, names = feature_table(data, cfg, n_jobs=jobs)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".part.npz")
    np.savez(tmp, x=x, names=np.array(names))
    tmp.replace(path)
    return x, names


def baselines(parts: dict, train_rows: dict, test_rows: dict, foreign, channel: str, jobs: int) -> dict:
    """The three feature-table baselines on the table read against the reference
    (:mod:`models.reference_features`) and, as the control, on the record's own columns of the same table (the
    baselines of ``eval_protocol``); the best of each chosen on an internal 80/20 split of the training part.

    ``parts``: name -> SignalSet (the sweep's draws), each tabulated once (cached under ``OUT / "features"``);
    ``train_rows``: part name -> its training rows; ``test_rows``: test name -> rows of ``parts["draw1"]``;
    ``foreign``: a further test set or None."""
    from classifier_runs import baseline_runs
    from models.baselines import feature_config_for
    from models.data import concat

    cfg = feature_config_for(parts["draw1"], reference=True)
    tab = {k: cached_table(v, cfg, OUT / "features" / f"{channel}_{k}.npz", jobs) for k, v in parts.items()}
    names = tab["draw1"][1]
    x = np.vstack([tab[k][0][r] for k, r in train_rows.items()])
    train = concat([parts[k].subset(r) for k, r in train_rows.items()])
    tests = {k: (parts["draw1"].subset(r), tab["draw1"][0][r]) for k, r in test_rows.items()}
    if foreign is not None:
        tests["foreign"] = (foreign, cached_table(foreign, cfg, OUT / "features" / f"{channel}_foreign.npz", jobs)[0])
    own = int(sum(not n.startswith(("delta:", "residual:")) for n in names))
    plain = {k: v for k, v in cfg.items() if k != "reference"}
    tag = "_".join(sorted(train_rows)) + "_" + "_".join(sorted(test_rows))
    return {"reference": baseline_runs(train, x, tests, names, cfg, OUT / f"baselines_ref_{channel}_{tag}"),
            "record_alone": baseline_runs(train, x[:, :own], {k: (t, v[:, :own]) for k, (t, v) in tests.items()},
                                          names[:own], plain, OUT / f"baselines_{channel}_{tag}"),
            "n_features": {"reference": len(names), "record_alone": own}, "n_train": len(train)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--records", type=int, default=8, help="foreign records per cell (12 cells)")
    ap.add_argument("--seed", type=int, default=1, help="foreign records' seed")
    ap.add_argument("--skip", nargs="*", default=[], choices=["foreign", "real"])
    ap.add_argument("--variants", nargs="*", default=["order_ref", "order", "tsa_ref_op", "tsa_op"],
                    choices=list(VARIANTS))
    ap.add_argument("--train-seed", type=int, default=None,
                    help="CNN training seed (default: the protocol's, 0; the split stays the protocol's)")
    ap.add_argument("--split", default="in_domain", choices=["in_domain", "speed", "load"],
                    help="speed / load: the sensor protocol's cross-condition splits (needs --more; test records "
                         "at or above 1200 rpm / 50 N m, training records below, from both draws)")
    ap.add_argument("--more", action="store_true",
                    help="train on the split's 70 %% plus a second draw of the sweep (2038 records, as "
                         "experiments/sensor_protocol.py does)")
    ap.add_argument("--channel", default=None, help="stored channel (default: the accelerometer; dte_m: the "
                    "transmission error, without the foreign and real parts, which have no such channel)")
    ap.add_argument("--baselines", action="store_true",
                    help="also the feature-table baselines (logreg, rf, gb) read against the reference, and on the "
                         "record's own columns as the control")
    ap.add_argument("--jobs", type=int, default=2, help="processes for the feature tables (--baselines)")
    args = ap.parse_args(argv)
    from classifier_runs import OUT as DATA_OUT, SEED, cnn_run, dataset, log, strata
    from models.sources import load_measurements, measurement_files
    from models.train import stratified_split

    t0 = time.perf_counter()
    data = dataset(TRAIN, DATA_OUT / "data", channel=args.channel)
    if args.channel not in (None, "acc_pinion_loa_m_s2"):
        args.skip = ["foreign", "real"]
    if args.split != "in_domain":
        assert args.more, "--split speed|load needs --more (the sensor protocol's training records)"
        args.skip = ["foreign", "real"]
    assert data.reference is not None, "the training sweep must store healthy twins"
    tr, te = stratified_split(strata(data), 0.3, SEED)
    tests = {"in_domain": data.subset(te)}
    parts, train_rows, test_rows = {"draw1": data}, {"draw1": tr}, {"in_domain": te}   # for the baselines
    if "foreign" not in args.skip:
        from foreign_classifier_check import write_folder

        folder = write_folder(OUT / f"foreign_seed{args.seed}", args.records, args.seed, references=True)
        tests["foreign"] = load_measurements(measurement_files(folder))
        log(f"foreign records with references: {folder} ({time.perf_counter() - t0:.0f} s)")
    train = data.subset(tr)
    if args.more:
        from models.data import concat
        from sensor_protocol_design import second_draw, training_and_test

        more = second_draw(DATA_OUT / "data", args.channel, base=TRAIN)
        parts["draw2"] = more
        if args.split == "in_domain":
            train = concat([train, more])
            train_rows["draw2"] = np.arange(len(more))
        else:
            train, test, (tr1, te1, tr2) = training_and_test(args.split, data, more)
            tests = {args.split: test}
            train_rows, test_rows = {"draw1": tr1, "draw2": tr2}, {args.split: te1}
    if args.train_seed is not None:       # cnn_run reads the protocol's seed when it trains
        import classifier_runs
        classifier_runs.SEED = args.train_seed
    res = {"train": TRAIN + (" + second draw" if args.more else ""), "split": args.split, "n_train": len(train),
           "n_test": {k: len(v) for k, v in tests.items()}, "cnn": {}}
    for variant in args.variants:  # "order", "tsa_op" read the same records without their references
        res["cnn"][variant] = cnn_run(train, tests, variant,
                                      OUT / f"cnn_{variant}{'_' + args.channel if args.channel else ''}"
                                      f"{'_more' if args.more else ''}"
                                      f"{'' if args.split == 'in_domain' else '_' + args.split}"
                                      f"{'' if args.train_seed is None else f'_seed{args.train_seed}'}",
                                      variants=VARIANTS)
    if args.baselines:
        res["baselines"] = baselines(parts, train_rows, test_rows, tests.get("foreign"), args.channel or "acc",
                                     args.jobs)
    if "real" not in args.skip:
        real = {ch: real_with_references(ch) for ch in ("a1", "a2", "a3", "a4")}
        if all(v is not None for v in real.values()):
            res["real"] = cnn_run(data, real, "mesh_order_ref", OUT / "cnn_mesh_order_ref", task="binary",
                                  allow_mismatch=True, variants=MESH_ORDER_REF)
            res["real"]["n_records"] = {ch: len(v) for ch, v in real.items()}
            res["real"]["called_damaged"] = {}
            for ch in real:
                m = json.loads((OUT / "cnn_mesh_order_ref" / ch / "metrics.json").read_text())
                conf = np.asarray(m["severity_class"]["confusion"])
                res["real"]["called_damaged"][ch] = float(conf[:, 1].sum() / conf.sum())
        else:
            res["real"] = {"skipped": f"no files in {REAL}"}
    print("| model | " + " | ".join(tests) + " |")
    print("|---|" + "---|" * len(tests))
    for variant, r in res["cnn"].items():
        print(f"| CNN {variant} | " + " | ".join(f"{100 * r[k]['accuracy']:.1f} / {100 * r[k]['teeth_accuracy']:.1f}"
                                                for k in tests) + " |")
    for group in ("reference", "record_alone"):
        if group not in res.get("baselines", {}):
            continue
        r = res["baselines"][group]
        best = r["best"]
        print(f"| baseline {best} ({group.replace('_', ' ')}) | " + " | ".join(
            f"{100 * r[best][k]['accuracy']:.1f} / {100 * r[best][k]['teeth_accuracy']:.1f}" for k in tests) + " |")
    if "real" in res and "skipped" not in res["real"]:
        print("real data (binary): " + ", ".join(f"{ch} {100 * res['real'][ch]['accuracy']:.1f} % "
                                                 f"(called damaged {100 * res['real']['called_damaged'][ch]:.0f} %)"
                                                 for ch in ("a1", "a2", "a3", "a4")))
    res["seconds"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(res, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
