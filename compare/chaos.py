"""Fitting an effect whose simulated record is chaotic: detect it, and give its parameters an interval that holds.

A nonlinear effect (backlash in its rattle regime: contact loss and back-flank impacts every few mesh cycles)
can make the drive train's response chaotic: a relative change of 1e-12 in a parameter changes the 2 s record
by O(1) (measured on spur-gds at 2 N m with 50 um of backlash, in the numpy and the compiled time loop alike).
Its error against a measurement is then one draw from a spread of errors: a single simulation per trial makes
the error surface ragged, its minimum a matter of luck, and the curvature-based 1-sigma of
:mod:`compare.fitting` meaningless (it treats that raggedness as signal). Worse, the amount can be unidentified
altogether: above the largest excursion of the dynamic transmission error the back flanks never meet and the
record no longer depends on the backlash at all (measured: 140 um, 200 um and 1 mm give bit-identical records
at that operating point, and their error equals the 50 um model's within its realisation scatter).

What this module does, for a nonlinear candidate (an effect with a mesh-force law) confirmed on the whole record
(:func:`compare.attribution._confirm_on_record`): :func:`profile_ladder` puts each fitted parameter in turn on a
ladder of values around the fit (offsets :data:`LADDER_DU` in the search coordinate, plus both bounds), each
simulated on the whole record :data:`REALISATIONS` times (the value scaled by ``1 + k 1e-12``,
:func:`twin_params`). A regular record repeats its error to ~1e-12 dB over such twins (the loop is deterministic
and smooth in its parameters); a chaotic one does not (:attr:`Profile.chaotic`). The fit becomes the value of
lowest mean error; the values whose mean error is within ``d s sqrt((c + c_best) / R)`` of it are consistent
with the measurement (``s`` the realisation scatter pooled over the chaotic values, ``c`` 1 for a chaotic value,
0 for a regular one; two regular values only when their errors are equal), and the interval runs between the
nearest rejected values on either side. Where every value up to a bound is consistent the interval is open on
that side: the measurement does not bound the parameter there.

``d`` is Gupta's subset-selection constant (:func:`selection_constant`), not a fixed 2: the lowest of ``k``
noisy means is biased low (the winner's curse), so the value of lowest *expected* error can lie further above
the lowest observed mean than two standard deviations of a difference: on a ladder of 27 values, up to 2.7 of
them in 5 % of the draws. With the fixed 2, a flat ladder's interval missed a value at its bound in 24 % of the
draws (``tests/test_compare_chaos.py`` measures it), and one realisation of the 50 um backlash example got
[26.6, 37.6] um (stop 46). ``d`` keeps the miss rate at the stated 5 % for every configuration of the
expected errors (Gupta 1965: the least favourable one is all equal), the scatter's own uncertainty (its
degrees of freedom) included (Gupta & Sobel 1962).

The ladder is dense (:data:`LADDER_STEP_U`, 0.025 in ``u``: a factor 1.19 for backlash) because the minimum can
be a narrow valley between rattle regimes. Measured on the backlash example (30 um, noise seed 4, the model's
default drive train, the attribution's solver, two realisations each): 26.6 and 31.6 um give 1.55-1.88 dB, 22.4
and 37.6 um 2.50-3.00 dB, every value from 106 um up (free flight) 2.18 dB. The former ladder (offsets 0.05, 0.1,
0.2, 0.3: factors 1.4, 2, 4, 8) around the window's fit of ~90 um asked 22 and 45 um, found 2.3-2.6 dB there and
reported free flight, [89 um, no bound], on noise seeds 3-5 alike; a valley narrower than a factor 2 falls
between its values from most centres. The cost is 27 values instead of 11 per parameter (54 whole-record
simulations at two realisations).

Nuisances
---------
The ladder's minimum is the value of lowest expected error *at the model's drive train*, and where the record is
chaotic it moves with the nuisances nobody measured (mesh and bearing damping, bearing stiffness): how often the
back flanks meet depends on the dynamic transmission error's excursion, which they set. Measured on the 50 um
backlash example (noise seed 3; the rig's nuisances 0.06 / 1.15e8 N/m / 0.06 against the model's 0.07 / 1e8 /
0.05, i.e. 14-20 % off): at the model's drive train the interval was [23.4, 39.2] um, which excludes the truth;
at the rig's own, [33.0 um, no bound]; with only the mesh damping at the rig's value, [19.7, 110.5] um; at the
calibrated nuisances (0.1 / 1.08e8 / 0.014), [23.4, 110.5] um. The realisation scatter cannot see this: it is a
bias, the same in every realisation.

So a chaotic fit reads a second drive train: the nuisances fitted with the candidate in at the ladder's fit
(:func:`compare.calibration.calibrate` from the model's values, ``time_stepped``: on the whole record with the
attribution's transient solver, its order view; ~46 simulations). On the 50 um example it lands at 0.055 /
1.12e8 / 0.054, beside the rig's, where the plain calibration (made without the candidate, on the periodic part)
lands at 0.1 / 1.08e8 / 0.014: a rattle bends a linear model's damping. Its ladder is profiled too (one batch,
58 more simulations) and both are judged together (:func:`joint_selection`: Gupta's rule over every mean of both
ladders, the realisation scatter pooled over them, :func:`pool_scatter`): where the second drive train fits
the measurement as well as the model's or better, the values consistent there join the interval (the hull,
:func:`hull_interval`); where every value there fits worse than the best at the model's, it is rejected and
widens nothing. The model's own interval is always kept: the fit is the model's drive train's (the model the
user compares and adds the effect to), and the interval holds it. Each drive train's ladder is reported
(``drivetrain_intervals``: best value, its error, interval, rejected). Tried first and dropped: two drive
trains at the plain calibration's values moved by its 1-sigma (an antithetic pair): both were rejected on the 30
and the 50 um examples (2.0-2.8 dB against 1.3 and 1.9 dB at the model's), and without the rejection their
hull was [1 um, no bound] at 50 um, which says nothing. The interval reads: the values that would be the fit at
the model's drive train or at the one the measurement prefers with the candidate in; a sensitivity bracket
over two drive trains, not a coverage statement over all of them.

References
----------
Gupta, S. S. (1965). On some multiple decision (selection and ranking) rules. Technometrics 7(2), 225-245
    (the subset that holds the best of k normal populations with probability P*: every population whose mean
    is within d sigma sqrt(2/n) of the best observed one).
Gupta, S. S. & Sobel, M. (1962). On selecting a subset which contains all populations better than a standard.
    Biometrika 49, 495-507 (d with the variance estimated: the Studentized version).
Dunnett, C. W. (1955). A multiple comparison procedure for comparing several treatments with a control. JASA
    50, 1096-1121 (Table 1a: the same one-sided points, correlation 1/2; the tests check d against it).
Strogatz, S. H. (2015). Nonlinear Dynamics and Chaos, 2nd ed., sec. 9.3 (sensitive dependence on initial
    conditions: nearby trajectories separate exponentially, so only statistics of a chaotic record are
    reproducible).
Kahraman, A. & Singh, R. (1990). Non-linear dynamics of a spur gear pair. J. Sound Vib. 142(1), 49-75
    (backlash: no-impact, single-sided and double-sided impact regimes; chaos in the latter two).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from compare.fitspace import FitSpace, fit_space

#: relative change of every float parameter between two realisations of the same fit
REALISATION_STEP = 1e-12
#: spacing of the ladder in the search coordinate (u in [0, 1]; for backlash 0.1 is a factor 2; module docstring)
LADDER_STEP_U = 0.025
#: how far the ladder reaches on each side of the fit (u); beyond it, only the bounds
LADDER_HALF_WIDTH_U = 0.3
#: ladder offsets in the search coordinate, both bounds added (:func:`ladder_points`)
LADDER_DU = tuple(round(k * LADDER_STEP_U, 6) for k in range(-round(LADDER_HALF_WIDTH_U / LADDER_STEP_U),
                                                           round(LADDER_HALF_WIDTH_U / LADDER_STEP_U) + 1))
#: realisations per ladder value
REALISATIONS = 2
#: two errors closer than this (dB) are the same record's
SAME_ERROR_DB = 1e-9
#: realisations of a chaotic model whose mean views a comparison reads (compare.comparison.evaluate, ensemble)
ENSEMBLE = 4
#: probability that the consistent values hold the one of lowest expected error (Gupta's P*; module docstring)
SELECTION_CONFIDENCE = 0.95


@functools.lru_cache(maxsize=256)
def selection_constant(k: int, dof: float | None = None, confidence: float = SELECTION_CONFIDENCE) -> float:
    """Gupta's subset-selection constant ``d`` for ``k`` means of equal variance: the subset of every mean within
    ``d sigma sqrt(2 / R)`` of the lowest holds the one of lowest expectation with probability ``confidence``
    whatever the expectations are. In the least favourable case (all equal) that probability is
    ``E_u[ integral phi(z) Phi(z + d sqrt(2) u)^(k-1) dz ]``, ``u = s / sigma`` (``sqrt(chi2_dof / dof)``;
    ``u = 1`` when ``dof`` is None: the variance known). Solved for ``d`` on fixed quadratures (normal: 801
    points over +/-8; ``u``: 200 quantiles of its distribution), so the value is deterministic. ``k <= 1``: 0."""
    from scipy import optimize, stats

    if k <= 1:
        return 0.0
    if not 0.5 < confidence < 1.0:
        raise ValueError(f"confidence = {confidence} is outside (0.5, 1)")
    z = np.linspace(-8.0, 8.0, 801)
    wz = stats.norm.pdf(z) * (z[1] - z[0])
    if dof is None or not math.isfinite(dof):
        u = np.ones(1)
    elif dof <= 0:
        raise ValueError(f"dof = {dof} must be positive (or None: the variance known)")
    else:
        u = np.sqrt(stats.chi2.ppf((np.arange(200) + 0.5) / 200, dof) / dof)

    def coverage(d):
        return float(np.mean(stats.norm.cdf(z[None, :] + d * math.sqrt(2.0) * u[:, None]) ** (k - 1) @ wz))

    hi = 20.0
    while coverage(hi) < confidence:    # few degrees of freedom (a heavy-tailed Studentized scatter): d is large
        if hi > 1e4:
            return math.inf             # the scatter is too poorly known to reject any value
        hi *= 4.0
    return float(optimize.brentq(lambda d: coverage(d) - confidence, 0.0, hi, xtol=1e-6))


def twin_params(params: dict, space: FitSpace, k: int = 1) -> dict:
    """``params`` with every fitted parameter of ``space`` scaled by ``1 + k REALISATION_STEP`` (by
    ``1 - k REALISATION_STEP`` where that would pass its upper bound); the other values kept."""
    out = dict(params)
    for p in space.params:
        v = float(params[p.name])
        up = v * (1.0 + k * REALISATION_STEP)
        out[p.name] = up if up <= p.hi else v * (1.0 - k * REALISATION_STEP)
    return out


@dataclass
class Profile:
    """One parameter's ladder: its values (SI), the errors (dB) per value and realisation, what they give."""

    parameter: str
    values: np.ndarray          # (n,), from the lower bound to the upper one (:func:`ladder_points`)
    errors_db: np.ndarray       # (n, R), raw total errors
    #: (scatter dB, degrees of freedom) pooled over several ladders of the same parameter (:func:`pool_scatter`);
    #: None: this ladder's own
    pooled: tuple | None = None

    @property
    def mean_db(self) -> np.ndarray:
        return self.errors_db.mean(axis=1)

    @property
    def chaotic(self) -> np.ndarray:
        """Per value: whether its realisations' errors differ (a regular record repeats them to ~1e-12 dB)."""
        e = self.errors_db
        return np.isfinite(e).all(axis=1) & (np.ptp(e, axis=1) > SAME_ERROR_DB)

    @property
    def scatter_db(self) -> float:
        """The realisation scatter pooled over the chaotic values (dB, 1-sigma of one draw; 0: none chaotic)."""
        if self.pooled is not None:
            return float(self.pooled[0])
        e = self.errors_db[self.chaotic]
        return float(np.sqrt(np.mean(np.var(e, axis=1, ddof=1)))) if len(e) and e.shape[1] > 1 else 0.0

    @property
    def best(self) -> int:
        return int(np.argmin(self.mean_db))

    @property
    def selection_d(self) -> float:
        """Gupta's constant for this ladder (:func:`selection_constant`): ``k`` its values of finite error, the
        scatter's degrees of freedom ``(R - 1)`` per chaotic value (of every pooled ladder, :attr:`pooled`); 0
        when none of this ladder's values is chaotic (no threshold is needed); infinite when the scatter is too
        poorly known to reject any value."""
        n_chaotic = int(self.chaotic.sum())
        r = self.errors_db.shape[1]
        if n_chaotic == 0 or r < 2:
            return 0.0
        k = int(np.isfinite(self.mean_db).sum())
        return selection_constant(k, dof=self.pooled[1] if self.pooled is not None else n_chaotic * (r - 1))

    def consistent(self) -> np.ndarray:
        """Per value: whether its mean error is within ``d s sqrt((c + c_best) / R)`` of the lowest mean (``d``
        :attr:`selection_d`; ``c`` 1 for a chaotic value, 0 for a regular one: two regular values are
        consistent only with equal errors, the plateau where the parameter no longer enters the record)."""
        m, c = self.mean_db, self.chaotic.astype(float)
        r = self.errors_db.shape[1]
        b = self.best
        w = c + c[b]
        margin = np.zeros_like(m)
        if w.any():     # regular against regular: equality only (d may be infinite)
            margin[w > 0] = self.selection_d * self.scatter_db * np.sqrt(w[w > 0] / r)
        return m <= m[b] + margin + SAME_ERROR_DB

    def interval(self, consistent: np.ndarray | None = None) -> tuple[float | None, float | None] | None:
        """The nearest ladder values below and above the consistent ones (:meth:`consistent`, or the mask
        ``consistent`` of :func:`joint_selection`) that the measurement rejects: the parameter lies between them.
        ``None`` on a side where every value up to the bound is consistent (the measurement does not bound it
        there); None altogether when no value is consistent (a drive train the measurement rejects)."""
        ok = np.flatnonzero(self.consistent() if consistent is None else consistent)
        if not len(ok):
            return None
        lo, hi = int(ok.min()), int(ok.max())
        lo_v = float(self.values[lo - 1]) if lo > 0 else None
        hi_v = float(self.values[hi + 1]) if hi < len(self.values) - 1 else None
        return lo_v, hi_v

    def sigma(self) -> float:
        """A 1-sigma for the report: a quarter of the interval's width; infinite when it is open."""
        return interval_sigma(self.interval())


