"""Residuals and the scalar error: gain fit, noise floors, weighted norm.

Definition (what ``error_db`` means everywhere in gearpit)
---------------------------------------------------------
1. **Levels.** Every location ``i`` of the plan (:mod:`compare.views`) has a
   measured level ``a_i`` and a model level ``b_i`` in dB, and floors ``fa_i``,
   ``fb_i`` (local noise; statistics have none).
2. **Sensor gain.** The model's gain-carrying levels are shifted by ``G`` dB,
   the weighted median of ``a_i - b_i`` over the gain-carrying locations where
   both signals stand ``FLOOR_MARGIN_DB`` above their floors (an L1 fit: a few
   large disagreements do not move it). ``G`` is fitted, never assumed.
3. **Floors.** Both levels are power-summed with the common floor
   ``F_i = max(fa_i, fb_i + G) + FLOOR_MARGIN_DB``:
   ``a'_i = 10 log10(10^(a_i/10) + 10^(F_i/10))``, likewise ``b'_i``. Where both
   signals are buried in noise the residual tends to 0 instead of comparing noise
   with noise; where one stands out it is (nearly) its level difference.
4. **Residual** ``r_i = a'_i - b'_i`` (dB; positive = the measurement has more).
5. **Weights.** Inside a view each group of locations (mesh harmonics, pinion
   sidebands, ...) carries the same total weight, shared equally by its
   locations: ``g_i = 1 / (groups in the view * locations in the group)``.
   In the views whose locations are single spectral lines (``order``,
   ``envelope``: :data:`LINE_VIEWS`) each residual is further weighted by its
   *reliability*, the inverse of the variance it would have if the model
   matched the measurement there: ``q_i = s0^2 / (sigma_i^2 + s0^2)``,
   ``w_i = g_i q_i``. ``sigma_i`` (:func:`noise_scatter_db`) is the scatter of
   ``r_i`` between two records of the same vibration with independent noise at
   the *measured* floor. With ``P_n`` the noise power per bin, ``S`` the line's
   power, ``s = S / P_n = 10^((a_i - fa_i)/10) - 1`` and ``m =
   10^(FLOOR_MARGIN_DB/10)``: a bin holding line and noise has power ``P = S +
   P_n`` with variance ``P_n (2 S + P_n)`` (complex Gaussian noise), step 3
   maps it to ``10 log10(P + m P_n)`` with slope ``(10 / ln 10) / (P + m
   P_n)``, and two records add their variances:
   ``sigma_i = (10 / ln 10) sqrt(2 (2 s + 1)) / (s + 1 + m)`` dB (1.23 dB for a
   bin of noise only, 0.27 dB for a line 30 dB above its floor; checked by
   Monte Carlo in ``tests/test_compare_views.py``). ``s0`` =
   :data:`MODEL_TOLERANCE_DB` keeps a few very clean lines from carrying a view
   alone. Bands, TSA powers and statistics average many bins or samples; their
   noise scatter is small (measured 0.2 dB for noise-only bands) and they keep
   ``q_i = 1``. The weights depend on the measurement only (not on the model),
   so ``E`` is one fixed weighted RMS of the residuals for a given measurement:
   every model, candidate and noise draw is measured with the same weights.
   Why: without them a line view's error is dominated by the many locations
   that hold only noise in both records (sidebands no effect excites), whose
   residuals scatter by ~1 dB whatever the model; an effect that changes a few
   clean lines by 1-2 dB (a tip relief) then moves the error by less than two
   noise draws do (measured, 10 noise seeds: the rig's own model kept up to
   0.67 of the baseline's excess error for a 10 um tip relief, 0.27 with the
   weights). ``s0`` = 0.5 dB rather than 0.3: with 0.3 the same floor fell to
   0.24, but a view came to hang on one or two clean lines and the error
   surface of a housing mode grew ragged enough that the attribution's search
   settled at 2775 Hz / 18 % damping (2.38 dB) instead of near the truth,
   3000 Hz / 5 % (1.14 dB); with 0.5 it lands at 2900 Hz / 5.1 %.

   **Status: off by default** (:data:`MODEL_TOLERANCE_DB` None, ``q_i = 1``:
   the error as before the weights). Switched on at 0.5 dB, the hidden-effect
   loop of ``tests/test_compare_attribution.py`` (seed 3) still passes for 7
   of the 9 effects that pass without the weights, tip_relief is claimed and
   fitted within tolerance (12.1 vs 10 um) but keeps 0.58 of the error (the
   mesh-damping nuisance, not the floor, now limits it), and the two
   fluctuation effects are no longer claimed: their amplitude search (time
   stepped, on a 0.5 s window: a 5-point grid and one quadratic step) lands on
   a grid point (torque: 0.316 against the true 0.2, whose full-record error
   is 0.70 dB against 3.8 dB), and with the noise-only locations no longer
   diluting the order view that poor fit raises it by 1.1-1.5 dB, past the
   claim rule's 1 dB. The weights go on once that search refines its
   amplitude (and frequency) well enough; until then they are available for
   study (``reliability(..., tolerance_db=0.5)``, or the module constant).
6. **View error** ``E_v = sqrt(sum_i w_i r_i^2 / sum_i w_i)`` over the view's
   locations; **total** ``E = sqrt(sum_v W_v E_v^2 / sum_v W_v)`` with the view
   weights :data:`VIEW_WEIGHTS` (all 1). Both in dB.

``E`` is 0 for identical signals (every ``r_i`` is 0 and ``G`` = 0), does not
change when the measurement is scaled (``G`` absorbs it), and grows with every
residual (it is a weighted RMS).

7. **Noise correction (the headline error).** Two records of the *same* vibration
   with independent sensor noise at the measured floor do not give ``E = 0``:
   levels near their floors scatter, and at SNR 30 dB this alone gives
   ``E`` of 0.5-0.9 dB, as large as many effects' signatures. The comparison
   therefore also measures the *noise error* ``N_v`` of each view: the error
   between the model record with independent noise draws at the measured floor
   (:func:`compare.comparison.evaluate`, ``noise_draws``; the RMS over the draw
   pairs). Since noise and model mismatch add in ``E_v^2`` (independent), the
   **excess error** ``X_v = sqrt(max(0, E_v^2 - N_v^2))`` estimates the error the
   two records would have without noise; ``X`` (total) combines the ``X_v`` as in
   step 6. ``X`` is what ``error_db`` reports (``raw_error_db``: ``E``;
   ``noise_error_db``: ``N``). It keeps the properties above: 0 for identical
   signals (``E`` = 0), gain-invariant, growing with every residual (``N`` does
   not depend on the measurement's residuals). A model at the noise floor has
   ``X`` near 0 (it fluctuates with the draws: a few 0.1 dB at 60 effective
   residuals), and halving ``X`` means halving the mismatch beyond noise.
   Where the model's own floor is already above the measured one no noise is
   drawn, ``N`` = 0 and ``X = E`` (conservative).

References
----------
Kish, L. (1965). Survey Sampling. Wiley (effective number of weighted observations, used for
    the fit uncertainty in :mod:`compare.attribution`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from compare.plan import VIEWS, Plan
from compare.views import SignalViews
from gearpit.errors import require

VIEW_WEIGHTS = {"order": 1.0, "band": 1.0, "envelope": 1.0, "tsa": 1.0, "stats": 1.0}
FLOOR_MARGIN_DB = 6.0
#: ``s0`` of step 5 (dB): the scatter below which a residual counts as free of noise; None switches the
#: reliability weights off (``q_i = 1``), which is the default: see step 5, "Status"
MODEL_TOLERANCE_DB: float | None = None
#: the value measured and recommended for when the weights are switched on (step 5)
RECOMMENDED_TOLERANCE_DB = 0.5
#: views whose locations are single spectral lines: their residuals get the reliability of step 5
LINE_VIEWS = ("order", "envelope")


@dataclass(frozen=True, eq=False)
class Residuals:
    """Residuals at every location of a plan and the errors they make (module docstring).

    Attributes
    ----------
    gain_db : float
        Fitted sensor gain G (dB), model -> measurement.
    residual_db : ndarray
        ``r_i`` per location (dB).
    view_error_db : dict
        ``E_v`` per view (dB), the raw error.
    total_db : float
        ``E`` (dB), the raw error (what fits minimise).
    noise_view_db : dict or None
        ``N_v`` per view (dB), the noise error (step 7), when measured.
    weights : ndarray
        ``w_i`` of step 5 (group weight times reliability), as used.
    """

    gain_db: float
    residual_db: np.ndarray
    view_error_db: dict
    total_db: float
    weights: np.ndarray
    noise_view_db: dict | None = None

    def with_noise(self, noise_view_db: dict | None) -> "Residuals":
        """The same residuals with the noise error ``N_v`` of each view (step 7)."""
        return replace(self, noise_view_db=None if noise_view_db is None else dict(noise_view_db))

    @property
    def excess_view_db(self) -> dict:
        """``X_v`` per view (step 7; ``E_v`` when no noise error is known)."""
        return excess(self.view_error_db, self.noise_view_db)

    @property
    def excess_total_db(self) -> float:
        """``X`` (step 7), the headline error."""
        return combine(self.excess_view_db)

    @property
    def noise_total_db(self) -> float:
        """The noise error's total, ``N`` (0 when unknown)."""
        return combine(self.noise_view_db) if self.noise_view_db else 0.0


