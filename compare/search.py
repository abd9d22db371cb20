"""The batched search of one effect's parameters: points, rounds, quadratic surrogate.

A :class:`Search` holds an effect's :class:`compare.fitspace.FitSpace` and the
points tried so far (:class:`Trial`, with the total error each gave). Each
round function proposes the next points from those already evaluated; the
caller (:mod:`compare.attribution`) simulates the points of every effect in one
batch, so a round costs one :func:`datagen.simulate.simulate` call. Rounds:

- :func:`round_a`: a grid of the first parameter (or the frequencies the
  measurement points to, for a parameter in Hz, and the midpoints of close
  neighbours among them: :func:`between_seeds`), plus the values the effect's
  physics singles out at this operating point (its ``fit_seeds``); the second
  at its default, or at three values when the first is a frequency; at every
  value of the string option for an effect whose option moves its lines
  (``fit_choice_grid``: which gear carries a local tooth fault), else at its
  default;
- :func:`round_b`: the second parameter's grid at the best first one (``rich``:
  nine values, crossed with steps of a first that is not a frequency), or a
  finer bracket of a lone parameter; the string option's other values;
  time-stepped fits then step a frequency at the valley of the second
  (:func:`round_b_frequency`) and close in with :func:`round_fine`;
- :func:`round_c`: steps around the best in every parameter (at most half the
  gap to the nearest value tried in its basin);
- :func:`round_d`: the minimum of :func:`quadratic`, a least-squares quadratic
  surrogate of ``E^2`` over the points nearest the best, minimised within the
  bounds by :func:`scipy.optimize.minimize` (L-BFGS-B).

After round A the :data:`MAX_BASINS` lowest local minima of its sweep of the
first parameter (of a frequency: the best clusters of values) are kept
(:meth:`Search.set_basins`) and rounds B-D work around
the best point of each (:func:`around_basins`; a quadratic uses only the points
of its own basin): error levels cannot tell a tone's amplitude from its
mirror across a zero, so a landscape can hold two minima of nearly the same
depth (a tip relief past the load deflection and one as far short of it), and
refining only the first round's best would settle in the wrong one.

References
----------
Press, W. H. et al. (2007). Numerical Recipes, 3rd ed., sec. 10.2 and 15.6 (parabolic interpolation;
    confidence limits from the curvature of the merit function).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from compare.fitspace import FitSpace, frequency_seeds, grid

#: how many local minima of the first round are refined (a level-only view can leave two mirror minima, e.g.
#: a tip relief as far above the load deflection as another is below it)
MAX_BASINS = 2
#: frequency seeds closer than this ratio are one hypothesis (:meth:`Search.set_basins`)
SEED_CLUSTER = 1.05

@dataclass
class Trial:
    values: dict
    choice: object
    u: np.ndarray
    error_db: float = math.inf
    residual_db: np.ndarray | None = None
    view_error_db: dict = field(default_factory=dict)
    note: str = ""


class Search:
    def __init__(self, cls, space: FitSpace, seeds: dict | None = None):
        self.cls = cls
        self.space = space
        #: values the operating point singles out (:meth:`datagen.effects.base.Effect.fit_seeds`), in bounds
        self.seeds = {p.name: np.array([float(v) for v in (seeds or {}).get(p.name, ()) if p.lo <= v <= p.hi])
                      for p in space.params}
        self.trials: list[Trial] = []
        self.choice = cls().params().get(space.choice[0]) if space.choice else None
        self.default_choice = self.choice
        #: first-round minima refined separately (:meth:`set_basins`); empty: refine around the best only
        self.basins: list[np.ndarray] = []

    def point(self, values: dict, choice=None) -> Trial:
        choice = self.choice if choice is None else choice
        u = np.array([p.to_u(values[p.name]) for p in self.space.params])
        return Trial(values=dict(values), choice=choice, u=u)

    def defaults(self) -> dict:
        return {p.name: p.default for p in self.space.params}

    @property
    def best(self) -> Trial | None:
        done = [t for t in self.trials if math.isfinite(t.error_db)]
        return min(done, key=lambda t: t.error_db) if done else None

    def set_basins(self, n: int = MAX_BASINS) -> None:
        """After the first round: the ``n`` lowest local minima of its sweep of the first parameter (the best
        over the other parameters at each value), each refined on its own by the later rounds; for a frequency,
        the best values of the ``n`` best clusters (values within :data:`SEED_CLUSTER`), minima or not."""
        done = [t for t in self.trials if math.isfinite(t.error_db)]
        if not done or not self.space.params:
            self.basins = [self.best.u.copy()] if done else []
            return
        by_v: dict[float, Trial] = {}
        for t in done:
            k = round(float(t.u[0]), 9)
            if k not in by_v or t.error_db < by_v[k].error_db:
                by_v[k] = t
        line = [by_v[k] for k in sorted(by_v)]
        e = [t.error_db for t in line]
        if self.space.params[0].unit == "Hz":
            # frequency seeds are separate hypotheses (lines the measurement points to, often mesh harmonics
            # apart), not samples of one landscape: the best of each cluster of seeds (neighbours within
            # SEED_CLUSTER) is a basin, minimum of the sweep or not. Measured: a housing mode between two
            # harmonics left the seed nearer to it slightly worse at round A's coarse dampings; a chain of
            # seeds 2 % apart at twice a torque ripple's frequency took both basins from its fundamental
            minima, cluster = [], [line[0]]
            for a, b in zip(line[:-1], line[1:]):
                if self.space.params[0].from_u(b.u[0]) > SEED_CLUSTER * self.space.params[0].from_u(a.u[0]):
                    minima.append(min(cluster, key=lambda t: t.error_db))
                    cluster = []
                cluster.append(b)
            minima.append(min(cluster, key=lambda t: t.error_db))
        else:
            minima = [t for i, t in enumerate(line)
                      if (i == 0 or e[i] < e[i - 1]) and (i == len(line) - 1 or e[i] <= e[i + 1])]
        minima.sort(key=lambda t: t.error_db)
        self.basins = [t.u.copy() for t in minima[:n]] or [self.best.u.copy()]

    def basin_of(self, t: Trial) -> int:
        """Index of the basin whose first-round minimum is nearest ``t`` (in the search coordinates)."""
        return int(np.argmin([float(np.sum((t.u - b) ** 2)) for b in self.basins])) if self.basins else 0

    def centres(self) -> list[Trial]:
        """The best trial of each basin (only the overall best before :meth:`set_basins`)."""
        if not self.basins:
            return [self.best] if self.best is not None else []
        out = []
        for i in range(len(self.basins)):
            own = [t for t in self.trials if math.isfinite(t.error_db) and self.basin_of(t) == i]
            if own:
                out.append(min(own, key=lambda t: t.error_db))
        return out

    def build(self, t: Trial):
        kw = dict(t.values)
        if self.space.choice:
            kw[self.space.choice[0]] = t.choice
        return self.cls(**kw)

    def seen(self, t: Trial) -> bool:
        return any(np.allclose(t.u, s.u, atol=1e-4) and t.choice == s.choice for s in self.trials)


def round_a(s: Search, ref_residual, ref) -> list[Trial]:
    ps = s.space.params
    if not ps:
        return [s.point({})]
    p0 = ps[0]
    first = between_seeds(frequency_seeds(ref, ref_residual, p0)) if p0.unit == "Hz" else grid(p0)
    first = np.unique(np.concatenate([first, s.seeds[p0.name]]))
    second = [None]
    if len(ps) > 1:
        second = list(grid(ps[1], 3)) if p0.unit == "Hz" else [ps[1].default]
    # an option that moves the lines (a local fault's gear) gets the sweep at each value: tried only at the
    # default's best point, a wheel pit of 0.3 (helical-dct, 1200 rpm) was tried at the best pinion pit, the
    # smallest of the grid (a pinion pit explains nothing there), and refined around it to 0.0625
    choices = list(s.space.choice[1]) if s.space.choice and getattr(s.cls, "fit_choice_grid", False) else [None]
    out = []
    for c in choices:
        for v0 in first:
            for v1 in second:
                vals = s.defaults()
                vals[p0.name] = float(v0)
                if v1 is not None:
                    vals[ps[1].name] = float(v1)
                out.append(s.point(vals, c))
    return out


def between_seeds(seeds: np.ndarray, max_ratio: float = 1.5) -> np.ndarray:
    """``seeds`` (Hz) and the geometric midpoint of every two neighbours less than ``max_ratio`` apart: a
    resonance amplifies the lines on either side of it (two neighbouring mesh harmonics) and sits between them,
    usually nearer neither (measured: a housing mode at 3000 Hz between harmonics at 2900 and 3383 Hz)."""
    s = np.unique(np.asarray(seeds, float))
    mid = [float(np.sqrt(a * b)) for a, b in zip(s[:-1], s[1:]) if b / a < max_ratio]
    return np.unique(np.concatenate([s, mid]))


def _primary_steps(p, best_u: float, rich: bool) -> list[float]:
    """Values of the first parameter around the best: only the best itself unless ``rich``; a third and two
    thirds of the grid spacing either side if ``rich`` and not a frequency (a frequency's steps come next, from
    :func:`round_b_frequency`)."""
    v = float(p.from_u(best_u))
    if not rich or p.unit == "Hz":
        return [v]
    return [float(p.from_u(best_u + du)) for du in (-1 / 12, 0.0, 1 / 12)]


def round_b(s: Search, rich: bool = False, best: Trial | None = None) -> list[Trial]:
    """Second parameter's grid at the best first one (``rich``: 9 values instead of 5, for a first parameter
    that is not a frequency crossed with steps of it; for time-stepped effects); ``best``: the centre to work
    around (default: the best trial)."""
    ps, best = s.space.params, best or s.best
    if best is None:
        return []
    out = []
    if len(ps) >= 2:
        for v0 in _primary_steps(ps[0], best.u[0], rich):
            for v in np.unique(np.concatenate([grid(ps[1], 9 if rich else 5), s.seeds[ps[1].name]])):
                out.append(s.point({**best.values, ps[0].name: v0, ps[1].name: float(v)}))
    elif len(ps) == 1:
        step = 1.0 / (2 * 6)
        for du in ((-2, -1.5, -1, -0.5, 0.5, 1, 1.5, 2) if rich else (-2, -1, 1, 2)):
            du = du * step
            out.append(s.point({ps[0].name: float(ps[0].from_u(best.u[0] + du))}))
    if s.space.choice:
        out += [s.point(best.values, c) for c in s.space.choice[1] if c != best.choice]
    return [t for t in out if not s.seen(t)]


#: a frequency's steps in :func:`round_b_frequency` (ratios to the best)
FREQUENCY_STEPS = (0.96, 0.98, 1.02, 1.04)


def round_b_frequency(s: Search, best: Trial | None = None) -> list[Trial]:
    """After a rich :func:`round_b` of a time-stepped effect whose first parameter is a frequency: the frequency
    +/- 2 % and 4 % at the best second value and its nearest tried neighbours on either side (the second's
    valley, where the two trade off near a resonance). Before, one round crossed those steps with all nine values
    (45 cases per basin against 21 now; measured on the benchmark's 2 s record, the fluctuations' batch of 168
    cases took 32 s); found by a slow end-to-end test: the torque twin of a hidden speed fluctuation ended at
    43 Hz (reduction 0.05), then at 22.5 Hz, before the frequency steps reached the valley (23.0 Hz)."""
    ps, best = s.space.params, best or s.best
    if best is None or len(ps) < 2 or ps[0].unit != "Hz":
        return []
    same_f = sorted({round(float(t.u[1]), 9) for t in s.trials
                     if np.isclose(t.u[0], best.u[0], atol=1e-6) and t.choice == best.choice})
    u1 = round(float(best.u[1]), 9)
    k = same_f.index(u1) if u1 in same_f else None
    seconds = [best.u[1]] if k is None else same_f[max(k - 1, 0):k + 2]
    f0 = float(ps[0].from_u(best.u[0]))
    out = [s.point({**best.values, ps[0].name: f0 * r, ps[1].name: float(ps[1].from_u(u))}, best.choice)
           for r in FREQUENCY_STEPS for u in seconds]
    return [t for t in out if not s.seen(t)]


def round_c(s: Search, best: Trial | None = None) -> list[Trial]:
    """Steps around ``best`` (default: the best trial) in every parameter."""
    ps, best = s.space.params, best or s.best
    if best is None or not ps:
        return []
    if best is s.best:
        s.choice = best.choice
    out = []
    for j, p in enumerate(ps):
        step = (0.02 if p.unit == "Hz" else 1.0 / 18) if j == 0 else 1.0 / 15
        # no wider than half the gap to the nearest value already tried in this basin (a dense seed ladder has
        # found a minimum narrower than the default step)
        home = s.basin_of(best)
        gaps = [abs(float(t.u[j] - best.u[j])) for t in s.trials if s.basin_of(t) == home]
        gaps = [g for g in gaps if g > 1e-6]
        if gaps:
            step = min(step, 0.5 * min(gaps))
        for du in (-step, step):
            u = best.u.copy()
            u[j] = np.clip(u[j] + du, 0, 1)
            out.append(s.point({q.name: float(q.from_u(u[i])) for i, q in enumerate(ps)}, best.choice))
    return [t for t in out if not s.seen(t)]


def round_fine(s: Search, best: Trial | None = None) -> list[Trial]:
    """Points along each parameter's axis through ``best`` at 1/4, 1/2 and 3/4 of the gap to the nearest value
    already tried in its basin on either side: each round cuts the bracket around the minimum to a quarter. A
    side without a tried value beyond (the minimum not bracketed) gets 1/2 and 1 times the other side's gap,
    outwards, up to the bound. For time-stepped effects, whose batch costs about
    the same for 6 or 40 cases (measured: a torque fluctuation's amplitude on the spur rig, a sharp minimum
    between the grid's 0.13 and 0.32 with the truth at 0.2; the quadratic surrogate of a sharp frequency
    minimum is unreliable there)."""
    ps, best = s.space.params, best or s.best
    if best is None or not ps:
        return []
    home = s.basin_of(best)
    out = []
    for j, p in enumerate(ps):
        d = [float(t.u[j] - best.u[j]) for t in s.trials if s.basin_of(t) == home]
        for side in (-1.0, 1.0):
            gaps = [abs(x) for x in d if x * side > 1e-6]
            fracs = (0.25, 0.5, 0.75)
            if not gaps:
                # the best is the last value tried on this side: not bracketed, so step outwards by the gap
                # on the other side (measured: a speed fluctuation's frequency seeded 4 % low stopped at the
                # top of round B's +/- 2 %)
                gaps = [abs(x) for x in d if x * side < -1e-6]
                fracs = (0.5, 1.0)
                if not gaps or not 0.0 < best.u[j] + side * 1e-6 < 1.0:
                    continue
            for frac in fracs:
                u = best.u.copy()
                u[j] = np.clip(u[j] + side * frac * min(gaps), 0, 1)
                out.append(s.point({q.name: float(q.from_u(u[i])) for i, q in enumerate(ps)}, best.choice))
    return [t for t in out if not s.seen(t)]


def fit_quadratic(U: np.ndarray, y: np.ndarray, bounds: list) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares ``y = c + g.u + 1/2 u'Hu`` through points ``U`` (m, n) and its minimum inside ``bounds``
    (one ``(lo, hi)`` per coordinate, L-BFGS-B); returns (u_min, H, y_min)."""
    m, n = U.shape
    cols = [np.ones(m)] + [U[:, j] for j in range(n)]
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    cols += [U[:, i] * U[:, j] * (0.5 if i == j else 1.0) for i, j in pairs]
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), y, rcond=None)
    g = coef[1:1 + n]
    H = np.zeros((n, n))
    for (i, j), c in zip(pairs, coef[1 + n:]):
        H[i, j] = H[j, i] = c

    def f(u):
        return coef[0] + g @ u + 0.5 * u @ H @ u

    res = minimize(f, np.zeros(n), jac=lambda u: g + H @ u, bounds=bounds, method="L-BFGS-B")
    return res.x, H, max(float(res.fun), 1e-12)


