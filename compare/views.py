"""The views an expert reads, as levels (dB) at named physical locations.

One :class:`Plan` (built once from the measurement, :func:`make_plan`) fixes the
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

Each location also has a *floor* (same unit): the local noise level at a line
(30 % quantile of the power within +/- ``FLOOR_HALF_WIDTH`` bins divided by the
30 % quantile of an exponential variable, i.e. the mean noise power), the
non-order floor for bands, the non-synchronous power left in the TSA
(``mean over angle of the variance over revolutions / R``). Statistics have none.

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

from features.indicators import gear_condition_indicators
from features.statistics import time_domain_statistics
from features.tsa import AngleTrack, angular_resample, default_samples_per_rev, split_tsa
from gearpit.errors import require

VIEWS = ("order", "band", "envelope", "tsa", "stats")
#: half width (bins) of the neighbourhood whose low quantile is a line's floor
FLOOR_HALF_WIDTH = 60
#: quantile used for floors, and the same quantile of a unit-mean exponential variable (power of noise)
FLOOR_QUANTILE = 0.30
_EXP_Q = -np.log(1 - FLOOR_QUANTILE)
#: bins either side of a shaft order that count as "at an order"
ORDER_MASK_BINS = 2
TINY = 1e-30
#: statistics: name -> (dB factor, label)
STATS = {"rms": (20, "rms"), "crest_factor": (20, "crest factor"), "kurtosis": (10, "kurtosis")}
INDICATORS = {"fm0": (20, "FM0"), "fm4": (10, "FM4"), "na4": (10, "NA4"), "nb4": (10, "NB4"), "m6a": (10, "M6A"),
              "m8a": (10, "M8A"), "energy_ratio": (20, "energy ratio"),
              "sideband_level_factor": (20, "sideband level factor")}


@dataclass(frozen=True)
class Location:
    """One named place where measurement and model are compared.

    Attributes
    ----------
    key : str
        Stable identifier, ``"<view>:<name>"``.
    view : str
        One of :data:`VIEWS`.
    group : str
        Weight group inside the view (each group carries equal weight, shared by its locations).
    label : str
        Physical description (``"2 fm - 1 fr_wheel"``, ``"2.9-3.3 kHz band"``).
    freq_hz : float or None
        Frequency at the plan's mean speed (Hz); band centre for bands.
    gain : bool
        Whether the level moves with the sensor gain (20 log10 g for amplitudes).
    gain_factor : float
        dB per dB of gain: 1 for amplitudes and 20 log10 levels, 1 for powers in 10 log10 (same dB), 0 otherwise.
    """

    key: str
    view: str
    group: str
    label: str
    freq_hz: float | None = None
    gain: bool = True
    order_pinion: float | None = None


@dataclass(frozen=True, eq=False)
class Plan:
    """Processing settings and locations, fixed for one comparison (see :func:`make_plan`)."""

    fs_hz: float
    fr_pinion_hz: float
    z_pinion: int
    z_wheel: int
    samples_per_rev: int
    n_revs: int
    samples_per_rev_wheel: int
    n_revs_wheel: int
    n_harmonics: int
    n_sidebands: int
    n_shaft_orders: int
    bands_hz: tuple
    envelope_band_hz: tuple
    extra_lines_hz: tuple = ()
    extra_envelope_hz: tuple = ()
    locations: tuple = ()

    @property
    def fr_wheel_hz(self) -> float:
        return self.fr_pinion_hz * self.z_pinion / self.z_wheel

    @property
    def fm_hz(self) -> float:
        return self.fr_pinion_hz * self.z_pinion

    @property
    def bin_hz(self) -> float:
        return self.fr_pinion_hz / self.n_revs

    @property
    def keys(self) -> list[str]:
        return [loc.key for loc in self.locations]

    def view_index(self, view: str) -> np.ndarray:
        return np.array([i for i, loc in enumerate(self.locations) if loc.view == view], dtype=int)


@dataclass(frozen=True, eq=False)
class SignalViews:
    """Levels and floors (dB) of one signal at the plan's locations, plus curves for figures."""

    levels: np.ndarray
    floors: np.ndarray
    curves: dict = field(default_factory=dict)