def pool_scatter(profiles) -> list:
    """``profiles`` (ladders of one parameter at several drive trains, the same realisations each) with their
    realisation scatter pooled (:attr:`Profile.pooled`): the variance over every chaotic value of every ladder,
    its degrees of freedom ``(R - 1)`` per such value. The chaos' scatter is the operating point's, and one
    drive train's ladder may have only a few chaotic values (measured: 3 of 27 on the 50 um backlash example at
    a bearing damping of 0.2), whose own scatter would be too poorly known to reject anything."""
    from dataclasses import replace

    rows = [p.errors_db[p.chaotic] for p in profiles]
    rows = [e for e in rows if len(e) and e.shape[1] > 1]
    if not rows:
        return list(profiles)
    e = np.concatenate(rows)
    pooled = (float(np.sqrt(np.mean(np.var(e, axis=1, ddof=1)))), int(len(e) * (e.shape[1] - 1)))
    return [replace(p, pooled=pooled) for p in profiles]


def joint_selection(profiles) -> list[np.ndarray]:
    """Gupta's rule over the ladders of one parameter at several drive trains at once (module docstring,
    "Nuisances"): per ladder, whether each value's mean error is within ``d s sqrt((c + c_best) / R)`` of the
    lowest mean over *all* ladders, ``d`` for every finite mean of all of them, ``s`` the pooled scatter
    (:func:`pool_scatter`; the ladders' own when not pooled: the first's). A drive train whose every value fits
    worse than the best value at another gets no consistent value: the measurement rejects it."""
    r = profiles[0].errors_db.shape[1]
    means = np.concatenate([p.mean_db for p in profiles])
    chaotic = np.concatenate([p.chaotic for p in profiles]).astype(float)
    b = int(np.argmin(means))
    n_chaotic = int(chaotic.sum())
    s = profiles[0].scatter_db
    if n_chaotic and r >= 2:
        dof = profiles[0].pooled[1] if profiles[0].pooled is not None else n_chaotic * (r - 1)
        d = selection_constant(int(np.isfinite(means).sum()), dof=dof)
    else:
        d = 0.0
    out = []
    for p in profiles:
        w = p.chaotic.astype(float) + chaotic[b]
        margin = np.zeros(len(p.values))
        if w.any():
            margin[w > 0] = d * s * np.sqrt(w[w > 0] / r)
        out.append(p.mean_db <= means[b] + margin + SAME_ERROR_DB)
    return out


