"""The views an expert reads, as levels (dB) at named physical locations.

One :class:`compare.plan.Plan` (built once from the measurement, :func:`compare.plan.make_plan`) fixes the
locations; :func:`analyse` evaluates any signal - measured or simulated - at
them, so that measurement and model go through the same processing and a
location means the same thing in both. All spectra are computed after angular
resampling (order-normalised): a location is a shaft order, not a frequency,
and a small speed difference between rig and model moves nothing.

=========  ============================================================================  =====================
view       locations                                                                     level
=========  ============================================================================  =====================
order      mesh harmonics ``m fm``; their sidebands ``m fm +/- k fr`` for both shafts;     20 log10 amplitude
           shaft orders ``k fr`` of both shafts (pinion lines from the pinion-angle
           spectrum, wheel lines from the wheel-angle spectrum: every line on a bin)
band       1/3-octave bands of the content that is no order of either shaft (bins         10 log10 mean power
           within 2 bins of any shaft order masked); lines found in the measurement
           at no shaft order ("line at 61.0 Hz")
envelope   envelope spectrum (band 0.5 fm .. 0.45 fs) at shaft orders of both shafts,      20 log10 amplitude
           at ``fm``, and at lines found in the measurement at no shaft order
tsa        per shaft: the time-synchronous average split into tooth segments; power of    10 log10 power
           the residual signal (mesh harmonics and low orders removed) in the strongest
           and the median tooth; power of the TSA in the loudest and quietest tooth
stats      rms, crest factor, kurtosis of the record; FM0, FM4, NA4, NB4, M6A, M8A,        dB of the value
           energy ratio, sideband level factor of each shaft's TSA
=========  ============================================================================  =====================

Each location also has a *floor* (same unit): at a line, the local noise level
(30 % quantile of the power of the non-order bins in blocks of
``2 FLOOR_HALF_WIDTH`` bins, divided by the 30 % quantile of a unit-mean
exponential variable, i.e. the mean noise power per bin, interpolated); for
bands, that quantity over the whole analysed range; in the TSA, the noise power
left after averaging R revolutions (the record variance the floor implies,
``sum of per-bin floor power / 3`` for a Hann window, divided by R).
Statistics have none.

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley: ch. 3 (order spectra, sidebands,
    envelope), ch. 5 (order tracking, TSA).
Lebold, M. et al. (2000). Review of vibration analysis methods for gearbox diagnostics and prognostics.
    Proc. 54th MFPT, 623-634 (regular/residual/difference signals, condition indicators).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from compare.plan import INDICATORS, STATS, Location, Plan
from compare.spectra import (EXP_Q, FLOOR_QUANTILE, angle_records, db, envelope_power, non_order, non_order_wheel,
                             power_spectrum, smooth_floor)
from features.indicators import gear_condition_indicators
from features.statistics import time_domain_statistics
from features.tsa import AngleTrack, angular_resample, split_tsa


@dataclass(frozen=True, eq=False)
class SignalViews:
    """Levels and floors (dB) of one signal at the plan's locations, plus curves for figures."""

    levels: np.ndarray
    floors: np.ndarray
    curves: dict = field(default_factory=dict)


def _tooth_powers(y: np.ndarray, z: int) -> np.ndarray:
    n = y.size
    edges = (np.arange(z + 1) * n) // z
    sq = np.concatenate([[0.0], np.cumsum(y * y)])
    return (sq[edges[1:]] - sq[edges[:-1]]) / np.diff(edges)


def _bin_level(p: np.ndarray, b: float) -> float:
    """Power at fractional bin ``b``: the largest of the two bins around it (lines off the bin grid)."""
    i = int(np.floor(b))
    if abs(b - round(b)) < 1e-6:
        return float(p[int(round(b))])
    return float(max(p[i], p[min(i + 1, p.size - 1)]))


def _pinion_part(xp: np.ndarray, plan: Plan):
    """Power spectrum, its floor, the non-order mask and the noise floor of a pinion-angle record."""
    pp = power_spectrum(xp)
    no_order = non_order(pp.size, plan)
    fl_p = smooth_floor(pp, no_order)
    fbins = np.arange(pp.size) * plan.bin_hz
    in_bands = (fbins > plan.bands_hz[0][0]) & (fbins < plan.bands_hz[-1][1])
    sel = pp[no_order & in_bands] if np.count_nonzero(no_order & in_bands) >= 16 else pp[in_bands]
    return pp, fl_p, no_order, float(np.quantile(sel, FLOOR_QUANTILE) / EXP_Q)


def pinion_lines(x: np.ndarray, fs_hz: float, track: AngleTrack, plan: Plan) -> SignalViews:
    """Quick look: levels and floors at the pinion-spectrum lines only (mesh harmonics, pinion sidebands and
    orders; NaN elsewhere), and the noise floor in ``curves`` - enough for a first gain estimate."""
    xp = angular_resample(x, fs_hz, track, samples_per_rev=plan.samples_per_rev, oversample=2)[:plan.n_revs].ravel()
    pp, fl_p, _, noise_floor = _pinion_part(xp, plan)
    levels = np.full(len(plan.locations), np.nan)
    floors = np.full(len(plan.locations), np.nan)
    for i, loc in enumerate(plan.locations):
        if loc.view == "order" and "wheel" not in loc.key:
            b = int(round(loc.order_pinion * plan.n_revs))
            levels[i], floors[i] = db(pp[b]), db(fl_p[b])
    return SignalViews(levels=levels, floors=floors, curves={"noise_floor": noise_floor})