def location_weights(plan: Plan) -> np.ndarray:
    """The group weights ``g_i`` of step 5 (module docstring), before the reliability."""
    w = np.zeros(len(plan.locations))
    for view in VIEWS:
        idx = plan.view_index(view)
        groups: dict[str, list[int]] = {}
        for i in idx:
            groups.setdefault(plan.locations[i].group, []).append(int(i))
        for members in groups.values():
            w[members] = 1.0 / (len(groups) * len(members))
    return w


def noise_scatter_db(meas: SignalViews, plan: Plan) -> np.ndarray:
    """``sigma_i`` of step 5 (dB): the scatter of the residual at each line location between two records of the
    same vibration with independent noise at the floors of ``meas``; NaN outside :data:`LINE_VIEWS` and where a
    level or floor is not finite."""
    snr_db = meas.levels - meas.floors
    line = np.array([loc.view in LINE_VIEWS for loc in plan.locations], dtype=bool) & np.isfinite(snr_db)
    s = np.clip(10 ** (np.where(line, np.minimum(snr_db, 300.0), 0.0) / 10) - 1.0, 0.0, None)
    m = 10 ** (FLOOR_MARGIN_DB / 10)
    sigma = (10 / np.log(10)) * np.sqrt(2 * (2 * s + 1)) / (s + 1 + m)
    return np.where(line, sigma, np.nan)