def hull_interval(intervals) -> tuple[float | None, float | None]:
    """The smallest interval holding every ``(low, high)`` of ``intervals`` (None: open on that side, and open
    in the hull when open in any; an interval that is None itself, a rejected drive train, is left out)."""
    intervals = [iv for iv in intervals if iv is not None]
    los = [lo for lo, _ in intervals]
    his = [hi for _, hi in intervals]
    return (None if any(v is None for v in los) else float(min(los)),
            None if any(v is None for v in his) else float(max(his)))


def interval_sigma(interval) -> float:
    """A 1-sigma for the report: a quarter of the interval's width; infinite when it is open."""
    if interval is None:
        return math.inf
    lo, hi = interval
    return math.inf if lo is None or hi is None else (hi - lo) / 4.0


def may_be_chaotic(effect_cls) -> bool:
    """Whether an effect's record may be chaotic and has parameters to profile: a mesh-force law (nonlinear)
    and at least one fitted parameter."""
    return effect_cls().is_nonlinear and fit_space(effect_cls).n > 0


def ladder_points(space: FitSpace, params: dict) -> list[tuple[str, np.ndarray]]:
    """Per fitted parameter of ``space``: (name, ladder values around ``params``, both bounds included)."""
    out = []
    for p in space.params:
        u0 = float(p.to_u(params[p.name]))
        u = np.unique(np.clip(np.r_[0.0, u0 + np.asarray(LADDER_DU), 1.0], 0.0, 1.0))
        v = np.unique(p.from_u(u))
        out.append((p.name, v))
    return out


