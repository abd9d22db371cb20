"""The shaft angle of a record whose speed drifts: what is slow enough to follow, and how it is followed.

A drift slower than about half the wheel's rotation (a motor's slip wandering with its load) has no place in the
constant-speed model and smears every order and synchronous average: the comparison follows it. What is faster (the
speed and torque fluctuations the attribution fits, a local fault's once-per-revolution modulation) stays in the
record, as it would in the model. :func:`slow_window_s` is that boundary; :func:`smooth_pulse_deviation` follows a
tachometer's pulses up to it (:func:`compare.speed.speed_from_tacho`); :func:`drift_track` reads the drift
without a tachometer from the mesh harmonics' phase.

References
----------
Bonnardot, F. et al. (2005). Mech. Syst. Signal Process. 19(4), 766-785 (the shaft angle from a mesh harmonic's
    phase).
Fan, J., Gijbels, I. (1996). Local Polynomial Modelling and Its Applications. Chapman & Hall, ch. 3 (local-linear
    smoothing: no bias at a boundary for a linear trend).
"""
from __future__ import annotations

import numpy as np

from features.tsa import AngleTrack

TWO_PI = 2.0 * np.pi
#: without a tachometer, a drift is followed only where the two harmonics it is read from differ by less than this
#: fraction of it (drift_track)
DRIFT_AGREEMENT = 0.5
#: ... and only from mesh harmonics standing this far (dB) above their local floor (the median within 4 shaft orders)
DRIFT_LINE_DB = 20.0


def slow_window_s(fr_hz: float, z_pinion: int, z_wheel: int) -> float:
    """The length (s) of the Hann window that keeps a drift and drops what the model can hold: two revolutions of
    the slower shaft (the wheel's, ``z_wheel / z_pinion`` pinion revolutions each). Its response falls to half at
    about 0.7 / window: what is slower than about half the wheel's rotation is followed (it has no place in the
    constant-speed model), a fluctuation faster than that stays in the record (the attribution fits it)."""
    return 2.0 * max(z_wheel, z_pinion) / (z_pinion * fr_hz)


def smooth_pulse_deviation(times: np.ndarray, values: np.ndarray, at: np.ndarray, window_s: float) -> np.ndarray:
    """Hann-weighted local-linear fit of ``values`` (sampled at the increasing ``times``) evaluated at ``at``, a
    window ``window_s`` long: the pulses' deviation from the constant speed, their scatter averaged, its slow part
    kept. Local-linear, not a local mean: a run-up's deviation is no bias at the record's ends, where the window
    holds pulses on one side only (a local mean there read a 10 % ramp's mean speed 0.09 % low), and beyond the
    last pulse the local line continues. The weight ``cos^2(pi d / W) = (1 + cos(2 pi d / W)) / 2`` splits into
    sums over the pulses within the window (cumulative sums between two ``searchsorted`` bounds): O(pulses +
    points), as many encoder pulses as a long record holds. A point whose window holds fewer than two pulses
    takes the nearest pulse's value."""
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    x = np.asarray(at, float)
    u_t, u_x = (t - t[0]) / window_s, (x - t[0]) / window_s       # in windows: sums of u^2 stay well scaled
    c, s_ = np.cos(TWO_PI * u_t), np.sin(TWO_PI * u_t)
    cx, sx = np.cos(TWO_PI * u_x), np.sin(TWO_PI * u_x)
    lo = np.searchsorted(t, x - 0.5 * window_s, side="right")
    hi = np.searchsorted(t, x + 0.5 * window_s, side="left")

    def wsum(g):              # sum over the window of w(x - tau) g(tau), at every x
        out = 0.0
        for weight, factor in ((0.5, 1.0), (0.5 * cx, c), (0.5 * sx, s_)):
            cum = np.concatenate(([0.0], np.cumsum(g * factor)))
            out = out + weight * (cum[hi] - cum[lo])
        return out

    s0, s1, s2 = wsum(np.ones_like(u_t)), wsum(u_t), wsum(u_t ** 2)
    t0, t1 = wsum(v), wsum(u_t * v)
    a1, a2, b1 = s1 - u_x * s0, s2 - 2 * u_x * s1 + u_x ** 2 * s0, t1 - u_x * t0   # about u = u_x
    det = s0 * a2 - a1 ** 2
    ok = (hi - lo >= 2) & (det > 1e-12 * np.maximum(s0, 1e-300) ** 2)
    est = (a2 * t0 - a1 * b1) / np.where(ok, det, 1.0)
    near = v[np.clip(np.searchsorted(t, x), 0, t.size - 1)]
    return np.where(ok, est, near)


