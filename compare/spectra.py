"""Order-domain records and spectra shared by the plan and the views.

A record is resampled on the pinion angle and on the wheel angle
(:func:`features.tsa.angular_resample`, whole revolutions), so that shaft
orders fall on spectral bins. Power spectra are window-corrected line powers
``(2 |X| / sum w)^2`` (Hann). Floors: the 30 % quantile of the power of the
non-order bins in blocks of ``2 FLOOR_HALF_WIDTH`` bins, divided by the same
quantile of a unit-mean exponential variable (so: the mean noise power per
bin), interpolated between blocks.

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley, ch. 5 (order tracking).
Harris, F. J. (1978). On the use of windows for harmonic analysis with the DFT. Proc. IEEE 66(1), 51-83.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import fft as sp_fft

from features.tsa import AngleTrack, TimeInterpolant, usable_angle_span
from gearpit.errors import require

#: half width (bins) of the neighbourhood whose low quantile is a line's floor
FLOOR_HALF_WIDTH = 60
#: quantile used for floors, and the same quantile of a unit-mean exponential variable (power of noise)
FLOOR_QUANTILE = 0.30
EXP_Q = -np.log(1 - FLOOR_QUANTILE)
#: bins either side of a shaft order that count as "at an order"
ORDER_MASK_BINS = 2
TINY = 1e-30


@lru_cache(maxsize=16)
def hann(n: int) -> np.ndarray:
    """Periodic Hann window (cached, read-only: every view of every comparison takes the same few lengths)."""
    w = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)
    w.flags.writeable = False
    return w


def power_spectrum(x: np.ndarray) -> np.ndarray:
    """Window-corrected line power ``(2 |X| / sum w)^2`` (Hann) of a mean-removed record."""
    w = hann(x.size)
    amp = 2.0 * np.abs(np.fft.rfft((x - x.mean()) * w)) / w.sum()
    return amp**2


def order_mask(n_bins: int, n_revs: int, ratio: float) -> np.ndarray:
    """True for bins near an integer order of a shaft; ``ratio``: resampling-shaft orders per order of that shaft.

    "Near" is ORDER_MASK_BINS bins, or 1 bin when the orders are fewer than 8 bins apart (short records).
    """
    k = np.arange(n_bins) / n_revs / ratio  # shaft order of each bin
    dist = np.abs(k - np.round(k)) * n_revs * ratio  # distance in bins
    half = ORDER_MASK_BINS if n_revs * ratio >= 8 else 1
    return dist <= half + 1e-9


def db(p, factor=10.0):
    """``factor log10(p)`` with p floored at TINY."""
    return factor * np.log10(np.maximum(np.asarray(p, float), TINY))


@dataclass(frozen=True, eq=False)
class AngleRecords:
    """The record resampled on the pinion angle and on the wheel angle, whole revolutions."""

    pinion: np.ndarray   # (R, N_p)
    wheel: np.ndarray    # (R_w, N_w)


#: the upsampling of :func:`angle_records`
OVERSAMPLE = 2


def usable_revolutions(track: AngleTrack, fs_hz: float) -> float:
    """Pinion revolutions of ``track`` that :func:`angle_records` resamples: the record's first and last
    ``TimeInterpolant.UPSAMPLING_HALF_TAPS`` samples are left out (the upsampling filter's edge, which rings in
    proportion to the record's end values: a model's noise-free wheel TSA read it as an impulse, M8A 5e5)."""
    a0, a1 = usable_angle_span(track, TimeInterpolant.UPSAMPLING_HALF_TAPS / fs_hz)
    return (a1 - a0) / (2 * np.pi)


#: content below this fraction of the slower shaft's rate is no order of either shaft; removed before every view
#: when the record holds enough of it (:func:`below_shafts_removed`, :data:`compare.comparison.BELOW_SHAFTS_REMOVED`)
LOW_CUT_ORDER = 0.5
LOW_CUT_POLES = 4
#: passes that continue the record's ends (:func:`below_shafts_removed`): on the test rig with a 0.7 Hz wander of
#: 1.5 RMS the TSA view's error was 0.28 / 0.12 / 0.00 dB after 2 / 3 / 5 passes (0.86 with mirrored ends alone)
LOW_CUT_PASSES = 5


@lru_cache(maxsize=32)
def _low_cut(fs_hz: float, cut_hz: float):
    from scipy.signal import butter

    return butter(LOW_CUT_POLES, cut_hz, btype="highpass", fs=fs_hz, output="sos")


def low_cut_hz(plan) -> float:
    """Below this frequency (Hz) a record holds no shaft order: :data:`LOW_CUT_ORDER` of the slower shaft's rate."""
    return LOW_CUT_ORDER * min(plan.fr_pinion_hz, plan.fr_wheel_hz)


