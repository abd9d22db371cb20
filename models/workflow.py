"""Train and evaluate in one call: the classifier stage of the main job (``gearpit demo``).

:func:`train_and_evaluate` trains the CNN on a generated dataset (on a stratified
training part of it, or on all of it when a separate test dataset is given),
saves the model, scores it on the held-out records and writes the evaluation
(JSON, Markdown, CSV, PNG), all under one output directory:

    OUT/model/       model.json, weights.pt
    OUT/eval/        metrics.json, metrics.md, predictions.csv, confusion.png, breakdown.png
"""
from __future__ import annotations

from pathlib import Path

from gearpit.errors import require
from models.io import save_model
from models.representation_spec import RepresentationSpec
from models.sources import load_dataset
from models.train import TrainConfig, stratified_split, train_cnn

#: the CNN configuration of the main job: the representation chosen in experiments/RESULTS.md
DEFAULT_CONFIG = TrainConfig(representation=RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=1024))


def train_and_evaluate(dataset: str | Path, out: str | Path, *, test_dataset: str | Path | None = None,
                       config: TrainConfig = DEFAULT_CONFIG, test_fraction: float = 0.3, seed: int = 0) -> dict:
    """Train the CNN on ``dataset`` and evaluate it; return a JSON-able summary.

    Parameters
    ----------
    dataset : path
        Generated dataset directory (:mod:`datagen.dataset`).
    out : path
        Output directory (``model/`` and ``eval/`` are written in it).
    test_dataset : path, optional
        A separate labelled dataset to evaluate on; default: a stratified
        ``test_fraction`` of ``dataset`` is held out.
    config : TrainConfig
    test_fraction : float
    seed : int
        Seed of the held-out split.
    """
    from models.evaluate import evaluate, write_report
    from models.plots import plot_breakdown, plot_confusions

    require(0.0 < test_fraction < 1.0, "test_fraction", test_fraction, "a fraction in (0, 1)")
    data = load_dataset(dataset)
    if test_dataset is None:
        strata = (data.labels["severity_class"].astype(str) + "/" + data.teeth_classes().astype(str)).to_numpy()
        tr, te = stratified_split(strata, test_fraction, seed)
        require(te.size >= 1 and tr.size >= 4, "dataset", len(data), "enough records to hold some out")
        train, test = data.subset(tr), data.subset(te)
    else:
        train, test = data, load_dataset(test_dataset, channel=data.channel)
    model = train_cnn(train, config)
    out = Path(out)
    save_model(model, out / "model")
    pred = model.predict(test)
    metrics = evaluate(test, pred)
    write_report(metrics, pred, test, out / "eval", title=f"CNN ({config.representation.kind}) on held-out records")
    plot_confusions(metrics, out / "eval" / "confusion.png")
    plot_breakdown(metrics, out / "eval" / "breakdown.png")
    t = model.spec.training
    return {"n_train": len(train), "n_test": len(test), "representation": config.representation.kind,
            "epochs": t["epochs_run"], "train_seconds": t["seconds"], "n_parameters": t["n_parameters"],
            "accuracy": metrics["severity_class"]["accuracy"], "macro_f1": metrics["severity_class"]["macro_f1"],
            "teeth_accuracy": metrics.get("teeth", {}).get("accuracy"), "severity_mae": metrics.get("severity_mae"),
            "classes": model.spec.severity_classes, "model": str(out / "model"), "eval": str(out / "eval")}
