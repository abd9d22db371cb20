"""The measured operating speed: refined from a tachometer or from the spectrum, and the shaft angle track.

- With a tachometer: the pulse times (:func:`features.tacho.tacho_pulse_times`, a Schmitt
  trigger; bounces, spikes and missing pulses: :func:`features.tacho.tacho_pulse_index`)
  give the shaft angle at each pulse, and their rate must lie within
  :data:`TACHO_SPEED_TOLERANCE` of the sidecar's speed; a straight line through them (least squares)
  is the angle track, or a cubic when the pulses stray more than
  :data:`DRIFT_RAD` (RMS) from a constant speed: slow drift is followed,
  fluctuations within a revolution are not (they stay visible in the views,
  as they would in the model).
- Without: the mean pinion speed maximises the harmonic sum
  ``S(f) = sum_m |X(m z1 f)|^2`` over the mesh harmonics below 0.45 fs (at most 10),
  searched within ``+/- search_fraction`` of the nominal speed, first on a
  zero-padded FFT, then by a bounded scalar search on the exact windowed DFT
  (no scalloping). The track is then a constant speed, unless the mesh phase
  drifts from it by more than :data:`models.order_tracking.TRACK_MIN_RAD`
  slower than about half the wheel's rotation (:func:`drift_track`): that drift
  is followed, as the tachometer's track follows it.

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
from features.tacho import tacho_pulse_index, tacho_pulse_times
from features.tsa import AngleTrack
from gearpit.errors import InputError, require

TWO_PI = 2.0 * np.pi
#: RMS deviation (rad) of the pulse angles from a constant speed above which the track follows a drift
DRIFT_RAD = 0.02
#: without a tachometer, a drift is followed only where the two harmonics it is read from differ by less than this
#: fraction of it (drift_track)
DRIFT_AGREEMENT = 0.5
#: ... and only from mesh harmonics standing this far (dB) above their local floor (the median within 4 shaft orders)
DRIFT_LINE_DB = 20.0
#: a tachometer's speed may differ from the sidecar's nominal one by this fraction; more is a wrong sidecar
#: (pulses per revolution, shaft) and is refused
TACHO_SPEED_TOLERANCE = 0.25


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
    #: without a tachometer: the RMS deviation (rad, mesh phase) of the slow part of the mesh phase from a constant
    #: speed (:func:`drift_track`), and whether the track follows it; None when not measured
    drift_rad: float | None = None
    tracked: bool = False

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
    per_rev = 1.0 if shaft == "pinion" else z_wheel / z_pinion  # pinion revs per tacho-shaft rev
    expected_s = 60.0 / nominal_rpm * per_rev / pulses_per_rev      # the pulse interval the sidecar implies
    times, index, step = tacho_pulse_index(tacho_pulse_times(tacho, fs_hz), expected_s)
    require(times.size >= pulses_per_rev + 2, "tacho", f"{times.size} pulses",
            f">= {pulses_per_rev + 2} pulses (more than one revolution of the {shaft})")
    require(abs(step / expected_s - 1.0) <= TACHO_SPEED_TOLERANCE, "tacho",
            f"a pulse every {1e3 * step:.4g} ms, i.e. {60.0 * per_rev / (pulses_per_rev * step):.5g} rpm of the pinion "
            f"with tacho_pulses_per_rev = {pulses_per_rev} on the {shaft}",
            f"within {100 * TACHO_SPEED_TOLERANCE:g} % of the sidecar's speed_rpm {nominal_rpm:g} (check speed_rpm, "
            "tacho_pulses_per_rev and tacho_shaft)")
    angle = TWO_PI * per_rev * index / pulses_per_rev
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
    est = speed_from_spectrum(measurement.signal, measurement.fs_hz, z_pinion=z1, nominal_rpm=measurement.speed_rpm,
                              search_fraction=search_fraction)
    drift, track = drift_track(measurement.signal, measurement.fs_hz, est.speed_rpm / 60.0, z1, z2)
    return SpeedEstimate(est.speed_rpm, est.nominal_rpm, est.method, track or est.track, drift, track is not None)


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
    w = np.hanning(max(3, int(round(2 * fs_hz * z_wheel / (z_pinion * fr_hz)))))      # two wheel revolutions
    norm = fftconvolve(np.ones(n), w, mode="same")
    slows = []
    for m in best:
        angle, _ = mesh_angle(a, fs_hz, fr_hz, z_pinion, harmonic=m)
        line = np.polyval(np.polyfit(t, angle, 1), t)
        slows.append(line + fftconvolve(angle - line, w, mode="same") / norm)
    slow = 0.5 * (slows[0] + slows[1])
    drift = phase_deviation_rad(slow, fs_hz, z_pinion)
    disagree = phase_deviation_rad(slows[0] - slows[1], fs_hz, z_pinion)
    if not (drift > TRACK_MIN_RAD and disagree < DRIFT_AGREEMENT * drift and np.all(np.diff(slow) > 0)):
        return float(drift), None
    return float(drift), AngleTrack(t, slow - slow[0])
