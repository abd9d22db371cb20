"""Gear condition indicators computed on a time-synchronous average (TSA).

Each function states its definition and the paper it follows. Inputs are one
averaged revolution (``N`` samples) of the shaft carrying the gear, or the
residual/difference signals of :func:`features.tsa.split_tsa`. Symbols: ``x`` the
TSA, ``r`` the residual, ``d`` the difference signal, a bar the mean over the
revolution, ``z`` the teeth on the gear (mesh order), ``A_k`` the amplitude of
shaft order ``k`` (:func:`features.tsa.order_amplitudes`).

The run-normalised indicators (NA4, NB4) divide by the variance averaged over all
records of a run up to the current one. For a single record (the default, and
what :class:`features.table.FeatureExtractor` computes) that average is the
record's own variance, so NA4 reduces to the kurtosis of the residual and NB4 to
the kurtosis of the envelope; pass ``ensemble_variances`` (or use
:func:`na4_trend`) to get the trend-normalised value of the original papers.

References
----------
.. [1] Stewart, R. M. (1977). Some useful data analysis techniques for gearbox
   diagnostics. Report MHM/R/10/77, Machine Health Monitoring Group, Institute of
   Sound and Vibration Research, University of Southampton (FM0, FM4).
.. [2] Zakrajsek, J. J., Townsend, D. P., Decker, H. J. (1993). An analysis of gear
   fault detection methods as applied to pitting fatigue failure data. NASA
   TM-105950 / Proc. 47th MFPT (FM0, FM4, NA4, M6A, M8A on pitting data).
.. [3] Zakrajsek, J. J., Handschuh, R. F., Decker, H. J. (1994). Application of
   fault detection techniques to spiral bevel gear fatigue data. NASA TM-106467
   (NB4).
.. [4] Martin, H. R. (1989). Statistical moment analysis as a means of surface
   damage detection. Proc. 7th International Modal Analysis Conference, 1016-1021
   (M6A, M8A).
.. [5] Swansson, N. S. (1980). Application of vibration signal analysis techniques
   to signal monitoring. Conference on Friction and Wear in Engineering, Institution
   of Engineers, Australia, 262-267 (energy ratio).
.. [6] Lebold, M., McClintic, K., Campbell, R., Byington, C., Maynard, K. (2000).
   Review of vibration analysis methods for gearbox diagnostics and prognostics.
   Proc. 54th MFPT, 623-634 (consolidated definitions incl. sideband level factor
   and sideband index).
.. [7] Decker, H. J. (2002). Crack detection for aerospace quality spur gears.
   NASA TM-2002-211492 / ARL-TR-2682 (FM4, NA4, NB4, M6A, M8A compared on one rig).
"""
from __future__ import annotations

import numpy as np

from features.statistics import integer_power
from features.tsa import mesh_orders, order_amplitudes, split_tsa
from gearpit.errors import require

#: name -> unit of :func:`gear_condition_indicators` (all ratios of like quantities)
INDICATOR_UNITS: dict[str, str] = {
    "fm0": "1",
    "fm4": "1",
    "na4": "1",
    "nb4": "1",
    "m6a": "1",
    "m8a": "1",
    "energy_ratio": "1",
    "sideband_level_factor": "1",
    "sideband_index": "signal",
}


def _one_rev(x: np.ndarray, field: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 8, field, a.shape, "a 1-D array of >= 8 samples (one revolution)")
    require(bool(np.all(np.isfinite(a))), field, "non-finite values", "finite samples only")
    return a


def _check_mesh_order(mesh_order: int, n: int) -> None:
    require(isinstance(mesh_order, (int, np.integer)) and 2 <= mesh_order <= n // 2 - 1, "mesh_order", mesh_order,
            f"an integer in [2, {n // 2 - 1}] for N = {n} samples per revolution")


def _normalised_moment(y: np.ndarray, order: int, mean_variance: float | None = None) -> float:
    """``N^(k/2 - 1) sum (y - ybar)^k / [sum (y - ybar)^2]^(k/2)``, optionally with a run-mean variance."""
    d = y - y.mean()
    m2 = float(np.mean(d * d)) if mean_variance is None else float(mean_variance)
    if m2 <= 0:
        return float("nan")
    return float(np.mean(integer_power(d, order)) / m2 ** (order / 2))


def fm0(tsa: np.ndarray, mesh_order: int) -> float:
    """FM0 = ``PP(x) / sum_{n=1}^{H} A_{n z}`` (Stewart 1977; Zakrajsek et al. 1993).

    Peak-to-peak of the TSA over the sum of the amplitudes of the mesh frequency
    and all its harmonics up to the Nyquist order. Grows with heavy wear or a
    localised defect that raises peaks but not the mesh tones.
    """
    x = _one_rev(tsa, "tsa")
    _check_mesh_order(mesh_order, x.size)
    amp = order_amplitudes(x)
    den = float(amp[mesh_orders(mesh_order, x.size)].sum())
    return float(np.ptp(x) / den) if den > 0 else float("nan")


