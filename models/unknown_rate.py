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

The tooth count of the gear that modulates the mesh most strongly can be read from
the spacing of its sidebands (:func:`estimate_tooth_count`; 32 on every
SpectraQuest file and channel, ``experiments/real_data_pair.py``); the loader does
not use it, since the models it feeds were trained on another pair anyway.

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
    logp, n = log_power(a, pad)
    f = np.arange(logp.size) / n
    cand = np.nonzero((f >= lo) & (f <= hi))[0]
    score = np.zeros(cand.size)
    for k in range(1, n_harmonics + 1):
        # best bin within +/- k bins of k f (the harmonic's position uncertainty grows with k)
        idx = k * cand
        best = np.max(np.stack([logp[np.clip(idx + d, 0, logp.size - 1)] for d in range(-k, k + 1)]), axis=0)
        score += best
    return float(f[cand[int(np.argmax(score))]])


def log_power(a: np.ndarray, pad: int) -> tuple[np.ndarray, int]:
    """Natural-log Hann power spectrum of ``a`` zero-padded ``pad`` times, and its FFT length."""
    n = a.size * pad
    p = np.abs(np.fft.rfft((a - a.mean()) * np.hanning(a.size), n=n)) ** 2
    return np.log(p + 1e-30 * p.max()), n


def tooth_count_scores(x: np.ndarray, mesh_cps: float, *, z_range: tuple[int, int] = (8, 200), n_harmonics: int = 4,
                       n_sidebands: int = 3, pad: int = 4) -> dict[int, float]:
    """How strongly the spectrum of ``x`` carries shaft-order sidebands spaced ``mesh_cps / z``, for every ``z``.

    A gear of ``z`` teeth turns at ``mesh_cps / z``; its run-out, pitch errors and any local fault modulate the mesh
    once per turn, so every mesh harmonic ``h fm`` carries sidebands at ``h fm +/- k fm / z`` (McFadden 1987; every
    real pair has such errors). The score of ``z`` is a comb contrast in dB: the mean log power on the sideband
    lines (``k = 1..n_sidebands``, both sides, around the ``n_harmonics`` strongest mesh harmonics: a housing
    resonance or the sensor's response can bury the first ones under noise) minus the mean log power half-way between
    them (``k - 1/2``), each read as the peak of the ``pad``-times zero-padded spectrum within +/- one padded bin
    of its place (the same statistic on and off the comb keeps the contrast unbiased). The places are counted
    from each harmonic's measured peak (within +/- ``h`` bins of ``h mesh_cps``) with the spacing that peak
    implies, so an error of ``mesh_cps`` does not grow with the harmonic; read that sharply, the comb of
    ``z +/- 1`` misses the true lines from ``k = 1`` on (by ``k/z`` of the spacing, a Hann main lobe's width for
    ``z`` ~ 30 and the record's resolution). A comb of twice the true spacing (half
    the teeth) has lines half-way too and scores near zero; a comb of half the spacing (twice the teeth) has every
    second line empty and scores about half. Only spacings resolved by the record (>= 4 bins: two Hann main-lobe
    widths) are scored.

    Returns
    -------
    dict
        ``z -> score_db`` for each scored tooth count (10 log10 of the power ratio).
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 1024, "x", a.shape, "a 1-D record of >= 1024 samples")
    require(0 < mesh_cps < 0.5, "mesh_cps", mesh_cps, "0 < mesh_cps < 0.5 cycles/sample")
    z_lo, z_hi = z_range
    require(isinstance(z_lo, (int, np.integer)) and isinstance(z_hi, (int, np.integer)) and 3 <= z_lo < z_hi,
            "z_range", z_range, "two integers 3 <= lo < hi")
    logp, n = log_power(a, pad)
    db = 10.0 / np.log(10.0)
    # the strongest mesh harmonics (a housing path or a sensor's own response can bury the first ones), each at its
    # measured peak within +/- h bins of the record, so that an error of the mesh estimate does not grow with h
    h_all = np.arange(1, int(0.5 / mesh_cps) + 1)
    h_all = h_all[(h_all * mesh_cps + 0.5 * mesh_cps / z_lo) < 0.5]
    require(h_all.size > 0, "mesh_cps", mesh_cps, "a mesh frequency with its sidebands below 0.5 cycles/sample")
    peaks = []
    for h in h_all:
        c = int(round(h * mesh_cps * n))
        lo = max(c - pad * int(h), 0)
        i = lo + int(np.argmax(logp[lo:c + pad * int(h) + 1]))
        peaks.append((logp[i], i))
    chosen = sorted(peaks, reverse=True)[:n_harmonics]
    scores = {}
    for z in range(z_lo, z_hi + 1):
        if mesh_cps / z * a.size < 4.0:       # spacing under 4 bins of the record (2 Hann main lobes): unresolved
            continue
        on, off = [], []
        for _, centre in chosen:
            # this harmonic's sideband spacing in padded bins: its measured line over (harmonic x z)
            h = max(1, int(round(centre / (mesh_cps * n))))
            step = centre / (h * z)
            if centre + (n_sidebands + 1) * step >= logp.size - 1:
                continue
            for k in range(1, n_sidebands + 1):
                for sign in (-1.0, 1.0):
                    for j, out in ((k, on), (k - 0.5, off)):
                        c = int(round(centre + sign * j * step))
                        out.append(np.max(logp[c - 1:c + 2]))
        if on:
            scores[z] = db * (float(np.mean(on)) - float(np.mean(off)))
    require(len(scores) > 0, "x", f"{a.size} samples", "a record long enough to resolve the shaft sidebands")
    return scores


def estimate_tooth_count(x: np.ndarray, mesh_cps: float, *, z_range: tuple[int, int] = (8, 200),
                         **kw) -> tuple[int, float, float]:
    """The tooth count of the gear whose shaft sidebands the spectrum of ``x`` carries most strongly
    (:func:`tooth_count_scores`), its comb contrast, and the best contrast of a count that is not within 2 % of a
    multiple or divisor of it (the comb's aliases): ``(z, score_db, runner_up_db)``.

    For a record whose sampling rate and gearbox are undocumented this gives a tooth count from the mesh frequency
    alone, and with it that shaft's rate ``mesh_cps / z`` in cycles per sample (for a synchronous average). It
    assumes that the strongest harmonic family is one stage's mesh. The other gear's count is not estimated: its
    comb shares lines with the first gear's and with the assembly's repeat period (``mesh_cps / lcm(z1, z2)``), so
    its contrast is not decisive (on the SpectraQuest files the wheel's 80 ranks first among the other counts on a
    third of the channels only).
    """
    scores = tooth_count_scores(x, mesh_cps, z_range=z_range, **kw)
    z = max(scores, key=scores.get)
    others = [v for k, v in scores.items() if abs(max(k, z) / min(k, z) - round(max(k, z) / min(k, z)))
              > 0.02 * max(k, z) / min(k, z)]
    return int(z), float(scores[z]), float(max(others)) if others else float("nan")


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
