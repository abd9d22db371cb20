"""Dataset directory: metadata, Parquet index, float32 signal shards, compressed pit masks.

Layout (``N`` samples in shards of ``shard_size``; shard ``k`` holds samples
``k * shard_size .. (k + 1) * shard_size - 1``)::

    DIR/metadata.json                  config (TOML document), seed, fingerprint, software versions,
                                       channels, fs_hz, n_time, shard_size, column units, class grid
    DIR/index.parquet                  one row per sample (merged from the parts when the run completes)
    DIR/shards/signals-KKKKKK.npy      float32 (n, n_channels, n_time), memory-mappable
    DIR/shards/masks-KKKKKK.parquet    one row per pitted tooth: sample_index, tooth, rows, cols,
                                       mask_packbits_zlib (np.packbits of the boolean mask, zlib)
    DIR/shards/index-KKKKKK.parquet    the shard's index rows; written last = the shard's commit mark

Every file is written to a temporary name and renamed (:func:`gearpit.atomic.atomic_path`),
so a killed run leaves whole files only; a shard counts as done when its index
part exists, and a restarted run computes only the missing shards. No file
holds a time stamp, a host name or a worker count, so the same sweep gives the
same bytes however it was run.

Why ``.npy`` shards rather than Zarr or HDF5: each shard is a pure function of
(config, seed, shard index) and is written whole by one process, so one file
per shard with an atomic rename gives resume and concurrent writers for free,
with no locking and no library-specific chunk layout; readers memory-map a
shard and slice it without reading the rest (the torch ``Dataset`` reads one
sample at a time this way); compression would save ~8 % on noisy float32
vibration (measured with Zarr's default codec), not worth a dependency or
the decode time.
"""
from __future__ import annotations

import json
import os
import platform
import zlib
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd

from gearpit import __version__
from gearpit.atomic import atomic_path
from gearpit.errors import InputError, require

METADATA = "metadata.json"
INDEX = "index.parquet"
SHARDS = "shards"


def shard_name(kind: str, shard: int) -> str:
    return f"{kind}-{shard:06d}.{'npy' if kind == 'signals' else 'parquet'}"


def software_versions() -> dict:
    import scipy

    return {"gearpit": __version__, "numpy": np.__version__, "scipy": scipy.__version__, "pandas": pd.__version__,
            "python": platform.python_version()}


def build_metadata(sweep) -> dict:
    """The metadata.json content of a sweep (no time stamps: identical for identical sweeps)."""
    from datagen.class_grid import class_grid
    from datagen.sampling import column_units
    from datagen.sweep import FORMAT_VERSION

    return {"format": "gearpit-dataset", "format_version": FORMAT_VERSION, "name": sweep.name, "seed": sweep.seed,
            "fingerprint": sweep.fingerprint, "software": software_versions(), "config": sweep.source,
            "stiffness": sweep.stiffness.to_dict(),
            "n_samples": sweep.n_samples, "shard_size": sweep.shard_size, "n_shards": sweep.n_shards,
            "channels": list(sweep.stored_channels), "fs_hz": sweep.fs_hz, "n_time": sweep.n_time, "dtype": "float32",
            "pairs": {p.name: {"z_pinion": p.pinion.teeth, "z_wheel": p.wheel.teeth} for p in sweep.pairs},
            "classes": [asdict(c) for c in class_grid(sweep)], "samples_per_class": sweep.samples_per_class,
            "severity_bins": {b.name: [b.min_fraction, b.max_fraction] for b in sweep.severity_bins},
            "teeth_classes": {t.name: [t.low, t.high] for t in sweep.teeth_classes},
            "severity_definition": "max over the pitted teeth of (pitted pixels / active-flank pixels)",
            "column_units": column_units(sweep),
            **({"plugins": [{"file": Path(p).name, "sha256": sha} for p, sha in sweep.plugins]}
               if sweep.plugins else {})}


# ---------------------------------------------------------------------- writing
def open_for_writing(path: str | Path, sweep) -> set[int]:
    """Create ``path`` for ``sweep``, or reopen a run of the same sweep; return the finished shards.

    Raises :class:`InputError` if ``path`` holds anything else (another sweep,
    other files), before writing anything.
    """
    root = Path(path)
    meta = build_metadata(sweep)
    if root.exists():
        require(root.is_dir(), "--out", str(root), "a directory (or a path that does not exist yet)")
        entries = {p.name for p in root.iterdir()}
        if entries:
            require(METADATA in entries, "--out", str(root),
                    "an empty directory or a dataset of this sweep (it holds other files)")
            old = read_metadata(root)
            require(old.get("fingerprint") == meta["fingerprint"], "--out", str(root),
                    f"a dataset of this sweep (it holds sweep '{old.get('name')}' with another config or seed)")
            require(old.get("software") == meta["software"], "--out", str(root),
                    f"a dataset started with the same software versions ({old.get('software')}; now "
                    f"{meta['software']}): resuming would mix versions, use a new directory")
    (root / SHARDS).mkdir(parents=True, exist_ok=True)
    for stale in (root / SHARDS).glob(".*.part*"):  # temporaries of a killed run
        stale.unlink()
    if not (root / METADATA).exists():
        with atomic_path(root / METADATA) as tmp:
            tmp.write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
    return finished_shards(root)


