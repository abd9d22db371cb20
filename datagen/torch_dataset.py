"""A ``torch.utils.data.Dataset`` over a generated dataset directory, reading samples lazily.

The index is read once (pandas); signals are memory-mapped per shard on first
use in each process (so ``DataLoader`` workers open their own maps) and one
sample is copied out per ``__getitem__``.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import torch
from torch.utils.data import Dataset

from datagen.dataset import load_index, open_shard, read_metadata
from gearpit.errors import require


class SignalDataset(Dataset):
    """Samples of a dataset directory as ``(signal, labels)``.

    Parameters
    ----------
    path : str or Path
        Dataset directory (:mod:`datagen.dataset`).
    channels : sequence of str, optional
        Stored channels to return, in this order (default: all stored channels).
    labels : sequence of str
        Index columns returned in the labels dict (floats become float32 tensors, integers int64
        tensors; strings and lists stay as they are).
    indices : sequence of int, optional
        ``sample_index`` values to expose, in this order (default: every finished sample).
    transform : callable, optional
        Applied to the float32 tensor ``(n_channels, n_time)``.

    Examples
    --------
    >>> ds = SignalDataset("data/demo", labels=("severity_class_index", "severity"))  # doctest: +SKIP
    >>> x, y = ds[0]; x.shape, y["severity_class_index"]                             # doctest: +SKIP
    (torch.Size([1, 6400]), tensor(0))
    """

    def __init__(self, path, *, channels=None, labels=("severity_class_index", "severity"), indices=None,
                 transform=None):
        self.path = Path(path)
        meta = read_metadata(self.path)
        stored = meta["channels"]
        channels = list(stored) if channels is None else list(channels)
        for c in channels:
            require(c in stored, "channels", c, f"stored channels: {', '.join(stored)}")
        self.channel_positions = [stored.index(c) for c in channels]
        self.channels = channels
        index = load_index(self.path).set_index("sample_index", drop=False)
        for col in labels:
            require(col in index.columns, "labels", col, "index columns: " + ", ".join(index.columns))
        if indices is not None:
            missing = sorted(set(int(i) for i in indices) - set(index.index))
            require(not missing, "indices", missing[:5], "sample indices of finished shards")
            index = index.loc[list(indices)]
        self.index = index.reset_index(drop=True)
        self.labels = tuple(labels)
        self.transform = transform
        self.shard_size = meta["shard_size"]
        self._maps: dict = {}
        self._pid = None

    def __len__(self) -> int:
        return len(self.index)

    def _shard(self, k: int) -> np.ndarray:
        if self._pid != os.getpid():  # a forked DataLoader worker opens its own maps
            self._maps, self._pid = {}, os.getpid()
        if k not in self._maps:
            self._maps[k] = open_shard(self.path, k)
        return self._maps[k]

    def __getitem__(self, i: int):
        row = self.index.iloc[i]
        s = int(row["sample_index"])
        k, j = divmod(s, self.shard_size)
        x = torch.from_numpy(np.array(self._shard(k)[j, self.channel_positions], dtype=np.float32))
        if self.transform is not None:
            x = self.transform(x)
        y = {}
        for col in self.labels:
            v = row[col]
            if isinstance(v, (float, np.floating)):
                v = torch.tensor(float(v), dtype=torch.float32)
            elif isinstance(v, (int, np.integer)) and not isinstance(v, bool):
                v = torch.tensor(int(v), dtype=torch.int64)
            y[col] = v
        return x, y

    def __getstate__(self):  # never pickle open memory maps
        state = dict(self.__dict__)
        state["_maps"], state["_pid"] = {}, None
        return state