def reliability(meas: SignalViews, plan: Plan, tolerance_db: float | None = None) -> np.ndarray:
    """``q_i = s0^2 / (sigma_i^2 + s0^2)`` of step 5 at the line locations, 1 elsewhere (dimensionless), with
    ``s0`` = ``tolerance_db`` or, when not given, :data:`MODEL_TOLERANCE_DB`; all 1 when that is None (off)."""
    s0 = MODEL_TOLERANCE_DB if tolerance_db is None else tolerance_db
    if s0 is None:
        return np.ones(len(plan.locations))
    require(s0 > 0, "reliability tolerance_db", s0, "> 0 dB (None: weights off)")
    sigma = noise_scatter_db(meas, plan)
    q = s0 ** 2 / (np.nan_to_num(sigma, nan=0.0) ** 2 + s0 ** 2)
    return np.where(np.isfinite(sigma), q, 1.0)


def effective_count(plan: Plan, views=None, q: np.ndarray | None = None) -> float:
    """Kish's effective number of residuals, ``(sum u)^2 / sum u^2`` with ``u_i = W_v w_i`` (``w_i`` with the
    reliability ``q`` when given, step 5); with ``views``, over the residuals of those views only."""
    view_w = np.array([VIEW_WEIGHTS[loc.view] if views is None or loc.view in views else 0.0
                       for loc in plan.locations])
    u = location_weights(plan) * (1.0 if q is None else q) * view_w
    return float(u.sum() ** 2 / np.sum(u * u))


def weighted_median(values: np.ndarray, weights: np.ndarray) -> float:
    order = np.argsort(values)
    v, w = values[order], weights[order]
    c = np.cumsum(w)
    return float(v[np.searchsorted(c, 0.5 * c[-1])])