def finished_shards(path: str | Path) -> set[int]:
    """Shards whose index part (the commit mark) exists."""
    out = set()
    for p in (Path(path) / SHARDS).glob("index-*.parquet"):
        out.add(int(p.stem.split("-")[1]))
    return out


def encode_mask(mask: np.ndarray) -> bytes:
    """Boolean mask -> zlib-compressed ``np.packbits`` bytes (row-major)."""
    return zlib.compress(np.packbits(np.asarray(mask, bool).ravel()).tobytes(), 6)


def decode_mask(blob: bytes, rows: int, cols: int) -> np.ndarray:
    bits = np.unpackbits(np.frombuffer(zlib.decompress(blob), np.uint8), count=rows * cols)
    return bits.reshape(rows, cols).astype(bool)


def write_shard(path: str | Path, shard: int, signals: np.ndarray, rows: list[dict], masks: list[dict]) -> None:
    """Commit one shard: signals, masks, then the index part (the commit mark)."""
    d = Path(path) / SHARDS
    signals = np.ascontiguousarray(signals, dtype=np.float32)
    require(signals.ndim == 3 and signals.shape[0] == len(rows), "signals", signals.shape,
            f"(n_samples={len(rows)}, n_channels, n_time)")
    with atomic_path(d / shard_name("signals", shard)) as tmp:
        with open(tmp, "wb") as fh:
            np.save(fh, signals)
    mask_frame = pd.DataFrame(masks, columns=["sample_index", "tooth", "rows", "cols", "mask_packbits_zlib"])
    _write_parquet(mask_frame.astype({"sample_index": "int64", "tooth": "int32", "rows": "int32", "cols": "int32"}),
                   d / shard_name("masks", shard))
    _write_parquet(pd.DataFrame(rows), d / shard_name("index", shard))


def _write_parquet(frame: pd.DataFrame, target: Path) -> None:
    with atomic_path(target) as tmp:
        frame.to_parquet(tmp, index=False)


def finalize(path: str | Path) -> pd.DataFrame:
    """Merge the index parts into ``index.parquet`` (once every shard is done) and return it."""
    root = Path(path)
    meta = read_metadata(root)
    done = finished_shards(root)
    missing = sorted(set(range(meta["n_shards"])) - done)
    require(not missing, "dataset", str(root), f"every shard finished (missing: {missing[:5]}...)")
    index = _concat_parts(root, sorted(done))
    _write_parquet(index, root / INDEX)
    return index


def _concat_parts(root: Path, shards: list[int]) -> pd.DataFrame:
    parts = [pd.read_parquet(root / SHARDS / shard_name("index", k)) for k in shards]
    if not parts:
        return pd.DataFrame()
    return pd.concat(parts, ignore_index=True)


# ---------------------------------------------------------------------- reading
def read_metadata(path: str | Path) -> dict:
    p = Path(path) / METADATA
    require(p.is_file(), "dataset", str(Path(path)), f"a dataset directory (no {METADATA})")
    try:
        return json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(METADATA, str(p), f"valid JSON ({exc})") from None


def load_index(path: str | Path) -> pd.DataFrame:
    """The index (one row per sample, sorted by ``sample_index``).

    A finished dataset reads ``index.parquet``; an unfinished one (a run still
    going, or killed) the parts of its finished shards.
    """
    root = Path(path)
    read_metadata(root)
    if (root / INDEX).is_file():
        return pd.read_parquet(root / INDEX)
    return _concat_parts(root, sorted(finished_shards(root)))


def _channel_position(meta: dict, channel: str | None) -> int:
    channels = meta["channels"]
    if channel is None:
        return 0
    require(channel in channels, "channel", channel, f"one of the stored channels: {', '.join(channels)}")
    return channels.index(channel)


def shard_damage(path: str | Path, shard: int) -> str:
    """What is wrong with the signals file of a finished shard ('' if nothing): its size against the size its
    ``.npy`` header declares (a truncated copy or a full disk), or an unreadable header."""
    f = Path(path) / SHARDS / shard_name("signals", shard)
    if not f.is_file():
        return f"{f.name} missing"
    size = f.stat().st_size
    try:
        with open(f, "rb") as fh:
            version = np.lib.format.read_magic(fh)
            if version not in ((1, 0), (2, 0)):     # np.save writes 1.0 (2.0 for a huge header)
                return ""
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _, dtype = read(fh)
            expected = fh.tell() + int(np.prod(shape)) * np.dtype(dtype).itemsize
    except (ValueError, OSError, EOFError, SyntaxError) as exc:
        return f"{f.name} unreadable ({size} bytes; {exc})"
    if size != expected:
        return f"{f.name} holds {size} bytes, its header declares {expected} ({list(shape)} {np.dtype(dtype).name})"
    return ""


