"""``gearpit evaluate MODEL DATA``: score a trained model on labelled records.

DATA is a generated dataset directory, a folder of labelled measurement files
(sidecars + ``labels.csv``, see :mod:`models.sources`) or measurement files.
Writes into ``--out`` (default ``MODEL/eval``): ``metrics.json`` and
``metrics.md`` (accuracy, macro-F1, confusion matrices, severity MAE, breakdown
per speed and load), ``predictions.csv``, ``confusion.png`` and ``breakdown.png``.
"""
from __future__ import annotations

import json
import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from gearpit.errors import require


def register(sub) -> None:
    p = sub.add_parser("evaluate", help="score a model on a labelled dataset or measurements (JSON, MD, PNG)",
                       description=__doc__)
    p.add_argument("model", type=Path, metavar="MODEL", help="model directory (gearpit train)")
    p.add_argument("data", type=Path, nargs="+", metavar="DATA", help="dataset directory, measurement folder or files")
    p.add_argument("--out", type=Path, default=None, help="output directory (default MODEL/eval)")
    p.add_argument("--channel", default=None, help="dataset channel (default: the model's training channel)")
    p.add_argument("--pair", default=None, help="gear pair of the dataset to use (if it holds several)")
    p.add_argument("--crops", type=int, default=3, help="test-time segments per record (CNN, default 3)")
    p.add_argument("--threads", type=int, default=min(2, os.cpu_count() or 1), choices=(1, 2),
                   help="worker threads of the CNN (default: 2 where there are two cores; same predictions)")
    p.add_argument("--sidecar-speed", action="store_true",
                   help="take each measurement's speed from its sidecar as it is (default: measured from the "
                        "tachometer channel, else from the mesh harmonics near the sidecar's value)")
    p.add_argument("--allow-mismatch", action="store_true",
                   help="warn instead of refusing a different sampling rate or gear pair where possible")
    p.set_defaults(func=run)


def predict_any(model, data, *, crops: int, allow_mismatch: bool, threads: int = 1):
    """Predictions of a CNN (``threads`` worker threads) or a feature baseline; ``data`` a signal set or the groups
    of measurement files (:class:`models.record_groups.RecordGroups`), each group checked, then predicted."""
    from models.classifier import CNNClassifier
    from models.record_groups import RecordGroups

    if isinstance(data, RecordGroups):
        return data.predict(lambda d: predict_any(model, d, crops=crops, allow_mismatch=allow_mismatch,
                                                  threads=threads), model.spec, allow_mismatch=allow_mismatch,
                            novelty=model.novelty if isinstance(model, CNNClassifier) else model.novelty_model())
    if isinstance(model, CNNClassifier):
        return model.predict(data, n_crops=crops, allow_mismatch=allow_mismatch, threads=threads)
    return model.predict(data, allow_mismatch=allow_mismatch)


def resolve_channel(model, paths: list[Path], channel: str | None) -> str | None:
    """The channel to read from a dataset: the flag, else the model's training channel.

    Raises
    ------
    InputError
        The dataset does not store the trained channel (and no ``--channel`` names another): naming both the
        trained channel and the stored ones.
    """
    if channel is not None or len(paths) != 1 or not (paths[0] / "metadata.json").is_file():
        return channel
    from datagen.dataset import read_metadata

    stored = read_metadata(paths[0])["channels"]
    trained = model.spec.channel
    if trained is None:          # a model saved before the channel was recorded: the dataset's first
        return None
    require(trained in stored, "channel", f"{trained} (the model's training channel)",
            f"a channel {paths[0]} stores: it stores {', '.join(stored)}; name one with --channel to evaluate on it")
    return trained


def no_novelty_note(model) -> str | None:
    """One line for a model without a novelty check (:mod:`models.novelty`), with the reason recorded in training;
    None when it has one."""
    from models.classifier import CNNClassifier

    has = model.novelty is not None if isinstance(model, CNNClassifier) else model.novelty_model() is not None
    if has:
        return None
    why = model.spec.training.get("novelty")
    why = why if isinstance(why, str) else "saved without one"
    return (f"note: this model has no novelty check ({why}): no novelty column, no warning for records unlike "
            "the training records")