# ---------------------------------------------------------------------- helpers
def _hann(n: int) -> np.ndarray:
    return 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)


def _power_spectrum(x: np.ndarray) -> np.ndarray:
    """Window-corrected line power ``(2 |X| / sum w)^2`` (Hann) of a mean-removed record."""
    w = _hann(x.size)
    amp = 2.0 * np.abs(np.fft.rfft((x - x.mean()) * w)) / w.sum()
    return amp**2


def _order_mask(n_bins: int, n_revs: int, ratio: float) -> np.ndarray:
    """True for bins near an integer order of a shaft; ``ratio``: resampling-shaft orders per order of that shaft.

    "Near" is ORDER_MASK_BINS bins, or 1 bin when the orders are fewer than 8 bins apart (short records).
    """
    k = np.arange(n_bins) / n_revs / ratio  # shaft order of each bin
    dist = np.abs(k - np.round(k)) * n_revs * ratio  # distance in bins
    half = ORDER_MASK_BINS if n_revs * ratio >= 8 else 1
    return dist <= half + 1e-9


def _db(p, factor=10.0):
    return factor * np.log10(np.maximum(np.asarray(p, float), TINY))


def _fmt_hz(f: float) -> str:
    return f"{f / 1000:.2f} kHz" if f >= 1000 else f"{f:.1f} Hz"


def _harmonic_label(m: int, shaft: str | None = None, k: int = 0) -> str:
    base = "fm" if m == 1 else f"{m} fm"
    if shaft is None:
        return base
    return f"{base} {'+' if k > 0 else '-'} {abs(k)} fr_{shaft}"


# ---------------------------------------------------------------------- resampled records
@dataclass(frozen=True, eq=False)
class AngleRecords:
    """The record resampled on the pinion angle and on the wheel angle, whole revolutions."""

    pinion: np.ndarray   # (R, N_p)
    wheel: np.ndarray    # (R_w, N_w)


def angle_records(x: np.ndarray, fs_hz: float, track: AngleTrack, plan: Plan) -> AngleRecords:
    """Resample ``x`` (pinion angle ``track``) for the plan; refuses records shorter than the plan."""
    ratio = plan.z_pinion / plan.z_wheel
    rp = angular_resample(x, fs_hz, track, samples_per_rev=plan.samples_per_rev, oversample=2)
    wt = AngleTrack(track.time_s, track.angle_rad * ratio)
    rw = angular_resample(x, fs_hz, wt, samples_per_rev=plan.samples_per_rev_wheel, oversample=2)
    require(rp.shape[0] >= plan.n_revs and rw.shape[0] >= plan.n_revs_wheel, "record",
            f"{rp.shape[0]} pinion / {rw.shape[0]} wheel revolutions",
            f">= {plan.n_revs} / {plan.n_revs_wheel} (as many as the measurement)")
    return AngleRecords(rp[:plan.n_revs], rw[:plan.n_revs_wheel])