def quadratic(s: Search, best: Trial | None = None):
    """Fit E^2 = c + g.u + 1/2 u'Hu on the points near ``best`` (default: the best trial), within its basin;
    returns (u_min, H, E2_min) or None."""
    best = best or s.best
    home = s.basin_of(best)
    pts = [t for t in s.trials if math.isfinite(t.error_db) and t.choice == best.choice and s.basin_of(t) == home]
    n = len(s.space.params)
    need = 1 + n + n * (n + 1) // 2
    if n == 0 or len(pts) < need:
        return None
    pts.sort(key=lambda t: float(np.sum((t.u - best.u) ** 2)))
    pts = pts[:max(need + 2, 2 * need)]
    U = np.array([t.u - best.u for t in pts])
    y = np.array([t.error_db ** 2 for t in pts])
    du, H, e2 = fit_quadratic(U, y, [(-bu, 1 - bu) for bu in best.u])
    return best.u + du, H, e2


def round_d(s: Search, best: Trial | None = None) -> list[Trial]:
    """The minimum of the quadratic surrogate around ``best`` (default: the best trial)."""
    best = best or s.best
    q = quadratic(s, best)
    if q is None:
        return []
    u = q[0]
    t = s.point({p.name: float(p.from_u(u[j])) for j, p in enumerate(s.space.params)}, best.choice)
    return [] if s.seen(t) else [t]


