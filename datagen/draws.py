"""Per-sample parameter distributions of a sweep file, and the checked readers of TOML values.

A sweep value is one of (units in the key name; ``scale`` converts to SI):

- a number: fixed for every sample;
- ``[lo, hi]``: uniform on the range (integer fields: uniform integers ``lo .. hi``);
- ``{choices = [a, b, ...]}``: one of the levels, each with the same probability;
- for string options, a list of names: one of them, each with the same probability.

Every reader raises :class:`~gearpit.errors.InputError` naming the field, the
value and what is allowed.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from gearpit.errors import require


@dataclass(frozen=True)
class Draw:
    """One per-sample parameter: fixed, uniform on a range, integer range, or a choice.

    Parameters
    ----------
    name : str
        Field name (its unit suffix included, e.g. ``snr_db``).
    kind : {"fixed", "uniform", "integer", "choice"}
    values : tuple
        ``(value,)``, ``(lo, hi)``, ``(lo, hi)`` or the choices.
    unit : str
        Unit of the value ("-" if dimensionless).
    """

    name: str
    kind: str
    values: tuple
    unit: str = "-"

    def draw(self, rng):
        """The value for one sample (``fixed`` draws nothing from ``rng``)."""
        if self.kind == "fixed":
            return self.values[0]
        if self.kind == "uniform":
            lo, hi = self.values
            return float(rng.uniform(lo, hi)) if hi > lo else float(lo)
        if self.kind == "integer":
            return int(rng.integers(self.values[0], self.values[1] + 1))
        return self.values[int(rng.integers(len(self.values)))]

    @property
    def span(self) -> tuple:
        """Smallest and largest value this draw can give (choices: all of them)."""
        return tuple(self.values) if self.kind == "choice" else (self.values[0], self.values[-1])


def is_int(v) -> bool:
    """True for a Python/TOML integer (not a bool)."""
    return isinstance(v, int) and not isinstance(v, bool)


def read_int(table, key, where, lo) -> int:
    """``table[key]`` as an integer >= ``lo``."""
    v = table[key]
    require(is_int(v) and v >= lo, f"{where}.{key}", v, f"an integer >= {lo}")
    return v


def read_number(v, field, *, positive=False) -> float:
    """A finite number (> 0 if ``positive``) as float."""
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and (v > 0 or not positive)
    require(ok, field, v, "a finite number > 0" if positive else "a finite number")
    return float(v)


def read_names(v, field, allowed) -> tuple[str, ...]:
    """A non-empty list of distinct names, each one of ``allowed``."""
    require(isinstance(v, list) and len(v) > 0, field, v, f"a non-empty list of: {', '.join(allowed)}")
    for s in v:
        require(s in allowed, field, s, f"one of: {', '.join(allowed)}")
    require(len(set(v)) == len(v), field, v, "distinct names")
    return tuple(v)


def read_draw(v, field, name, unit, bounds=None, *, scale=1.0, choices=None, integer=False) -> Draw:
    """The :class:`Draw` a sweep value describes (module docstring), checked against ``bounds`` or ``choices``.

    Parameters
    ----------
    v : number, list or table
        The TOML value.
    field : str
        Dotted name for error messages (``"operating.speed_rpm"``).
    name, unit : str
        Name and SI unit of the drawn parameter.
    bounds : (float, float)
        Allowed SI interval of numeric values (stated in the file's unit, ``bounds / scale``, in errors).
    scale : float
        Factor from the file's unit to SI (``1e-3`` for a ``_mm`` key).
    choices : tuple of str, optional
        For a string option: its allowed names.
    integer : bool
        Integer parameter (ranges draw integers).
    """
    if choices is not None:
        vals = [v] if isinstance(v, str) else v
        return Draw(name, "choice", read_names(vals, field, choices), unit)
    lo_b, hi_b = bounds
    # the bounds as the file gives the value (its key's unit)
    kind = "an integer, [lo, hi] of integers" if integer else "a number, [lo, hi]"
    allowed = (f"{kind} with lo <= hi or {{choices = [a, b, ...]}}, within "
               f"[{lo_b / scale:g}, {hi_b / scale:g}]")
    levels = isinstance(v, Mapping)
    if levels:
        require(set(v) == {"choices"} and isinstance(v["choices"], list) and len(v["choices"]) > 0, field, v,
                allowed)
        vals = v["choices"]
    else:
        vals = v if isinstance(v, list) else [v]
        require(len(vals) in (1, 2), field, v, allowed)
    for x in vals:
        ok = is_int(x) if integer else isinstance(x, (int, float)) and not isinstance(x, bool)
        require(ok and math.isfinite(x) and lo_b <= x * scale <= hi_b, field, v, allowed)
    require(levels or vals[0] <= vals[-1], field, v, allowed)
    vals = tuple(int(x) if integer else float(x) * scale for x in vals)
    if levels:
        require(len(set(vals)) == len(vals), field, v, "distinct choices")
        return Draw(name, "choice", vals, unit)
    if len(vals) == 1:
        return Draw(name, "fixed", vals, unit)
    return Draw(name, "integer" if integer else "uniform", vals, unit)
