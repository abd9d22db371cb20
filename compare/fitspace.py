"""Which parameters of an effect the attribution fits, on which scale, and the starting grids.

Each effect declares what the comparison fits in its ``fit_parameters``
(:meth:`datagen.effects.base.Effect.fit_declaration`: field names or
:class:`datagen.effects.base.Fit` entries with bounds and a log or linear scale;
a default rule for effects that declare nothing). Built-in effects and user
plugins declare theirs the same way; this module only turns a declaration into
search coordinates:

- a parameter is searched in ``u`` in [0, 1]: linearly between its bounds, or
  in log10 from ``max(lo, hi / 1000)`` to ``hi`` on a log scale;
- a parameter in Hz starts from the frequencies the measurement itself points
  to (:func:`frequency_seeds`): centres of bands, lines at no order, and
  modulation offsets (sideband spacings) where the model falls short;
- values the effect's physics singles out at the measured operating point
  (:meth:`datagen.effects.base.Effect.fit_seeds`, :func:`operating_seeds`: a
  tip relief near the tooth deflection under the load) join the grid;
- the declared string option is tried at every value once the numeric
  parameters have a first estimate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

GRID_POINTS = 6
#: measurement-chain effects, never candidates: noise is fitted in every comparison (gain, noise floor); the
#: encoders' error belongs to the transmission-error channel, not to the accelerometer a comparison reads
CHAIN_EFFECTS = ("noise", "shaft_encoder_error")


@dataclass(frozen=True)
class FitParameter:
    """One fitted parameter: bounds, scale, unit, default."""

    name: str
    lo: float
    hi: float
    unit: str
    default: float
    log: bool

    def to_u(self, v) -> np.ndarray:
        """Value -> search coordinate in [0, 1]."""
        v = np.asarray(v, float)
        if self.log:
            a = max(self.lo, self.hi / 1000.0)
            return (np.log10(np.maximum(v, a)) - math.log10(a)) / (math.log10(self.hi) - math.log10(a))
        return (v - self.lo) / (self.hi - self.lo)

    def from_u(self, u) -> np.ndarray:
        u = np.clip(np.asarray(u, float), 0.0, 1.0)
        if self.log:
            a = max(self.lo, self.hi / 1000.0)
            v = 10 ** (math.log10(a) + u * (math.log10(self.hi) - math.log10(a)))
        else:
            v = self.lo + u * (self.hi - self.lo)
        return np.clip(v, self.lo, self.hi)     # no rounding past a bound (the effect would refuse it)

    def sigma_from_u(self, value: float, sigma_u: float) -> float:
        """1-sigma in parameter units from a 1-sigma in the search coordinate (linearised)."""
        if not math.isfinite(sigma_u):
            return math.inf
        if self.log:
            a = max(self.lo, self.hi / 1000.0)
            return value * math.log(10) * sigma_u * (math.log10(self.hi) - math.log10(a))
        return sigma_u * (self.hi - self.lo)


@dataclass(frozen=True)
class FitSpace:
    """The fitted parameters of one effect and its first string option."""

    effect: str
    params: tuple          # FitParameter
    choice: tuple | None   # (field name, values)
    transient: bool

    @property
    def n(self) -> int:
        return len(self.params)


def fit_space(effect_cls) -> FitSpace:
    """The :class:`FitSpace` of a registered effect class (its :meth:`~datagen.effects.base.Effect.fit_declaration`)."""
    fits, choice = effect_cls.fit_declaration()
    probe = effect_cls()
    defaults = probe.params()
    units = {f.name: f.metadata.get("unit", "-") for f in fields(effect_cls)}
    params = tuple(FitParameter(f.name, f.bounds[0], f.bounds[1], units[f.name],
                                float(min(max(defaults[f.name], f.bounds[0]), f.bounds[1])), f.scale == "log")
                   for f in fits)
    return FitSpace(effect_cls.name, params, choice, bool(probe.is_nonlinear or probe.is_nonstationary))


#: a fitted value within this fraction of the search coordinate's span of a bound is on the bound
BOUND_TOL_U = 1e-3


def bound_side(u: float) -> str | None:
    """"lower" / "upper" when the search coordinate ``u`` is within :data:`BOUND_TOL_U` of that bound, else None."""
    return "lower" if u <= BOUND_TOL_U else ("upper" if u >= 1.0 - BOUND_TOL_U else None)


def bounds_hit(space: FitSpace, params: dict) -> dict:
    """The numeric parameters of ``params`` (fitted values of ``space``'s effect) that lie on a bound of their
    search: name -> "lower" or "upper" (:func:`bound_side`; on a log scale the lower end is where the search
    starts, ``max(lo, hi / 1000)``)."""
    out = {}
    for p in space.params:
        v = params.get(p.name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            continue
        side = bound_side(float(p.to_u(v)))
        if side is not None:
            out[p.name] = side
    return out


def grid(p: FitParameter, n: int = GRID_POINTS) -> np.ndarray:
    """``n`` values spread evenly in the search coordinate (ends excluded: a bound is rarely the answer)."""
    return p.from_u((np.arange(n) + 0.5) / n)


def frequency_seeds(ref, residual_db: np.ndarray, p: FitParameter, *, max_seeds: int = 6,
                    threshold_db: float = 3.0) -> np.ndarray:
    """Frequencies (Hz) in ``p``'s bounds that the measurement points to, strongest first."""
    plan = ref.plan
    cand: list[tuple[float, float]] = []
    fm = plan.fm_hz
    for loc, r in zip(plan.locations, residual_db):
        if r < threshold_db or loc.freq_hz is None:
            continue
        name = loc.key.split(":", 1)[1]
        if loc.view == "band":
            cand.append((r, loc.freq_hz))
            m = max(1, round(loc.freq_hz / fm))
            cand.append((r, abs(loc.freq_hz - m * fm)))
        elif loc.view == "envelope":
            cand.append((r, loc.freq_hz))
        elif loc.view == "order" and ("+" in name or "-" in name):
            k = int(name.split("pinion" if "pinion" in name else "wheel")[1])
            fr = plan.fr_pinion_hz if "pinion" in name else plan.fr_wheel_hz
            cand.append((r, abs(k) * fr))
        elif loc.view == "order":
            cand.append((r, loc.freq_hz))
    cand.sort(key=lambda t: -t[0])
    seeds: list[float] = []
    for _, f in cand:
        if p.lo < f <= p.hi and all(abs(f - s) > 0.02 * s for s in seeds):
            seeds.append(float(f))
        if len(seeds) == max_seeds:
            break
    g = fundamental_seed(seeds)
    if g is not None and p.lo < g <= p.hi:
        seeds = [g] + seeds[:max_seeds - 1]
    return np.array(seeds) if seeds else grid(p)


def fundamental_seed(seeds: list, tol: float = 0.02) -> float | None:
    """The fundamental ``f0 / n`` (n = 2, 3) of the strongest seed ``f0`` when another seed is a multiple of it
    that ``f0`` cannot make (``m f0 / n`` with ``m`` not a multiple of ``n``, within ``tol`` of ``f0 / n``);
    None when no such seed exists or the fundamental is a seed already.

    Why: a modulation at ``f`` puts lines at every ``j f`` from the carrier, and with a large modulation index
    the first ones are not the strongest: a 1 % speed fluctuation at 23 Hz is a phase swing of 2.1 rad at the
    10th mesh harmonic (``beta = k a f_m / f``), whose strongest sidebands are then ``+/- 2 f`` (Bessel
    ``J_2(2.1) > J_1(2.1)``). Measured on a record of another simulator (``tests/foreign_rig.py``, spur pair,
    1000 rpm): the seeds were 46.0, 69.0, 131, 234, 967, 32.7 Hz, without 23 Hz, and the fit landed at 45.8 Hz
    (error 8.76 dB) although 23 Hz gives 5.2 dB. 69 Hz is 3 x 23 Hz, which a modulation at 46 Hz cannot make.
    """
    if len(seeds) < 2:
        return None
    f0 = seeds[0]
    for n in (2, 3):
        g = f0 / n
        if any(abs(s - g) <= tol * g for s in seeds):
            return None
        for s in seeds[1:]:
            m = round(s / g)
            if m >= 1 and m % n and abs(s - m * g) <= tol * g:
                return g
    return None


def operating_seeds(ref, effect_cls) -> dict:
    """``effect_cls.fit_seeds`` at the operating point of the measurement behind ``ref`` (a
    :class:`compare.comparison.Reference`), with the healthy mesh stiffness of its pair."""
    from datagen.effects.base import Effect, EffectContext

    if getattr(effect_cls.fit_seeds, "__func__", None) is Effect.fit_seeds.__func__:
        return {}
    from datagen.stiffness import mesh_stiffness

    m = ref.measurement
    ctx = EffectContext(pair=m.pair, speed_rpm=float(ref.speed.speed_rpm), torque_nm=float(m.torque_nm),
                        fs_hz=float(m.fs_hz), duration_s=len(ref.x) / float(ref.fs_hz))
    return effect_cls.fit_seeds(ctx, mesh_stiffness(m.pair))