def fm4(difference: np.ndarray) -> float:
    """FM4 = ``N sum (d - dbar)^4 / [sum (d - dbar)^2]^2`` (Stewart 1977; Zakrajsek et al. 1993).

    The kurtosis of the difference signal: about 3 for a healthy gear (Gaussian
    difference signal), larger when one or two teeth carry a localised defect.
    """
    return _normalised_moment(_one_rev(difference, "difference"), 4)


def m6a(difference: np.ndarray) -> float:
    """M6A = ``N^2 sum (d - dbar)^6 / [sum (d - dbar)^2]^3`` (Martin 1989; Zakrajsek et al. 1993).

    Sixth normalised moment of the difference signal (15 for Gaussian, 2.5 for a sine).
    """
    return _normalised_moment(_one_rev(difference, "difference"), 6)


def m8a(difference: np.ndarray) -> float:
    """M8A = ``N^3 sum (d - dbar)^8 / [sum (d - dbar)^2]^4`` (Martin 1989; Zakrajsek et al. 1993).

    Eighth normalised moment of the difference signal (105 for Gaussian, 4.375 for a sine).
    """
    return _normalised_moment(_one_rev(difference, "difference"), 8)


def _ensemble_mean_variance(current: np.ndarray, ensemble_variances) -> float | None:
    if ensemble_variances is None:
        return None
    v = np.asarray(ensemble_variances, dtype=float).ravel()
    require(v.size >= 1 and bool(np.all(np.isfinite(v))) and bool(np.all(v >= 0)), "ensemble_variances",
            ensemble_variances, "one or more finite variances >= 0 (the earlier records of the run)")
    d = current - current.mean()
    return float((v.sum() + np.mean(d * d)) / (v.size + 1))


def na4(residual: np.ndarray, *, ensemble_variances=None) -> float:
    """NA4 = ``N sum (r_M - rbar_M)^4 / [ (1/M) sum_{j=1}^{M} sum_i (r_ij - rbar_j)^2 ]^2``.

    Zakrajsek, Townsend, Decker (1993). The fourth moment of the current residual
    signal (record ``M`` of a run) over the square of the residual variance
    averaged over records ``1..M``, so that NA4 keeps growing as damage spreads
    instead of falling back to 3 like FM4.

    Parameters
    ----------
    residual : array_like, shape (N,)
        Residual signal of the current record.
    ensemble_variances : array_like, optional
        Variances ``mean((r_j - rbar_j)^2)`` of the earlier records ``1..M-1`` of
        the run. Default: none, i.e. ``M = 1`` and NA4 equals the kurtosis of the
        residual. Pass the variance of a healthy baseline alone to get NA4*
        (Decker 2002 normalises by the healthy-gear variance).
    """
    r = _one_rev(residual, "residual")
    return _normalised_moment(r, 4, _ensemble_mean_variance(r, ensemble_variances))


def na4_trend(residuals: np.ndarray) -> np.ndarray:
    """NA4 of every record of a run, each normalised by the records up to it.

    Parameters
    ----------
    residuals : array_like, shape (M, N)
        Residual signals of consecutive records, oldest first.
    """
    r = np.asarray(residuals, dtype=float)
    require(r.ndim == 2 and r.shape[0] >= 1, "residuals", r.shape, "a 2-D array (records, samples per revolution)")
    var = np.var(r, axis=1)
    return np.array([na4(r[j], ensemble_variances=var[:j] if j else None) for j in range(r.shape[0])])


