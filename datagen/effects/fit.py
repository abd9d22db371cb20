"""What the model-vs-measurement comparison fits of an effect: :class:`Fit` entries and their resolution.

An effect declares ``fit_parameters`` (field names or :class:`Fit` entries; see
:mod:`datagen.effects.base`, rule 6); :func:`resolve_fit` turns the declaration,
or the default rule when there is none, into bounded :class:`Fit` entries with a
"log" or "linear" scale and the string option tried at every value. Kept apart
from the effect contract because only :mod:`compare` consumes it.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

from gearpit.errors import InputError

#: scales of a fitted parameter (:class:`Fit`)
FIT_SCALES = ("auto", "log", "linear")
#: fitted numeric parameters when an effect declares none
MAX_FIT = 2
#: bounds spanning more than this factor are searched on a log scale ("auto")
LOG_SPAN = 30.0


@dataclass(frozen=True)
class Fit:
    """One parameter the comparison fits (entry of :attr:`Effect.fit_parameters`).

    Parameters
    ----------
    name : str
        Field name of the effect.
    bounds : (float, float) or None
        Search interval (field units), inside the field's bounds; None: the field's bounds.
    scale : {"auto", "log", "linear"}
        Search coordinate; ``"auto"`` resolves as described in :mod:`datagen.effects.base` (rule 6). A log scale whose lower
        bound is 0 searches from ``hi / 1000``.
    """

    name: str
    bounds: tuple | None = None
    scale: str = "auto"

    def __post_init__(self):
        if self.scale not in FIT_SCALES:
            raise InputError(f"fit parameter {self.name}.scale", self.scale, f"one of: {', '.join(FIT_SCALES)}")


def resolve_fit(cls) -> tuple[tuple[Fit, ...], tuple[str, tuple] | None]:
    """The fitted numeric parameters of effect class ``cls`` (resolved :class:`Fit`: bounds set, scale "log" or
    "linear") and the string option tried at every value (``(field, choices)`` or None).

    Raises :class:`InputError` for an entry that names no field, a numeric entry with bounds outside the
    field's, or more than one string option.
    """
    by_name = {f.name: f for f in fields(cls)}
    declared = cls.fit_parameters
    if declared is None:
        numeric = [f.name for f in fields(cls) if "bounds" in f.metadata and f.metadata.get("unit") != "rad"]
        choice = next((f.name for f in fields(cls) if "choices" in f.metadata), None)
        declared = tuple(numeric[:MAX_FIT]) + ((choice,) if choice else ())
    where = f"effect {cls.name}.fit_parameters"
    if not isinstance(declared, (tuple, list)):
        raise InputError(where, declared, "a tuple of field names or Fit entries")
    numeric_fits, choices = [], []
    for item in declared:
        fit = Fit(item) if isinstance(item, str) else item
        if not isinstance(fit, Fit) or fit.name not in by_name:
            raise InputError(where, item, f"a field name or Fit of a field: {', '.join(by_name) or '(none)'}")
        meta = by_name[fit.name].metadata
        if "choices" in meta:
            choices.append((fit.name, tuple(meta["choices"])))
            continue
        flo, fhi = (float(v) for v in meta["bounds"])
        lo, hi = (flo, fhi) if fit.bounds is None else (float(fit.bounds[0]), float(fit.bounds[1]))
        if not (flo <= lo < hi <= fhi):
            raise InputError(f"{where}.{fit.name}.bounds", fit.bounds, f"lo < hi inside the field's [{flo}, {fhi}]")
        scale = fit.scale
        if scale == "auto":
            scale = "log" if (lo > 0 and hi / lo > LOG_SPAN) or (lo == 0 and 0 < hi <= 1.0) else "linear"
        if scale == "log" and hi <= 0:
            raise InputError(f"{where}.{fit.name}.scale", "log", "a positive upper bound for a log scale")
        numeric_fits.append(Fit(fit.name, (lo, hi), scale))
    if len(choices) > 1:
        raise InputError(where, [c[0] for c in choices], "at most one string option")
    return tuple(numeric_fits), (choices[0] if choices else None)


__all__ = ["FIT_SCALES", "Fit", "LOG_SPAN", "MAX_FIT", "resolve_fit"]
