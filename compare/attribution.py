"""Which effect is missing: fit every registered effect absent from the model, rank, flag the unexplained.

For every registered effect that is not in the model (and is not part of the measurement chain,
:data:`compare.fitspace.CHAIN_EFFECTS`), its few parameters are fitted to the measurement
(:mod:`compare.fitting`: batched search rounds, 1-sigma from the curvature of the error), the effects are ranked
by how much they lower the error, and the best one that passes the claim rule is claimed
(:mod:`compare.candidates`). The periodic effects are fitted in this process, the time-stepped ones (on a
window, then confirmed on the whole record, :func:`_confirm_on_record`) in worker processes meanwhile, one per
:func:`compare.fitting.transient_groups` group. When the model itself needs time stepping (an earlier ``--add``
put a fluctuation, backlash or Hertz contact in it), every candidate is fitted the time-stepped way.

Nuisance calibration: when the model's drive-train nuisances were calibrated
first (:mod:`compare.calibration`; ``calibration`` given), the model handed in
is the calibrated one, so every candidate's error reduction is measured
against the calibrated baseline. The ``refine_top`` periodic candidates with
the lowest error then get the nuisances and their own parameters refitted
jointly (:func:`compare.calibration.calibrate` with ``free_effect``: short
coordinate scans around the calibrated values and the fitted parameters), and
keep the lower of the two errors (and the parameters that gave it), measured against the baseline given the same
refit, on the periodic path they were searched on (:func:`compare.nuisance_refit.refine_nuisances`): an effect whose signature resembles a nuisance
(Hertz stiffness moves the mesh resonance as bearing stiffness does) is not
penalised because the calibration already bent the nuisances towards it. The
time-stepped candidates (fitted in the second process on a shorter window)
are fitted at the calibrated nuisances without refit.
"""
from __future__ import annotations

import math
import os
import pickle
import time

import numpy as np

from compare.candidates import (Attribution, AttributionSettings, CandidateResult, choose_claim, passes_claim_rule,
                                rivals_of, unexplained_of)
from compare.calibration import drivetrain_values
from compare.chaos import (chaotic_realisations, hull_interval, interval_sigma, joint_selection, may_be_chaotic,
                           pool_scatter, profile_ladder, profile_ladders)
from compare.comparison import NOISE_DRAWS, Reference, evaluate, simulate_model
from compare.error import effective_count
from compare.fitspace import CHAIN_EFFECTS, bounds_hit, fit_space
from compare.fitting import (explained_keys, frequency_ladder, prepared_case, record_period_s, search_group,
                             transient_groups, window_label, window_s)
from compare.nuisance_refit import refine_nuisances, refit_args, refit_payload
from compare.path_regime import check_asymptotes
from compare.response import mark_shaft_locks
from gearpit.errors import GearpitError

__all__ = ["attribute", "Attribution", "AttributionSettings", "CandidateResult", "choose_claim", "rivals_of",
           "transient_groups"]


def _search_and_confirm(names_: list, ref: Reference, model, settings, disagreements, n_eff: float,
                        seed_residual: np.ndarray):
    """Fit the time-stepped effects ``names_`` on a window (:func:`compare.fitting.search_group`), then measure those that could
    be claimed on the whole record (:func:`compare.attribution._confirm_on_record`): in the group's own process, since a batch
    waits for its slowest case (:func:`transient_groups`). Returns (results, n_simulations, seconds)."""
    t0 = time.perf_counter()
    r, n, _ = search_group(names_, ref, model, settings, True, disagreements, n_eff, seed_residual)
    n += _confirm_on_record(r, ref, model, settings, list(disagreements))
    return r, n, time.perf_counter() - t0


def _search_and_confirm_payload(names_: list, payload: bytes):
    """:func:`_search_and_confirm` in a worker process, its other arguments pickled by the caller."""
    args, tail = pickle.loads(payload)
    return _search_and_confirm(names_, *args, *tail)


