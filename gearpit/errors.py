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
        super().__init__(f"{field}: got {_shown(value)}; allowed: {allowed}")

    def __reduce__(self):
        """Pickle by the three fields, so that the error crosses a process boundary (a worker of
        :func:`compare.attribution.attribute`) as itself rather than as a failure to unpickle it."""
        return type(self), (self.field, self.value, self.allowed)


#: a table value whose repr is longer than this is shown by its keys only (a whole case dict is no message)
MAX_TABLE_REPR = 160


def _shown(value: object) -> str:
    """How an error message shows a value: its repr, but a long table (dict) by its keys only."""
    text = repr(value)
    if isinstance(value, dict) and len(text) > MAX_TABLE_REPR:
        return f"a table with keys {', '.join(map(str, value))}"
    return text


class DesignError(GearpitError):
    """A gear pair that cannot be built or cannot mesh (undercut, interference, ...)."""


class DesignLimitError(DesignError):
    """A design limit that one field breaks: ``field`` must stay below ``limit`` (a bore that leaves no rim).

    Parameters
    ----------
    field : str
        Dotted name of the field (``"pinion.bore_radius_m"``).
    value, limit : float
        The field's value and the limit it must stay below, in ``unit``.
    unit : str
    what : str
        What the value does (``"leaves no rim"``).
    why : str
        Where the limit comes from (``"root radius minus one module"``).

    A file boundary that gives the field in other units re-expresses it with :meth:`in_units`.
    """

    def __init__(self, field: str, value: float, limit: float, unit: str, what: str, why: str):
        self.field, self.value, self.limit, self.unit, self.what, self.why = field, value, limit, unit, what, why
        super().__init__(f"{field}: {value:g} {unit} {what}; allowed: < {limit:.6g} {unit} ({why})")

    def in_units(self, field: str, per_unit: float, unit: str) -> "DesignLimitError":
        """The same error for ``field`` given in ``unit`` (``per_unit``: this error's unit per ``unit``)."""
        return DesignLimitError(field, self.value / per_unit, self.limit / per_unit, unit, self.what, self.why)

    def __reduce__(self):
        return type(self), (self.field, self.value, self.limit, self.unit, self.what, self.why)


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