def open_shard(path: str | Path, shard: int) -> np.ndarray:
    """Memory-mapped signals of one shard, float32 ``(n, n_channels, n_time)``."""
    f = Path(path) / SHARDS / shard_name("signals", shard)
    require(f.is_file(), "shard", shard, "a finished shard of this dataset")
    damage = shard_damage(path, shard)
    require(not damage, "shard", str(f), f"a whole signals file; {damage}: damaged or truncated, generate the "
            "dataset again")
    return np.load(f, mmap_mode="r")


def load_signals(path: str | Path, indices=None, channel: str | None = None) -> np.ndarray:
    """Signals of one channel, float32 ``(len(indices), n_time)``.

    Parameters
    ----------
    path : str or Path
        Dataset directory.
    indices : sequence of int, optional
        ``sample_index`` values (default: every row of :func:`load_index`, in its order).
    channel : str, optional
        A stored channel (default: the first, ``metadata["channels"][0]``).

    Examples
    --------
    >>> index = load_index("gearpit_out/dataset")                              # doctest: +SKIP
    >>> severe = index[index.severity_class == "severe"].sample_index
    >>> x = load_signals("gearpit_out/dataset", severe, channel="acc_pinion_loa_m_s2")
    >>> x.shape                                                                # (n, n_time)
    """
    root = Path(path)
    meta = read_metadata(root)
    c = _channel_position(meta, channel)
    idx = load_index(root)["sample_index"].to_numpy() if indices is None else np.asarray(indices, dtype=np.int64)
    require(idx.ndim == 1 and (idx.size == 0 or (idx.min() >= 0 and idx.max() < meta["n_samples"])), "indices",
            idx[:5].tolist(), f"sample indices in [0, {meta['n_samples'] - 1}]")
    out = np.empty((idx.size, meta["n_time"]), np.float32)
    size = meta["shard_size"]
    shards = idx // size
    for k in np.unique(shards):
        sel = np.nonzero(shards == k)[0]
        out[sel] = open_shard(root, int(k))[idx[sel] - k * size, c]
    return out


def load_masks(path: str | Path, sample_index: int) -> dict[int, np.ndarray]:
    """Stored boolean pit masks of one sample: tooth -> mask (profile x face); empty if healthy."""
    root = Path(path)
    meta = read_metadata(root)
    k = int(sample_index) // meta["shard_size"]
    f = root / SHARDS / shard_name("masks", k)
    require(f.is_file(), "sample_index", sample_index, "a sample of a finished shard")
    frame = pd.read_parquet(f, filters=[("sample_index", "==", int(sample_index))])
    return {int(r.tooth): decode_mask(r.mask_packbits_zlib, int(r.rows), int(r.cols)) for r in frame.itertuples()}


def regenerate_pit_map(path: str | Path, sample_index: int):
    """The :class:`~datagen.flank.PitMap` (with depths) of one sample, recomputed from the stored config."""
    from datagen.sampling import build_pit_map, draw_sample
    from datagen.sweep import sweep_from_dict

    sweep = sweep_from_dict(read_metadata(path)["config"])
    return build_pit_map(sweep, draw_sample(sweep, int(sample_index)))


def disk_bytes(path: str | Path) -> int:
    total = 0
    for dirpath, _, files in os.walk(path):
        total += sum(os.path.getsize(os.path.join(dirpath, f)) for f in files)
    return total


def dataset_info(path: str | Path) -> dict:
    """Summary of a dataset: progress, class counts, ranges of numeric columns (with units), size on disk."""
    root = Path(path)
    meta = read_metadata(root)
    index = load_index(root)
    counts = {"/".join(map(str, (c["pair"], c["severity_class"], c["teeth_class"], c["shape"]))): 0
              for c in meta["classes"]}
    if len(index):
        keys = index["pair"] + "/" + index["severity_class"] + "/" + index["teeth_class"] + "/" + index["shape"]
        for k, n in keys.value_counts().items():
            counts[k] = int(n)
    units = meta.get("column_units", {})
    damaged = {int(k): d for k in sorted(finished_shards(root)) if (d := shard_damage(root, k))}
    ranges = {}
    skip = {"sample_index", "seed", "shard", "class_index", "pit_seed", "simulation_seed"}
    for col in index.columns:
        if col in skip or not pd.api.types.is_numeric_dtype(index[col]) or pd.api.types.is_bool_dtype(index[col]):
            continue
        v = index[col].to_numpy(dtype=float)
        v = v[np.isfinite(v)]
        if v.size:
            ranges[col] = {"min": float(v.min()), "max": float(v.max()), "unit": units.get(col, "-")}
    return {"path": str(root), "name": meta["name"], "seed": meta["seed"], "software": meta["software"],
            "fingerprint": meta["fingerprint"], "n_samples": meta["n_samples"], "n_finished": int(len(index)),
            "n_shards": meta["n_shards"], "finished_shards": len(finished_shards(root)),
            "complete": (root / INDEX).is_file() and not damaged, "damaged_shards": damaged,
            "n_classes": len(meta["classes"]),
            "samples_per_class": meta["samples_per_class"], "channels": meta["channels"], "fs_hz": meta["fs_hz"],
            "n_time": meta["n_time"], "class_counts": counts, "ranges": ranges, "size_bytes": disk_bytes(root)}