def attribute(ref: Reference, model, baseline_residual: np.ndarray, *, candidates=None,
              settings: AttributionSettings | None = None, disagreements=(), parallel: bool = True,
              calibration=None, model_error_db: float | None = None) -> Attribution:
    """Fit, rank and flag (module docstring).

    Parameters
    ----------
    ref : Reference
        The measurement side (:func:`compare.comparison.prepare_reference`).
    model : ComparisonModel
        The current model; its effects are not candidates.
    baseline_residual : ndarray
        The current model's residuals on ``ref`` (from :func:`compare.comparison.compare`).
    candidates : sequence of str, optional
        Restrict to these registered effect names (default: every registered effect not in the model).
    disagreements : sequence of Disagreement
        The current model's ranked disagreements (for the explained / unexplained bookkeeping).
    parallel : bool
        Fit the time-stepped effects in worker processes (one per :func:`transient_groups` group) while this
        one fits the others.
    calibration : compare.calibration.Calibration, optional
        The nuisance calibration that made ``model`` (its drive train holds the calibrated values); the
        leading periodic candidates then get their nuisances refitted with the effect in (module docstring).
    model_error_db : float, optional
        The excess error of the comparison that ``baseline_residual`` comes from: a time-stepped candidate is
        claimed only if it lowers this one by ``claim_reduction`` too (:mod:`compare.candidates`).
    """
    from datagen.effects import get, names

    settings = settings or AttributionSettings()
    t0 = time.perf_counter()
    pool = [n for n in (candidates if candidates is not None else names())
            if n not in model.effect_names and n not in CHAIN_EFFECTS]
    # a model that needs time stepping itself (it holds a fluctuation, backlash, Hertz contact: added by an
    # earlier --add) has no periodic steady state, so every candidate is fitted on the time-stepped path with it
    model_transient = any(e.is_nonlinear or e.is_nonstationary for e in model.effects)
    transient = [n for n in pool if model_transient or fit_space(get(n)).transient]
    transient += long_period_candidates([n for n in pool if n not in transient], ref, model)
    periodic = [n for n in pool if n not in transient]
    n_eff = effective_count(ref.plan, q=ref.reliability)
    results, n_sims, seconds = [], 0, {}
    args = (ref, model, settings)
    tail = (list(disagreements), n_eff, np.asarray(baseline_residual))
    refit = bool(periodic) and calibration is not None and settings.refine_top > 0
    if parallel and pool:
        r, n = _fit_in_workers(transient, periodic, args, tail, calibration if refit else None, seconds)
        results += r
        n_sims += n
    else:
        if transient:
            r, n, seconds["time_stepped"] = _search_and_confirm(transient, *args, *tail)
            results += r
            n_sims += n
        if periodic:
            r, n, seconds["periodic"] = search_group(periodic, *args, False, *tail)
            if refit:
                t1 = time.perf_counter()
                n += refine_nuisances(r, ref, model, calibration, settings, list(disagreements))
                seconds["nuisance_refit"] = time.perf_counter() - t1
            results += r
            n_sims += n
    if calibration is not None:     # the drive train each candidate was fitted at (refitted ones keep theirs)
        for c in results:
            c.nuisance = c.nuisance or dict(calibration.values)
    if model_error_db is not None:
        for c in results:
            if c.effect in transient:
                c.model_error_db = float(model_error_db)
    for c in results:
        if c.params:
            c.at_bound = bounds_hit(fit_space(get(c.effect)), c.params)
    mark_shaft_locks(results, ref.measurement.pair, speed_rpm=ref.speed.speed_rpm,
                     resolution_hz=ref.fs_hz / ref.x.size)
    for c in results:               # a housing mode beside the mesh harmonics: is it located? (3 comparisons)
        if c.status == "fitted" and c.reduction > 0:
            check_asymptotes(c, ref, model, settings.seed)
    results.sort(key=lambda c: -c.reduction)
    claimed = choose_claim(results, settings)
    return Attribution(candidates=results, unexplained=unexplained_of(results, disagreements, settings), elapsed_s=time.perf_counter() - t0,
                       n_simulations=n_sims, group_seconds=seconds, rivals=rivals_of(claimed, results, settings))


