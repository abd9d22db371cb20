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
from functools import lru_cache

import numpy as np

from compare.plan import INDICATORS, STATS, Location, Plan
from compare.spectra import (EXP_Q, FLOOR_QUANTILE, OVERSAMPLE, angle_records, below_shafts_removed, db,
                             envelope_power, non_order, non_order_wheel, power_spectrum, smooth_floor)
from features.indicators import gear_condition_indicators
from features.statistics import time_domain_statistics
from features.tsa import AngleTrack, TimeInterpolant, split_tsa


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


def _in_bands(n_bins: int, plan: Plan) -> np.ndarray:
    """Pinion-spectrum bins inside the analysed band range."""
    fbins = np.arange(n_bins) * plan.bin_hz
    return (fbins > plan.bands_hz[0][0]) & (fbins < plan.bands_hz[-1][1])


def _noise_floor(pp: np.ndarray, no_order: np.ndarray, in_bands: np.ndarray) -> float:
    """Mean noise power per bin of a pinion-angle spectrum: the floor quantile of its non-order bins in the
    analysed range (of all its bins there when fewer than 16 are no order)."""
    sel = pp[no_order & in_bands] if np.count_nonzero(no_order & in_bands) >= 16 else pp[in_bands]
    return float(np.quantile(sel, FLOOR_QUANTILE) / EXP_Q)


def _pinion_part(xp: np.ndarray, plan: Plan):
    """Power spectrum, its floor, the non-order mask and the noise floor of a pinion-angle record."""
    pp = power_spectrum(xp)
    no_order = non_order(pp.size, plan)
    return pp, smooth_floor(pp, no_order), no_order, _noise_floor(pp, no_order, _in_bands(pp.size, plan))


def pinion_lines(x: np.ndarray, fs_hz: float, track: AngleTrack, plan: Plan) -> SignalViews:
    """Quick look: levels and floors at the pinion-spectrum lines only (mesh harmonics, pinion sidebands and
    orders; NaN elsewhere), and the noise floor in ``curves`` - enough for a first gain estimate."""
    xp = TimeInterpolant(x, fs_hz, oversample=OVERSAMPLE).resample(
        track, samples_per_rev=plan.samples_per_rev, skip_edges=True)[:plan.n_revs].ravel()    # as angle_records
    pp, fl_p, _, noise_floor = _pinion_part(xp, plan)
    levels = np.full(len(plan.locations), np.nan)
    floors = np.full(len(plan.locations), np.nan)
    for i, loc in enumerate(plan.locations):
        if loc.view == "order" and "wheel" not in loc.key:
            b = int(round(loc.order_pinion * plan.n_revs))
            levels[i], floors[i] = db(pp[b]), db(fl_p[b])
    return SignalViews(levels=levels, floors=floors, curves={"noise_floor": noise_floor})


@dataclass(frozen=True, eq=False)
class _Layout:
    """Where each of a plan's locations is read, as index arrays (made once per plan and spectrum length by
    :func:`_layout`; a comparison evaluates hundreds of signals on one plan)."""

    no_order: np.ndarray      # non-order bins of the pinion-angle (and envelope) spectrum
    no_order_w: np.ndarray    # non-order bins of the wheel-angle spectrum
    in_bands: np.ndarray      # pinion-spectrum bins inside the analysed band range
    order_p: tuple            # (location rows, lower bin, upper bin, floor bin): lines on the pinion spectrum
    order_w: tuple            # the same on the wheel spectrum
    band_lines: tuple         # (rows, lower, upper, centre bin): lines at no shaft order, the largest of 3 bins
    bands: tuple              # ((row, bins of the band that are no order, or all of its bins), ...)
    envelope: tuple           # (rows, lower bin, upper bin, floor bin, whether the level is the largest of 3 bins)
    tsa: tuple                # ((row, shaft, key), ...)
    stats: tuple              # ((row, name, gain), ...)