def profile_ladder(space: FitSpace, params: dict, simulate_errors) -> list[Profile]:
    """:class:`Profile` of every fitted parameter of ``space`` around ``params`` (the others held there).

    ``simulate_errors(list_of_param_dicts) -> list of raw total errors (dB)`` simulates and evaluates one batch
    on the whole record (the caller's solver, seed and baseline)."""
    return profile_ladders(space, params, simulate_errors, 1)[0]


def profile_ladders(space: FitSpace, params: dict, simulate_errors, n_models: int) -> list[list[Profile]]:
    """:func:`profile_ladder` for ``n_models`` models at once (the same ladders; one batch):
    ``simulate_errors(trials)`` returns the errors of every model at every trial, model by model (``n_models *
    len(trials)`` values). Returns one list of profiles per model."""
    plans = ladder_points(space, params)
    trials = [twin_params({**params, name: float(v)}, space, k) for name, vs in plans for v in vs
              for k in range(REALISATIONS)]
    errors = np.asarray(simulate_errors(trials), float).reshape(n_models, len(trials))
    out = []
    for e in errors:
        ps, i = [], 0
        for name, vs in plans:
            n = len(vs) * REALISATIONS
            ps.append(Profile(name, vs, e[i:i + n].reshape(len(vs), REALISATIONS)))
            i += n
        out.append(ps)
    return out