def _search_payload(names_: list, payload: bytes):
    """:func:`compare.fitting.search_group` of the periodic effects ``names_`` in a worker process."""
    args, tail = pickle.loads(payload)
    return search_group(names_, *args, False, *tail)


def _fit_in_workers(transient: list, periodic: list, args: tuple, tail: tuple, calibration, seconds: dict):
    """Fit every candidate in a pool of worker processes, one per core (this process waits): each
    :func:`transient_groups` group is one job (searched on a window, confirmed on the record), each periodic
    effect another, then the nuisance refit of the leading periodic ones (``calibration`` given,
    :func:`compare.nuisance_refit.refine_nuisances`: the baseline's refit is queued before the periodic jobs, the candidates' after
    them, since the ranking needs them all). Returns (results, n_simulations); ``seconds`` gets each job's wall time.

    Why one job per periodic effect and none in this process: the longest jobs go first and the pool hands out
    the rest as cores free up, so neither core idles while the other finishes. Measured on the escalated default
    path of ``experiments/bench_compare.py`` (2 cores, idle): with the periodic effects searched together in
    this process and the refit after them, the calibrated pass took 29.4 s of which the second core idled about a
    third. Each periodic effect is now searched with its own baseline in its batch; since the solver gives every
    case of a batch the same steps per mesh cycle (:func:`datagen.dynamics._merge_step_counts`), that baseline's
    error can differ from the one of a joint batch, by 5e-5 dB on that rig (reductions by 6e-4).
    """
    import concurrent.futures as cf
    import multiprocessing as mp

    ref, model, settings = args
    disagreements = tail[0]
    executor = cf.ProcessPoolExecutor(max_workers=max(2, os.cpu_count() or 2), mp_context=mp.get_context("fork"))
    try:
        # the arguments pickled here, in this thread: the executor pickles a submitted call in a feeder thread,
        # and a search fills cached properties of objects the arguments hold (the gear pair's geometry), so
        # pickling them there raced with this thread ("dictionary changed size during iteration", seen on the
        # foreign rig's loop, when the periodic fits ran in this process)
        payload = pickle.dumps((args, tail))
        stepped = [executor.submit(_search_and_confirm_payload, g, payload) for g in transient_groups(transient)]
        null_refit = (executor.submit(refit_payload, pickle.dumps(refit_args(ref, model, calibration, settings)))
                      if calibration is not None else None)
        jobs = [(n, executor.submit(_search_payload, [n], payload)) for n in periodic]
        results, n_sims = [], 0
        for name, f in jobs:
            r, n, seconds[f"periodic:{name}"] = f.result()
            results += r
            n_sims += n
        if calibration is not None:
            t1 = time.perf_counter()
            n_sims += refine_nuisances(results, ref, model, calibration, settings, list(disagreements),
                                       executor=executor, null_refit=null_refit)
            seconds["nuisance_refit"] = time.perf_counter() - t1
        for i, f in enumerate(stepped):
            r, n, seconds[f"time_stepped_{i + 1}"] = f.result()
            results += r
            n_sims += n
    finally:
        executor.shutdown(cancel_futures=True)
    return results, n_sims


