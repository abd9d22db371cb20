"""Segments of a record shared by the representations (:mod:`models.representations`) and the TSA
(:mod:`models.tsa`): the per-record normalisation, where a segment starts in the record, and per-record
parameters."""
from __future__ import annotations

import numpy as np

from gearpit.errors import require


def _normalise(seg: np.ndarray) -> np.ndarray:
    """The record less its mean, over its standard deviation (unless zero)."""
    s = seg - seg.mean()
    sd = s.std()
    return s / sd if sd > 0 else s


def _split_pair(pair: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """A record followed by its reference (:meth:`models.data.SignalSet.paired_signals`): both less their mean
    and over the reference's standard deviation (1 if zero), and that deviation."""
    half = pair.size // 2
    rec, ref = pair[:half].astype(float), pair[half:].astype(float)
    rec, ref = rec - rec.mean(), ref - ref.mean()
    sd = float(ref.std()) or 1.0
    return rec / sd, ref / sd, sd


def _starts(size: int, n_seg: int, start: float, average: bool) -> list[int]:
    """Segment starts: one at ``start`` of the free room, or (``average``) one every half
    segment, the first shifted by ``start`` of at most half a segment."""
    room = size - n_seg
    if not average:
        return [int(np.floor(start * room + 1e-9))]
    hop = max(n_seg // 2, 1)
    first = int(np.floor(start * min(room, hop - 1) + 1e-9))
    return list(range(first, room + 1, hop))


def _per_record(value, n: int, field: str) -> np.ndarray | None:
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    require(arr.shape == (n,), field, arr.shape, f"a scalar or {n} values (one per record)")
    return arr
