"""The points of a calibration's coordinate scans (:mod:`compare.calibration`): a batch of drive-train values
simulated and scored, a scan's parabolic vertex and the conditional 1-sigma from its curvature. Shared with the
joint refit's global stage (:mod:`compare.joint_refit`), which scores Sobol points the same way.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from compare.error import VIEW_WEIGHTS
from gearpit.errors import GearpitError

__all__ = ["Point", "evaluate_points", "find_point", "scan_sigma", "scan_vertex"]


@dataclass(eq=False)
class Point:
    """One point of a calibration's coordinate scans: search coordinates ``u`` and the errors simulated there."""

    u: np.ndarray
    error_db: float = math.inf          # what is minimised: the error over the calibration's views
    total_db: float = math.inf
    gain_db: float = math.nan
    residual_db: np.ndarray | None = None
    view_error_db: dict = field(default_factory=dict)


def find_point(points: list[Point], u: np.ndarray) -> Point | None:
    """The point of ``points`` at coordinates ``u`` (to 1e-7), or None."""
    return next((q for q in points if np.allclose(q.u, u, atol=1e-7)), None)


def scan_vertex(scan: list[Point], j: int, fallback: float) -> float:
    """Coordinate ``j`` of the minimum of the parabola in ``u_j`` through the scan's best point and its two
    neighbours (the best point itself at an end of the scan or for a non-convex triple)."""
    if len(scan) < 3:
        return fallback
    scan = sorted(scan, key=lambda q: q.u[j])
    i = int(np.argmin([q.error_db for q in scan]))
    if i == 0 or i == len(scan) - 1:
        return float(scan[i].u[j])
    (x0, x1, x2), (y0, y1, y2) = ((q.u[j] for q in scan[i - 1:i + 2]), (q.error_db ** 2 for q in scan[i - 1:i + 2]))
    if min(x1 - x0, x2 - x1) < 1e-9:
        return float(x1)
    # vertex of the parabola through three points (Numerical Recipes eq. 10.2.1)
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    if den >= 0:          # not convex: keep the best point
        return float(x1)
    return float(np.clip(x1 - 0.5 * num / den, x0, x2))


def evaluate_points(ref, model, params, pts, extra_effects, seed, solver, counter, views, exact=None, start=None,
              free=None) -> None:
    """Simulate the model at every point (one batch) and record the errors of each; point ``exact`` is
    simulated at the ``start`` values themselves (not their clipped search coordinate)."""
    from compare.comparison import evaluate
    from datagen.simulate import simulate

    if not pts:
        return
    m = ref.measurement
    dur = ref.model_duration_s()
    cases = []
    for q in pts:
        vals = dict(start) if q is exact else {p.name: float(p.from_u(q.u[j])) for j, p in enumerate(params)}
        extra = tuple(extra_effects)
        if free is not None:
            mine = {k: vals.pop(k) for k in list(vals) if k in free.params()}
            extra = extra[:-1] + (replace(free, **mine),)
        mm = model.with_drivetrain(vals)
        cases.append(mm.case(m.pair, speed_rpm=ref.speed.speed_rpm, torque_nm=m.torque_nm, duration_s=dur,
                             fs_hz=m.fs_hz, seed=seed, extra_effects=extra, solver=solver))
    try:
        sigs = simulate(cases, channels=(model.sensor,))
    except (GearpitError, FloatingPointError, np.linalg.LinAlgError):
        sigs = []
        for c in cases:
            try:
                sigs += simulate([c], channels=(model.sensor,))
            except (GearpitError, FloatingPointError, np.linalg.LinAlgError):
                sigs.append(None)
    counter[0] += len(cases)
    for q, s in zip(pts, sigs):
        y = None if s is None else s.channels.get(model.sensor)
        if y is None or not np.all(np.isfinite(y)):
            continue
        ev = evaluate(ref, y, m.fs_hz, seed=seed)
        ve = ev.residuals.view_error_db
        num = sum(VIEW_WEIGHTS[v] * ve[v] ** 2 for v in views if v in ve)
        den = sum(VIEW_WEIGHTS[v] for v in views if v in ve)
        q.error_db = math.sqrt(num / den) if den > 0 else ev.residuals.total_db
        q.total_db, q.gain_db = ev.residuals.total_db, ev.residuals.gain_db
        q.residual_db, q.view_error_db = ev.residuals.residual_db, ev.residuals.view_error_db


def scan_sigma(ref, params, values, scans, best, views) -> dict:
    """Conditional 1-sigma of each nuisance (the others held): curvature of E^2 along its last scan."""
    from compare.error import effective_count
    from compare.search import line_sigma_u

    n_eff = effective_count(ref.plan, views, q=ref.reliability)     # Kish's count over the calibrated views
    out = {}
    for j, p in enumerate(params):
        line = [q for q in scans[j] if math.isfinite(q.error_db)] if scans else []
        su = line_sigma_u([q.u[j] - best.u[j] for q in line], [q.error_db for q in line], best.error_db, n_eff)
        sg = p.sigma_from_u(values[p.name], su)
        out[p.name] = sg if sg <= p.hi - p.lo else math.inf
    return out
