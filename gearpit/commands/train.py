"""``gearpit train DATASET --out MODEL``: train a classifier on a generated dataset.

The CNN (default) or a feature-table baseline (``--model logreg|rf|gb``) for the
severity class, the severity fraction and the number of pitted teeth; or, with
``--task binary``, healthy versus damaged. Writes the model directory
(``model.json`` + ``weights.pt`` or ``arrays.npz``; see :mod:`models.io`).

Training options come from ``--config TRAIN.toml`` (a ``[train]`` table of
:class:`models.train.TrainConfig` fields with ``[train.representation]`` and
``[train.augment]`` sub-tables); the flags override it.
"""
from __future__ import annotations

import json
from pathlib import Path

from gearpit.errors import require


def register(sub) -> None:
    from models.representation_spec import KINDS

    p = sub.add_parser("train", help="train a classifier (CNN or feature baseline) on a dataset", description=__doc__)
    p.add_argument("dataset", type=Path, metavar="DATASET", help="generated dataset directory")
    p.add_argument("--out", type=Path, required=True, help="model directory to write")
    p.add_argument("--model", choices=("cnn", "logreg", "rf", "gb"), default="cnn", help="model type (default cnn)")
    p.add_argument("--config", type=Path, default=None, help="TOML with a [train] table (CNN options)")
    p.add_argument("--representation", choices=KINDS, default=None, help="CNN input representation (default order)")
    p.add_argument("--reference", action="store_true",
                   help="read each record against its healthy reference (a dataset generated with [sweep] "
                        "healthy_reference = true): the CNN's order / mesh_order / tsa input, or a baseline's "
                        "feature table with each column's change since the reference and the TSA residual's "
                        "indicators (models/reference_features.py)")
    p.add_argument("--task", choices=("multi", "binary"), default=None, help="severity classes or healthy/damaged")
    p.add_argument("--channel", default=None, help="dataset channel (default: the first stored)")
    p.add_argument("--pair", default=None, help="gear pair of the dataset to use (if it holds several)")
    p.add_argument("--epochs", type=int, default=None, help="maximum epochs (CNN)")
    p.add_argument("--seed", type=int, default=None, help="seed (default 0)")
    p.add_argument("--jobs", type=int, default=1, help="processes for the feature table (baselines)")
    p.add_argument("--quiet", action="store_true", help="no per-epoch lines")
    p.set_defaults(func=run)


def train_config_from(args):
    """The :class:`models.train.TrainConfig` of the TOML file and the flags (flags win)."""
    from gearpit.tomlio import check_keys, read_toml
    from models.train import TrainConfig

    values: dict = {}
    if args.config is not None:
        doc = read_toml(args.config)
        check_keys(doc, {"train"}, "", required={"train"})
        values = dict(doc["train"])
    if args.representation is not None:
        rep = dict(values.get("representation", {}))
        rep["kind"] = args.representation
        values["representation"] = rep
    if getattr(args, "reference", False):
        values["representation"] = {**dict(values.get("representation", {})), "reference": True}
    for flag, key in (("task", "task"), ("epochs", "max_epochs"), ("seed", "seed")):
        v = getattr(args, flag)
        if v is not None:
            values[key] = v
    return TrainConfig.from_dict(values)


def run(args) -> int:
    from models.io import save_model
    from models.sources import load_dataset

    require(args.jobs >= 1, "--jobs", args.jobs, "an integer >= 1")
    require(args.epochs is None or args.epochs >= 1, "--epochs", args.epochs, "an integer >= 1")
    cfg = train_config_from(args) if args.model == "cnn" else None  # validate before loading
    data = load_dataset(args.dataset, channel=args.channel, pair=args.pair)
    if args.model == "cnn":
        from models.train import train_cnn

        model = train_cnn(data, cfg, log=None if args.quiet else print)
    else:
        from models.baselines import feature_config_for, feature_table, fit_baseline

        fcfg = feature_config_for(data, reference=bool(args.reference))
        x, names = feature_table(data, fcfg, n_jobs=args.jobs)
        model = fit_baseline(data, args.model, features=x, feature_names=names, feature_config=fcfg,
                             task=args.task or "multi", seed=args.seed or 0)
    save_model(model, args.out)
    t = model.spec.training
    summary = {"model": str(args.out), "model_type": model.spec.model_type, "task": model.spec.task,
               "classes": model.spec.severity_classes, "n_train": t.get("n_train")}
    for k in ("val_accuracy", "val_teeth_accuracy", "epochs_run", "best_epoch", "seconds", "n_parameters"):
        if k in t:
            summary[k] = t[k]
    print(json.dumps(summary))
    return 0
