"""``gearpit predict MODEL FILES``: classify unlabelled measurements.

FILES are measurement files with sidecars (:mod:`compare.measurement`, :mod:`compare.sidecar`), folders
of them (together in one call), or a generated dataset directory. For every record prints the
predicted severity class with its probability (the confidence), the severity
fraction (clipped to [0, 1], with a warning when the regression lay far outside) and the pitted-teeth class, its novelty (how unlike the training records
its signal is, :mod:`models.novelty`: above 1 it is farther from every class than
99 % of held-out training records) and a warning when the record lies outside
what the model was trained on (speed, load or SNR outside the trained range; a
novelty above 1; with ``--allow-mismatch``, a different sampling rate or gear pair). A different
sampling rate, gear pair or a record too short is refused otherwise. A model trained without a healthy class
cannot answer "healthy": said once per call (stderr; ``model_has_healthy_class`` in every JSON / CSV row).
"""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np

from gearpit.errors import require
from models.data import BINARY_CLASSES


def register(sub) -> None:
    p = sub.add_parser("predict", help="classify unlabelled measurements with a trained model", description=__doc__)
    p.add_argument("model", type=Path, metavar="MODEL", help="model directory (gearpit train)")
    p.add_argument("files", type=Path, nargs="+", metavar="FILES", help="measurement files and folders of them, or a dataset")
    p.add_argument("--out", type=Path, default=None, help="also write the predictions to this CSV")
    p.add_argument("--json", action="store_true", help="print one JSON object per record instead of a table")
    p.add_argument("--channel", default=None, help="dataset channel (default: the model's training channel)")
    p.add_argument("--crops", type=int, default=3, help="test-time segments per record (CNN, default 3)")
    p.add_argument("--threads", type=int, default=min(2, os.cpu_count() or 1), choices=(1, 2),
                   help="worker threads of the CNN (default: 2 where there are two cores; same predictions)")
    p.add_argument("--sidecar-speed", action="store_true",
                   help="take each measurement's speed from its sidecar as it is (default: measured from the "
                        "tachometer channel, else from the mesh harmonics near the sidecar's value)")
    p.add_argument("--allow-mismatch", action="store_true",
                   help="warn instead of refusing a different sampling rate or gear pair where possible")
    p.set_defaults(func=run)


def run(args) -> int:
    from gearpit.atomic import atomic_path
    from gearpit.commands.evaluate import (load_data_without_meta, measurement_notes, no_novelty_note, predict_any,
                                           resolve_channel)
    from models.io import check_out_dir, load_model

    require(args.crops >= 1, "--crops", args.crops, "an integer >= 1")
    if args.out is not None:
        check_out_dir(args.out, "--out", file=True)
    model = load_model(args.model)
    data = load_data_without_meta(args.files, channel=resolve_channel(model, args.files, args.channel),
                                  refine_speed=not args.sidecar_speed, spec=model.spec,
                                  allow_mismatch=args.allow_mismatch)
    measurement_notes(data)
    pred = predict_any(model, data, crops=args.crops, allow_mismatch=args.allow_mismatch, threads=args.threads)
    data = data.merged() if hasattr(data, "merged") else data
    table = pred.to_frame()
    names = data.labels["file"] if "file" in data.labels else data.labels.get("sample_index", table.index)
    table.insert(0, "record", [str(v) for v in names])
    # a model without a healthy class calls every record a fault: said once per call (stderr), and in every row
    table["model_has_healthy_class"] = HEALTHY in model.spec.severity_classes
    # measurement files: the speed the model was given, how it was measured, whether the record was order-tracked
    for col in ("speed_rpm", "speed_method", "order_tracked"):
        if "speed_method" in data.labels and col in data.labels:
            table[col] = data.labels[col].to_numpy()
    if args.out is not None:
        with atomic_path(args.out) as tmp:
            table.to_csv(tmp, index=False)
    if args.json:
        for row in table.to_dict(orient="records"):
            print(json.dumps(row))
    else:
        cols = ["record", "severity_class", "confidence", "severity", "teeth_class", "teeth_confidence"]
        cols += [c for c in ("novelty", "speed_rpm", "speed_method") if c in table]
        print(table[cols].to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    for rec, w in zip(table["record"], table["warning"]):
        if w:
            print(f"warning: {rec}: {w}", file=sys.stderr)
    from models.novelty import batch_warning

    if pred.novelty_batch is not None and pred.novelty_batch["shifted"]:
        print("warning: " + batch_warning(pred.novelty_batch), file=sys.stderr)
    summary = warning_summary(pred, data)
    if summary:
        print(f"warning: {summary}; treat them with care", file=sys.stderr)
    for note in (no_novelty_note(model), no_healthy_note(model.spec)):
        if note:
            print(note, file=sys.stderr)
    return 0


#: the class of a gear without a fault (the binary task's first class, the sweeps' healthy bin)
HEALTHY = BINARY_CLASSES[0]


def no_healthy_note(spec) -> str | None:
    """One line for a model trained without a ``healthy`` class: it cannot answer "healthy", so a healthy gear
    always gets one of its fault classes; None when it has one."""
    if HEALTHY in spec.severity_classes:
        return None
    return (f"note: this model was trained without a healthy class (its classes: {', '.join(spec.severity_classes)}):"
            " it cannot answer 'healthy', so a healthy gear always gets one of these fault classes (JSON and CSV: "
            "model_has_healthy_class false); train with healthy records to tell a healthy gear from a pitted one")


#: the per-record notes of :func:`models.spec.check_input` that come from a label column, and what they are
NOTE_COLUMNS = (("unit_note", "no sensor_unit for a model that reads levels"), ("speed_note", "a speed note"), ("pair_note", "a pair or mesh-line note"), ("clip_note", "clipped"),
                ("drift_note", "drift removed"))


def warning_summary(pred, data) -> str:
    """How many records carry a warning, counted by what the warnings are (beyond the trained ranges, a note on
    the sidecar's speed or pair, clipping, drift, an allowed mismatch, novelty > 1); '' if none."""
    n = len(data)
    w = [str(v) for v in pred.warnings]
    kinds = [("beyond the trained ranges", np.array(["outside the trained range" in v for v in w]))]
    for col, what in NOTE_COLUMNS:
        if col in data.labels:
            kinds.append((what, data.labels[col].fillna("").astype(str).to_numpy() != ""))
    kinds.append(("severity regression clipped to [0, 1]", np.array(["severity regression" in v for v in w])))
    kinds.append(("another fs or pair (allowed)", np.array(["differs from the trained" in v or "gear pair named" in v
                                                            for v in w])))
    if pred.novelty is not None:
        kinds.append(("unlike the training records (novelty > 1)", np.asarray(pred.novelty) > 1.0))
    n_warn = sum(1 for v in w if v)
    if not n_warn:
        return ""
    counts = [f"{int(m.sum())} {what}" for what, m in kinds if m.any()]
    return f"{n_warn} of {n} records with warnings" + (f" ({', '.join(counts)})" if counts else "")