def twin_effect(effect, k: int):
    """``effect`` with its fitted parameters scaled by ``1 + k 1e-12`` (:func:`twin_params`)."""
    from dataclasses import replace

    space = fit_space(type(effect))
    return replace(effect, **twin_params(effect.params(), space, k)) if space.n else effect


def chaotic_realisations(ref, model, *, seed: int = 0, extra_effects: tuple = (), solver: dict | None = None,
                         n: int = ENSEMBLE) -> tuple:
    """Simulate ``model`` (plus ``extra_effects``) at the reference; when it holds a nonlinear effect with fitted
    parameters, ``n`` realisations of it (:func:`twin_effect`) in one batch. Returns ``(record, others)``:
    ``others`` the further realisations when they differ from the first (a chaotic record: compare its mean
    views, :func:`compare.comparison.evaluate`), else empty."""
    from compare.comparison import simulate_model

    effects = {e.name: e for e in model.effects}
    effects.update({e.name: e for e in extra_effects})
    nonlinear = [e for e in effects.values() if may_be_chaotic(type(e))]
    extras = [tuple(extra_effects)]
    if nonlinear:
        names = {e.name for e in nonlinear}
        kept = tuple(e for e in extra_effects if e.name not in names)
        extras += [kept + tuple(twin_effect(e, k) for e in nonlinear) for k in range(1, n)]
    ys = simulate_model(ref, model, extra_effects_list=extras, seed=seed, solver=solver,
                        duration_s=ref.model_duration_s())
    y, others = ys[0], ys[1:]
    if all(np.array_equal(y, o) for o in others):
        others = []
    return y, others