def drift_track(x: np.ndarray, fs_hz: float, fr_hz: float, z_pinion: int,
                z_wheel: int) -> tuple[float, AngleTrack | None]:
    """The slow drift of the pinion speed within a record without a tachometer, and the angle track that follows
    it when it is real and matters: ``(drift_rad, track or None)``.

    The pinion angle from the phase of a mesh harmonic (:func:`models.order_tracking.mesh_angle`: complex
    demodulation, low-passed over two pinion revolutions), low-passed again over two revolutions of the wheel (a
    Hann window, renormalised at the ends): what is left is the drift slower than about half the wheel's
    rotation. A fluctuation faster than that (the speed and torque fluctuations the attribution fits, a local
    fault's once-per-revolution modulation) stays in the record, as it would stay in the model; what is slower
    has no place in the model (it runs at the constant mean speed), smears every order and the synchronous
    averages, and is followed, as the tachometer's track follows a drift.

    The angle is read from the two mesh harmonics that stand out most from their local floor, both at least
    :data:`DRIFT_LINE_DB` above it (a line near the noise has a phase that slips), and the drift is believed only
    where both agree: a real change of speed moves every harmonic's phase by the same angle. ``drift_rad`` is the
    RMS deviation of the slow angle (their mean) from the constant-speed line, in radians of the first mesh
    harmonic; the track follows it when that exceeds
    :data:`models.order_tracking.TRACK_MIN_RAD` (0.1 rad: within what the demodulation scatters on a
    constant-speed record) and the two harmonics differ by less than :data:`DRIFT_AGREEMENT` of it; else the
    track is None and the constant-speed one stays (bit for bit).

    Measured: the SpectraQuest recording h30hz50 (a 32/80 stage at ~30 Hz, no tachometer) drifts by 0.50 rad RMS,
    mostly below 1 Hz, read alike from the first and third mesh harmonics (35 and 27 dB above their floor; they
    differ by 0.15 rad; the even harmonics, 8-22 dB, by 1.2 rad: another source shares those lines). On
    gearpit's 49 simulated rigs (constant mean speed, fluctuations included) the strongest harmonic among the
    first five gave up to 1.05 rad on a weak helical mesh (phase slips of a line 7.5 dB above its floor); with
    the rule above none is tracked (``experiments/pair_check_scan.py`` prints every rig's drift).
    """
    from scipy.signal import fftconvolve

    from models.order_tracking import TRACK_MIN_RAD, mesh_angle, phase_deviation_rad

    a = np.asarray(x, dtype=float) - np.mean(x)
    n = a.size
    fm = z_pinion * fr_hz
    harm = [m for m in range(1, 41) if m * fm + fr_hz < 0.45 * fs_hz]
    if len(harm) < 2:
        return float("nan"), None
    spec = np.abs(np.fft.rfft(a * np.hanning(n)))
    half = max(4, int(round(0.5 * fr_hz * n / fs_hz)))         # half a shaft order, in bins

    prominence = {}
    for m in harm:
        i = int(round(m * fm * n / fs_hz))
        prominence[m] = float(spec[i] / (np.median(spec[max(i - 8 * half, 0):i + 8 * half + 1]) + 1e-300))
    best = [m for m in sorted(harm, key=prominence.get, reverse=True)[:2]
            if prominence[m] >= 10 ** (DRIFT_LINE_DB / 20)]
    if len(best) < 2:                                         # one phase alone cannot be confirmed
        return float("nan"), None
    t = np.arange(n) / fs_hz
    w = np.hanning(max(3, int(round(slow_window_s(fr_hz, z_pinion, z_wheel) * fs_hz))))    # two wheel revolutions
    norm = fftconvolve(np.ones(n), w, mode="same")
    demod = np.hanning(max(3, int(round(2 * fs_hz / fr_hz))))                            # two pinion revolutions
    demod_norm = fftconvolve(np.ones(n), demod, mode="same")

    def smooth(y):
        return fftconvolve(y, w, mode="same") / norm

    def along(slow, m):
        """``slow`` corrected by harmonic ``m``'s phase read along it: demodulated by its own carrier
        ``m z1 slow(t)``, the line's remaining phase is what ``slow`` misses (a pit's sidebands then sit at the
        demodulating window's zeros, as they do at a constant speed: demodulated at a fixed carrier, the m-th
        harmonic of a 0.3 % drift wanders by 0.003 m fm, and at the sixth mesh harmonic the sidebands pass)."""
        base = fftconvolve(a * np.exp(-1j * m * z_pinion * slow), demod, mode="same") / demod_norm
        psi = np.unwrap(np.angle(base))
        return slow + smooth(psi - psi.mean()) / (m * z_pinion)

    m1, m2 = best
    angle, _ = mesh_angle(a, fs_hz, fr_hz, z_pinion, harmonic=m1)
    line = np.polyval(np.polyfit(t, angle, 1), t)
    first = along(line + smooth(angle - line), m1)
    second = along(first, m2)
    slow = 0.5 * (first + second)
    drift = phase_deviation_rad(slow, fs_hz, z_pinion)
    disagree = phase_deviation_rad(first - second, fs_hz, z_pinion)
    if not (drift > TRACK_MIN_RAD and disagree < DRIFT_AGREEMENT * drift and np.all(np.diff(slow) > 0)):
        return float(drift), None
    return float(drift), AngleTrack(t, slow - slow[0])
