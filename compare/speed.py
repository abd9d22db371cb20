"""The measured operating speed: refined from a tachometer or from the spectrum, and the shaft angle track.

- With a tachometer: the pulse times (:func:`features.tsa.tacho_pulse_times`) give
  the shaft angle at each pulse; a straight line through them (least squares)
  is the angle track, or a cubic when the pulses stray more than
  :data:`DRIFT_RAD` (RMS) from a constant speed: slow drift is followed,
  fluctuations within a revolution are not (they stay visible in the views,
  as they would in the model).
- Without: the mean pinion speed maximises the harmonic sum
  ``S(f) = sum_m |X(m z1 f)|^2`` over the mesh harmonics below 0.45 fs (at most 10),
  searched within ``+/- search_fraction`` of the nominal speed, first on a
  zero-padded FFT, then by a bounded scalar search on the exact windowed DFT
  (no scalloping). The track is then a constant speed.

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring, sec. 5.2 (order tracking from a tachometer).
Bonnardot, F. et al. (2005). Mech. Syst. Signal Process. 19(4), 766-785 (speed from the mesh harmonics).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from features.spectra import line_amplitudes
from features.tsa import AngleTrack, tacho_pulse_times
from gearpit.errors import require

TWO_PI = 2.0 * np.pi
#: RMS deviation (rad) of the pulse angles from a constant speed above which the track follows a drift
DRIFT_RAD = 0.02


@dataclass(frozen=True, eq=False)
class SpeedEstimate:
    """Refined mean pinion speed and the pinion angle track used by the views.

    Attributes
    ----------
    speed_rpm : float
        Mean pinion speed over the record (rpm).
    nominal_rpm : float
        The sidecar's value.
    method : {"tacho", "spectrum", "nominal"}
    track : AngleTrack
        Pinion angle (rad) versus time (s) over the whole record.
    """

    speed_rpm: float
    nominal_rpm: float
    method: str
    track: AngleTrack

    @property
    def fr_pinion_hz(self) -> float:
        return self.speed_rpm / 60.0


def constant_track(n_samples: int, fs_hz: float, fr_hz: float) -> AngleTrack:
    """Angle track at a constant shaft frequency over ``n_samples`` samples (knots at both ends)."""
    duration = (n_samples - 1) / fs_hz
    return AngleTrack(np.array([0.0, duration]), np.array([0.0, TWO_PI * fr_hz * duration]))


def speed_from_tacho(tacho: np.ndarray, fs_hz: float, *, z_pinion: int, z_wheel: int, pulses_per_rev: int = 1,
                     shaft: str = "pinion", nominal_rpm: float) -> SpeedEstimate:
    """Mean speed and smooth pinion angle track from tachometer pulses (module docstring)."""
    times = tacho_pulse_times(tacho, fs_hz)
    require(times.size >= pulses_per_rev + 2, "tacho", f"{times.size} pulses",
            f">= {pulses_per_rev + 2} pulses (more than one revolution of the {shaft})")
    per_rev = 1.0 if shaft == "pinion" else z_wheel / z_pinion  # pinion revs per tacho-shaft rev
    angle = TWO_PI * per_rev * np.arange(times.size) / pulses_per_rev
    n = len(tacho)
    duration = (n - 1) / fs_hz
    tc = times.mean()
    coef = np.polyfit(times - tc, angle, 1)
    drift = np.sqrt(np.mean((np.polyval(coef, times - tc) - angle) ** 2))
    if drift > DRIFT_RAD and times.size >= 16:  # the speed drifts: follow it (cubic at most)
        coef = np.polyfit(times - tc, angle, 3)
    grid = np.linspace(0.0, duration, 257)
    ang = np.polyval(coef, grid - tc)
    speed = np.polyval(np.polyder(coef), grid - tc)
    require(bool(np.all(speed > 0)), "tacho", "speed changes sign", "a shaft turning one way")
    mean_hz = (ang[-1] - ang[0]) / duration / TWO_PI
    return SpeedEstimate(60.0 * mean_hz, nominal_rpm, "tacho", AngleTrack(grid, ang - ang[0]))


def speed_from_spectrum(x: np.ndarray, fs_hz: float, *, z_pinion: int, nominal_rpm: float,
                        search_fraction: float = 0.05, n_harmonics: int = 10) -> SpeedEstimate:
    """Mean pinion speed from the mesh harmonics (module docstring); constant-speed track."""
    a = np.asarray(x, float) - np.mean(x)
    n = a.size
    fm0 = z_pinion * nominal_rpm / 60.0
    harm = [m for m in range(1, n_harmonics + 1) if m * fm0 * (1 + search_fraction) < 0.45 * fs_hz]
    require(harm, "speed_rpm", nominal_rpm, f"a mesh frequency below 0.45 fs ({0.45 * fs_hz:g} Hz)")
    pad = 4
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft(a * w, n=pad * n)) ** 2
    df = fs_hz / (pad * n)
    lo, hi = fm0 * (1 - search_fraction), fm0 * (1 + search_fraction)
    cand = np.arange(lo, hi, df / 2)
    score = np.zeros(cand.size)
    for m in harm:
        score += np.interp(m * cand, np.arange(spec.size) * df, spec) / max(np.max(spec), 1e-300)
    f0 = float(cand[int(np.argmax(score))])
    bin_hz = fs_hz / n

    def neg(f):
        return -float(np.sum(line_amplitudes(a, fs_hz, [m * f for m in harm]) ** 2))

    res = minimize_scalar(neg, bounds=(f0 - bin_hz, f0 + bin_hz), method="bounded",
                          options={"xatol": 1e-4 * bin_hz})
    fm = float(res.x)
    rpm = 60.0 * fm / z_pinion
    return SpeedEstimate(rpm, nominal_rpm, "spectrum", constant_track(n, fs_hz, rpm / 60.0))


def refine_speed(measurement, *, search_fraction: float = 0.05) -> SpeedEstimate:
    """Refined speed of a :class:`compare.measurement.Measurement` (tacho if it has one, else spectrum)."""
    pair = measurement.pair
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    if measurement.tacho is not None:
        sc = measurement.sidecar
        return speed_from_tacho(measurement.tacho_signal, measurement.fs_hz, z_pinion=z1, z_wheel=z2,
                                pulses_per_rev=sc.tacho_pulses_per_rev, shaft=sc.tacho_shaft,
                                nominal_rpm=measurement.speed_rpm)
    return speed_from_spectrum(measurement.signal, measurement.fs_hz, z_pinion=z1, nominal_rpm=measurement.speed_rpm,
                               search_fraction=search_fraction)
