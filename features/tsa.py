"""Angular resampling and time-synchronous averaging (TSA) per shaft.

The shaft angle as a function of time (an :class:`AngleTrack`) comes from one of
three sources, all reduced to monotone knots ``(time_s, angle_rad)``:

- a constant, nominal or estimated shaft speed (:func:`angle_track_constant_speed`);
- a tachometer channel with ``pulses_per_rev`` pulses per revolution
  (:func:`angle_track_from_tacho`);
- the phase of a mesh harmonic in the vibration signal itself, when there is no
  tachometer (:func:`angle_track_from_mesh_phase`, Bonnardot et al. 2005).

:func:`angular_resample` interpolates the record at equal angle steps (``N``
samples per revolution) and cuts it into whole revolutions;
:func:`synchronous_average` averages them. In the averaged revolution the FFT bin
``k`` is shaft order ``k``, which makes the order-domain split into regular,
residual and difference signals (:func:`split_tsa`) a matter of zeroing bins.

References
----------
.. [1] McFadden, P. D. (1987). A revised model for the extraction of periodic
   waveforms by time domain averaging. Mechanical Systems and Signal Processing
   1(1), 83-95.
.. [2] Bonnardot, F., El Badaoui, M., Randall, R. B., Daniere, J., Guillet, F.
   (2005). Use of the acceleration signal of a gearbox in order to perform angular
   resampling (with limited speed fluctuation). Mechanical Systems and Signal
   Processing 19(4), 766-785.
.. [3] Lebold, M. et al. (2000). Review of vibration analysis methods for gearbox
   diagnostics and prognostics. Proc. 54th MFPT, 623-634 (regular, residual and
   difference signals).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq
from scipy.ndimage import map_coordinates, spline_filter1d
from scipy.signal import firwin, resample_poly

from features.tacho import tacho_pulse_index, tacho_pulse_times
from gearpit.errors import require, require_positive

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class AngleTrack:
    """Shaft angle (rad) as a monotone function of time (s), given by knots.

    Between knots the time of a given angle is interpolated with a monotone
    piecewise-cubic (PCHIP), i.e. a smoothly varying speed.
    """

    time_s: np.ndarray
    angle_rad: np.ndarray

    def __post_init__(self):
        t = np.asarray(self.time_s, dtype=float)
        a = np.asarray(self.angle_rad, dtype=float)
        require(t.ndim == 1 and t.shape == a.shape and t.size >= 2, "angle_track", (t.shape, a.shape),
                "two 1-D arrays of equal length >= 2")
        require(bool(np.all(np.diff(t) > 0)), "angle_track.time_s", "not increasing", "strictly increasing times")
        require(bool(np.all(np.diff(a) > 0)), "angle_track.angle_rad", "not increasing",
                "strictly increasing angles (the shaft must turn one way)")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "angle_rad", a)

    @property
    def revolutions(self) -> float:
        """Revolutions covered by the track (not rounded)."""
        return float((self.angle_rad[-1] - self.angle_rad[0]) / TWO_PI)


def angle_track_constant_speed(n_samples: int, fs_hz: float, shaft_hz: float) -> AngleTrack:
    """Angle track of a shaft turning at a constant ``shaft_hz`` (Hz) over the record."""
    require(isinstance(n_samples, (int, np.integer)) and n_samples >= 2, "n_samples", n_samples, "an integer >= 2")
    require_positive("fs_hz", fs_hz)
    require_positive("shaft_hz", shaft_hz)
    duration = (n_samples - 1) / fs_hz
    return AngleTrack(np.array([0.0, duration]), np.array([0.0, TWO_PI * shaft_hz * duration]))


def angle_track_from_tacho(tacho: np.ndarray, fs_hz: float, *, pulses_per_rev: int = 1,
                           threshold: float | None = None) -> AngleTrack:
    """Angle track from tachometer pulses: pulse ``k`` is at angle ``2 pi k / pulses_per_rev`` (bounces, spikes
    and missing pulses: :func:`features.tacho.tacho_pulse_index`).

    The track spans first to last pulse only; no extrapolation.
    """
    require(isinstance(pulses_per_rev, (int, np.integer)) and pulses_per_rev >= 1, "pulses_per_rev",
            pulses_per_rev, "an integer >= 1")
    times, index, _ = tacho_pulse_index(tacho_pulse_times(tacho, fs_hz, threshold=threshold))
    require(times.size >= pulses_per_rev + 1, "tacho", f"{times.size} pulses",
            f">= {pulses_per_rev + 1} pulses (one whole revolution)")
    return AngleTrack(times, TWO_PI * index / pulses_per_rev)


def angle_track_from_mesh_phase(x: np.ndarray, fs_hz: float, *, mesh_order: int, shaft_hz_nominal: float,
                                half_band_hz: float | None = None) -> AngleTrack:
    """Angle track estimated from the phase of the mesh tone (no tachometer).

    The record is band-passed around the nominal mesh frequency
    ``mesh_order * shaft_hz_nominal`` (ideal FFT filter, ``+/- half_band_hz``,
    default half the nominal shaft frequency so the first sidebands stay out);
    the unwrapped phase of its analytic signal divided by ``mesh_order`` is the
    shaft angle up to a constant (Bonnardot et al. 2005). Valid while the speed
    fluctuation keeps the mesh tone inside that band.
    """
    a = np.asarray(x, dtype=float)
    require(a.ndim == 1 and a.size >= 16, "x", a.shape, "a 1-D array of >= 16 samples")
    require_positive("fs_hz", fs_hz)
    require(isinstance(mesh_order, (int, np.integer)) and mesh_order >= 1, "mesh_order", mesh_order, "an integer >= 1")
    require_positive("shaft_hz_nominal", shaft_hz_nominal)
    fm = mesh_order * shaft_hz_nominal
    if half_band_hz is None:
        half_band_hz = 0.5 * shaft_hz_nominal
    require_positive("half_band_hz", half_band_hz)
    require(fm + half_band_hz < fs_hz / 2, "shaft_hz_nominal", shaft_hz_nominal,
            f"a mesh band below Nyquist ({fs_hz / 2} Hz)")
    n = a.size
    spec = np.fft.fft(a)
    f = np.fft.fftfreq(n, 1.0 / fs_hz)
    mask = (f >= fm - half_band_hz) & (f <= fm + half_band_hz)
    analytic = np.fft.ifft(2.0 * spec * mask)
    phase = np.unwrap(np.angle(analytic))
    angle = phase / mesh_order
    angle = angle - angle[0]
    # guard against phase slips where the band holds almost nothing
    keep = np.concatenate(([True], np.diff(angle) > 0))
    require(bool(keep.all()), "x", "mesh phase not monotone",
            "a record whose mesh tone dominates its band (else give a tacho or the speed)")
    return AngleTrack(np.arange(n) / fs_hz, angle)


def default_samples_per_rev(fs_hz: float, shaft_hz: float) -> int:
    """Power of two >= samples per revolution in time (so resampling never decimates)."""
    require_positive("fs_hz", fs_hz)
    require_positive("shaft_hz", shaft_hz)
    return int(2 ** np.ceil(np.log2(fs_hz / shaft_hz)))


def angular_resample(x: np.ndarray, fs_hz: float, track: AngleTrack, *, samples_per_rev: int,
                     oversample: int = 4, skip_edges: bool = True) -> np.ndarray:
    """Resample a record at equal shaft-angle steps, cut into whole revolutions.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Record sampled at ``fs_hz`` starting at t = 0.
    fs_hz : float
        Sampling rate (Hz).
    track : AngleTrack
        Shaft angle versus time; revolutions start at ``track.angle_rad[0]``.
    samples_per_rev : int
        Samples per revolution ``N`` of the output.
    oversample : int
        The record is first upsampled by this factor with a polyphase anti-imaging
        filter, then interpolated by a cubic spline: interpolation error about
        1e-5 of the amplitude up to 0.15 ``fs_hz`` and below 6e-4 up to 0.43
        ``fs_hz`` (1 = cubic spline only: 2e-3 at 0.15 ``fs_hz``, 10 % at 0.37
        ``fs_hz``). The first and last 20 samples carry the filter's edge effect.
    skip_edges : bool
        Start and end the revolutions :attr:`TimeInterpolant.UPSAMPLING_HALF_TAPS` samples inside the track's
        first and last time (default), out of that edge effect; a record of exactly ``R`` revolutions then gives
        ``R - 1``. ``False`` starts at the track's first angle (the edge rings into the first and last
        revolutions' ends: on a wheel average of 3 revolutions of a pure mesh comb, 2.3e-2 of the tone's
        amplitude, FM4 86 for 2.9).

    Returns
    -------
    ndarray, shape (n_revolutions, samples_per_rev)
    """
    return TimeInterpolant(x, fs_hz, oversample=oversample).resample(track, samples_per_rev=samples_per_rev,
                                                                      skip_edges=skip_edges)


class TimeInterpolant:
    """A record made continuous in time (upsampled by ``oversample``, then a cubic spline), to be resampled on
    several angle tracks (:meth:`resample`: the pinion's and the wheel's) at the cost of one upsampling and one
    spline; each resampling equals :func:`angular_resample`'s exactly (it is the same computation).

    The spline is the interpolating cubic spline on the (upsampled) sample grid, built as B-spline coefficients
    by the recursive prefilter of Unser et al. (1991) (:func:`scipy.ndimage.spline_filter1d`) and evaluated by
    :func:`scipy.ndimage.map_coordinates`: ~4x faster than :class:`scipy.interpolate.CubicSpline` on a 2 s
    record, the same function inside the record (they differ only in the end condition, mirror here and
    not-a-knot there; measured 4e-11 of the RMS more than 40 upsampled samples from either end), where the
    upsampling filter's own edge effect is larger anyway.

    That edge effect: the filter reads :data:`UPSAMPLING_HALF_TAPS` input samples either side and takes the record
    as zero outside it, so the first and last that many samples ring in proportion to the step from zero to the
    record's end values (a record with a mean of 10 x its RMS: 0.44 x the RMS at the first samples; measured on a
    line comb, ``tests/test_features_tsa.py``). :meth:`resample` with ``skip_edges=True`` starts and ends the
    revolutions that far inside the record.
    """

    #: input samples either side that the upsampling filter reads (its half length); the record's first and last
    #: that many samples carry the filter's edge effect
    UPSAMPLING_HALF_TAPS = 20

    def __init__(self, x: np.ndarray, fs_hz: float, *, oversample: int = 4):
        a = np.asarray(x, dtype=float)
        require(a.ndim == 1 and a.size >= 2, "x", a.shape, "a 1-D array of >= 2 samples")
        require_positive("fs_hz", fs_hz)
        require(isinstance(oversample, (int, np.integer)) and oversample >= 1, "oversample", oversample,
                "an integer >= 1")
        self.duration_s = (a.size - 1) / fs_hz
        if oversample > 1:
            # Kaiser beta 8.6 (~80 dB stop band, ~1e-4 pass-band ripple), 20 input samples each side
            taps = firwin(2 * self.UPSAMPLING_HALF_TAPS * oversample + 1, 1.0 / oversample, window=("kaiser", 8.6))
            a = resample_poly(a, oversample, 1, window=taps)
        self.rate_hz = fs_hz * oversample
        self.edge_s = (self.UPSAMPLING_HALF_TAPS if oversample > 1 else 0) / fs_hz
        self.coefficients = spline_filter1d(a, order=3, mode="mirror")

    def at(self, times_s: np.ndarray) -> np.ndarray:
        """The spline at ``times_s`` (s, within the record)."""
        t = np.asarray(times_s, dtype=float)
        return map_coordinates(self.coefficients, t.reshape(1, -1) * self.rate_hz, order=3, prefilter=False,
                               mode="mirror").reshape(t.shape)

    def resample(self, track: AngleTrack, *, samples_per_rev: int, skip_edges: bool = False) -> np.ndarray:
        """The record at equal steps of ``track``'s angle, whole revolutions: ``(n_revolutions, samples_per_rev)``.

        ``skip_edges``: the revolutions start at the track's angle :attr:`edge_s` after its first time and end
        before the angle that long before its last (:func:`usable_angle_span`), out of the upsampling filter's
        edge effect."""
        require(isinstance(samples_per_rev, (int, np.integer)) and samples_per_rev >= 4, "samples_per_rev",
                samples_per_rev, "an integer >= 4")
        require(track.time_s[0] >= -1e-12 and track.time_s[-1] <= self.duration_s + 1e-9, "track",
                (float(track.time_s[0]), float(track.time_s[-1])), f"times within the record [0, {self.duration_s}] s")
        a0, a1 = usable_angle_span(track, self.edge_s if skip_edges else 0.0)
        # revolution r spans target angles 2 pi (r + j/N), j < N: the last one must be inside the span
        n_rev = int(np.floor((a1 - a0) / TWO_PI + 1.0 / samples_per_rev + 1e-9))
        require(n_rev >= 1, "track", f"{n_rev} revolutions", ">= 1 whole revolution in the record")
        target = a0 + TWO_PI * np.arange(n_rev * samples_per_rev) / samples_per_rev
        if track.angle_rad.size == 2:      # a constant speed: PCHIP through two knots is the straight line
            times = np.interp(target, track.angle_rad, track.time_s)
        else:
            times = PchipInterpolator(track.angle_rad, track.time_s)(target)
        return self.at(times).reshape(n_rev, samples_per_rev)


def usable_angle_span(track: AngleTrack, margin_s: float) -> tuple[float, float]:
    """First and last angle of ``track`` at least ``margin_s`` inside its first and last time: the angles whose
    times (the track's PCHIP, as :meth:`TimeInterpolant.resample` reads it) are exactly those."""
    a_first, a_last = float(track.angle_rad[0]), float(track.angle_rad[-1])
    if margin_s <= 0:
        return a_first, a_last
    t0, t1 = float(track.time_s[0]) + margin_s, float(track.time_s[-1]) - margin_s
    require(t1 > t0, "track", f"{track.time_s[-1] - track.time_s[0]:.3g} s", f"> 2 x {margin_s:.3g} s (the edges)")
    if track.angle_rad.size == 2:
        a = np.interp([t0, t1], track.time_s, track.angle_rad)
        return float(a[0]), float(a[1])
    time_of = PchipInterpolator(track.angle_rad, track.time_s)
    return tuple(float(brentq(lambda a, t=t: float(time_of(a)) - t, a_first, a_last, xtol=1e-13, rtol=1e-15))
                 for t in (t0, t1))


@dataclass(frozen=True)
class SynchronousAverage:
    """One averaged revolution and how many revolutions went into it."""

    average: np.ndarray
    n_revolutions: int

    @property
    def samples_per_rev(self) -> int:
        return int(self.average.size)


def synchronous_average(x: np.ndarray, fs_hz: float, track: AngleTrack, *, samples_per_rev: int,
                        oversample: int = 4, skip_edges: bool = True) -> SynchronousAverage:
    """Time-synchronous average of a record over the whole revolutions of ``track`` (by default those clear of the
    upsampling filter's edge effect, ``skip_edges`` of :func:`angular_resample`; ``n_revolutions`` counts the
    revolutions actually averaged).

    Components locked to the shaft (its orders, the mesh harmonics of the gear on
    it and their sidebands) are kept; white noise falls as ``1/sqrt(R)`` in
    amplitude with ``R`` revolutions; a tone at order ``k + delta`` is multiplied
    by the comb filter ``|sin(pi R delta) / (R sin(pi delta))|`` (McFadden 1987),
    whose power averaged over ``delta`` is ``1/R``.
    """
    revs = angular_resample(x, fs_hz, track, samples_per_rev=samples_per_rev, oversample=oversample,
                            skip_edges=skip_edges)
    return SynchronousAverage(revs.mean(axis=0), int(revs.shape[0]))


def order_amplitudes(tsa: np.ndarray) -> np.ndarray:
    """Amplitude of each shaft order ``k = 0..N/2`` in one averaged revolution.

    ``A_k = 2 |X_k| / N`` so a component ``a cos(k theta)`` gives ``a``; the DC
    term and the Nyquist order (even ``N``) use ``|X_k| / N``.
    """
    a = np.asarray(tsa, dtype=float)
    n = a.shape[-1]
    amp = 2.0 * np.abs(np.fft.rfft(a, axis=-1)) / n
    amp[..., 0] /= 2.0
    if n % 2 == 0:
        amp[..., -1] /= 2.0
    return amp


def keep_orders(tsa: np.ndarray, orders) -> np.ndarray:
    """The part of an averaged revolution made of the listed shaft orders only."""
    a = np.asarray(tsa, dtype=float)
    n = a.shape[-1]
    spec = np.fft.rfft(a, axis=-1)
    mask = np.zeros(spec.shape[-1], dtype=bool)
    idx = np.asarray(sorted(set(int(k) for k in orders)), dtype=int)
    idx = idx[(idx >= 0) & (idx < mask.size)]
    mask[idx] = True
    return np.fft.irfft(spec * mask, n=n, axis=-1)


def mesh_orders(mesh_order: int, samples_per_rev: int) -> list[int]:
    """Mesh harmonics ``m * z`` (m >= 1) up to the Nyquist order ``N / 2``."""
    return list(range(mesh_order, samples_per_rev // 2 + 1, mesh_order))


@dataclass(frozen=True)
class TsaSignals:
    """Order-domain split of one averaged revolution (Lebold et al. 2000).

    - ``regular``: low shaft orders ``1..n_shaft_orders``, all mesh harmonics and
      their sidebands ``m z +/- s`` for ``s <= n_sideband_orders``;
    - ``residual``: TSA minus its mean, the low shaft orders and the mesh
      harmonics (sidebands kept) - the input of NA4;
    - ``difference``: residual minus those sidebands, i.e. TSA minus mean minus
      ``regular`` - the input of FM4, M6A, M8A and the energy ratio.
    """

    tsa: np.ndarray
    regular: np.ndarray
    residual: np.ndarray
    difference: np.ndarray


def split_tsa(tsa: np.ndarray, mesh_order: int, *, n_shaft_orders: int = 2, n_sideband_orders: int = 1) -> TsaSignals:
    """Regular, residual and difference signals of an averaged revolution.

    Parameters
    ----------
    tsa : array_like, shape (N,)
        One averaged revolution of the shaft carrying the gear.
    mesh_order : int
        Teeth on that gear (the mesh frequency is order ``mesh_order``).
    n_shaft_orders : int
        Low shaft orders ``1..n_shaft_orders`` treated as regular (once- and
        twice-per-revolution unbalance and misalignment by default).
    n_sideband_orders : int
        Sidebands ``m z +/- 1..n_sideband_orders`` treated as regular (first-order
        sidebands by default, as in Lebold et al. 2000).

    References
    ----------
    Lebold et al. (2000), section "Residual, difference and regular signals";
    Zakrajsek, Townsend, Decker (1993), NASA TM-105950.
    """
    a = np.asarray(tsa, dtype=float)
    require(a.ndim == 1 and a.size >= 8, "tsa", a.shape, "a 1-D array of >= 8 samples")
    n = a.size
    require(isinstance(mesh_order, (int, np.integer)) and 1 <= mesh_order <= n // 2, "mesh_order", mesh_order,
            f"an integer in [1, {n // 2}] (N/2 for N = {n} samples per revolution)")
    require(isinstance(n_shaft_orders, (int, np.integer)) and n_shaft_orders >= 0, "n_shaft_orders",
            n_shaft_orders, "an integer >= 0")
    require(isinstance(n_sideband_orders, (int, np.integer)) and n_sideband_orders >= 0, "n_sideband_orders",
            n_sideband_orders, "an integer >= 0")
    mesh = mesh_orders(mesh_order, n)
    shaft = list(range(1, n_shaft_orders + 1))
    sidebands = [m + s * sign for m in mesh for s in range(1, n_sideband_orders + 1) for sign in (-1, 1)]
    sidebands = [k for k in sidebands if 1 <= k <= n // 2 and k not in mesh]
    centred = a - a.mean()
    residual = centred - keep_orders(a, shaft + mesh)
    regular = keep_orders(a, shaft + mesh + sidebands)
    difference = centred - regular
    return TsaSignals(tsa=a, regular=regular, residual=residual, difference=difference)