def long_period_candidates(names_: list, ref: Reference, model) -> list:
    """The periodic candidates ``names_`` whose steady state with ``model`` repeats only after more than the
    measurement's duration: they are fitted like the time-stepped ones (a window, then the whole record).

    Why: with a once-per-revolution error of one gear in the model (an eccentricity added by an earlier
    ``--add``), a candidate that puts one on the other gear makes the record periodic only over the hunting
    period (spur-gds 29 / 100 teeth: 100 pinion revolutions, 6 s at 1000 rpm), with every mesh cycle distinct.
    The periodic path then shoots over 2900 cycles to give 2 s of record: measured 18 s a simulation on a busy
    2-core machine, ~25 per round, four rounds, against a time-stepped batch on the 0.5 s window whose cost
    hardly grows with the batch (its per-step overhead is shared). A hidden pitch error, the wheel eccentricity in
    the model, 2 s, the two candidates: 184 s on the periodic path, 95 s this way (one core each, side by side);
    pitch error grade 8.0 and 7.8 (true 8). A window case's record holds only the cycles it rolls through, not the
    hunting period (:func:`datagen.mesh_excitation.mesh_record`, ``cycles_needed``: the far helical rig's wheel
    eccentricity beside a pinion pitch error, 1020 cycles, 575.6 -> 225.5 s at stop 59). A model whose own record
    repeats every mesh cycle cannot make such a pair (a candidate alone repeats within a wheel revolution), so
    nothing is checked then (and nothing costs)."""
    from datagen.effects import get

    if prepared_case(ref, model).record.period_cycles <= 1:
        return []
    record_s = len(ref.x) / ref.fs_hz
    out = []
    for n in names_:
        try:
            if record_period_s(ref, model, get(n)()) > record_s:
                out.append(n)
        except GearpitError:
            continue
    return out


def _confirm_on_record(results: list, ref: Reference, model, settings: AttributionSettings,
                       disagreements) -> int:
    """Measure every candidate fitted on a window (time-stepped effects) that could be claimed on the whole
    record, so that all candidates are ranked and claimed on the same record.

    The window's reduction is measured against a baseline on the same window; it need not hold over the whole
    record (measured, ``experiments/generalisation_check.py --calibrate``: a speed fluctuation fitted on 0.5 s of
    a calibrated helical rig with a hidden Hertz stiffness claimed 39 % there and *raised* the whole record's
    error by 43 %), and two window fits are not comparable with fits made on the whole record. Candidates
    with status "fitted" whose window reduction reaches ``claim_reduction`` are simulated on the whole record in
    one batch with the baseline (time-stepped alike, the baseline with its noise draws, each candidate against
    the baseline's noise error), each with its best window fit and its ``runners_up`` (the next
    :data:`RUNNERS_UP` distinct window trials: the error surface of a short window is ragged, measured for a
    50 um backlash: 2.33-2.86 dB among fits from 60 to 130 um, and its minimum need not be the whole record's)
    and the best fit with each frequency moved by up to the window's resolution in steps of the record's
    (:func:`compare.fitting.frequency_ladder`); the one with the lowest whole-record error is kept, its errors
    become the candidate's (the 1-sigma stays the window's), and one that then fails the claim rule gets the
    status "not confirmed on the whole record". A nonlinear candidate (a mesh-force law: its record may be
    chaotic) is then profiled on whole-record ladders
    (:func:`_profile_nonlinear`, :mod:`compare.chaos`). Such a candidate is checked from
    ``chaotic_confirm_fraction`` of ``claim_reduction`` on its window: its window fit can sit on the free-flight
    plateau beside a narrow valley between rattle regimes (:mod:`compare.chaos`), which only the ladder finds
    (measured: the 30 um backlash example on noise seed 5 was fitted at 178 um on its window, 29.4 %, and never
    reached the record). Returns the number of simulations run (0 when no candidate needed it).
    """
    from datagen.effects import EffectSpec, get

    whole = window_label(ref)
    todo = [c for c in results if c.window != whole and c.status == "fitted"
            and c.reduction >= settings.claim_reduction * (settings.chaotic_confirm_fraction
                                                           if may_be_chaotic(get(c.effect)) else 1.0)]
    if not todo:
        return 0
    solver = settings.search_solver(transient=True)
    record_s, win_s = len(ref.x) / ref.fs_hz, window_s(ref, settings)
    options = [[c.params] + list(c.runners_up)
               + frequency_ladder(fit_space(get(c.effect)), c.params, record_s, win_s) for c in todo]
    extra = [()] + [(EffectSpec.from_dict({"name": c.effect, **p}).build(),) for c, ps in zip(todo, options) for p in ps]
    try:
        ys = simulate_model(ref, model, extra_effects_list=extra, seed=settings.seed,
                            duration_s=ref.model_duration_s(), solver=solver)
    except (GearpitError, FloatingPointError, MemoryError, np.linalg.LinAlgError):
        for c in todo:
            c.status = "not confirmed on the whole record (simulation failed)"
        return len(extra)
    base = evaluate(ref, ys[0], ref.fs_hz, seed=settings.seed, noise_draws=NOISE_DRAWS).residuals
    k, n_sims = 1, len(extra)
    for c, ps in zip(todo, options):
        evs = [evaluate(ref, y, ref.fs_hz, seed=settings.seed).residuals for y in ys[k:k + len(ps)]]
        k += len(ps)
        i = int(np.argmin([ev.total_db for ev in evs]))     # the raw error, what the fits minimise
        ev = evs[i]
        c.params = dict(ps[i])
        if may_be_chaotic(get(c.effect)):
            ev, n = _profile_nonlinear(c, ev, ref, model, settings, solver)
            n_sims += n
        c.noise_view_db = dict(base.noise_view_db or {})
        c.baseline_view_error_db = base.excess_view_db
        c.baseline_error_db = base.excess_total_db
        c.raw_baseline_error_db = base.total_db
        c.set_raw(dict(ev.view_error_db), ev.total_db)
        c.window = whole
        c.explains = explained_keys(ref, ev.residual_db, disagreements)
        if not passes_claim_rule(c, settings):
            c.status = "not confirmed on the whole record"
    return n_sims