def around_basins(make, s: Search) -> list[Trial]:
    """The points of round ``make`` around the best trial of every basin of ``s``, without duplicates."""
    out: list[Trial] = []
    for c in s.centres():
        for t in make(s, best=c):
            if not any(np.allclose(t.u, o.u, atol=1e-4) and t.choice == o.choice for o in out):
                out.append(t)
    return out


def line_sigma_u(offsets_u, error_db, best_error_db: float, n_eff: float) -> float:
    """1-sigma in the search coordinate of one parameter with the others held: the curvature of ``E^2`` of a
    parabola through the (at most 5) points nearest the best along that line, ``offsets_u`` from the best,
    ``E^2 ~ a du^2 + ...`` gives ``sigma_u^2 = E_min^2 / (N a)`` (:mod:`compare.attribution`: the chi-square
    ``N E^2 / E_min^2`` rises by 1); ``inf`` with fewer than 3 distinct points or no positive curvature."""
    pts = sorted(zip((float(d) for d in offsets_u), (float(e) for e in error_db)), key=lambda t: abs(t[0]))[:5]
    if len({round(d, 9) for d, _ in pts}) < 3:
        return math.inf
    a2 = np.polyfit([d for d, _ in pts], [e ** 2 for _, e in pts], 2)[0]
    return math.sqrt(best_error_db ** 2 / (n_eff * a2)) if a2 > 0 else math.inf


def surrogate_sigma_u(H: np.ndarray, j: int, best_error_db: float, n_eff: float) -> float:
    """1-sigma in the search coordinate of parameter ``j`` from the Hessian ``H`` of the quadratic surrogate of
    ``E^2`` (:func:`quadratic`): ``sigma_u^2 = (2 E_min^2 / N) (H^-1)_jj`` (:mod:`compare.attribution`);
    ``inf`` unless ``H`` is positive definite."""
    try:
        hinv = np.linalg.inv(H)
        if np.all(np.linalg.eigvalsh(H) > 0) and hinv[j, j] > 0:
            return math.sqrt(2.0 * best_error_db ** 2 / n_eff * hinv[j, j])
    except np.linalg.LinAlgError:
        pass
    return math.inf
