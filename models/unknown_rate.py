"""Recordings whose sampling rate, speed and tooth counts are not documented.

Such a record can still be fed to a model trained on the ``mesh_order``
representation (:mod:`models.representations`), which needs only the mesh
frequency in cycles per sample. :func:`estimate_mesh_cps` finds it as the
fundamental of the strongest harmonic family in a search band (harmonic
product of a zero-padded Hann power spectrum); :func:`load_unknown_rate_csv`
cuts a multi-channel CSV into records and labels them.

The reader is written for the SpectraQuest gearbox-fault CSV files
(``a1,a2,a3,a4`` header, one row per sample; healthy ``h*`` and broken-tooth
``b*`` files, load in percent after ``hz``), but any CSV of that shape works.

Assumptions (they are assumptions, not documented facts):

- the strongest harmonic family between 0.05 and 0.10 cycles/sample is the gear
  mesh frequency and its harmonics (for the SpectraQuest files: 0.0740-0.0744
  cycles/sample, lines k x 0.0740 for k = 1..4 in every file);
- the sampling rate is set to 1 Hz, so frequencies are in cycles per sample and
  any rate-bound quantity is meaningless; only ``mesh_order`` models apply;
- tooth counts are unknown (``PairInfo(z_pinion=0, z_wheel=0)``): a model trained
  on another pair must be applied with ``allow_mismatch`` and every prediction
  carries that warning.

References
----------
.. [1] Schroeder, M. R. (1968). Period histogram and product spectrum: new
   methods for fundamental-frequency measurement. J. Acoust. Soc. Am. 43(4),
   829-834 (harmonic product spectrum).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from gearpit.errors import require
from models.data import PairInfo, SignalSet

UNKNOWN_PAIR = PairInfo("unknown", 0, 0)
_NAME = re.compile(r"^(?P<cond>[hb])(?P<speed>\d+)hz(?P<load>\d+)$")


def estimate_mesh_cps(x: np.ndarray, *, band_cps: tuple[float, float] = (0.05, 0.10), n_harmonics: int = 4,
                      pad: int = 4) -> float:
    """Fundamental (cycles/sample) of the strongest harmonic family with fundamental in ``band_cps``.

    Score of a candidate ``f``: sum over ``k = 1..n_harmonics`` of the log power at
    ``k f`` (harmonic product spectrum [1]_), on a Hann power spectrum zero-padded
    ``pad`` times; candidates on the padded bin grid; the harmonics must stay
    below 0.5 cycles/sample.
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 256, "x", a.shape, "a 1-D record of >= 256 samples")
    lo, hi = band_cps
    require(0 < lo < hi and hi * n_harmonics < 0.5, "band_cps", band_cps,
            f"(lo, hi) with 0 < lo < hi and hi * {n_harmonics} < 0.5")
    n = a.size * pad
    w = np.hanning(a.size)
    p = np.abs(np.fft.rfft((a - a.mean()) * w, n=n)) ** 2
    logp = np.log(p + 1e-30 * p.max())
    f = np.arange(p.size) / n
    cand = np.nonzero((f >= lo) & (f <= hi))[0]
    score = np.zeros(cand.size)
    for k in range(1, n_harmonics + 1):
        # best bin within +/- k bins of k f (the harmonic's position uncertainty grows with k)
        idx = k * cand
        best = np.max(np.stack([logp[np.clip(idx + d, 0, p.size - 1)] for d in range(-k, k + 1)]), axis=0)
        score += best
    return float(f[cand[int(np.argmax(score))]])


def load_unknown_rate_csv(paths: list[str | Path], *, channel: str, record_samples: int = 16384,
                          labels: dict[str, str] | None = None) -> SignalSet:
    """Records of one channel of rate-unknown CSV files, cut into non-overlapping pieces.

    Parameters
    ----------
    paths : list of path
        CSV files with a header line naming the channels.
    channel : str
        Column to read (e.g. ``"a1"``).
    record_samples : int
        Samples per record; the tail of a file shorter than that is dropped.
    labels : dict, optional
        ``file stem -> severity class``; default from SpectraQuest names: ``h*`` ->
        ``"healthy"``, ``b*`` -> ``"broken_tooth"`` (a damage class, not pitting).

    Returns
    -------
    SignalSet
        ``fs_hz`` = 1 (cycles per sample); label columns ``file``, ``severity_class``,
        ``severity`` (0 for healthy, NaN otherwise: not documented), ``load_percent``
        (from the file name, if it has the SpectraQuest form), ``mesh_cps`` (estimated
        per file on the whole file).
    """
    require(isinstance(record_samples, int) and record_samples >= 1024, "record_samples", record_samples,
            "an integer >= 1024")
    rows, recs = [], []
    for path in map(Path, paths):
        require(path.is_file(), "file", str(path), "an existing CSV file")
        table = pd.read_csv(path)
        require(channel in table.columns, "channel", channel, f"one of the columns of {path.name}: "
                + ", ".join(map(str, table.columns)))
        x = table[channel].to_numpy(dtype=float)
        require(bool(np.all(np.isfinite(x))), f"{path.name}: {channel}", "non-finite samples", "finite samples only")
        mesh = estimate_mesh_cps(x)
        m = _NAME.match(path.stem)
        if labels is not None:
            require(path.stem in labels, "labels", path.stem, "a class for every file")
            cls = labels[path.stem]
        else:
            require(m is not None, "file", path.name, "a SpectraQuest name (h30hz0.csv, b30hz90.csv, ...) or labels")
            cls = "healthy" if m["cond"] == "h" else "broken_tooth"
        for k in range(x.size // record_samples):
            recs.append(x[k * record_samples:(k + 1) * record_samples].astype(np.float32))
            row = {"file": path.name, "piece": k, "severity_class": cls, "severity": 0.0 if cls == "healthy" else np.nan,
                   "mesh_cps": mesh}
            if m is not None:
                row["load_percent"] = float(m["load"])
            rows.append(row)
    require(len(recs) >= 1, "paths", [str(p) for p in paths], f"files holding >= {record_samples} samples")
    return SignalSet(np.stack(recs), 1.0, UNKNOWN_PAIR, pd.DataFrame(rows), source="rate-unknown CSV: "
                     + ", ".join(sorted({r['file'] for r in rows})), channel=channel)