def _profile_nonlinear(c: CandidateResult, ev, ref: Reference, model, settings: AttributionSettings, solver: dict):
    """Profile candidate ``c``, a nonlinear effect fitted on the whole record (residuals ``ev``), on the ladders of
    :func:`compare.chaos.profile_ladder` (whole record, several realisations per value). When the record is
    chaotic at any ladder value, the fit is the ladder's: the values of lowest mean error at the model's drive
    train; ``interval`` the hull of the interval the realisation scatter allows there and, unless the
    measurement rejects it, the one at the drive train fitted with the candidate in (:func:`_drivetrain_draws`;
    the ladder's minimum moves with the nuisances: :mod:`compare.chaos`, "Nuisances"), each in
    ``drivetrain_intervals``; ``sigma`` a quarter of the hull, ``realisation_scatter_db`` the pooled scatter. When it is regular everywhere, the fit stays, and a
    parameter whose ladder shows a plateau reaching a bound (the record no longer depends on it: backlash the
    back flanks never reach) gets that open interval and an infinite sigma.
    Returns the residuals of the kept fit (for a ladder fit the mean views of its realisations, as
    :func:`compare.comparison.compare` reads the model with the effect added) and the number of simulations run."""
    from datagen.effects import EffectSpec, get

    def errors_at(models):
        def errors(trials):
            mods = [mod.with_effect(EffectSpec.from_dict({"name": c.effect, **p}).build())
                    for mod in models for p in trials]
            ys = simulate_model(ref, model, models=mods, seed=settings.seed, duration_s=ref.model_duration_s(),
                                solver=solver)
            return [evaluate(ref, y, ref.fs_hz, seed=settings.seed).residuals.total_db
                    if y is not None and np.all(np.isfinite(y)) else math.inf for y in ys]
        return errors

    space = fit_space(get(c.effect))
    centre = dict(c.params)
    profiles = profile_ladder(space, centre, errors_at([model]))
    n = sum(p.errors_db.size for p in profiles)
    if not any(p.chaotic.any() for p in profiles):
        for p in profiles:
            iv = p.interval()
            if None in iv:
                c.interval[p.parameter], c.sigma[p.parameter] = iv, math.inf
        return ev, n
    c.params.update({p.parameter: float(p.values[p.best]) for p in profiles})
    draws, n_scan = _drivetrain_draws(c, ref, model, settings, solver)
    n += n_scan
    # every drive train's ladders in one batch (the ladder values are the same: the same centre)
    per_draw = (profile_ladders(space, centre, errors_at([model.with_drivetrain(d) for d in draws]), len(draws))
                if draws else [])
    n += sum(p.errors_db.size for ps in per_draw for p in ps)
    # one realisation scatter per parameter, pooled over the drive trains (compare.chaos.pool_scatter)
    for j in range(len(profiles)):
        pooled = pool_scatter([profiles[j]] + [ps[j] for ps in per_draw])
        profiles[j] = pooled[0]
        for ps, q in zip(per_draw, pooled[1:]):
            ps[j] = q
    ladders = [profiles] + per_draw
    # per parameter, the values consistent at each drive train against the best over all of them; the model's own
    # interval is kept whatever the other drive train says (it holds the fit, which is the model's)
    masks = [joint_selection([ps[j] for ps in ladders]) for j in range(len(profiles))]
    intervals = [[ps[j].interval(masks[j][i]) for j in range(len(profiles))] for i, ps in enumerate(ladders)]
    rejected = [[iv is None for iv in ivs] for ivs in intervals]
    intervals[0] = [p.interval() for p in profiles]
    c.drivetrain_intervals = [{"drivetrain": dict(dt), "best": {p.parameter: float(p.values[p.best]) for p in ps},
                               "best_error_db": {p.parameter: float(p.mean_db[p.best]) for p in ps},
                               "interval": {p.parameter: iv for p, iv in zip(ps, ivs)},
                               "rejected": {p.parameter: r for p, r in zip(ps, rej)},
                               "realisation_scatter_db": max(p.scatter_db for p in ps)}
                              for dt, ps, ivs, rej in zip([drivetrain_values(model)] + draws, ladders, intervals,
                                                          rejected)]
    for j, p in enumerate(profiles):
        c.params[p.parameter] = float(p.values[p.best])
        c.interval[p.parameter] = hull_interval([ivs[j] for ivs in intervals])
        c.sigma[p.parameter] = interval_sigma(c.interval[p.parameter])
    c.realisation_scatter_db = max(p.scatter_db for ps in [profiles] + per_draw for p in ps)
    # the chosen fit as a comparison reads a chaotic model: the mean views of its realisations
    y, others = chaotic_realisations(ref, model, seed=settings.seed, solver=solver,
                                     extra_effects=(c.build_effect(),))
    return evaluate(ref, y, ref.fs_hz, seed=settings.seed, ensemble=others).residuals, n + 1 + len(others)


def _drivetrain_draws(c: CandidateResult, ref: Reference, model, settings: AttributionSettings,
                      solver: dict) -> tuple[list, int]:
    """The drive train a chaotic fit's interval also reads (:mod:`compare.chaos`, "Nuisances"): the nuisances
    fitted with candidate ``c`` in at its ladder fit (:func:`compare.calibration.calibrate` from the model's
    values, time-stepped on the whole record with the attribution's transient ``solver``, its order view).
    Returns ``([drive train], simulations run)``; none when the calibration fails or stays at the model's."""
    from compare.calibration import CalibrationSettings, calibrate

    try:
        cal = calibrate(ref, model, extra_effects=(c.build_effect(),), settings=CalibrationSettings(seed=settings.seed),
                        solver=solver, time_stepped=True)
    except (GearpitError, FloatingPointError, MemoryError, np.linalg.LinAlgError):
        return [], 0
    same = all(math.isclose(v, cal.start[k], rel_tol=1e-9) for k, v in cal.values.items())
    return ([] if same else [dict(cal.values)]), cal.n_simulations
