"""Time-domain statistics of a vibration record (one value per signal).

All functions reduce along the last axis, so a batch ``(n_signals, n_samples)``
gives ``(n_signals,)``. Moments (variance, skewness, kurtosis) are central; RMS
and the peak-based factors use the signal as given (no mean removal), as is usual
for accelerometer records that are already zero-mean.

References
----------
.. [1] Lebold, M., McClintic, K., Campbell, R., Byington, C., Maynard, K. (2000).
   Review of vibration analysis methods for gearbox diagnostics and prognostics.
   Proc. 54th Meeting of the Society for Machinery Failure Prevention Technology,
   Virginia Beach, pp. 623-634 (RMS, crest factor, kurtosis).
.. [2] Samanta, B., Al-Balushi, K. R. (2003). Artificial neural network based fault
   diagnostics of rolling element bearings using time-domain features. Mechanical
   Systems and Signal Processing 17(2), 317-328 (shape, impulse, clearance factors).
"""
from __future__ import annotations

import numpy as np

from gearpit.errors import require

#: name -> unit of the statistics returned by :func:`time_domain_statistics`;
#: ``"signal"`` stands for the unit of the input record, ``"1"`` for dimensionless
STATISTIC_UNITS: dict[str, str] = {
    "rms": "signal",
    "peak": "signal",
    "peak_to_peak": "signal",
    "crest_factor": "1",
    "kurtosis": "1",
    "skewness": "1",
    "shape_factor": "1",
    "impulse_factor": "1",
    "clearance_factor": "1",
}


def _as_signal(x: np.ndarray, field: str = "x") -> np.ndarray:
    a = np.asarray(x, dtype=float)
    require(a.ndim >= 1 and a.shape[-1] >= 2, field, a.shape, "an array whose last axis has >= 2 samples")
    require(bool(np.all(np.isfinite(a))), field, "non-finite values", "finite samples only")
    return a


def rms(x: np.ndarray) -> np.ndarray:
    """Root mean square ``sqrt(mean(x**2))`` along the last axis (unit of ``x``)."""
    a = _as_signal(x)
    return np.sqrt(np.mean(a * a, axis=-1))


def peak(x: np.ndarray) -> np.ndarray:
    """Largest absolute value ``max |x|`` along the last axis (unit of ``x``)."""
    return np.max(np.abs(_as_signal(x)), axis=-1)


def peak_to_peak(x: np.ndarray) -> np.ndarray:
    """``max(x) - min(x)`` along the last axis (unit of ``x``)."""
    a = _as_signal(x)
    return np.max(a, axis=-1) - np.min(a, axis=-1)


def integer_power(d: np.ndarray, k: int) -> np.ndarray:
    """``d**k`` for an integer ``k >= 1`` by repeated squaring: numpy's ``**`` calls ``pow`` per element for any
    exponent but 2 (~10x slower on a 2 s record; the features and the comparison's views take several moments of
    every record)."""
    out = None
    sq = np.asarray(d, dtype=float)
    while k:
        if k & 1:
            out = sq.copy() if out is None else out * sq
        k >>= 1
        if k:
            sq = sq * sq
    return out


def central_moment_ratio(x: np.ndarray, order: int) -> np.ndarray:
    """Normalised central moment ``m_k / m_2**(k/2)`` with ``m_k = mean((x - mean x)**k)``.

    ``order=3`` is the skewness, ``order=4`` the (Pearson, non-excess) kurtosis:
    3 for Gaussian noise, 1.5 for a sine. ``order=6`` and ``8`` are the moments
    used by M6A and M8A. A constant record (``m_2 = 0``) gives ``nan``.
    """
    require(isinstance(order, int) and order >= 2, "order", order, "an integer >= 2")
    a = _as_signal(x)
    d = a - a.mean(axis=-1, keepdims=True)
    m2 = np.mean(d * d, axis=-1)
    mk = np.mean(integer_power(d, order), axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = mk / m2 ** (order / 2)
    return np.where(m2 > 0, out, np.nan)


def kurtosis(x: np.ndarray) -> np.ndarray:
    """Pearson kurtosis ``m4 / m2**2`` (not excess): sine 1.5, Gaussian 3."""
    return central_moment_ratio(x, 4)


def skewness(x: np.ndarray) -> np.ndarray:
    """Skewness ``m3 / m2**1.5``: 0 for any symmetric distribution."""
    return central_moment_ratio(x, 3)


def crest_factor(x: np.ndarray) -> np.ndarray:
    """Crest factor ``max|x| / rms(x)``: sqrt(2) for a sine."""
    return _safe_ratio(peak(x), rms(x))


def shape_factor(x: np.ndarray) -> np.ndarray:
    """Shape factor ``rms(x) / mean|x|``: pi / (2 sqrt 2) = 1.1107 for a sine."""
    a = _as_signal(x)
    return _safe_ratio(rms(a), np.mean(np.abs(a), axis=-1))


def impulse_factor(x: np.ndarray) -> np.ndarray:
    """Impulse factor ``max|x| / mean|x|``: pi / 2 for a sine."""
    a = _as_signal(x)
    return _safe_ratio(peak(a), np.mean(np.abs(a), axis=-1))


def clearance_factor(x: np.ndarray) -> np.ndarray:
    """Clearance (margin) factor ``max|x| / mean(sqrt|x|)**2``."""
    a = _as_signal(x)
    return _safe_ratio(peak(a), np.mean(np.sqrt(np.abs(a)), axis=-1) ** 2)


def _safe_ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def time_domain_statistics(x: np.ndarray) -> dict[str, np.ndarray]:
    """All statistics of :data:`STATISTIC_UNITS` for one record or a batch.

    Parameters
    ----------
    x : array_like, shape (..., n_samples)
        Vibration record(s); any unit.

    Returns
    -------
    dict
        ``name -> value`` (a float for a 1-D input, an array for a batch), in the
        order of :data:`STATISTIC_UNITS`.

    Examples
    --------
    >>> t = np.arange(1000) / 1000
    >>> round(float(time_domain_statistics(np.sin(2 * np.pi * 5 * t))["kurtosis"]), 3)
    1.5
    """
    a = _as_signal(x)
    funcs = {
        "rms": rms,
        "peak": peak,
        "peak_to_peak": peak_to_peak,
        "crest_factor": crest_factor,
        "kurtosis": kurtosis,
        "skewness": skewness,
        "shape_factor": shape_factor,
        "impulse_factor": impulse_factor,
        "clearance_factor": clearance_factor,
    }
    out = {}
    for name, f in funcs.items():
        v = f(a)
        out[name] = float(v) if np.ndim(v) == 0 else v
    return out