def gain_mask(plan: Plan) -> np.ndarray:
    return np.array([loc.gain for loc in plan.locations], dtype=bool)


#: a location more than this far (dB) below the strongest gain-carrying location of its record is no line of it
#: for the gain fit: a noise-free simulation's healthy sidebands are numerical dust 210-230 dB below its mesh line,
#: yet above its own floor (lower still), and on a foreign record whose followed mean speed the model matched to the
#: last digit, 20 of them entered the median and fitted the gain 115 dB off (+59 dB for -56: no noise was added to
#: the model, the comparison read 32 dB and claimed a pit on a healthy gear); 24-bit converters span 144 dB
DYNAMIC_RANGE_DB = 150.0


def fit_gain_db(meas: SignalViews, model: SignalViews, plan: Plan, *, mask: np.ndarray | None = None) -> float:
    """Step 2: weighted median of the level differences at clearly visible gain-carrying locations.

    ``mask`` restricts to a subset of the plan's locations (``meas`` and ``model`` then hold only those).
    """
    g = gain_mask(plan)
    w = location_weights(plan)
    if mask is not None:
        g, w = g[mask], w[mask]
    above = g & (meas.levels > meas.floors + FLOOR_MARGIN_DB) & (model.levels > model.floors + FLOOR_MARGIN_DB)
    for v in (meas, model):     # numerical dust is no line, however far it stands above a noise-free record's floor
        top = np.max(v.levels[g]) if g.any() else np.inf
        above &= v.levels > top - DYNAMIC_RANGE_DB
    sel = above if above.sum() >= 3 else g
    return weighted_median(meas.levels[sel] - model.levels[sel], w[sel])


def _psum(a: np.ndarray, f: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(f), 10 * np.log10(10 ** (a / 10) + 10 ** (np.where(np.isfinite(f), f, 0.0) / 10)), a)


def residuals(meas: SignalViews, model: SignalViews, plan: Plan, gain_db: float | None = None,
              q: np.ndarray | None = None) -> Residuals:
    """Steps 2-6 of the module docstring; ``gain_db`` fitted when not given; ``q`` the reliability of step 5,
    from ``meas`` when not given (pass the measurement's when ``meas`` is a noise draw of the model)."""
    if gain_db is None:
        gain_db = fit_gain_db(meas, model, plan)
    g = gain_mask(plan).astype(float) * gain_db
    b = model.levels + g
    fb = model.floors + g
    floor = np.fmax(meas.floors, fb) + FLOOR_MARGIN_DB
    r = _psum(meas.levels, floor) - _psum(b, floor)
    return summarise(r, plan, gain_db, reliability(meas, plan) if q is None else q)


def summarise(r: np.ndarray, plan: Plan, gain_db: float = 0.0, q: np.ndarray | None = None) -> Residuals:
    """View errors and the total from residuals (steps 5-6); ``q``: the reliability (1 everywhere if None)."""
    w = location_weights(plan) * (1.0 if q is None else q)
    views = {}
    for view in VIEWS:
        idx = plan.view_index(view)
        if idx.size == 0:
            continue
        views[view] = float(np.sqrt(np.sum(w[idx] * r[idx] ** 2) / np.sum(w[idx])))
    return Residuals(gain_db=float(gain_db), residual_db=r, view_error_db=views, total_db=combine(views),
                     weights=w)


def combine(view_db: dict) -> float:
    """The total of step 6 from per-view errors: ``sqrt(sum_v W_v E_v^2 / sum_v W_v)``."""
    num = sum(VIEW_WEIGHTS[v] * e * e for v, e in view_db.items())
    den = sum(VIEW_WEIGHTS[v] for v in view_db)
    return float(np.sqrt(num / den)) if den > 0 else 0.0


def excess(view_db: dict, noise_view_db: dict | None) -> dict:
    """``X_v = sqrt(max(0, E_v^2 - N_v^2))`` per view (step 7); ``E_v`` where ``N_v`` is unknown."""
    n = noise_view_db or {}
    return {v: float(np.sqrt(max(0.0, e * e - n.get(v, 0.0) ** 2))) for v, e in view_db.items()}
