"""Which parameters of an effect the attribution fits, on which scale, and the starting grids.

Rules (any registered effect, built-in or plugin):

- an effect class may name its fit parameters in a class attribute
  ``fit_parameters = ("a", "b")``; otherwise the first :data:`MAX_FIT`
  numeric fields whose unit is not ``rad`` are fitted (phases leave the
  amplitude spectra, envelope and TSA levels unchanged, so they are held at
  their defaults); every other field keeps its default;
- a parameter is searched on a log scale (from ``max(lo, hi / 1000)`` to ``hi``)
  when its bounds are positive and span more than a factor :data:`LOG_SPAN`, or
  when they start at 0 and end at most at 1 (SI magnitudes such as lengths in m
  or fractions, where 0 means "off"); otherwise linearly (a grade, a count);
- a parameter in Hz starts from the frequencies the measurement itself points
  to (:func:`frequency_seeds`): centres of bands, lines at no order, and
  modulation offsets (sideband spacings) where the model falls short;
- the first string option (``choices``) is tried at every value once the
  numeric parameters have a first estimate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

MAX_FIT = 2
LOG_SPAN = 30.0
GRID_POINTS = 6
#: measurement-chain effects: fitted in every comparison (gain, noise floor), never candidates
CHAIN_EFFECTS = ("noise",)
#: fit parameters of built-in effects whose field order alone would pick a degenerate one
#: (a housing mass only scales the level, which the gain fit absorbs)
DEFAULT_FIT_PARAMETERS = {
    "transmission_path": ("housing_frequency_hz", "housing_damping_ratio"),
    "speed_fluctuation": ("frequency_hz", "amplitude_fraction"),
    "torque_fluctuation": ("frequency_hz", "amplitude_fraction"),
    # the displaced tooth is given in units of the grade's f_pt: grade and factor trade off along a valley
    "pitch_error": ("grade",),
}


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
            return 10 ** (math.log10(a) + u * (math.log10(self.hi) - math.log10(a)))
        return self.lo + u * (self.hi - self.lo)

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
    """The :class:`FitSpace` of a registered effect class (module docstring)."""
    named = getattr(effect_cls, "fit_parameters", None) or DEFAULT_FIT_PARAMETERS.get(effect_cls.name)
    numeric = [f for f in fields(effect_cls) if "bounds" in f.metadata]
    if named is None:
        named = [f.name for f in numeric if f.metadata.get("unit") != "rad"][:MAX_FIT]
    by_name = {f.name: f for f in numeric}
    params = []
    for name in named:
        f = by_name[name]
        lo, hi = (float(v) for v in f.metadata["bounds"])
        log = (lo > 0 and hi / lo > LOG_SPAN) or (lo == 0 and 0 < hi <= 1.0)
        params.append(FitParameter(name, lo, hi, f.metadata.get("unit", "-"), float(f.default), log))
    choice = next(((f.name, tuple(f.metadata["choices"])) for f in fields(effect_cls) if "choices" in f.metadata), None)
    probe = effect_cls()
    return FitSpace(effect_cls.name, tuple(params), choice, bool(probe.is_nonlinear or probe.is_nonstationary))


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
    return np.array(seeds) if seeds else grid(p)
