"""``gearpit rank-features DATASET``: feature table of a dataset and a ranking of
every feature by class separation, monotonicity with severity and robustness
to speed and noise -> features.parquet, feature_ranking.csv/.md/.png.

Two dataset layouts are read:

1. a ``gearpit generate`` dataset (``DATASET/metadata.json`` with
   ``"format": "gearpit-dataset"``): index, signals (``--channel``, default the
   first) and tooth counts per ``pair`` through :mod:`datagen.dataset`; the
   features' unit follows the channel's (:func:`channel_unit`). A dataset still
   being generated (or stopped) is ranked on its finished samples with a warning
   ``incomplete dataset: N of M samples`` on stderr, in ``feature_ranking.md`` and
   in the ``dataset`` attribute of ``features.parquet``;
2. a plain layout for signals from elsewhere:

   - ``DATASET/index.parquet``: one row per record, in the order of the signals,
     with ``severity`` (required), ``severity_class``, ``n_pitted_teeth``,
     ``speed_rpm`` (pinion speed, required), ``snr_db`` and any other labels;
     without ``severity_class`` the classes are made from ``severity``
     (:func:`features.ranking.severity_classes`: its distinct values when few, else
     healthy records and equal-frequency bins of the damaged ones), said on stderr
     and atop ``feature_ranking.md``; too few records for two classes is an error;
   - ``DATASET/signals.npy``: float array ``(n_records, n_samples)``;
   - ``DATASET/meta.json``: ``{"fs_hz": ..., "z_pinion": ..., "z_wheel": ...}``
     (optional ``"signal_unit"``; other keys are ignored).

Feature options come from ``--config`` (a ``[features]`` table, e.g.
``speed_source = "mesh_phase"``) and the flags; ``speed_source = "tacho"`` is not
available here (neither layout has a tacho channel).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from features.ranking import rank_features, ranking_markdown, write_ranking
from features.table import ENVELOPE_BANDS, HHT_METHODS, FeatureConfig, extract_features
from gearpit.atomic import atomic_path
from gearpit.errors import InputError, require
from gearpit.tomlio import check_keys, read_toml

META_KEYS = {"fs_hz", "z_pinion", "z_wheel", "signal_unit"}
#: unit of a simulator channel from its name, which carries it (datagen.output_channels); longest suffix first
CHANNEL_UNITS = (("_m_s2", "m/s^2"), ("_rpm", "rpm"), ("_n", "N"), ("_m", "m"))


def register(sub) -> None:
    p = sub.add_parser("rank-features", help="feature table of a dataset and a ranking of the features (CSV, MD, PNG)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("dataset", type=Path, metavar="DATASET",
                   help="dataset directory (gearpit generate output, or index.parquet + signals.npy + meta.json)")
    p.add_argument("--channel", default=None, help="signal channel of a generated dataset (default: the first)")
    p.add_argument("--out", type=Path, default=None, help="output directory (default DATASET/feature_ranking)")
    p.add_argument("--config", type=Path, default=None,
                   help="TOML with a [features] table of features.table.FeatureConfig fields (fs_hz, teeth from the dataset)")
    p.add_argument("--hht", choices=HHT_METHODS, default=None, help="decomposition for the HHT features (default emd)")
    p.add_argument("--envelope-band", choices=ENVELOPE_BANDS, default=None, help="envelope band (default full)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1; -1 = all cores)")
    p.add_argument("--seed", type=int, default=0, help="seed of EEMD noise and of the MI estimator")
    p.add_argument("--top", type=int, default=25, help="features in the Markdown table and the figure")
    p.set_defaults(func=run)


def read_plain_dataset(path: Path) -> tuple[pd.DataFrame, np.ndarray, dict]:
    """Index, signals and metadata of the plain layout (module docstring, layout 2)."""
    files = {name: path / name for name in ("index.parquet", "signals.npy", "meta.json")}
    for name, f in files.items():
        require(f.is_file(), "DATASET", str(path), f"a gearpit dataset (metadata.json) or a directory with {name}")
    try:
        meta = json.loads(files["meta.json"].read_text())
    except json.JSONDecodeError as exc:
        raise InputError("meta.json", str(files["meta.json"]), f"valid JSON ({exc})") from None
    require(isinstance(meta, dict), "meta.json", type(meta).__name__, "a JSON object")
    known = {k: v for k, v in meta.items() if k in META_KEYS}
    check_keys(known, META_KEYS, "meta.json", required={"fs_hz", "z_pinion", "z_wheel"})
    index = pd.read_parquet(files["index.parquet"]).reset_index(drop=True)
    signals = np.load(files["signals.npy"], mmap_mode="r")
    require(signals.ndim == 2, "signals.npy", signals.shape, "a 2-D array (records, samples)")
    require(len(index) == signals.shape[0], "index.parquet", f"{len(index)} rows",
            f"one row per record of signals.npy ({signals.shape[0]})")
    index["_z_pinion"] = int(known["z_pinion"])
    index["_z_wheel"] = int(known["z_wheel"])
    return index, signals, known


def channel_unit(channel: str) -> str | None:
    """Unit of a ``gearpit generate`` channel, read from the suffix its name carries (:mod:`datagen.output_channels`).

    ``acc_*_m_s2`` -> ``"m/s^2"``, ``dte_m`` / ``mesh_deflection_m`` -> ``"m"``, ``*_n`` -> ``"N"``, ``*_rpm`` ->
    ``"rpm"``, the 0/1 ``tacho_*`` pulses -> ``"1"``; a healthy twin ``<channel>@reference`` has its channel's
    unit. None for a name without a known unit (the features then keep FeatureConfig's default).

    Examples
    --------
    >>> [channel_unit(c) for c in ("acc_pinion_loa_m_s2", "dte_m", "force_bearing_wheel_loa_n", "dte_m@reference")]
    ['m/s^2', 'm', 'N', 'm']
    """
    from datagen.sweep import REFERENCE_SUFFIX

    name = channel.removesuffix(REFERENCE_SUFFIX)
    if name.startswith("tacho_"):
        return "1"
    return next((unit for suffix, unit in CHANNEL_UNITS if name.endswith(suffix)), None)


def read_generated_dataset(path: Path, channel: str | None) -> tuple[pd.DataFrame, np.ndarray, dict]:
    """Index, one channel of signals, fs, the channel's unit and the sample counts (finished ``n_finished`` of
    ``n_samples``, as ``gearpit dataset info`` counts them) of a ``gearpit generate`` dataset (tooth counts per
    pair)."""
    from datagen import dataset as ds

    meta = ds.read_metadata(path)
    index = ds.load_index(path).reset_index(drop=True)
    require(len(index) > 0, "DATASET", str(path), "a dataset with finished samples")
    signals = ds.load_signals(path, index["sample_index"].to_numpy(), channel=channel)
    pairs = meta.get("pairs", {})
    unknown = sorted(set(index["pair"]) - set(pairs))
    require(not unknown, "metadata.json pairs", sorted(pairs), f"tooth counts for every pair of the index ({unknown})")
    index["_z_pinion"] = index["pair"].map(lambda p: int(pairs[p]["z_pinion"]))
    index["_z_wheel"] = index["pair"].map(lambda p: int(pairs[p]["z_wheel"]))
    out = {"fs_hz": float(meta["fs_hz"]), "n_finished": int(len(index)), "n_samples": int(meta["n_samples"])}
    unit = channel_unit(channel if channel is not None else meta["channels"][0])
    if unit is not None:
        out["signal_unit"] = unit
    return index, signals, out


def read_dataset(path: Path, channel: str | None = None) -> tuple[pd.DataFrame, np.ndarray, dict]:
    """Index (with ``_z_pinion``, ``_z_wheel`` per row), signals ``(n, n_samples)`` and ``fs_hz`` (+ unit, and
    the sample counts of a generated dataset)."""
    require(path.is_dir(), "DATASET", str(path), "an existing directory")
    if (path / "metadata.json").is_file():
        index, signals, meta = read_generated_dataset(path, channel)
    else:
        require(channel is None, "--channel", channel, "absent for the plain layout (one channel)")
        index, signals, meta = read_plain_dataset(path)
    for col in ("severity", "speed_rpm"):
        require(col in index.columns, "index.parquet", col, "a column of the index (" + ", ".join(index.columns) + ")")
    return index, signals, meta


def build_config(args, meta: dict, z_pinion: int, z_wheel: int) -> FeatureConfig:
    """FeatureConfig from the dataset metadata, the optional TOML and the flags (flags win)."""
    values: dict = {"fs_hz": float(meta["fs_hz"]), "z_pinion": int(z_pinion), "z_wheel": int(z_wheel)}
    if "signal_unit" in meta:
        values["signal_unit"] = str(meta["signal_unit"])
    if args.config is not None:
        doc = read_toml(args.config)
        check_keys(doc, {"features"}, "", required={"features"})
        table = doc["features"]
        for key in ("fs_hz", "z_pinion", "z_wheel"):
            require(key not in table, f"features.{key}", table.get(key), "absent (it comes from the dataset)")
        values.update(table)
    if args.hht is not None:
        values["hht_method"] = args.hht
    if args.envelope_band is not None:
        values["envelope_band"] = args.envelope_band
    values["seed"] = args.seed
    return FeatureConfig.from_dict(values)


def run(args) -> int:
    require(args.jobs >= 1 or args.jobs == -1, "--jobs", args.jobs, "an integer >= 1, or -1")
    require(args.top >= 1, "--top", args.top, "an integer >= 1")
    index, signals, meta = read_dataset(args.dataset, args.channel)
    groups = index.groupby(["_z_pinion", "_z_wheel"], sort=True).indices
    configs = {key: build_config(args, meta, *key) for key in groups}  # validate every group before work
    out = args.out if args.out is not None else args.dataset / "feature_ranking"
    note = None
    if "n_samples" in meta and meta["n_finished"] < meta["n_samples"]:
        note = (f"incomplete dataset: {meta['n_finished']} of {meta['n_samples']} samples "
                "(the ranking uses the finished ones)")
        print(f"warning: {note}", file=sys.stderr)

    fr = index["speed_rpm"].to_numpy(dtype=float) / 60.0
    parts = []
    for key, rows in groups.items():
        rows = np.sort(rows)
        names = ([f"sample {v}" for v in index["sample_index"].to_numpy()[rows]] if "sample_index" in index.columns
                 else [f"index row {r}" for r in rows])
        part = extract_features(signals[rows], configs[key], fr_pinion_hz=fr[rows], n_jobs=args.jobs,
                                record_names=names)
        part.index = rows
        parts.append(part)
    table = pd.concat(parts).sort_index()
    labels = index.drop(columns=["_z_pinion", "_z_wheel"])
    full = pd.concat([labels, table], axis=1)
    if "n_samples" in meta:
        full.attrs["dataset"] = {"n_finished": meta["n_finished"], "n_samples": meta["n_samples"]}
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "features.parquet") as tmp:
        full.to_parquet(tmp, index=False)

    ranking = rank_features(full, list(table.columns), seed=args.seed)
    if "severity_classes" in ranking.attrs:     # the index has no severity_class column
        print(f"note: {ranking.attrs['severity_classes']}", file=sys.stderr)
        note = "; ".join(n for n in (note, ranking.attrs["severity_classes"]) if n)
    write_ranking(ranking, out / "feature_ranking.csv", out / "feature_ranking.md", top=args.top, note=note)
    from features.plots import plot_feature_ranking

    plot_feature_ranking(ranking, out / "feature_ranking.png", top=args.top)
    print(ranking_markdown(ranking[["feature", "rank", "score", "f_severity", "mi_severity", "monotonicity",
                                    *[c for c in ("f_teeth", "robustness") if c in ranking.columns]]], top=10))
    print(f"wrote {out}/features.parquet, feature_ranking.csv, feature_ranking.md, feature_ranking.png")
    return 0
