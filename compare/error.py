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
   locations: ``w_i = 1 / (groups in the view * locations in the group)``.
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

from dataclasses import dataclass

import numpy as np

from compare.plan import VIEWS, Plan
from compare.views import SignalViews

VIEW_WEIGHTS = {"order": 1.0, "band": 1.0, "envelope": 1.0, "tsa": 1.0, "stats": 1.0}
FLOOR_MARGIN_DB = 6.0


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
    """

    gain_db: float
    residual_db: np.ndarray
    view_error_db: dict
    total_db: float
    noise_view_db: dict | None = None

    def with_noise(self, noise_view_db: dict | None) -> "Residuals":
        """The same residuals with the noise error ``N_v`` of each view (step 7)."""
        return Residuals(self.gain_db, self.residual_db, self.view_error_db, self.total_db,
                         None if noise_view_db is None else dict(noise_view_db))

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
    """``w_i`` of step 5 (module docstring)."""
    w = np.zeros(len(plan.locations))
    for view in VIEWS:
        idx = plan.view_index(view)
        groups: dict[str, list[int]] = {}
        for i in idx:
            groups.setdefault(plan.locations[i].group, []).append(int(i))
        for members in groups.values():
            w[members] = 1.0 / (len(groups) * len(members))
    return w


def effective_count(plan: Plan, views=None) -> float:
    """Kish's effective number of residuals, ``(sum u)^2 / sum u^2`` with ``u_i = W_v w_i``; with ``views``,
    over the residuals of those views only."""
    u = location_weights(plan) * np.array([VIEW_WEIGHTS[loc.view] if views is None or loc.view in views else 0.0
                                           for loc in plan.locations])
    return float(u.sum() ** 2 / np.sum(u * u))


def weighted_median(values: np.ndarray, weights: np.ndarray) -> float:
    order = np.argsort(values)
    v, w = values[order], weights[order]
    c = np.cumsum(w)
    return float(v[np.searchsorted(c, 0.5 * c[-1])])


def gain_mask(plan: Plan) -> np.ndarray:
    return np.array([loc.gain for loc in plan.locations], dtype=bool)


def fit_gain_db(meas: SignalViews, model: SignalViews, plan: Plan, *, mask: np.ndarray | None = None) -> float:
    """Step 2: weighted median of the level differences at clearly visible gain-carrying locations.

    ``mask`` restricts to a subset of the plan's locations (``meas`` and ``model`` then hold only those).
    """
    g = gain_mask(plan)
    w = location_weights(plan)
    if mask is not None:
        g, w = g[mask], w[mask]
    above = g & (meas.levels > meas.floors + FLOOR_MARGIN_DB) & (model.levels > model.floors + FLOOR_MARGIN_DB)
    sel = above if above.sum() >= 3 else g
    return weighted_median(meas.levels[sel] - model.levels[sel], w[sel])


def _psum(a: np.ndarray, f: np.ndarray) -> np.ndarray:
    return np.where(np.isfinite(f), 10 * np.log10(10 ** (a / 10) + 10 ** (np.where(np.isfinite(f), f, 0.0) / 10)), a)


def residuals(meas: SignalViews, model: SignalViews, plan: Plan, gain_db: float | None = None) -> Residuals:
    """Steps 2-6 of the module docstring; ``gain_db`` fitted when not given."""
    if gain_db is None:
        gain_db = fit_gain_db(meas, model, plan)
    g = gain_mask(plan).astype(float) * gain_db
    b = model.levels + g
    fb = model.floors + g
    floor = np.fmax(meas.floors, fb) + FLOOR_MARGIN_DB
    r = _psum(meas.levels, floor) - _psum(b, floor)
    return summarise(r, plan, gain_db)


def summarise(r: np.ndarray, plan: Plan, gain_db: float = 0.0) -> Residuals:
    """View errors and the total from residuals (steps 5-6)."""
    w = location_weights(plan)
    views = {}
    for view in VIEWS:
        idx = plan.view_index(view)
        if idx.size == 0:
            continue
        views[view] = float(np.sqrt(np.sum(w[idx] * r[idx] ** 2) / np.sum(w[idx])))
    return Residuals(gain_db=float(gain_db), residual_db=r, view_error_db=views, total_db=combine(views))


def combine(view_db: dict) -> float:
    """The total of step 6 from per-view errors: ``sqrt(sum_v W_v E_v^2 / sum_v W_v)``."""
    num = sum(VIEW_WEIGHTS[v] * e * e for v, e in view_db.items())
    den = sum(VIEW_WEIGHTS[v] for v in view_db)
    return float(np.sqrt(num / den)) if den > 0 else 0.0


def excess(view_db: dict, noise_view_db: dict | None) -> dict:
    """``X_v = sqrt(max(0, E_v^2 - N_v^2))`` per view (step 7); ``E_v`` where ``N_v`` is unknown."""
    n = noise_view_db or {}
    return {v: float(np.sqrt(max(0.0, e * e - n.get(v, 0.0) ** 2))) for v, e in view_db.items()}
