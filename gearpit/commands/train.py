"""``gearpit train DATASET [DATASET ...] --out MODEL``: train a classifier on generated datasets.

The CNN (default) or a feature-table baseline (``--model logreg|rf|gb``) for the
severity class, the severity fraction and the number of pitted teeth; or, with
``--task binary``, healthy versus damaged. Writes the model directory
(``model.json`` + ``weights.pt`` or ``arrays.npz``; see :mod:`models.io`).

Training options come from ``--config TRAIN.toml`` (a ``[train]`` table of
:class:`models.train.TrainConfig` fields with ``[train.representation]`` and
``[train.augment]`` sub-tables); the flags override it. The representation defaults to the
main job's (``gearpit demo``, :data:`models.workflow.DEFAULT_CONFIG`: TSA, chosen in experiments/RESULTS.md).
Several dataset directories (``data/default data/default_healthy``) are trained on as one.
A dataset not yet generated to its end, or a model whose novelty check could not be fitted,
is warned about on stderr and recorded in ``model.json``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from gearpit.errors import require

#: flags of the CNN only: a baseline trains on the feature table and ignores them
CNN_ONLY = (("representation", "--representation"), ("epochs", "--epochs"), ("config", "--config"))


def register(sub) -> None:
    from models.representation_spec import KINDS

    p = sub.add_parser("train", help="train a classifier (CNN or feature baseline) on a dataset", description=__doc__)
    p.add_argument("dataset", type=Path, nargs="+", metavar="DATASET",
                   help="generated dataset directory (several: trained on as one, e.g. data/default "
                        "data/default_healthy)")
    p.add_argument("--out", type=Path, required=True, help="model directory to write")
    p.add_argument("--model", choices=("cnn", "logreg", "rf", "gb"), default="cnn", help="model type (default cnn)")
    p.add_argument("--config", type=Path, default=None, help="TOML with a [train] table (CNN options)")
    p.add_argument("--representation", choices=KINDS, default=None, help="CNN input representation (default tsa, 8 revolutions x 1024 samples: the main job's, "
                        "chosen in experiments/RESULTS.md)")
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

    from models.workflow import DEFAULT_CONFIG

    values: dict = {}
    if args.config is not None:
        doc = read_toml(args.config)
        check_keys(doc, {"train"}, "", required={"train"})
        values = dict(doc["train"])
    if args.representation is None and "kind" not in dict(values.get("representation", {})):
        values["representation"] = {**DEFAULT_CONFIG.representation.to_dict(), **dict(values.get("representation", {}))}
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
    from dataclasses import replace

    from models.io import check_out_dir, save_model

    require(args.jobs >= 1, "--jobs", args.jobs, "an integer >= 1")
    require(args.epochs is None or args.epochs >= 1, "--epochs", args.epochs, "an integer >= 1")
    check_out_dir(args.out, "--out")
    cfg = train_config_from(args) if args.model == "cnn" else None  # validate before loading
    if args.model != "cnn":
        ignored = [flag for attr, flag in CNN_ONLY if getattr(args, attr) is not None]
        if ignored:
            warn(f"{', '.join(ignored)} {'does' if len(ignored) == 1 else 'do'} not apply to the {args.model} "
                 "baseline (it trains on the feature table); ignored")
    data, notes = training_data(args.dataset, channel=args.channel, pair=args.pair)
    for note in notes:
        warn(note)
    if args.model == "cnn":
        from models.train import train_cnn

        model = train_cnn(data, cfg, log=None if args.quiet else print)
    else:
        from models.baselines import feature_config_for, feature_table, fit_baseline, trainable

        trainable(data, args.task or "multi")       # two classes at least, before the feature table
        fcfg = feature_config_for(data, reference=bool(args.reference))
        x, names = feature_table(data, fcfg, n_jobs=args.jobs)
        model = fit_baseline(data, args.model, features=x, feature_names=names, feature_config=fcfg,
                             task=args.task or "multi", seed=args.seed or 0)
    t = model.spec.training
    if notes:
        t = {**t, "incomplete_dataset": "; ".join(notes)}
        model.spec = replace(model.spec, training=t)
    if isinstance(t.get("novelty"), str):
        warn(f"novelty check {t['novelty']}: predictions of this model carry no novelty (no warning for records "
             "unlike the training records); train on more records to have one")
    save_model(model, args.out)
    summary = {"model": str(args.out), "model_type": model.spec.model_type, "task": model.spec.task,
               "classes": model.spec.severity_classes, "n_train": t.get("n_train")}
    for k in ("val_accuracy", "val_teeth_accuracy", "epochs_run", "best_epoch", "seconds", "n_parameters"):
        if k in t:
            summary[k] = t[k]
    print(json.dumps(summary))
    return 0


def warn(text: str) -> None:
    print(f"warning: {text}", file=sys.stderr)


def training_data(paths: list[Path], *, channel: str | None, pair: str | None):
    """The records of one or several dataset directories (joined) and a note for every incomplete one
    ("incomplete dataset: N of M samples ...": the run that generates it did not finish)."""
    from datagen.dataset import INDEX, finished_shards, load_index, read_metadata
    from models.data import SignalSet, concat
    from models.sources import load_dataset

    sets, notes = [], []
    for path in paths:
        sets.append(load_dataset(path, channel=channel, pair=pair))
        if not (Path(path) / INDEX).is_file():     # the merged index is written when the last shard is done
            meta = read_metadata(path)
            notes.append(f"incomplete dataset: {len(load_index(path))} of {meta['n_samples']} samples ({path}: "
                         f"{len(finished_shards(path))} of {meta['n_shards']} shards generated); training on those")
    if len(sets) == 1:
        return sets[0], notes
    d = concat(sets)
    return SignalSet(d.signals, d.fs_hz, d.pair, d.labels, source=" + ".join(s.source for s in sets),
                     channel=d.channel, reference=d.reference), notes
