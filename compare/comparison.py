"""One comparison end to end: measurement + model -> residuals, errors, disagreements.

Steps (each in its own module):

1. the measured speed is refined (:mod:`compare.speed`) and the plan of
   locations is built on the measurement (:mod:`compare.views`);
2. the model is simulated at the refined speed, the sidecar's torque, the
   measurement's sampling rate and length (:mod:`compare.model`,
   :func:`datagen.simulate.simulate`) and its sensor channel analysed on the
   same plan, with a constant-speed angle track at the refined speed;
3. the measurement chain is matched, not assumed: a first gain estimate from
   the visible lines, then white noise is added to the model record so that its
   floor between the orders equals the measured one (per-bin power ``P`` of
   white noise of variance ``s2`` in the order spectrum is ``6 s2 df / fs``, so
   ``s2 = (P_meas / g^2 - P_model) fs / (6 df)``, none when the model's floor is
   already as high); then the gain is fitted again on all views
   (:mod:`compare.error`);
4. residuals, the error per view and in total, and the ranked disagreements
   (:mod:`compare.disagreements`);
5. the noise error (:mod:`compare.error`, step 7): the model record with
   ``noise_draws`` further independent draws of that noise, each pair of the
   draws compared like measurement and model; ``N_v^2`` is the mean of their
   ``E_v^2``. The headline ``error_db`` is the excess over it.

The noise is drawn from ``seed`` (same seed, same bytes) and, in attribution,
is the same draw for every candidate (common random numbers).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from compare.error import Residuals, fit_gain_db, reliability, residuals
from compare.measurement import Measurement
from compare.speed import SpeedEstimate, constant_track, refine_speed
from compare.plan import VIEWS, Plan, make_plan
from compare.quality import clipping
from compare.spectra import below_shafts_share, low_cut_hz
from compare.views import SignalViews, analyse, pinion_lines
from gearpit.errors import require

#: extra pinion revolutions simulated beyond the measurement, so the model never has fewer
EXTRA_REVS = 1.5
#: relative excess of the target noise floor over the model's below which no noise is added (:func:`evaluate`)
NOISE_FLOOR_RTOL = 1e-6


@dataclass(frozen=True, eq=False)
class Reference:
    """Everything about the measurement that a comparison holds fixed."""

    measurement: Measurement
    x: np.ndarray
    speed: SpeedEstimate
    plan: Plan
    views: SignalViews
    #: RMS of the measurement's content below every shaft order (its mean left out), over the RMS of the rest;
    #: above :data:`BELOW_SHAFTS_REMOVED` that content is removed before every view (the plan's ``low_cut_hz``);
    #: 0 for a window of a record (it follows the whole record's decision)
    below_shafts_ratio: float = 0.0
    @cached_property
    def clipping(self) -> dict:
        """Whether the sensor channel is clipped (:func:`compare.quality.clipping`), reported; computed when asked
        (only the comparison's own reference is reported, not its windows or further channels)."""
        return clipping(self.x)

    @property
    def fs_hz(self) -> float:
        return self.measurement.fs_hz

    @property
    def reliability(self) -> np.ndarray:
        """The measurement's reliability ``q_i`` of :mod:`compare.error` step 5 (all 1 while switched off)."""
        return reliability(self.views, self.plan)

    @property
    def noise_floor(self) -> float:
        """Per-bin power of the measured floor between the orders (measurement units squared)."""
        return float(self.views.curves["noise_floor"])

    def model_duration_s(self) -> float:
        return len(self.x) / self.fs_hz + EXTRA_REVS / self.speed.fr_pinion_hz


def prepare_reference(measurement: Measurement, *, duration_s: float | None = None,
                      speed: SpeedEstimate | None = None, lines_from: Plan | None = None) -> Reference:
    """Refine the speed, build the plan and analyse the measurement (optionally its first ``duration_s``;
    ``lines_from``: take the lines at no order, and whether content below every shaft order is removed, from that
    plan instead of finding them again: :data:`BELOW_SHAFTS_REMOVED`)."""
    x = measurement.signal
    if speed is None:
        speed = refine_speed(measurement)
    if duration_s is not None:
        n = min(len(x), int(round(duration_s * measurement.fs_hz)))
        x = x[:n]
    track = speed.track if duration_s is None else _crop_track(speed, len(x), measurement.fs_hz)
    plan = make_plan(x, measurement.fs_hz, track, measurement.pair, lines_from=lines_from)
    x = np.asarray(x, float)
    low = 0.0
    if lines_from is not None:      # a window of a measurement: as the whole record was decided
        plan = replace(plan, low_cut_hz=float(lines_from.low_cut_hz))
    else:
        low, _ = below_shafts_share(x, measurement.fs_hz, low_cut_hz(plan))
        if low > BELOW_SHAFTS_REMOVED:
            plan = replace(plan, low_cut_hz=low_cut_hz(plan))
    views = analyse(x, measurement.fs_hz, track, plan, keep_curves=True)
    return Reference(measurement=measurement, x=x, speed=speed, plan=plan, views=views, below_shafts_ratio=low)


#: content below every shaft order (:func:`compare.spectra.low_cut_hz`) whose RMS exceeds this fraction of the
#: rest's is removed from measurement and model before every view, and reported. Why a threshold: the
#: simulator's own records hold 0.3-2.2 % there (the twelve hidden-effect rigs, the far rig's pit), the real
#: SpectraQuest recordings 0.6-0.8 %; removing that changed no view by more than 0.05 dB but moved a fit of the
#: rugged fluctuation landscapes (a torque fluctuation at 37.16 Hz for 37.0, its encoders' resolution lost), so
#: every comparison whose measurement holds no drift reads its record as before; a drift of the size that matters
#: (a 0.7 Hz wander and a ramp of 1.5-2 RMS: the total error 0.46 -> 3.79 dB) is removed. Decided on the whole
#: record: a window of it (the time-stepped fits' 0.5 s) follows that decision (a window's own share differs)
BELOW_SHAFTS_REMOVED = 0.05


def below_shafts_message(ref: Reference) -> str | None:
    """One line when content below every shaft order was removed (:data:`BELOW_SHAFTS_REMOVED`)."""
    if ref.plan.low_cut_hz <= 0.0:
        return None
    return (f"the measurement holds content below {ref.plan.low_cut_hz:.3g} Hz (half the slower shaft's rate), "
            f"{ref.below_shafts_ratio:.3g} times the RMS of the rest: no order of either shaft (a sensor's drift, a "
            "foundation's sway, a slow process), removed from measurement and model before every view")


def _crop_track(speed: SpeedEstimate, n: int, fs_hz: float):
    from features.tsa import AngleTrack

    t_end = (n - 1) / fs_hz
    t = speed.track.time_s
    grid = np.linspace(0.0, t_end, 129)
    return AngleTrack(grid, np.interp(grid, t, speed.track.angle_rad))


@dataclass(frozen=True, eq=False)
class Evaluation:
    """A model record compared with the reference."""

    views: SignalViews
    residuals: Residuals
    noise_added_rms: float
    x: np.ndarray = field(repr=False, default=None)

    @property
    def total_db(self) -> float:
        return self.residuals.total_db


#: noise draws of the noise error in a comparison (module docstring, step 5): with the model's own draw
#: they make three pairs; measured standard deviation of the total N over 6 seeds on three hidden-effect
#: rigs (pitch_error, eccentricity_wheel, hertz_nonlinear; N = 0.59-0.66 dB): 0.02-0.06 dB
NOISE_DRAWS = 2


def evaluate(ref: Reference, y: np.ndarray, fs_hz: float, *, seed: int = 0, keep_curves: bool = False,
             keep_signal: bool = False, noise_draws: int = 0, noise_view_db: dict | None = None,
             ensemble=()) -> Evaluation:
    """Compare a model record ``y`` (at the refined speed, from t = 0) with the reference (module docstring).

    ``noise_draws`` > 0 measures the noise error (step 5) with that many further draws; ``noise_view_db``
    instead attaches one measured before (e.g. the baseline's, for the candidates of an attribution).
    ``ensemble``: further realisations of a chaotic model (:mod:`compare.chaos`); each gets the same noise
    level (its own draw) and the model's views are their mean level and floor in dB, the expectation a chaotic
    model predicts, instead of one draw of it (curves, signal and noise error stay ``y``'s)."""
    require(abs(fs_hz - ref.fs_hz) <= 1e-6 * ref.fs_hz, "model fs_hz", fs_hz, f"the measurement's {ref.fs_hz} Hz")
    y = np.asarray(y, float)
    plan = ref.plan
    track = constant_track(len(y), fs_hz, ref.speed.fr_pinion_hz)
    v0 = pinion_lines(y, fs_hz, track, plan)
    ok = np.isfinite(v0.levels)
    g0 = fit_gain_db(SignalViews(ref.views.levels[ok], ref.views.floors[ok]), SignalViews(v0.levels[ok], v0.floors[ok]),
                     plan, mask=ok)
    p_model = float(v0.curves["noise_floor"])
    p_target = ref.noise_floor / 10 ** (g0 / 10)
    # a floor within NOISE_FLOOR_RTOL of the target is the same floor (identical records whose angle tracks differ
    # in the last bits fit a gain of ~1e-8 dB; noise of that power would move only the faintest lines, by 1e-4 dB)
    s2 = max(0.0, p_target - p_model * (1.0 + NOISE_FLOOR_RTOL)) * fs_hz / (6.0 * plan.bin_hz)
    y0 = y
    if s2 > 0:
        rng = np.random.default_rng(seed)
        y = y + np.sqrt(s2) * rng.standard_normal(y.size)
    v = analyse(y, fs_hz, track, plan, keep_curves=keep_curves)
    if len(ensemble):
        members = [v]
        for k, e in enumerate(ensemble, start=1):
            e = np.asarray(e, float)
            if s2 > 0:
                e = e + np.sqrt(s2) * np.random.default_rng([seed, k]).standard_normal(e.size)
            members.append(analyse(e, fs_hz, track, plan))
        v = SignalViews(levels=np.mean([m.levels for m in members], axis=0),
                        floors=np.mean([m.floors for m in members], axis=0), curves=v.curves)
    q = ref.reliability
    res = residuals(ref.views, v, plan, q=q)
    if noise_view_db is None and noise_draws > 0:
        noise_view_db = noise_error(y0, fs_hz, track, plan, s2, v, seed=seed, draws=noise_draws, q=q)
    res = res.with_noise(noise_view_db)
    return Evaluation(views=v, residuals=res, noise_added_rms=float(np.sqrt(s2)), x=y if keep_signal else None)


def noise_error(y0: np.ndarray, fs_hz: float, track, plan: Plan, s2: float, first: SignalViews, *, seed: int,
                draws: int, q: np.ndarray | None = None) -> dict:
    """``N_v`` per view (module docstring, step 5): ``first`` is ``y0`` plus the comparison's own draw
    (variance ``s2``); ``draws`` more (seeds ``seed + 1 ...``) are analysed, and every pair of the draws is
    compared as measurement and model (gain fitted), with the measurement's reliability ``q``
    (:func:`compare.error.reliability`), so that ``N`` weighs the residuals as ``E`` does. All zero when no
    noise is drawn (``s2`` = 0)."""
    if s2 <= 0:
        return {v: 0.0 for v in VIEWS if plan.view_index(v).size}
    views = [first]
    for k in range(1, draws + 1):
        rng = np.random.default_rng(seed + k)
        views.append(analyse(y0 + np.sqrt(s2) * rng.standard_normal(y0.size), fs_hz, track, plan))
    pairs = [(a, b) for i, a in enumerate(views) for b in views[i + 1:]]
    sq: dict = {}
    for a, b in pairs:
        for view, e in residuals(a, b, plan, q=q).view_error_db.items():
            sq[view] = sq.get(view, 0.0) + e * e / len(pairs)
    return {view: float(np.sqrt(e2)) for view, e2 in sq.items()}


def simulate_model(ref: Reference, model, *, extra_effects_list=((),), seed: int = 0, duration_s: float | None = None,
                   solver: dict | None = None, channels: tuple | None = None, models=None) -> list:
    """Simulate ``model`` (plus each entry of ``extra_effects_list``; or each of ``models``) at the reference
    operating point, one batch: the sensor channel of each, or with ``channels`` a dict of those channels."""
    from datagen.simulate import simulate

    m = ref.measurement
    dur = ref.model_duration_s() if duration_s is None else duration_s
    op = {"speed_rpm": ref.speed.speed_rpm, "torque_nm": m.torque_nm, "duration_s": dur, "fs_hz": m.fs_hz, "seed": seed,
          "solver": solver}
    cases = ([mod.case(m.pair, **op) for mod in models] if models is not None else
             [model.case(m.pair, extra_effects=tuple(extra), **op) for extra in extra_effects_list])
    wanted = (model.sensor,) if channels is None else tuple(channels)
    # only the channels read are made and decimated: in a time-stepped batch of a helical pair that was 13 channels
    # for one (a fit of a speed fluctuation on the far rig of experiments/bench_compare.py: 18.6 -> 12.5 s)
    signals = simulate(cases, channels=wanted, channels_field="model.sensor" if channels is None else "secondary channel")
    if channels is None:
        return [s.channels[model.sensor] for s in signals]
    return [{ch: s.channels[ch] for ch in wanted} for s in signals]


@dataclass(frozen=True, eq=False)
class Comparison:
    """Result of :func:`compare`: the reference, the model's evaluation and the ranked disagreements."""

    reference: Reference
    model: object
    evaluation: Evaluation
    disagreements: list
    model_signal: np.ndarray = field(repr=False, default=None)
    calibration: object = None      # compare.calibration.Calibration that made ``model``'s drive train, if any

    @property
    def error_db(self) -> dict:
        """The headline error: the excess over the noise error, per view and ``total`` (compare.error, step 7)."""
        r = self.evaluation.residuals
        return {**r.excess_view_db, "total": r.excess_total_db}

    @property
    def raw_error_db(self) -> dict:
        """``E``: the error before the noise correction, per view and ``total``."""
        r = self.evaluation.residuals
        return {**r.view_error_db, "total": r.total_db}

    @property
    def noise_error_db(self) -> dict:
        """``N``: the noise error, per view and ``total`` (zeros when no noise was drawn)."""
        r = self.evaluation.residuals
        return {**(r.noise_view_db or {}), "total": r.noise_total_db}


def compare(measurement: Measurement, model, *, seed: int = 0, reference: Reference | None = None,
            calibration=None) -> Comparison:
    """Compare ``model`` (a :class:`compare.model.ComparisonModel`) with ``measurement`` as it is (no nuisance
    calibration: :func:`compare.calibration.calibrated_compare` calibrates first; ``calibration`` only records
    the one that made ``model``)."""
    from compare.chaos import chaotic_realisations
    from compare.disagreements import rank_disagreements

    ref = reference if reference is not None else prepare_reference(measurement)
    y, others = chaotic_realisations(ref, model, seed=seed)
    ev = evaluate(ref, y, measurement.fs_hz, seed=seed, keep_curves=True, keep_signal=True, noise_draws=NOISE_DRAWS,
                  ensemble=others)
    dis = rank_disagreements(ref, ev)
    return Comparison(reference=ref, model=model, evaluation=ev, disagreements=dis, model_signal=ev.x,
                      calibration=calibration)