def drivetrains_message(effect: str, drivetrain_intervals: list) -> str:
    """A chaotic fit's ladders per drive train as one sentence for the CLI and the report (module docstring,
    "Nuisances"): each drive train's nuisances, best value and interval; empty when there is none."""
    if not drivetrain_intervals:
        return ""
    parts = []
    for i, d in enumerate(drivetrain_intervals):
        dt = ", ".join(f"{k} {v:.3g}" for k, v in d["drivetrain"].items())
        fits = "; ".join(f"{k} {d['best'][k]:.3g} ({d['best_error_db'][k]:.2f} dB)"
                         + (describe_interval(iv).replace(" (chaotic record)", "") if iv is not None else "")
                         + (", rejected (fits worse than the best at the other drive train)"
                            if d.get("rejected", {}).get(k) else "")
                         for k, iv in d["interval"].items())
        parts.append(f"{'the model' if i == 0 else 'fitted with it'} ({dt}): {fits}")
    return (f"{effect}'s record is chaotic, so its interval also holds the values the measurement allows at the "
            "drive train fitted with it in: " + " | ".join(parts))


def describe_interval(interval) -> str:
    """A fitted parameter's interval for the CLI and the report: " in [lo, hi] (chaotic record)", an open side
    (None) as "no bound"."""
    lo, hi = interval
    if lo is None and hi is None:
        return " (not bounded by the measurement: chaotic record)"
    side = [f"{v:.3g}" if v is not None else "no bound" for v in (lo, hi)]
    return f" in [{side[0]}, {side[1]}] (chaotic record)"

