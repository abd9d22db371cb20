"""Order tracking of a measured record: its speed varies within the record, the TSA assumes it does not.

The TSA and order representations (:mod:`models.representations`) cut a record into revolutions at a constant
speed. A rig's speed drifts and fluctuates (a motor's slip under a varying load, a controller's hunting): a
speed that changes by 1 % over a 1 s record at 20 Hz moves the pinion 0.0125 revolutions off the constant-speed
line, 0.36 cycles of the 29-tooth mesh, and the average over the record smears the teeth. So a measurement is
resampled at constant angle steps first (computed order tracking, Fyfe and Munck [1]_):

1. the pinion angle at every sample, from the tachometer's pulses (monotone cubic through the pulse angles,
   :func:`tacho_angle`) or, without one, from the phase of the strongest mesh harmonic (:func:`mesh_angle`:
   band-pass of +/- half a shaft order around it, analytic signal, unwrapped phase over ``m z1``; Bonnardot
   et al. [2]_), which follows speed changes slower than half the shaft frequency;
2. the straight line through it (least squares): the constant speed with the same mean;
3. the record read (cubic spline) at the times the shaft reaches that line's angle at each sample
   (:func:`resample_to_constant_speed`): a record of the same length and sampling rate at the constant mean
   speed, which every representation then reads as it is.

A record whose mesh phase strays less than :data:`TRACK_MIN_RAD` (RMS) from the line is left as it is
(bit for bit): its speed is constant to within what the demodulation itself scatters.

References
----------
.. [1] Fyfe, K. R., Munck, E. D. S. (1997). Analysis of computed order tracking. Mech. Syst. Signal Process.
   11(2), 187-205.
.. [2] Bonnardot, F., El Badaoui, M., Randall, R. B., Daniere, J., Guillet, F. (2005). Use of the acceleration
   signal of a gearbox in order to perform angular resampling (with limited speed fluctuation). Mech. Syst.
   Signal Process. 19(4), 766-785.
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline, PchipInterpolator
from scipy.signal import fftconvolve

from features.tacho import tacho_pulse_index, tacho_pulse_times
from gearpit.errors import require

TWO_PI = 2.0 * np.pi
#: RMS deviation of the mesh phase (rad, first mesh harmonic) from the constant-speed line below which a record
#: is not resampled: on every 20th record of the default dataset (constant speed) the demodulated deviation was
#: at most 0.025 rad RMS on the accelerometer and 0.031 rad on the transmission error (measured), so 0.1 rad
#: (the mesh tone's coherence over the record: cos 0.1 = 0.995) leaves every constant-speed record alone
TRACK_MIN_RAD = 0.1


def mesh_angle(x: np.ndarray, fs_hz: float, fr_hz: float, z_pinion: int, max_harmonic: int = 5, *,
               harmonic: int | None = None) -> tuple[np.ndarray, int]:
    """Pinion angle (rad, arbitrary offset) at every sample of ``x`` from the phase of its strongest mesh
    harmonic ``m`` (1 .. ``max_harmonic``, below 0.45 fs; or ``harmonic`` when given), and ``m``: the record is
    shifted down by ``m z1 fr``
    (complex demodulation) and low-passed by a Hann window two shaft revolutions long, whose spectrum is zero at
    every multiple of the shaft frequency, so a local fault's sidebands drop out; at the ends the window's
    available part is renormalised (a real, symmetric kernel: the phase stays unbiased where it is cut)."""
    a = np.asarray(x, dtype=float) - np.mean(x)
    n = a.size
    fm = z_pinion * fr_hz
    if harmonic is None:
        harm = [m for m in range(1, max_harmonic + 1) if m * fm + fr_hz < 0.45 * fs_hz]
        if not harm:
            from compare.speed import below_nyquist

            require(False, "speed_rpm", 60.0 * fr_hz, below_nyquist(fm + fr_hz, fs_hz))
        spec = np.abs(np.fft.rfft(a * np.hanning(n)))
        m = max(harm, key=lambda h: float(spec[int(round(h * fm * n / fs_hz))]))
    else:
        m = harmonic
        require(m * fm + fr_hz < 0.45 * fs_hz, "harmonic", m, f"a mesh harmonic below 0.45 fs ({0.45 * fs_hz:g} Hz)")
    carrier = TWO_PI * m * fm * np.arange(n) / fs_hz
    win = np.hanning(max(3, int(round(2 * fs_hz / fr_hz))))
    base = fftconvolve(a * np.exp(-1j * carrier), win, mode="same") / fftconvolve(np.ones(n), win, mode="same")
    return (np.unwrap(np.angle(base)) + carrier) / (m * z_pinion), m


def tacho_angle(tacho: np.ndarray, fs_hz: float, *, pulses_per_rev: int = 1, per_rev: float = 1.0,
                nominal_rpm: float | None = None) -> np.ndarray:
    """Pinion angle (rad) at every sample from a tachometer channel: pulse ``k`` at ``2 pi k per_rev /
    pulses_per_rev`` (``per_rev``: pinion revolutions per revolution of the tachometer's shaft; a missing pulse
    skips a ``k``, a bounce or a spike is dropped: :func:`features.tacho.tacho_pulse_index`, its interval from
    ``nominal_rpm`` of the pinion when given), a monotone cubic between pulses, the mean speed of the first and
    last revolution beyond them."""
    expected = None if nominal_rpm is None else 60.0 / nominal_rpm * per_rev / pulses_per_rev
    times, index, _ = tacho_pulse_index(tacho_pulse_times(tacho, fs_hz), expected)
    require(times.size >= 2 * pulses_per_rev + 1, "tacho", f"{times.size} pulses",
            f">= {2 * pulses_per_rev + 1} pulses (two revolutions)")
    ang = TWO_PI * per_rev * index / pulses_per_rev
    t = np.arange(len(tacho)) / fs_hz
    out = PchipInterpolator(times, ang, extrapolate=False)(t)
    k = pulses_per_rev
    lo, hi = t < times[0], t > times[-1]
    out[lo] = ang[0] + (t[lo] - times[0]) * (ang[k] - ang[0]) / (times[k] - times[0])
    out[hi] = ang[-1] + (t[hi] - times[-1]) * (ang[-1] - ang[-1 - k]) / (times[-1] - times[-1 - k])
    return out


def resample_to_constant_speed(x: np.ndarray, fs_hz: float, angle: np.ndarray) -> tuple[np.ndarray, float]:
    """``x`` read at the times its shaft reaches the angles of a constant speed (the least-squares line through
    ``angle``), one per sample: ``(record, mean shaft frequency in Hz)``. Times beyond the record (where the
    shaft is behind or ahead of the line at an end) are held at the end."""
    n = len(x)
    t = np.arange(n) / fs_hz
    slope, icpt = np.polyfit(t, angle, 1)
    mono = np.maximum.accumulate(angle)        # the shaft does not turn back; noise must not make it
    tt = np.clip(np.interp(icpt + slope * t, mono, t), 0.0, t[-1])
    return CubicSpline(t, np.asarray(x, dtype=float))(tt), float(slope / TWO_PI)


def phase_deviation_rad(angle: np.ndarray, fs_hz: float, z_pinion: int) -> float:
    """RMS deviation of the first mesh harmonic's phase (``z1`` times the pinion angle, rad) from the
    constant-speed line through ``angle``."""
    t = np.arange(len(angle)) / fs_hz
    line = np.polyval(np.polyfit(t, angle, 1), t)
    return float(np.sqrt(np.mean((angle - line) ** 2)) * z_pinion)