def high_passed(x: np.ndarray, fs_hz: float, cut: float) -> np.ndarray:
    """``x`` without its content below ``cut`` Hz (:func:`low_cut_hz`; a zero-phase Butterworth high-pass of
    :data:`LOW_CUT_POLES` poles, applied forwards and backwards: -0.03 dB at the slower shaft's first order).

    Why: a sensor's drift, an offset or a foundation's sway (a 0.7 Hz wander and a ramp of 1.5-2 times the RMS on
    the test rig, whose wheel turns at 4.8 Hz) is no gear physics, but the wheel's TSA of ten revolutions does
    not average it out: the comparison read it as +17 dB in the wheel TSA's strongest tooth, +13 dB in its energy
    ratio, +6 dB at the first wheel order (total error 0.46 -> 3.79 dB on a healthy rig) and named none of it.
    Measurement and model pass through the same filter (:func:`below_shafts_removed`), so identical records stay
    identical; when and why: :func:`compare.comparison.prepare_reference`.

    The record's ends: a filter run forwards and backwards needs the record continued beyond them. Point-reflected
    (scipy's default) a record's gear content jumps by twice its end value there, a step whose decay (~0.3 s at
    2.4 Hz) the statistics read: on the suite's hidden 3 kHz housing mode the fit then went from 0.75 to 1.20 dB.
    Mirrored, a drift's slope breaks there instead (the wander's TSA error 0.86 dB). So the record is continued
    part by part: its slow part (below the cut) point-reflected, which keeps its value and slope, and the rest
    mirrored, which keeps it without a step; the slow part is estimated with mirrored ends first and then again
    from the filtered record, :data:`LOW_CUT_PASSES` times (7 ms for 2 s at 20 kHz, 54 ms for 10 s at 51.2 kHz)."""
    x = np.asarray(x, float)
    if not 0.0 < cut < 0.45 * fs_hz or x.size < 16:
        return x
    from scipy.signal import sosfiltfilt

    sos = _low_cut(float(fs_hz), float(cut))
    n = min(x.size - 1, int(round(fs_hz / cut)))
    slow = x - sosfiltfilt(sos, x, padtype="even", padlen=n)      # first estimate: mirrored ends
    for _ in range(LOW_CUT_PASSES):
        fast = x - slow
        head = 2.0 * slow[0] - slow[n:0:-1] + fast[n:0:-1]          # the slow part point-reflected, the fast mirrored
        tail = 2.0 * slow[-1] - slow[-2:-n - 2:-1] + fast[-2:-n - 2:-1]
        y = sosfiltfilt(sos, np.concatenate([head, x, tail]), padtype=None)[n:n + x.size]
        slow = x - y
    return y


def below_shafts_share(x: np.ndarray, fs_hz: float, cut: float) -> tuple[float, np.ndarray]:
    """``(share, rest)``: the RMS of ``x``'s content below ``cut`` Hz (its mean left out) over the RMS of the rest,
    and the rest (:func:`high_passed`)."""
    x = np.asarray(x, float)
    rest = high_passed(x, fs_hz, cut)
    return float(np.std(x - rest)) / max(float(np.std(rest)), 1e-300), rest