def default_nb4_half_band(mesh_order: int) -> int:
    """Half width (orders) of the NB4 band: 10 sidebands, fewer if they would reach 0 or 2z."""
    return int(max(1, min(10, (mesh_order - 1) // 2)))


def mesh_band_envelope(tsa: np.ndarray, mesh_order: int, *, half_band_orders: int | None = None) -> np.ndarray:
    """Envelope ``|s + i H(s)|`` of the TSA band-passed to orders ``z +/- half_band_orders``.

    The band-pass and the Hilbert transform are one ideal order-domain filter
    (positive orders in the band doubled, the rest zeroed).
    """
    x = _one_rev(tsa, "tsa")
    _check_mesh_order(mesh_order, x.size)
    h = default_nb4_half_band(mesh_order) if half_band_orders is None else half_band_orders
    require(isinstance(h, (int, np.integer)) and 1 <= h < mesh_order, "half_band_orders", h,
            f"an integer in [1, {mesh_order - 1}]")
    n = x.size
    spec = np.fft.fft(x)
    k = np.fft.fftfreq(n, 1.0 / n)
    mask = (k >= mesh_order - h) & (k <= mesh_order + h)
    return np.abs(np.fft.ifft(2.0 * spec * mask))


def nb4(tsa: np.ndarray, mesh_order: int, *, half_band_orders: int | None = None, ensemble_variances=None) -> float:
    """NB4 = ``N sum (E_M - Ebar_M)^4 / [ (1/M) sum_j sum_i (E_ij - Ebar_j)^2 ]^2``.

    Zakrajsek, Handschuh, Decker (1994): NA4 applied to the envelope ``E`` of the
    TSA band-passed around the mesh frequency (:func:`mesh_band_envelope`); a
    damaged tooth modulates the mesh tone and leaves transients in ``E``. Run
    normalisation as in :func:`na4` (single record: kurtosis of ``E``).
    """
    e = mesh_band_envelope(tsa, mesh_order, half_band_orders=half_band_orders)
    return _normalised_moment(e, 4, _ensemble_mean_variance(e, ensemble_variances))


def energy_ratio(difference: np.ndarray, regular: np.ndarray) -> float:
    """ER = ``RMS(d) / RMS(y)`` with ``y`` the regular meshing components (Swansson 1980; Lebold 2000).

    Heavy, distributed damage moves energy from the mesh harmonics into the
    difference signal.
    """
    d = _one_rev(difference, "difference")
    y = _one_rev(regular, "regular")
    ry = float(np.sqrt(np.mean((y - y.mean()) ** 2)))
    return float(np.sqrt(np.mean((d - d.mean()) ** 2)) / ry) if ry > 0 else float("nan")


def _first_sidebands(tsa: np.ndarray, mesh_order: int) -> tuple[float, float]:
    x = _one_rev(tsa, "tsa")
    _check_mesh_order(mesh_order, x.size)
    amp = order_amplitudes(x)
    return float(amp[mesh_order - 1]), float(amp[mesh_order + 1])


def sideband_level_factor(tsa: np.ndarray, mesh_order: int) -> float:
    """SLF = ``(A_{z-1} + A_{z+1}) / std(x)`` (Lebold et al. 2000).

    Sum of the first-order sidebands about the fundamental mesh frequency over the
    standard deviation of the TSA; a shaft or a single-tooth fault raises it.
    """
    lo, hi = _first_sidebands(tsa, mesh_order)
    s = float(np.std(np.asarray(tsa, dtype=float)))
    return (lo + hi) / s if s > 0 else float("nan")


def sideband_index(tsa: np.ndarray, mesh_order: int) -> float:
    """SI = ``(A_{z-1} + A_{z+1}) / 2`` (Lebold et al. 2000), in the unit of the signal.

    Mean amplitude of the first-order sidebands about the fundamental mesh frequency.
    """
    lo, hi = _first_sidebands(tsa, mesh_order)
    return 0.5 * (lo + hi)


def gear_condition_indicators(tsa: np.ndarray, mesh_order: int, *, n_shaft_orders: int = 2,
                              n_sideband_orders: int = 1, nb4_half_band_orders: int | None = None) -> dict[str, float]:
    """All indicators of :data:`INDICATOR_UNITS` for one averaged revolution (single record).

    Parameters
    ----------
    tsa : array_like, shape (N,)
        Averaged revolution of the shaft carrying the gear.
    mesh_order : int
        Teeth on that gear.
    n_shaft_orders, n_sideband_orders : int
        Passed to :func:`features.tsa.split_tsa`.
    nb4_half_band_orders : int, optional
        Passed to :func:`nb4`.

    Examples
    --------
    >>> theta = 2 * np.pi * np.arange(256) / 256
    >>> ci = gear_condition_indicators(np.cos(16 * theta) + 0.3 * np.cos(7 * theta), 16)
    >>> round(ci["fm4"], 3)  # the difference signal is the order-7 sine
    1.5
    """
    parts = split_tsa(tsa, mesh_order, n_shaft_orders=n_shaft_orders, n_sideband_orders=n_sideband_orders)
    return {
        "fm0": fm0(parts.tsa, mesh_order),
        "fm4": fm4(parts.difference),
        "na4": na4(parts.residual),
        "nb4": nb4(parts.tsa, mesh_order, half_band_orders=nb4_half_band_orders),
        "m6a": m6a(parts.difference),
        "m8a": m8a(parts.difference),
        "energy_ratio": energy_ratio(parts.difference, parts.regular),
        "sideband_level_factor": sideband_level_factor(parts.tsa, mesh_order),
        "sideband_index": sideband_index(parts.tsa, mesh_order),
    }
