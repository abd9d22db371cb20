"""Error hierarchy: every message names the field, the value and what is allowed."""
from __future__ import annotations


class GearpitError(ValueError):
    """Base class of all user-facing gearpit errors (bad input, impossible design)."""


class InputError(GearpitError):
    """A value given by the user is outside what is allowed.

    Parameters
    ----------
    field : str
        Dotted name of the offending field (``"pinion.teeth"``, ``"speed_rpm"``).
    value : object
        The value that was given.
    allowed : str
        What would have been accepted (``"> 0"``, ``"one of: ellipse, rectangle"``).
    """

    def __init__(self, field: str, value: object, allowed: str):
        self.field = field
        self.value = value
        self.allowed = allowed
        super().__init__(f"{field}: got {value!r}; allowed: {allowed}")

    def __reduce__(self):
        """Pickle by the three fields, so that the error crosses a process boundary (a worker of
        :func:`compare.attribution.attribute`) as itself rather than as a failure to unpickle it."""
        return type(self), (self.field, self.value, self.allowed)


class DesignError(GearpitError):
    """A gear pair that cannot be built or cannot mesh (undercut, interference, ...)."""


def require(condition: bool, field: str, value: object, allowed: str) -> None:
    """Raise :class:`InputError` unless ``condition`` holds."""
    if not condition:
        raise InputError(field, value, allowed)


def require_positive(field: str, value: float) -> None:
    """Raise :class:`InputError` unless ``value`` is a finite number > 0."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0 and value < float("inf")
    require(ok, field, value, "a finite number > 0")


def require_range(field: str, value: float, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False) -> None:
    """Raise :class:`InputError` unless ``lo <= value <= hi`` (ends optionally open)."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if ok:
        ok = (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)
    lb = "(" if lo_open else "["
    rb = ")" if hi_open else "]"
    require(ok, field, value, f"a number in {lb}{lo}, {hi}{rb}")