def load_data_without_meta(paths, **kw):
    """:func:`models.sources.load_data`, its missing-sidecar message worded for a command without ``--meta``."""
    from gearpit.errors import InputError
    from models.sources import load_data

    try:
        return load_data(paths, **kw)
    except InputError as exc:
        if exc.field != "--meta":
            raise
        raise InputError("sidecar", exc.value, exc.allowed.replace(" given with --meta or found beside the file as",
                                                                   " beside the file, named")) from None


def measurement_notes(data) -> None:
    """The files a folder run skipped, one line each on stderr."""
    for line in getattr(data, "skipped", ()):
        print(f"warning: {line}", file=sys.stderr)


def unit_notes(data) -> list[str]:
    """The measurement files read without a ``sensor_unit`` by a model that reads absolute levels, one note each
    (:func:`models.measurement_files.unit_note`); [] for a dataset or a level-free model."""
    if "unit_note" not in data.labels:
        return []
    notes = data.labels["unit_note"].fillna("").astype(str)
    return [f"{f}: {v}" for f, v in zip(data.labels["file"], notes) if v]


def run(args) -> int:
    from models.evaluate import evaluate, report_markdown, write_report
    from models.io import check_out_dir, load_model
    from models.plots import plot_breakdown, plot_confusions

    require(args.crops >= 1, "--crops", args.crops, "an integer >= 1")
    out = check_out_dir(args.out if args.out is not None else args.model / "eval", "--out")
    model = load_model(args.model)
    data = load_data_without_meta(args.data, channel=resolve_channel(model, args.data, args.channel), pair=args.pair,
                                  refine_speed=not args.sidecar_speed, spec=model.spec,
                                  allow_mismatch=args.allow_mismatch, classes=model.spec.severity_classes)
    measurement_notes(data)
    labelled = data.merged() if hasattr(data, "merged") else data
    require(labelled.has_labels(), "DATA", labelled.source, "labelled records (a severity_class label at least)")
    unscored = labelled.labels["severity_class"].isna().to_numpy()     # label 'unknown': predicted, not scored
    require(not unscored.all(), "DATA", labelled.source, "at least one labelled record (not 'unknown')")
    pred = predict_any(model, data, crops=args.crops, allow_mismatch=args.allow_mismatch, threads=args.threads)
    data = labelled
    if unscored.any():
        print(f"warning: {int(unscored.sum())} file(s) predicted but not scored (label 'unknown'): "
              + ", ".join(str(v) for v in labelled.labels["file"][unscored]), file=sys.stderr)
        keep = np.flatnonzero(~unscored)
        data, pred = labelled.subset(keep), pred.subset(keep)
        data = replace(data, source=", ".join(str(v) for v in data.labels["file"][:3])
                       + (f" (+{len(data) - 3})" if len(data) > 3 else ""))
    metrics = evaluate(data, pred)
    metrics["n_unscored"] = int(unscored.sum())
    metrics["unit_notes"] = unit_notes(labelled)
    for line in metrics["unit_notes"]:
        print(f"warning: {line}", file=sys.stderr)
    metrics["model"] = str(args.model)
    note = no_novelty_note(model)
    if note:
        print(note, file=sys.stderr)
    write_report(metrics, pred, data, out, title=f"Evaluation of {args.model.name} on {data.source}")
    plot_confusions(metrics, out / "confusion.png")
    plot_breakdown(metrics, out / "breakdown.png")
    print(report_markdown(metrics).split("## Severity class confusion")[0].rstrip())
    print(json.dumps({"accuracy": metrics["severity_class"]["accuracy"], "macro_f1": metrics["severity_class"]["macro_f1"],
                      "teeth_accuracy": metrics.get("teeth", {}).get("accuracy"), "severity_mae": metrics.get("severity_mae"),
                      "severity_mae_n": metrics.get("severity_mae_n"), "unit_notes": len(metrics["unit_notes"]),
                      "out": str(out)}))
    return 0