def below_shafts_removed(x: np.ndarray, fs_hz: float, plan) -> np.ndarray:
    """``x`` high-passed at the plan's ``low_cut_hz`` (:func:`high_passed`); unchanged when it is 0."""
    cut = float(getattr(plan, "low_cut_hz", 0.0))
    return np.asarray(x, float) if cut <= 0.0 else high_passed(x, fs_hz, cut)


def angle_records(x: np.ndarray, fs_hz: float, track: AngleTrack, plan) -> AngleRecords:
    """Resample ``x`` (pinion angle ``track``) for the plan, out of the record's edges (:func:`usable_revolutions`);
    refuses records shorter than the plan."""
    ratio = plan.z_pinion / plan.z_wheel
    rec = TimeInterpolant(x, fs_hz, oversample=OVERSAMPLE)   # one upsampling and spline for both shafts
    rp = rec.resample(track, samples_per_rev=plan.samples_per_rev, skip_edges=True)
    wt = AngleTrack(track.time_s, track.angle_rad * ratio)
    rw = rec.resample(wt, samples_per_rev=plan.samples_per_rev_wheel, skip_edges=True)
    require(rp.shape[0] >= plan.n_revs and rw.shape[0] >= plan.n_revs_wheel, "record",
            f"{rp.shape[0]} pinion / {rw.shape[0]} wheel revolutions",
            f">= {plan.n_revs} / {plan.n_revs_wheel} (as many as the measurement)")
    return AngleRecords(rp[:plan.n_revs], rw[:plan.n_revs_wheel])


def refined_bin(p: np.ndarray, b: int) -> float:
    """Peak position between bins: vertex of the parabola through the log powers of bins b-1, b, b+1."""
    if b <= 0 or b >= p.size - 1:
        return float(b)
    y0, y1, y2 = np.log(np.maximum(p[b - 1:b + 2], TINY))
    den = y0 - 2 * y1 + y2
    return float(b + (0.5 * (y0 - y2) / den if den < 0 else 0.0))


def non_order(n_bins: int, plan) -> np.ndarray:
    """Bins at no integer order of either shaft in the pinion-angle spectrum."""
    return ~(order_mask(n_bins, plan.n_revs, 1.0) | order_mask(n_bins, plan.n_revs, plan.z_pinion / plan.z_wheel))


def non_order_wheel(n_bins: int, plan) -> np.ndarray:
    """Non-order bins of the wheel-angle spectrum (bin = 1/R_w wheel orders)."""
    ratio_w = plan.z_wheel / plan.z_pinion  # wheel orders per pinion order
    return ~(order_mask(n_bins, plan.n_revs_wheel, 1.0) | order_mask(n_bins, plan.n_revs_wheel, ratio_w))


def smooth_floor(p: np.ndarray, ok: np.ndarray) -> np.ndarray:
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
    vals = src[np.arange(n_blocks), idx] / EXP_Q
    centres = np.arange(n_blocks) * b + b / 2
    return np.maximum(np.interp(np.arange(p.size), centres, vals), TINY)


def envelope_power(xa: np.ndarray, plan) -> np.ndarray:
    """Power spectrum of the envelope of ``xa`` band-passed to the plan's envelope band (ideal FFT filter): the
    analytic signal of the band is the inverse transform of twice its positive-frequency bins."""
    n = xa.size
    fs_eq = plan.samples_per_rev * plan.fr_pinion_hz
    half = sp_fft.rfft(xa - xa.mean())
    f = np.arange(half.size) * (fs_eq / n)
    lo, hi = plan.envelope_band_hz
    band = (f >= lo) & (f <= hi)
    spec = np.zeros(n, complex)
    spec[:half.size][band] = 2.0 * half[band]
    return power_spectrum(np.abs(sp_fft.ifft(spec)))