# ---------------------------------------------------------------------- the plan
def make_plan(x: np.ndarray, fs_hz: float, track: AngleTrack, pair, *, n_sidebands: int = 3,
              n_shaft_orders: int = 5, max_harmonics: int = 5, n_extra_lines: int = 6,
              line_prominence_db: float = 12.0) -> Plan:
    """Locations for a measurement ``x`` whose pinion angle is ``track``.

    The lines found at no shaft order (band and envelope views) are the
    ``n_extra_lines`` most prominent local maxima at least ``line_prominence_db``
    above their local floor.
    """
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    duration = (len(x) - 1) / fs_hz
    fr = (track.angle_rad[-1] - track.angle_rad[0]) / (2 * np.pi) / (track.time_s[-1] - track.time_s[0])
    fm = fr * z1
    frw = fr * z1 / z2
    n_revs = int(np.floor((track.angle_rad[-1] - track.angle_rad[0]) / (2 * np.pi) + 1e-9))
    n_revs_w = int(np.floor((track.angle_rad[-1] - track.angle_rad[0]) * z1 / z2 / (2 * np.pi) + 1e-9))
    require(n_revs_w >= 2, "measurement length", f"{duration:.3g} s", "at least two wheel revolutions")
    top = 0.45 * fs_hz
    n_harm = int(min(max_harmonics, np.floor((top - n_sidebands * fr) / fm)))
    require(n_harm >= 1, "fs_hz", fs_hz, f"> {2 * (fm + n_sidebands * fr) / 0.9:.4g} Hz (mesh sidebands below 0.45 fs)")
    f_lo = max(2.0 * fr, 10.0)
    n_bands = int(np.floor(3 * np.log2(top / f_lo)))
    edges = f_lo * 2.0 ** (np.arange(n_bands + 1) / 3.0)
    bands = tuple((float(a), float(b)) for a, b in zip(edges[:-1], edges[1:]))
    plan = Plan(fs_hz=float(fs_hz), fr_pinion_hz=float(fr), z_pinion=z1, z_wheel=z2,
                samples_per_rev=default_samples_per_rev(fs_hz, fr), n_revs=n_revs,
                samples_per_rev_wheel=default_samples_per_rev(fs_hz, frw), n_revs_wheel=n_revs_w,
                n_harmonics=n_harm, n_sidebands=n_sidebands, n_shaft_orders=n_shaft_orders, bands_hz=bands,
                envelope_band_hz=(0.5 * fm, top))
    rec = angle_records(x, fs_hz, track, plan)
    extra, extra_env = _discover(rec, plan, n_extra_lines, line_prominence_db)
    plan = Plan(**{**plan.__dict__, "extra_lines_hz": extra, "extra_envelope_hz": extra_env})
    object.__setattr__(plan, "locations", tuple(_locations(plan)))
    return plan


def _peaks(p: np.ndarray, ok: np.ndarray, floor: np.ndarray, n: int, prominence_db: float) -> list[int]:
    lm = np.zeros(p.size, bool)
    lm[1:-1] = (p[1:-1] > p[:-2]) & (p[1:-1] >= p[2:])
    cand = np.nonzero(lm & ok & (p > floor * 10 ** (prominence_db / 10)))[0]
    cand = cand[np.argsort(-(p[cand] / floor[cand]))]
    chosen: list[int] = []
    for c in cand:
        if all(abs(c - d) > 2 * ORDER_MASK_BINS for d in chosen):
            chosen.append(int(c))
        if len(chosen) == n:
            break
    return sorted(chosen)


def _non_order(n_bins: int, plan: Plan) -> np.ndarray:
    return ~(_order_mask(n_bins, plan.n_revs, 1.0) | _order_mask(n_bins, plan.n_revs, plan.z_pinion / plan.z_wheel))


