"""The nuisance refit of the leading candidates of a calibrated attribution (:mod:`compare.attribution`).

When the drive train was calibrated first, the ``refine_top`` periodic candidates with the lowest error get the
nuisances and their own parameters refitted jointly (short coordinate scans of
:func:`compare.calibration.calibrate` with ``free_effect``), measured against the baseline given the same refit
(:func:`refine_nuisances` says why both rules are needed). One refit is one deterministic function of its
arguments (:func:`refit_args`), so it runs alike in this process or in a worker (:func:`refit_payload`).
"""
from __future__ import annotations

import math
import pickle

from compare.candidates import AttributionSettings
from compare.comparison import Reference
from compare.fitting import explained_keys

__all__ = ["refine_nuisances", "refit_args", "refit_payload", "refit_settings"]


def refit_settings(calibration, settings: AttributionSettings):
    """The :class:`compare.calibration.CalibrationSettings` of the nuisance refit (:func:`refine_nuisances`)."""
    from compare.calibration import CalibrationSettings

    return CalibrationSettings(parameters=tuple(calibration.values), widths_u=tuple(settings.refine_widths_u),
                               points_per_side=tuple(settings.refine_points), seed=settings.seed)


def refit_args(ref: Reference, model, calibration, settings: AttributionSettings, start: dict | None = None,
                effect=None) -> tuple:
    """The arguments of one refit of :func:`_refine_nuisances` (:func:`_refit`): from ``start`` (default: the
    calibration's values), with ``effect`` (an :class:`datagen.effects.Effect`) in and free, or the baseline."""
    return (ref, model, refit_settings(calibration, settings), settings.search_solver(transient=False),
            dict(start if start is not None else calibration.values), effect)


def _refit(ref, model, cs, solver, start, effect):
    """One nuisance refit (:func:`refit_args`)."""
    from compare.calibration import calibrate

    extra = () if effect is None else (effect,)
    return calibrate(ref, model, extra_effects=extra, settings=cs, free_effect=effect is not None, solver=solver,
                     start=start)


def refit_payload(payload: bytes):
    """:func:`_refit` in a worker process, its arguments pickled by the caller (:func:`compare.attribution._fit_in_workers` says why)."""
    return _refit(*pickle.loads(payload))


def refine_nuisances(results: list, ref: Reference, model, calibration, settings: AttributionSettings,
                      disagreements, *, executor=None, null_refit=None) -> int:
    """Refit the calibrated nuisances with each of the ``refine_top`` best periodic candidates in (held at its
    fitted parameters); a candidate keeps the better of the two errors. Returns the simulations run.

    Two rules keep the refit fair (:mod:`compare.attribution`):

    - Every refit runs on the periodic path, the one the candidates were searched on
      (:func:`compare.fitting._run`). Left to "auto", a candidate whose record period is long (a wheel
      eccentricity: one wheel revolution) went time-stepped, whose steady state differs from the periodic one
      at weak mesh harmonics by up to 2.4 dB (the mesh follows the vibrating angle there; spur-gds, 1000 rpm,
      4 f_m): measured on a rig with a hidden pitch error and housing mode, both fitted and added, a wheel
      eccentricity of 0.2 um - its lower bound, no effect at all - was claimed with a 36 % reduction.
    - The baseline gets the same refit first (no candidate in). When that lowers its error, every candidate's
      refit starts from the baseline's refitted nuisances and a refitted candidate is measured against the
      refitted baseline: what more nuisance fitting gives is not credited to the effect. A candidate's refit
      that walks on from there may find nuisances better for the baseline too, so the baseline is also
      measured at the nuisances the candidate's refit ended on, and the lower of the two is its baseline (one
      simulation per candidate; stop 56: with the compare views kept out of the record's edges the null wheel
      eccentricity below was credited 11.6 % without this, 1.31 -> 1.16 dB). Measured on that rig
      (1 s, calibrated): the null wheel eccentricity was credited 22 % of the error before; the refitted
      baseline's error was 1.46 dB against the calibration's 2.07 dB (coordinate scans stop short where two
      dampings trade off).

    With ``executor`` (a process pool) the candidates' refits run in its workers, and ``null_refit`` is the
    baseline's, submitted before the search (:func:`compare.attribution.attribute`): each refit is one deterministic function of
    its pickled arguments, so the result is the same as in this process. Measured on the escalated default
    path (``experiments/bench_compare.py``, 2 idle cores): the calibrated pass's refit 18.4 s in this process,
    10.9 s in two workers (the candidates' refits, free in their effect too, cost more than the baseline's).
    """
    from compare.calibration import error_at
    from compare.error import combine, excess

    ranked = sorted((c for c in results if c.status == "fitted" and math.isfinite(c.raw_error_db)),
                    key=lambda c: c.raw_error_db)[:settings.refine_top]
    if not ranked:
        if null_refit is not None:
            null_refit.cancel()
        return 0
    null = null_refit.result() if null_refit is not None else _refit(*refit_args(ref, model, calibration, settings))
    n = null.n_simulations
    # raw errors (Calibration.error_db is raw)
    better = [null.error_db < c.raw_baseline_error_db for c in ranked]
    jobs = [refit_args(ref, model, calibration, settings, start=null.values if b else None,
                        effect=c.build_effect())
            for c, b in zip(ranked, better)]
    if executor is not None:
        cals = [f.result() for f in [executor.submit(refit_payload, pickle.dumps(j)) for j in jobs]]
    else:
        cals = [_refit(*j) for j in jobs]
    for c, b, cal in zip(ranked, better, cals):
        n += cal.n_simulations
        # raw errors on both sides: the fit's objective
        c.nuisance = dict(cal.values) if cal.error_db < c.raw_error_db else dict(calibration.values)
        if cal.error_db < c.raw_error_db:
            c.params = {**c.params, **cal.effect_params}
            c.set_raw(dict(cal.view_error_db), cal.error_db)
            c.explains = explained_keys(ref, cal.residual_db, disagreements)
            base_err, base_views = (null.error_db, null.view_error_db) if b else (c.raw_baseline_error_db, None)
            # the baseline at the nuisances the candidate's refit ended on: a refit that starts from the
            # baseline's and walks on finds what more nuisance fitting gives, with or without the effect
            at = error_at(ref, model, cal.values, settings=refit_settings(calibration, settings),
                          solver=settings.search_solver(transient=False))
            n += 1
            if at.total_db < base_err:
                base_err, base_views = at.total_db, at.view_error_db
            if base_views is not None:
                c.raw_baseline_error_db = base_err
                c.baseline_view_error_db = excess(dict(base_views), c.noise_view_db)
                c.baseline_error_db = combine(c.baseline_view_error_db)
    return n