def _line_bins(b: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The two bins whose larger power is a line's level at fractional bin ``b``: the bin itself when ``b`` is on
    the grid, else the bins either side (a line off the bin grid)."""
    on = np.abs(b - np.round(b)) < 1e-6
    lo = np.where(on, np.round(b), np.floor(b)).astype(int)
    hi = np.where(on, lo, np.minimum(np.floor(b).astype(int) + 1, size - 1))
    return lo, hi


@lru_cache(maxsize=8)
def _layout(plan: Plan, n_p: int, n_w: int) -> _Layout:
    R, Rw, zp, zw = plan.n_revs, plan.n_revs_wheel, plan.z_pinion, plan.z_wheel
    no_order = non_order(n_p, plan)
    rows = {k: [] for k in ("op", "ow", "bl", "env", "env_line")}
    pos = {k: [] for k in rows}
    bands, tsa, stats = [], [], []
    for i, loc in enumerate(plan.locations):
        view, name = loc.key.split(":", 1)
        if view == "order":
            k = "ow" if "wheel" in name else "op"
            rows[k].append(i)
            pos[k].append(loc.order_pinion * zw / zp * Rw if k == "ow" else loc.order_pinion * R)
        elif view == "band" and name.startswith("line"):
            rows["bl"].append(i)
            pos["bl"].append(loc.freq_hz / plan.bin_hz)
        elif view == "band":
            lo_b, hi_b = _band_bins(loc, plan)
            sel = no_order[lo_b:hi_b]
            bins = np.arange(lo_b, min(hi_b, n_p))
            bands.append((i, bins[sel[:bins.size]] if sel.any() else bins))
        elif view == "envelope":
            k = "env_line" if name.startswith("line") else "env"
            rows[k].append(i)
            pos[k].append(loc.order_pinion * R)
        elif view == "tsa":
            shaft, key = name.split("_", 1)
            tsa.append((i, shaft, key))
        else:
            stats.append((i, name, loc.gain))

    def lines(k, size):
        b = np.asarray(pos[k], float)
        lo, hi = _line_bins(b, size)
        return np.asarray(rows[k], int), lo, hi, np.round(b).astype(int)

    def three_bins(k, size):
        i0 = np.round(np.asarray(pos[k], float)).astype(int)
        return np.asarray(rows[k], int), np.maximum(i0 - 1, 0), np.minimum(i0 + 1, size - 1), i0

    env_lines, env_three = lines("env", n_p), three_bins("env_line", n_p)
    envelope = tuple(np.concatenate([a, b]) for a, b in zip(env_lines, env_three)) + (
        np.concatenate([np.zeros(env_lines[0].size, bool), np.ones(env_three[0].size, bool)]),)
    return _Layout(no_order=no_order, no_order_w=non_order_wheel(n_w, plan), in_bands=_in_bands(n_p, plan),
                   order_p=lines("op", n_p), order_w=lines("ow", n_w), band_lines=three_bins("bl", n_p),
                   bands=tuple(bands), envelope=envelope, tsa=tuple(tsa), stats=tuple(stats))


def _three_max(p: np.ndarray, lo: np.ndarray, i0: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.maximum(np.maximum(p[lo], p[i0]), p[hi])


def analyse(x: np.ndarray, fs_hz: float, track: AngleTrack, plan: Plan, *, keep_curves: bool = False) -> SignalViews:
    """Levels and floors (dB) of ``x`` at the plan's locations (module docstring), its content below every shaft
    order removed first when the plan says so (:func:`compare.spectra.below_shafts_removed`)."""
    x = below_shafts_removed(x, fs_hz, plan)
    rec = angle_records(x, fs_hz, track, plan)
    xp = rec.pinion.ravel()
    pp = power_spectrum(xp)
    pw = power_spectrum(rec.wheel.ravel())
    lay = _layout(plan, pp.size, pw.size)
    fl_p = smooth_floor(pp, lay.no_order)
    noise_floor = _noise_floor(pp, lay.no_order, lay.in_bands)
    R, Rw = plan.n_revs, plan.n_revs_wheel
    zp, zw = plan.z_pinion, plan.z_wheel
    env = envelope_power(xp, plan)
    fl_w = smooth_floor(pw, lay.no_order_w)
    fl_e = smooth_floor(env, lay.no_order)
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
    n_loc = len(plan.locations)
    power = np.empty(n_loc)              # levels as powers (10 log10), floors likewise, converted once at the end
    floor = np.full(n_loc, np.nan)
    for (rows, lo, hi, fb), p, fl in ((lay.order_p, pp, fl_p), (lay.order_w, pw, fl_w)):
        power[rows] = np.maximum(p[lo], p[hi])
        floor[rows] = fl[fb]
    rows, lo, hi, i0 = lay.band_lines
    power[rows], floor[rows] = _three_max(pp, lo, i0, hi), fl_p[i0]
    for row, bins in lay.bands:
        power[row], floor[row] = pp[bins].mean(), noise_floor
    rows, lo, hi, i0, three = lay.envelope
    power[rows] = np.where(three, _three_max(env, lo, i0, hi), np.maximum(env[lo], env[hi]))
    floor[rows] = fl_e[i0]
    for row, shaft, key in lay.tsa:
        power[row], floor[row] = tsa_vals[shaft][key], tsa_parts[shaft][2]
    levels = db(power)
    floors = np.where(np.isnan(floor), np.nan, db(np.nan_to_num(floor, nan=1.0)))
    for row, name, gain in lay.stats:
        if name in STATS:
            levels[row] = db(abs(stats[name]) ** 2 if STATS[name][0] == 20 else abs(stats[name]))
        else:
            shaft, key = name.split("_", 1)
            v = ind[shaft][key]
            v = v if np.isfinite(v) else 0.0
            levels[row] = db(abs(v) ** 2 if INDICATORS[key][0] == 20 else abs(v))
        if not gain:                     # dimensionless indicators near 0; the RMS is a level and moves with the gain
            levels[row] = max(levels[row], -60.0)
    curves = {}
    if keep_curves:
        curves = {"order_hz": np.arange(pp.size) * plan.bin_hz, "order_power": pp, "order_floor": fl_p,
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