def _smooth_floor(p: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """Floor at every bin: the FLOOR_QUANTILE of blocks of 2*FLOOR_HALF_WIDTH bins (masked bins left out,
    unless fewer than 8 remain), divided by that quantile of a unit-mean exponential, interpolated."""
    b = 2 * FLOOR_HALF_WIDTH
    n_blocks = int(np.ceil(p.size / b))
    pad = n_blocks * b - p.size
    blocks = np.pad(p, (0, pad), constant_values=np.nan).reshape(n_blocks, b)
    masked = np.where(np.pad(ok, (0, pad), constant_values=False).reshape(n_blocks, b), blocks, np.nan)
    enough = np.sum(np.isfinite(masked), axis=1) >= 8
    src = np.sort(np.where(np.isfinite(np.where(enough[:, None], masked, blocks)),
                           np.where(enough[:, None], masked, blocks), np.inf), axis=1)
    n_valid = np.sum(np.isfinite(src), axis=1)
    idx = np.floor(FLOOR_QUANTILE * (np.maximum(n_valid, 1) - 1)).astype(int)
    vals = src[np.arange(n_blocks), idx] / _EXP_Q
    centres = np.arange(n_blocks) * b + b / 2
    return np.maximum(np.interp(np.arange(p.size), centres, vals), TINY)


def _discover(rec: AngleRecords, plan: Plan, n: int, prominence_db: float):
    bin_hz = plan.bin_hz
    p = _power_spectrum(rec.pinion.ravel())
    ok = _non_order(p.size, plan)
    f = np.arange(p.size) * bin_hz
    ok &= (f > plan.bands_hz[0][0]) & (f < plan.bands_hz[-1][1])
    lines = tuple(float(b * bin_hz) for b in _peaks(p, ok, _smooth_floor(p, ok), n, prominence_db))
    e = _envelope_power(rec.pinion.ravel(), plan)
    ok_e = _non_order(e.size, plan)
    fe = np.arange(e.size) * bin_hz
    ok_e &= (fe > 0.5 * plan.fr_wheel_hz) & (fe < plan.fm_hz * 2.5)
    env = tuple(float(b * bin_hz) for b in _peaks(e, ok_e, _smooth_floor(e, ok_e), n, prominence_db))
    return lines, env


def _locations(plan: Plan) -> list[Location]:
    fr, frw, fm = plan.fr_pinion_hz, plan.fr_wheel_hz, plan.fm_hz
    ratio = plan.z_pinion / plan.z_wheel
    locs = []
    for m in range(1, plan.n_harmonics + 1):
        locs.append(Location(f"order:fm{m}", "order", "mesh harmonics", _harmonic_label(m), m * fm, True,
                             float(m * plan.z_pinion)))
    for shaft, f_s, r in (("pinion", fr, 1.0), ("wheel", frw, ratio)):
        for m in range(1, plan.n_harmonics + 1):
            for k in range(-plan.n_sidebands, plan.n_sidebands + 1):
                if k:
                    locs.append(Location(f"order:fm{m}_{shaft}{k:+d}", "order", f"{shaft} sidebands",
                                         _harmonic_label(m, shaft, k), m * fm + k * f_s, True,
                                         m * plan.z_pinion + k * r))
    for shaft, f_s, r in (("pinion", fr, 1.0), ("wheel", frw, ratio)):
        for k in range(1, plan.n_shaft_orders + 1):
            locs.append(Location(f"order:{shaft}{k}", "order", f"{shaft} orders", f"{k} fr_{shaft}", k * f_s, True,
                                 k * r))
    for lo, hi in plan.bands_hz:
        locs.append(Location(f"band:{lo:.0f}-{hi:.0f}", "band", "bands",
                             f"{_fmt_hz(lo)}-{_fmt_hz(hi)} band (no order structure)", float(np.sqrt(lo * hi))))
    for f in plan.extra_lines_hz:
        locs.append(Location(f"band:line{f:.1f}", "band", "lines at no order",
                             f"line at {_fmt_hz(f)} ({f / fr:.2f} x fr_pinion): not a shaft order", f, True, f / fr))
    for shaft, f_s, r in (("pinion", fr, 1.0), ("wheel", frw, ratio)):
        for k in range(1, plan.n_shaft_orders + 1):
            locs.append(Location(f"envelope:{shaft}{k}", "envelope", f"envelope {shaft} orders",
                                 f"envelope line at {k} fr_{shaft}", k * f_s, True, k * r))
    locs.append(Location("envelope:fm1", "envelope", "envelope mesh", "envelope line at fm", fm, True,
                         float(plan.z_pinion)))
    for f in plan.extra_envelope_hz:
        locs.append(Location(f"envelope:line{f:.2f}", "envelope", "envelope lines at no order",
                             f"envelope line at {f / fr:.2f} x fr_pinion: not a shaft order", f, True, f / fr))
    for shaft in ("pinion", "wheel"):
        for name, label in (("residual_max", "strongest tooth (residual)"), ("residual_median", "median tooth (residual)"),
                            ("tooth_max", "loudest tooth"), ("tooth_min", "quietest tooth")):
            locs.append(Location(f"tsa:{shaft}_{name}", "tsa", f"TSA {shaft}", f"TSA {shaft}: {label}", None, True))
    for name, (_, label) in STATS.items():
        locs.append(Location(f"stats:{name}", "stats", "record", label, None, name == "rms"))
    for shaft in ("pinion", "wheel"):
        for name, (_, label) in INDICATORS.items():
            locs.append(Location(f"stats:{shaft}_{name}", "stats", f"{shaft} indicators", f"{label} ({shaft} TSA)",
                                 None, False))
    return locs


# ---------------------------------------------------------------------- analysis
def _envelope_power(xa: np.ndarray, plan: Plan) -> np.ndarray:
    n = xa.size
    fs_eq = plan.samples_per_rev * plan.fr_pinion_hz
    spec = np.fft.fft(xa - xa.mean())
    f = np.fft.fftfreq(n, 1.0 / fs_eq)
    lo, hi = plan.envelope_band_hz
    env = np.abs(np.fft.ifft(spec * np.where((f >= lo) & (f <= hi), 2.0, 0.0)))
    return _power_spectrum(env)


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
    pp = _power_spectrum(xp)
    non_order = _non_order(pp.size, plan)
    fl_p = _smooth_floor(pp, non_order)
    fbins = np.arange(pp.size) * plan.bin_hz
    in_bands = (fbins > plan.bands_hz[0][0]) & (fbins < plan.bands_hz[-1][1])
    sel = pp[non_order & in_bands] if np.count_nonzero(non_order & in_bands) >= 16 else pp[in_bands]
    return pp, fl_p, non_order, float(np.quantile(sel, FLOOR_QUANTILE) / _EXP_Q)


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
            levels[i], floors[i] = _db(pp[b]), _db(fl_p[b])
    return SignalViews(levels=levels, floors=floors, curves={"noise_floor": noise_floor})


def analyse(x: np.ndarray, fs_hz: float, track: AngleTrack, plan: Plan, *, keep_curves: bool = False) -> SignalViews:
    """Levels and floors (dB) of ``x`` at the plan's locations (module docstring)."""
    rec = angle_records(x, fs_hz, track, plan)
    pp, fl_p, non_order, noise_floor = _pinion_part(rec.pinion.ravel(), plan)
    pw = _power_spectrum(rec.wheel.ravel())
    R, Rw = plan.n_revs, plan.n_revs_wheel
    zp, zw = plan.z_pinion, plan.z_wheel
    env = _envelope_power(rec.pinion.ravel(), plan)
    fl_w = _smooth_floor(pw, _non_order_wheel(pw.size, plan))
    fl_e = _smooth_floor(env, _non_order(env.size, plan))
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
                levels[i], floors[i] = _db(_bin_level(pw, b)), _db(fl_w[int(round(b))])
            else:
                b = loc.order_pinion * R
                levels[i], floors[i] = _db(_bin_level(pp, b)), _db(fl_p[int(round(b))])
        elif view == "band":
            if name.startswith("line"):
                b = loc.freq_hz / bin_hz
                i0 = int(round(b))
                levels[i] = _db(pp[max(i0 - 1, 0):i0 + 2].max())
                floors[i] = _db(fl_p[i0])
            else:
                lo, hi = (float(v) for v in name.split("-"))
                lo_b, hi_b = _band_bins(loc, plan)
                sel = non_order[lo_b:hi_b]
                seg = pp[lo_b:hi_b][sel] if sel.any() else pp[lo_b:hi_b]
                levels[i], floors[i] = _db(seg.mean()), _db(noise_floor)
        elif view == "envelope":
            b = loc.order_pinion * R
            i0 = int(round(b))
            levels[i] = _db(_bin_level(env, b) if not name.startswith("line") else env[max(i0 - 1, 0):i0 + 2].max())
            floors[i] = _db(fl_e[i0])
        elif view == "tsa":
            shaft, key = name.split("_", 1)
            levels[i], floors[i] = _db(tsa_vals[shaft][key]), _db(tsa_parts[shaft][2])
        else:
            if name in STATS:
                levels[i] = _db(abs(stats[name]) ** 2 if STATS[name][0] == 20 else abs(stats[name]))
            else:
                shaft, key = name.split("_", 1)
                v = ind[shaft][key]
                v = v if np.isfinite(v) else 0.0
                levels[i] = _db(abs(v) ** 2 if INDICATORS[key][0] == 20 else abs(v))
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


def _non_order_wheel(n_bins: int, plan: Plan) -> np.ndarray:
    """Non-order bins of the wheel-angle spectrum (bin = 1/R_w wheel orders)."""
    ratio_w = plan.z_wheel / plan.z_pinion  # wheel orders per pinion order
    return ~(_order_mask(n_bins, plan.n_revs_wheel, 1.0) | _order_mask(n_bins, plan.n_revs_wheel, ratio_w))
