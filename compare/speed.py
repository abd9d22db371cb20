"""The measured operating speed: refined from a tachometer or from the spectrum, and the shaft angle track.

- With a tachometer: the pulse times (:func:`features.tacho.tacho_pulse_times`, a Schmitt
  trigger; bounces, spikes and missing pulses: :func:`features.tacho.tacho_pulse_index`)
  give the shaft angle at each pulse, and their rate must lie within
  :data:`TACHO_SPEED_TOLERANCE` of the sidecar's speed; a straight line through them (least squares)
  is the angle track; when the pulses stray more than :data:`DRIFT_RAD` (RMS) from a
  constant speed, a cubic (a run-up, to the record's ends) plus the pulses' remaining
  deviation smoothed over two revolutions of the slower shaft (:func:`slow_window_s`, a
  local-linear Hann smoother): a drift slower than about half the wheel's rotation is
  followed, a fluctuation faster than that is not (it stays in the views, as it
  would in the model). Measured on an independent simulator's 31/47 rig (1440 rpm, a
  +/-0.3 % wander at 0.4 Hz, 2 s): the cubic alone missed the true angle by 0.52 rad
  RMS of the mesh phase (the sixth mesh harmonic smeared by 3 rad), the smoothed
  track by 0.033 rad.
- Without: the mean pinion speed maximises the harmonic sum
  ``S(f) = sum_m |X(m z1 f)|^2`` over the mesh harmonics below 0.45 fs (at most 10),
  searched within ``+/- search_fraction`` of the nominal speed, first on a
  zero-padded FFT, then by a bounded scalar search on the exact windowed DFT
  (no scalloping). The search spans :data:`SEARCH_FRACTION` of the sidecar's speed; when no mesh line is
  where it ends (the maximum on the search's edge, or a family that fails :func:`widened_speed`'s tests: a
  sidecar holding a set point or a nameplate speed further off), it is widened to
  :data:`WIDE_SEARCH_FRACTION`, and a line is taken from it only where the median of its harmonics and of its
  odd ones stands out of the families beside it (a family at ``p/q`` of the mesh frequency hits every ``q``-th
  mesh harmonic), it is the strongest family within :data:`NEIGHBOURS` pinion orders, and its sidebands are no
  other gear's; otherwise the first search's answer stays and the pair check reports what it finds
  (:func:`spectrum_speed`). The track is then a constant speed, unless the mesh phase
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
from compare.speed_track import drift_track, slow_window_s, smooth_pulse_deviation
from features.tsa import AngleTrack
from gearpit.errors import InputError, require

TWO_PI = 2.0 * np.pi
#: RMS deviation (rad) of the pulse angles from a constant speed above which the track follows a drift
DRIFT_RAD = 0.02
#: a tachometer's speed may differ from the sidecar's nominal one by this fraction; more is a wrong sidecar
#: (pulses per revolution, shaft) and is refused
TACHO_SPEED_TOLERANCE = 0.25
#: without a tachometer the speed is searched within this fraction of the sidecar's speed ...
SEARCH_FRACTION = 0.05
#: ... and within this one when the first search finds no mesh line that stands out (:func:`spectrum_speed`)
WIDE_SEARCH_FRACTION = 0.25
#: a line of the widened search must stand out from the families beside it by this much (dB) on the median of
#: its odd harmonics (:func:`compare.pair_check.mesh_line_db` with ``odd``): half of the all-harmonics threshold,
#: since a quiet pair's odd harmonics are as weak as its even ones, while a family at half the mesh frequency has
#: no line on its odd harmonics at all (measured: -2 to 0 dB; the true mesh lines 40-53 dB)
ODD_LINE_DB = 5.0
#: the widened search ranks this many local maxima of its harmonic sum by how far their family stands out
N_PEAKS = 8
#: a line of the speed search must be the strongest within this many pinion orders on ...
NEIGHBOURS = 2.5
#: ... at least this share of its harmonics (:func:`local_maximum_share`)
LOCAL_MAXIMUM_SHARE = 0.6
#: a maximum within this fraction of the search's half-width from its edge is on the edge
EDGE_FRACTION = 0.95


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
    #: the RMS deviation (rad, mesh phase) of the pinion's angle from a constant speed (with a tachometer: its
    #: pulses'; without: the slow part of the mesh phase, :func:`drift_track`), and whether the track follows it;
    #: None when not measured
    drift_rad: float | None = None
    tracked: bool = False
    #: without a tachometer: the half-width (fraction of the nominal speed) of the search that found the speed
    #: (:data:`SEARCH_FRACTION`, or :data:`WIDE_SEARCH_FRACTION` when the first found no mesh line); None: tacho
    search_fraction: float | None = None

    @property
    def fr_pinion_hz(self) -> float:
        return self.speed_rpm / 60.0


def constant_track(n_samples: int, fs_hz: float, fr_hz: float) -> AngleTrack:
    """Angle track at a constant shaft frequency over ``n_samples`` samples (knots at both ends)."""
    duration = (n_samples - 1) / fs_hz
    return AngleTrack(np.array([0.0, duration]), np.array([0.0, TWO_PI * fr_hz * duration]))


#: a tachometer channel with more than this share of its samples inside its Schmitt trigger's band (the middle
#: :data:`features.tacho.TACHO_HYSTERESIS` of its range) is no pulse train: a pulse train sits at its low or its
#: high level but on its edges (a TTL train with 2 % noise: 0 %; 10 % noise: ~8 %), a sine from an inductive
#: pickup 26 %, a level with noise (a speed channel, a disconnected input) 80-95 %, a ramp 40 %
PULSE_TRAIN_MAX_BETWEEN = 0.35
#: a channel that is not a pulse train but a level this many times its spread, within these rpm, may be a speed
#: channel (rpm)
SPEED_CHANNEL_LEVEL = 10.0
SPEED_CHANNEL_RPM = (10.0, 1e5)


def check_pulse_train(tacho: np.ndarray, channel: str = "tacho") -> None:
    """Refuse a tachometer channel that is no pulse train (:data:`PULSE_TRAIN_MAX_BETWEEN`), saying what it looks
    like instead: a constant, a level (a speed channel in rpm, or in volts: the sidecar has no key for one, so the
    advice is to leave ``tacho`` out), or noise (a disconnected input). Without this, the Schmitt trigger read
    edges in noise and the error was a pulse rate against speed_rpm ("a pulse every 36.9 ms, i.e. 1625.9 rpm")."""
    from features.tacho import TACHO_HYSTERESIS

    x = np.asarray(tacho, dtype=float)
    lo, hi = float(np.min(x)), float(np.max(x))
    require(hi > lo, "tacho", f"channel {channel}: constant", "a pulse train (no pulses: is it connected?)")
    half = 0.5 * TACHO_HYSTERESIS * (hi - lo)
    mid = 0.5 * (lo + hi)
    between = float(np.mean(np.abs(x - mid) < half))
    if between <= PULSE_TRAIN_MAX_BETWEEN:
        return
    mean, spread = float(np.mean(x)), float(np.std(x))
    if abs(mean) > SPEED_CHANNEL_LEVEL * spread:
        rpm_lo, rpm_hi = SPEED_CHANNEL_RPM
        kind = ("a speed channel in rpm?" if rpm_lo <= mean <= rpm_hi else
                "a speed channel in volts or another unit?")
        looks = (f"a level of {mean:.5g} with a spread of {100 * spread / abs(mean):.2g} %: {kind} The sidecar has "
                 "no key for a speed channel: leave tacho out (the speed is then measured from the mesh harmonics"
                 + (f") and give its mean as speed_rpm = {mean:.5g}" if rpm_lo <= mean <= rpm_hi else ")"))
    else:
        looks = (f"noise around {mean:.3g} (RMS {spread:.3g}): no pulses; is the tachometer connected, and is tacho "
                 "the pulse channel?")
    raise InputError("tacho", f"channel {channel}: {100 * between:.0f} % of its samples between its low and high levels",
                     f"a pulse train (at most {100 * PULSE_TRAIN_MAX_BETWEEN:g} % between them: a pulse train sits "
                     f"at one level or the other); it looks like {looks}")


def speed_from_tacho(tacho: np.ndarray, fs_hz: float, *, z_pinion: int, z_wheel: int, pulses_per_rev: int = 1,
                     shaft: str = "pinion", nominal_rpm: float, channel: str = "tacho") -> SpeedEstimate:
    """Mean speed and smooth pinion angle track from tachometer pulses (module docstring); a channel that is no
    pulse train is refused saying what it looks like (:func:`check_pulse_train`; ``channel``: its name)."""
    check_pulse_train(tacho, channel)
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
    dev = angle - np.polyval(coef, times - tc)
    drift = float(np.sqrt(np.mean(dev ** 2)))
    tracked = bool(drift > DRIFT_RAD and times.size >= 16)
    if tracked:     # the speed drifts: follow its slow part (as drift_track does without a tachometer)
        window_s = max(slow_window_s(coef[0] / TWO_PI, z_pinion, z_wheel), 4.0 * step)
        grid = np.linspace(0.0, duration, max(257, int(np.ceil(8 * duration / window_s)) + 1))
        coef = np.polyfit(times - tc, angle, 3)       # a run-up's trend exactly (to the record's ends), then
        dev = angle - np.polyval(coef, times - tc)    # what a cubic cannot follow (a wander within the record)
        ang = np.polyval(coef, grid - tc) + smooth_pulse_deviation(times, dev, grid, window_s)
        speed_ok = bool(np.all(np.diff(ang) > 0))
    else:
        grid = np.linspace(0.0, duration, 257)
        ang = np.polyval(coef, grid - tc)
        speed_ok = bool(coef[0] > 0)
    require(speed_ok, "tacho", "speed changes sign", "a shaft turning one way")
    mean_hz = (ang[-1] - ang[0]) / duration / TWO_PI
    return SpeedEstimate(60.0 * mean_hz, nominal_rpm, "tacho", AngleTrack(grid, ang - ang[0]),
                         drift_rad=z_pinion * drift, tracked=tracked)


def speed_from_spectrum(x: np.ndarray, fs_hz: float, *, z_pinion: int, nominal_rpm: float,
                        search_fraction: float = 0.05, n_harmonics: int = 10) -> SpeedEstimate:
    """Mean pinion speed from the mesh harmonics (module docstring); constant-speed track."""
    a, harm, maxima = _comb_maxima(x, fs_hz, z_pinion * nominal_rpm / 60.0, search_fraction, n_harmonics, 1)
    rpm = 60.0 * _refined(a, fs_hz, harm, maxima[0]) / z_pinion
    return SpeedEstimate(rpm, nominal_rpm, "spectrum", constant_track(a.size, fs_hz, rpm / 60.0))


def _comb_maxima(x: np.ndarray, fs_hz: float, fm0: float, fraction: float, n_harmonics: int,
                 n_maxima: int) -> tuple[np.ndarray, list[int], list[float]]:
    """``(record without its mean, harmonics used, mesh frequencies)``: the ``n_maxima`` highest local maxima of the
    harmonic sum within ``fm0 (1 +/- fraction)`` on a 4-times zero-padded FFT, highest first."""
    a = np.asarray(x, float) - np.mean(x)
    n = a.size
    harm = [m for m in range(1, n_harmonics + 1) if m * fm0 * (1 + fraction) < 0.45 * fs_hz]
    require(harm, "speed_rpm", f"a mesh frequency of {fm0:.4g} Hz (+/- {100 * fraction:g} %)",
            below_nyquist(fm0 * (1 + fraction), fs_hz))
    pad = 4
    spec = np.abs(np.fft.rfft(a * np.hanning(n), n=pad * n)) ** 2
    df = fs_hz / (pad * n)
    cand = np.arange(fm0 * (1 - fraction), fm0 * (1 + fraction), df / 2)
    score = np.zeros(cand.size)
    for m in harm:
        score += np.interp(m * cand, np.arange(spec.size) * df, spec) / max(np.max(spec), 1e-300)
    best = int(np.argmax(score))
    if n_maxima <= 1:
        return a, harm, [float(cand[best])]
    peaks = np.flatnonzero((score[1:-1] >= score[:-2]) & (score[1:-1] > score[2:])) + 1
    peaks = peaks[np.argsort(score[peaks])[::-1][:n_maxima]]
    return a, harm, [float(cand[i]) for i in peaks] or [float(cand[best])]


def below_nyquist(fm_hz: float, fs_hz: float, fs_from: str | None = None) -> str:
    """What a mesh frequency ``fm_hz`` must be, in a message refusing one at or above 0.45 fs: below it, and either
    fs (``fs_from``: where it came from, :func:`compare.measurement.fs_source`) or the speed is wrong."""
    source = f" from {fs_from}" if fs_from else ""
    return (f"a mesh frequency (here {fm_hz:.4g} Hz) below 0.45 fs ({0.45 * fs_hz:.4g} Hz): fs {fs_hz:.6g} Hz{source} "
            "is wrong if the record is a gear's (a time column in ms read as seconds? a rate written in kHz? "
            "correct it there, or give fs_hz in the sidecar), else check speed_rpm and the pair's teeth")


def check_mesh_below_nyquist(measurement, fraction: float = SEARCH_FRACTION) -> None:
    """Refuse a measurement whose mesh frequency, searched within ``fraction`` of the sidecar's speed, reaches
    0.45 fs: the message names fs and where it came from (:func:`below_nyquist`), not only speed_rpm."""
    from compare.measurement import fs_source

    z1 = measurement.pair.pinion.teeth
    fm = z1 * float(measurement.speed_rpm) / 60.0 * (1.0 + fraction)
    require(fm < 0.45 * measurement.fs_hz, "fs_hz / speed_rpm",
            f"fs {measurement.fs_hz:.6g} Hz, speed_rpm {float(measurement.speed_rpm):g} ({z1} teeth)",
            below_nyquist(fm, measurement.fs_hz, fs_source(measurement.sidecar, measurement.source)))


def _refined(a: np.ndarray, fs_hz: float, harm: list[int], f0: float) -> float:
    """The mesh frequency within one bin of ``f0`` that maximises the harmonic sum on the exact windowed DFT."""
    bin_hz = fs_hz / a.size

    def neg(f):
        return -float(np.sum(line_amplitudes(a, fs_hz, [m * f for m in harm]) ** 2))

    res = minimize_scalar(neg, bounds=(f0 - bin_hz, f0 + bin_hz), method="bounded",
                          options={"xatol": 1e-4 * bin_hz})
    return float(res.x)


def record_spectrum(x: np.ndarray) -> tuple[np.ndarray, int]:
    """The record's padded log power spectrum the mesh-line tests read (:func:`models.unknown_rate.log_power` at
    :data:`compare.pair_check.PAD`): computed once per search and passed to them."""
    from compare.pair_check import PAD
    from models.unknown_rate import log_power

    return log_power(np.asarray(x, dtype=float), PAD)


def mesh_line_stands_out(x: np.ndarray, fs_hz: float, fm_hz: float, *,
                         spectrum: tuple[np.ndarray, int] | None = None) -> tuple[float, float, float]:
    """``(all_db, median_db, odd_db)``: how far the harmonic family at ``fm_hz`` stands out of the families beside
    it (:func:`compare.pair_check.mesh_line_db`): on all its harmonics as the pair check reads it, on their median,
    and on its odd ones (their median). ``spectrum``: :func:`record_spectrum` of ``x``, if already computed."""
    from compare.pair_check import mesh_line_db

    logp, n_fft = spectrum if spectrum is not None else record_spectrum(x)
    f = fm_hz / fs_hz
    return (mesh_line_db(logp, n_fft, f), mesh_line_db(logp, n_fft, f, quantile=0.5),
            mesh_line_db(logp, n_fft, f, odd=True, quantile=0.5))


def spectrum_speed(x: np.ndarray, fs_hz: float, *, z_pinion: int, z_wheel: int, nominal_rpm: float) -> SpeedEstimate:
    """Mean pinion speed from the mesh harmonics, searched within :data:`SEARCH_FRACTION` of ``nominal_rpm`` and, when
    no mesh line stands out there, within :data:`WIDE_SEARCH_FRACTION` (module docstring). The estimate's
    ``search_fraction`` says which search found it.

    The first search's line must pass the same tests as the widened one's, except the odd harmonics (a quiet
    pair's): a record with a local fault holds every order of its shaft, and within +/- 5 % of a sidecar a few
    percent off lie families of them that stand out (a broken wheel tooth of the 29/100 rig at 920 rpm for 1000:
    95 wheel orders); when the widened search finds no line either, the first search's answer stays.

    Measured (``tests/test_compare_speed_search.py``; sidecars 0.70-1.30 of the true speed in steps of 0.02 on
    gearpit's spur rig with a pitted or broken pinion tooth, a broken wheel tooth or an eccentric pinion, and a
    helical rig with a broken pinion tooth): every sidecar within 18 % of the true speed is read to 0.1 %, none
    further off is read as another speed; a sidecar naming a 17-tooth pinion for the 29-tooth rig keeps the first
    search's answer and is questioned (the family at half the mesh frequency stands out by ~0 dB on its odd
    harmonics)."""
    kw = dict(z_pinion=z_pinion, nominal_rpm=nominal_rpm)
    est = speed_from_spectrum(x, fs_hz, search_fraction=SEARCH_FRACTION, **kw)
    est = SpeedEstimate(est.speed_rpm, est.nominal_rpm, est.method, est.track, search_fraction=SEARCH_FRACTION)
    a = np.asarray(x, float) - np.mean(x)
    if not _on_edge(est, SEARCH_FRACTION) and is_mesh_line(a, fs_hz, z_pinion * est.fr_pinion_hz, z_pinion, z_wheel,
                                                           spectrum=record_spectrum(a)):
        return est
    return widened_speed(x, fs_hz, z_wheel=z_wheel, **kw) or est


def widened_speed(x: np.ndarray, fs_hz: float, *, z_pinion: int, z_wheel: int,
                  nominal_rpm: float) -> SpeedEstimate | None:
    """The speed searched within :data:`WIDE_SEARCH_FRACTION` of ``nominal_rpm``: the first of its harmonic sum's
    :data:`N_PEAKS` highest maxima, ranked by how far their family stands out, that lies inside the search, has two odd
    harmonics below 0.45 fs, stands out on all its harmonics (:data:`compare.pair_check.MESH_FAMILY_DB`) and on its
    odd ones (:data:`ODD_LINE_DB`), its line is the strongest within :data:`NEIGHBOURS` pinion orders on
    :data:`LOCAL_MAXIMUM_SHARE` of its harmonics (:func:`local_maximum_share`), and the sideband family around it is
    no other gear's
    (:func:`compare.pair_check.sideband_family`): a record with a local fault holds every order of its shaft, and
    ``k fr`` for any ``k`` near ``z1`` is a harmonic family that stands out; the mesh is the strongest of them
    (a broken tooth of the helical rig searched below its speed: ``16 fr`` stands out by 28 dB and its sidebands
    count 16 teeth, within the record's resolution of 17, but ``17 fr`` is the stronger). None when none does."""
    fm0 = z_pinion * nominal_rpm / 60.0
    try:
        a, harm, maxima = _comb_maxima(x, fs_hz, fm0, WIDE_SEARCH_FRACTION, 10, N_PEAKS)
    except InputError:      # no mesh harmonic below 0.45 fs at the widened search's top
        return None
    spectrum = record_spectrum(a)
    for f0 in sorted(maxima, key=lambda f: -mesh_line_stands_out(a, fs_hz, f, spectrum=spectrum)[0]):
        fm_hz = _refined(a, fs_hz, harm, f0)
        if abs(fm_hz / fm0 - 1.0) >= EDGE_FRACTION * WIDE_SEARCH_FRACTION or 3.0 * fm_hz >= 0.45 * fs_hz:
            continue
        if not is_mesh_line(a, fs_hz, fm_hz, z_pinion, z_wheel, strict=True, spectrum=spectrum):
            continue
        rpm = 60.0 * fm_hz / z_pinion
        return SpeedEstimate(rpm, nominal_rpm, "spectrum", constant_track(a.size, fs_hz, rpm / 60.0),
                             search_fraction=WIDE_SEARCH_FRACTION)
    return None


def is_mesh_line(a: np.ndarray, fs_hz: float, fm_hz: float, z_pinion: int, z_wheel: int, *,
                 strict: bool = False, spectrum: tuple[np.ndarray, int] | None = None) -> bool:
    """Whether ``fm_hz`` is the mesh line (:func:`widened_speed`'s tests; ``strict``: also the median of its
    harmonics and of its odd ones stand out, which the first search does not require of a quiet pair;
    ``spectrum``: :func:`record_spectrum` of ``a``, if already computed)."""
    from compare.pair_check import MESH_FAMILY_DB, sideband_family

    spectrum = spectrum if spectrum is not None else record_spectrum(a)
    all_db, median_db, odd_db = mesh_line_stands_out(a, fs_hz, fm_hz, spectrum=spectrum)
    if all_db < MESH_FAMILY_DB or (strict and (median_db < MESH_FAMILY_DB or odd_db < ODD_LINE_DB)):
        return False
    if local_maximum_share(a, fs_hz, fm_hz, z_pinion, spectrum=spectrum) < LOCAL_MAXIMUM_SHARE:
        return False
    family = sideband_family(a, fm_hz / fs_hz, z_pinion, z_wheel)
    return family is None or not family["other_family"]


def local_maximum_share(a: np.ndarray, fs_hz: float, fm_hz: float, z_pinion: int, *, n_harmonics: int = 10,
                        spectrum: tuple[np.ndarray, int] | None = None) -> float:
    """The share of the harmonics of ``fm_hz`` below 0.45 fs (at most ``n_harmonics``) whose line is the strongest
    within :data:`NEIGHBOURS` pinion orders of it (``fm_hz / z_pinion`` each; the line: the peak of the 4-times
    padded spectrum within one bin of the harmonic; its neighbours: the peak over the rest of the window beyond
    half an order). A mesh harmonic outweighs its sidebands; in a record with a local fault every pinion order is a
    line, and a family at ``(z1 +/- k) fr`` is made of sidebands, each the strongest of its neighbourhood about as
    often as any of them. A vote, not a power sum: one harmonic on a housing resonance leads a power sum.
    ``spectrum``: :func:`record_spectrum` of ``a``, if already computed."""
    from compare.pair_check import PAD

    logp, n_fft = spectrum if spectrum is not None else record_spectrum(a)
    order = fm_hz / z_pinion * n_fft / fs_hz           # one pinion order, in padded bins
    half, reach = max(PAD + 1, int(0.5 * order)), int(NEIGHBOURS * order)
    votes = []
    for m in range(1, n_harmonics + 1):
        c = int(round(m * fm_hz * n_fft / fs_hz))
        if m * fm_hz >= 0.45 * fs_hz or c + reach >= logp.size:
            break
        line = np.max(logp[c - PAD:c + PAD + 1])
        around = np.concatenate([logp[max(c - reach, 0):c - half], logp[c + half + 1:c + reach + 1]])
        votes.append(bool(around.size == 0 or line > np.max(around)))
    return float(np.mean(votes)) if votes else 0.0


def _on_edge(est: SpeedEstimate, fraction: float) -> bool:
    return abs(est.speed_rpm / est.nominal_rpm - 1.0) >= EDGE_FRACTION * fraction


def speed_message(speed: SpeedEstimate) -> str | None:
    """One line when the speed was found by the widened search (the sidecar's speed is further off than
    :data:`SEARCH_FRACTION`), else None."""
    if speed.search_fraction is None or speed.search_fraction <= SEARCH_FRACTION:
        return None
    return off_sidecar_message(speed.speed_rpm, speed.nominal_rpm, SEARCH_FRACTION)


def off_sidecar_message(speed_rpm: float, nominal_rpm: float, first_fraction: float) -> str:
    """The sidecar's speed is further off than the first search covered; the widened one found the mesh line."""
    off = 100.0 * (speed_rpm / nominal_rpm - 1.0)
    return (f"the mesh line is at {speed_rpm:.1f} rpm of the pinion, {abs(off):.1f} % "
            f"{'above' if off > 0 else 'below'} the sidecar's speed_rpm {nominal_rpm:g} (no mesh line stands "
            f"out within +/-{100 * first_fraction:.3g} % of it; found searching +/-{100 * WIDE_SEARCH_FRACTION:g} %): "
            "the measured speed is used; check speed_rpm (a set point or a nameplate speed?)")


def refine_speed(measurement, *, search_fraction: float | None = None) -> SpeedEstimate:
    """Refined speed of a :class:`compare.measurement.Measurement` (tacho if it has one, else spectrum: by
    :func:`spectrum_speed`, or within ``search_fraction`` alone when given)."""
    pair = measurement.pair
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    if measurement.tacho is not None:
        sc = measurement.sidecar
        return speed_from_tacho(measurement.tacho_signal, measurement.fs_hz, z_pinion=z1, z_wheel=z2,
                                pulses_per_rev=sc.tacho_pulses_per_rev, shaft=sc.tacho_shaft,
                                nominal_rpm=measurement.speed_rpm, channel=measurement.tacho)
    check_mesh_below_nyquist(measurement, SEARCH_FRACTION if search_fraction is None else search_fraction)
    kw = dict(z_pinion=z1, nominal_rpm=measurement.speed_rpm)
    if search_fraction is None:
        est = spectrum_speed(measurement.signal, measurement.fs_hz, z_wheel=z2, **kw)
    else:
        est = speed_from_spectrum(measurement.signal, measurement.fs_hz, search_fraction=search_fraction, **kw)
    drift, track = drift_track(measurement.signal, measurement.fs_hz, est.speed_rpm / 60.0, z1, z2)
    speed_rpm = est.speed_rpm
    if track is not None:     # the mean speed is the followed angle over the record, not the comb's maximum
        t, ang = track.time_s, track.angle_rad      # (which a drift's dwell at its extremes pulls towards them)
        speed_rpm = 60.0 * (ang[-1] - ang[0]) / (TWO_PI * (t[-1] - t[0]))
    return SpeedEstimate(speed_rpm, est.nominal_rpm, est.method, track or est.track, drift, track is not None,
                         est.search_fraction)
