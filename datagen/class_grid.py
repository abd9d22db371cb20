"""The class grid of a dataset sweep: which labelled classes a dataset holds.

A class is one cell of gear pair x severity bin x pitted-teeth class x pit
shape family (:func:`class_grid`); the healthy bin ``[0, 0]`` gives one class
per pair (no pitted teeth, shape ``"none"``). This module holds the class
vocabulary (:class:`SeverityBin`, :class:`TeethClass`, :class:`ClassKey`) and
reads the two entries of the sweep file's ``[classes]`` table that define it,
``severity_bins`` and ``teeth`` (:func:`read_severity_bins`,
:func:`read_teeth_classes`); the file itself is read by :mod:`datagen.sweep`.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from datagen.draws import is_int
from gearpit.errors import require

HEALTHY_SHAPE = "none"


@dataclass(frozen=True)
class SeverityBin:
    """A named severity class: pitted flank fraction in ``[min_fraction, max_fraction)``; ``[0, 0]`` = healthy."""

    name: str
    min_fraction: float
    max_fraction: float

    @property
    def healthy(self) -> bool:
        return self.max_fraction == 0.0

    def contains(self, severity: float) -> bool:
        if self.healthy:
            return severity == 0.0
        return self.min_fraction <= severity < self.max_fraction


@dataclass(frozen=True)
class TeethClass:
    """Number of pitted teeth: ``"k"`` (exactly k) or ``"k+"`` (k .. max_pitted_teeth)."""

    name: str
    low: int
    high: int


@dataclass(frozen=True)
class ClassKey:
    """One cell of the class grid."""

    pair: str
    severity_class: str
    teeth_class: str
    shape: str

    @property
    def label(self) -> str:
        return f"{self.pair}/{self.severity_class}/{self.teeth_class}/{self.shape}"


def class_grid(sweep) -> list[ClassKey]:
    """All classes, in a fixed order: per pair, the healthy class first, then bin x teeth x shape.

    ``sweep`` is a :class:`datagen.sweep.Sweep` (its pairs, severity bins, teeth classes and shapes).
    """
    out = []
    for pair in sweep.pairs:
        for b in sweep.severity_bins:
            if b.healthy:
                out.append(ClassKey(pair.name, b.name, "0", HEALTHY_SHAPE))
                continue
            for tc in sweep.teeth_classes:
                if tc.high == 0:
                    continue
                for shape in sweep.shapes:
                    out.append(ClassKey(pair.name, b.name, tc.name, shape))
    return out


def read_severity_bins(table) -> tuple[SeverityBin, ...]:
    """The bins of ``[classes.severity_bins]``: at most one healthy ``[0, 0]``, the pitted ones sorted, disjoint."""
    allowed = "a table name = [min_fraction, max_fraction] with 0 < min < max <= 1 (or [0, 0] for healthy)"
    require(isinstance(table, Mapping) and len(table) > 0, "classes.severity_bins", table, allowed)
    bins = []
    for name, edges in table.items():
        field = f"classes.severity_bins.{name}"
        ok = isinstance(edges, list) and len(edges) == 2 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and 0 <= x <= 1 for x in edges)
        require(ok, field, edges, allowed)
        lo, hi = float(edges[0]), float(edges[1])
        require((lo == hi == 0.0) or 0 < lo < hi, field, edges,
                "[0, 0] (healthy) or 0 < min < max: this bin is empty" if lo >= hi else allowed)
        bins.append(SeverityBin(name, lo, hi))
    require(sum(b.healthy for b in bins) <= 1, "classes.severity_bins", [b.name for b in bins if b.healthy],
            "at most one healthy bin [0, 0]")
    pitted = [b for b in bins if not b.healthy]
    for a, b in zip(pitted, pitted[1:]):
        require(b.min_fraction >= a.max_fraction, f"classes.severity_bins.{b.name}",
                [b.min_fraction, b.max_fraction],
                f"bins sorted by severity and not overlapping: min >= {a.max_fraction:g} (max of '{a.name}')")
    return tuple(bins)


def read_teeth_classes(cl, has_healthy, has_pitted, z_min) -> tuple[TeethClass, ...]:
    """The teeth classes of the ``[classes]`` table ``cl`` (``teeth``, ``max_pitted_teeth``), at most ``z_min``
    teeth (the pitted gear's), a ``"0"`` class exactly when there is a healthy bin."""
    names = cl.get("teeth", ["0", "1"] if has_healthy else ["1"])
    require(isinstance(names, list) and len(names) > 0 and all(isinstance(n, str) for n in names), "classes.teeth",
            names, 'a non-empty list of names like "0", "1", "2", "3+"')
    max_t = cl.get("max_pitted_teeth")
    if max_t is not None:
        require(is_int(max_t) and 1 <= max_t <= z_min, "classes.max_pitted_teeth", max_t,
                f"an integer in [1, {z_min}] (teeth of the pitted gear)")
    out = []
    for name in names:
        m = re.fullmatch(r"(\d+)(\+?)", name)
        require(m is not None, "classes.teeth", name, 'a count "k" or "k+" (k .. max_pitted_teeth)')
        low = int(m.group(1))
        if m.group(2):
            require(max_t is not None, "classes.max_pitted_teeth", None,
                    f'a value (needed by the teeth class "{name}")')
            require(max_t >= low, "classes.max_pitted_teeth", max_t, f'>= {low} (teeth class "{name}" is empty)')
            high = max_t
        else:
            high = low
        require(high <= z_min, "classes.teeth", name, f"at most {z_min} teeth (the pitted gear's teeth)")
        out.append(TeethClass(name, low, high))
    for a, b in zip(out, out[1:]):
        require(b.low > a.high, "classes.teeth", names, "increasing, non-overlapping counts")
    has_zero = any(t.high == 0 for t in out)
    require(has_zero == has_healthy, "classes.teeth", names,
            'a "0" class exactly when there is a healthy severity bin [0, 0] (else that class is empty)')
    require(not has_pitted or any(t.low > 0 for t in out), "classes.teeth", names,
            "at least one class with pitted teeth (the pitted severity bins would be empty)")
    return tuple(out)