def analyse(x: np.ndarray, fs_hz: float, track: AngleTrack, plan: Plan, *, keep_curves: bool = False) -> SignalViews:
    """Levels and floors (dB) of ``x`` at the plan's locations (module docstring)."""
    rec = angle_records(x, fs_hz, track, plan)
    pp, fl_p, no_order, noise_floor = _pinion_part(rec.pinion.ravel(), plan)
    pw = power_spectrum(rec.wheel.ravel())
    R, Rw = plan.n_revs, plan.n_revs_wheel
    zp, zw = plan.z_pinion, plan.z_wheel
    env = envelope_power(rec.pinion.ravel(), plan)
    fl_w = smooth_floor(pw, non_order_wheel(pw.size, plan))
    fl_e = smooth_floor(env, non_order(env.size, plan))
    bin_hz = plan.bin_hz
    tsa_p = rec.pinion.mean(axis=0)
    tsa_w = rec.wheel.mean(axis=0)
    # noise left in a TSA: record variance of the floor (sum of per-bin floor power / 3 for a Hann
    # window: white noise of variance s2 gives 6 s2 / N per bin over N / 2 bins) divided by R
    nsf_p = float(np.sum(fl_p)) / 3.0 / R
    nsf_w = float(np.sum(fl_w)) / 3.0 / Rw
    tsa_parts = {"pinion": (tsa_p, zp, nsf_p), "wheel": (tsa_w, zw, nsf_w)}
    tsa_vals = {}
    for shaft, (tsa, z, _) in tsa_parts.items():
        res = split_tsa(tsa, z).residual
        tp_res = _tooth_powers(res, z)
        tp = _tooth_powers(tsa - tsa.mean(), z)
        tsa_vals[shaft] = {"residual_max": tp_res.max(), "residual_median": np.median(tp_res), "tooth_max": tp.max(),
                           "tooth_min": tp.min()}
    stats = time_domain_statistics(np.asarray(x, float) - np.mean(x))
    ind = {s: gear_condition_indicators(tsa_parts[s][0], tsa_parts[s][1]) for s in ("pinion", "wheel")}
    levels = np.empty(len(plan.locations))
    floors = np.full(len(plan.locations), np.nan)
    for i, loc in enumerate(plan.locations):
        view, name = loc.key.split(":", 1)
        if view == "order":
            if "wheel" in name:          # wheel lines: integer wheel orders, on the wheel-angle spectrum
                b = loc.order_pinion * zw / zp * Rw
                levels[i], floors[i] = db(_bin_level(pw, b)), db(fl_w[int(round(b))])
            else:
                b = loc.order_pinion * R
                levels[i], floors[i] = db(_bin_level(pp, b)), db(fl_p[int(round(b))])
        elif view == "band":
            if name.startswith("line"):
                b = loc.freq_hz / bin_hz
                i0 = int(round(b))
                levels[i] = db(pp[max(i0 - 1, 0):i0 + 2].max())
                floors[i] = db(fl_p[i0])
            else:
                lo, hi = (float(v) for v in name.split("-"))
                lo_b, hi_b = _band_bins(loc, plan)
                sel = no_order[lo_b:hi_b]
                seg = pp[lo_b:hi_b][sel] if sel.any() else pp[lo_b:hi_b]
                levels[i], floors[i] = db(seg.mean()), db(noise_floor)
        elif view == "envelope":
            b = loc.order_pinion * R
            i0 = int(round(b))
            levels[i] = db(_bin_level(env, b) if not name.startswith("line") else env[max(i0 - 1, 0):i0 + 2].max())
            floors[i] = db(fl_e[i0])
        elif view == "tsa":
            shaft, key = name.split("_", 1)
            levels[i], floors[i] = db(tsa_vals[shaft][key]), db(tsa_parts[shaft][2])
        else:
            if name in STATS:
                levels[i] = db(abs(stats[name]) ** 2 if STATS[name][0] == 20 else abs(stats[name]))
            else:
                shaft, key = name.split("_", 1)
                v = ind[shaft][key]
                v = v if np.isfinite(v) else 0.0
                levels[i] = db(abs(v) ** 2 if INDICATORS[key][0] == 20 else abs(v))
            if not loc.gain:             # dimensionless indicators near 0; the RMS is a level and moves with the gain
                levels[i] = max(levels[i], -60.0)
    curves = {}
    if keep_curves:
        curves = {"order_hz": np.arange(pp.size) * bin_hz, "order_power": pp, "order_floor": fl_p,
                  "envelope_power": env, "envelope_floor": fl_e, "tsa_pinion": tsa_p, "tsa_wheel": tsa_w,
                  "noise_floor": noise_floor}
    return SignalViews(levels=levels, floors=floors, curves=curves)


def _band_bins(loc: Location, plan: Plan) -> tuple[int, int]:
    lo, hi = (float(v) for v in loc.key.split(":", 1)[1].split("-"))
    # the key rounds the edges; use the plan's exact band with that rounded name
    for a, b in plan.bands_hz:
        if f"{a:.0f}-{b:.0f}" == f"{lo:.0f}-{hi:.0f}":
            lo, hi = a, b
            break
    return int(np.ceil(lo / plan.bin_hz)), int(np.floor(hi / plan.bin_hz)) + 1
