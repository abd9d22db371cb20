"""The plan of a comparison: named physical locations, fixed once from the measurement.

See :mod:`compare.views` for what each view measures at its locations. The
plan is built by :func:`make_plan` on the measured record: processing settings
(samples per revolution, whole revolutions, harmonics below 0.45 fs, 1/3-octave
bands from ``max(2 fr, 10 Hz)`` to 0.45 fs, envelope band 0.5 fm .. 0.45 fs) and
the lines the measurement shows at no shaft order (the
``n_extra_lines`` most prominent local maxima at least ``line_prominence_db``
above their floor, position interpolated between bins).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from compare.spectra import (ORDER_MASK_BINS, AngleRecords, angle_records, envelope_power, non_order, power_spectrum,
                             refined_bin, smooth_floor, usable_revolutions)
from features.tsa import AngleTrack, default_samples_per_rev
from gearpit.errors import require

VIEWS = ("order", "band", "envelope", "tsa", "stats")
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
        Whether the level moves with the sensor gain (by 20 log10 g dB: amplitudes in 20 log10, powers in
        10 log10 alike); dimensionless statistics do not.
    order_pinion : float or None
        Position in pinion orders (lines), used to find its bin in either angle-domain spectrum.
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
    #: content below this frequency is removed from every signal before the views (0: nothing removed;
    #: :func:`compare.comparison.prepare_reference` sets it when the measurement holds such content)
    low_cut_hz: float = 0.0

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


def _fmt_hz(f: float) -> str:
    return f"{f / 1000:.2f} kHz" if f >= 1000 else f"{f:.1f} Hz"


def _harmonic_label(m: int, shaft: str | None = None, k: int = 0) -> str:
    base = "fm" if m == 1 else f"{m} fm"
    if shaft is None:
        return base
    return f"{base} {'+' if k > 0 else '-'} {abs(k)} fr_{shaft}"


def make_plan(x: np.ndarray, fs_hz: float, track: AngleTrack, pair, *, n_sidebands: int = 3,
              n_shaft_orders: int = 5, max_harmonics: int = 12, n_extra_lines: int = 6,
              line_prominence_db: float = 12.0, lines_from: Plan | None = None) -> Plan:
    """Locations for a measurement ``x`` whose pinion angle is ``track``.

    The lines found at no shaft order (band and envelope views) are the
    ``n_extra_lines`` most prominent local maxima at least ``line_prominence_db``
    above their local floor, or those of ``lines_from`` (a plan of a longer part
    of the same record: the same locations, so residuals can be matched key by key).
    """
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    duration = (len(x) - 1) / fs_hz
    fr = (track.angle_rad[-1] - track.angle_rad[0]) / (2 * np.pi) / (track.time_s[-1] - track.time_s[0])
    fm = fr * z1
    frw = fr * z1 / z2
    revs = usable_revolutions(track, fs_hz)
    n_revs = int(np.floor(revs + 1e-9))
    n_revs_w = int(np.floor(revs * z1 / z2 + 1e-9))
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
    if lines_from is not None:
        extra, extra_env = lines_from.extra_lines_hz, lines_from.extra_envelope_hz
    else:
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


def _discover(rec: AngleRecords, plan: Plan, n: int, prominence_db: float):
    bin_hz = plan.bin_hz
    p = power_spectrum(rec.pinion.ravel())
    ok = non_order(p.size, plan)
    f = np.arange(p.size) * bin_hz
    ok &= (f > plan.bands_hz[0][0]) & (f < plan.bands_hz[-1][1])
    lines = tuple(refined_bin(p, b) * bin_hz for b in _peaks(p, ok, smooth_floor(p, ok), n, prominence_db))
    e = envelope_power(rec.pinion.ravel(), plan)
    ok_e = non_order(e.size, plan)
    fe = np.arange(e.size) * bin_hz
    ok_e &= (fe > 0.5 * plan.fr_wheel_hz) & (fe < plan.fm_hz * 2.5)
    env = tuple(refined_bin(e, b) * bin_hz for b in _peaks(e, ok_e, smooth_floor(e, ok_e), n, prominence_db))
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
