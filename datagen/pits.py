"""Pit maps of a gear: pits of one shape family on chosen teeth at chosen severities.

This is the entry point the CLI and experiments use: :func:`make_pit_map` (from
arguments) and :class:`PitSpec` (from a TOML ``[pits]`` table, lengths in mm at
the file boundary). The drawing itself lives in :mod:`datagen.pitshapes`
(ellipses, rectangles, depth profiles, tolerances) and :mod:`datagen.pitcluster`
(progressive clusters); their public functions are re-exported here.

Severity is the pitted fraction of one tooth's active flank (pitted pixels /
all pixels), as the spur paper's 15/20/25 % [2]_. Randomness: tooth ``t`` draws
from :func:`tooth_rng` ``(seed, t)``, so a tooth's pits never change when other
teeth are added or removed.

References
----------
.. [1] Helical-gear pitting study (ellipsoidal / rectangular pits of uniform
   depth 0.2 mm); /work/shared/seeds/001_79b645ef5780dc4a.txt.
.. [2] Spur-gear pitting model based on image processing (15/20/25 % pitting
   near the pitch line); /work/shared/seeds/000_3879ffd8da6fd0be.txt.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from datagen.flank import FlankGrid, PitMap
from datagen.pitcluster import cluster
from datagen.pitshapes import (CLUSTER_MAX_SEVERITY, DEFAULT_DEPTH_M, DEPTH_PROFILES, DEPTH_RANGE_M,
                               default_tolerance, ellipse, max_severity, rectangle, require_depth, sized_pit,
                               subpixel_pit)
from gearpit.errors import require, require_positive, require_range
from gearpit.tomlio import check_keys

__all__ = ["SHAPES", "PitSpec", "make_pit_map", "tooth_rng", "ellipse", "rectangle", "cluster", "sized_pit",
           "max_severity", "default_tolerance", "DEFAULT_DEPTH_M", "DEPTH_PROFILES", "DEPTH_RANGE_M", "require_depth",
           "CLUSTER_MAX_SEVERITY"]

SHAPES = ("ellipse", "rectangle", "cluster")


def tooth_rng(seed: int, tooth: int) -> np.random.Generator:
    """Generator of one tooth: child ``tooth`` of ``SeedSequence(seed)``.

    It is the generator ``SeedSequence(seed).spawn(tooth + 1)[tooth]`` would
    give, so a tooth's pits never depend on which other teeth are pitted.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(int(tooth),)))


def make_pit_map(grid: FlankGrid, *, shape: str, severity: float | Mapping[int, float],
                 teeth: Sequence[int] | None = None, gear: str = "pinion", seed: int = 0,
                 depth_m: float = DEFAULT_DEPTH_M, tolerance: float | None = None,
                 aspect_w_to_s: float | None = None, profile: str = "flat",
                 pit_diameter_m: float | None = None, spread_s_m: float | None = None,
                 subpixel: bool = False) -> PitMap:
    """Pits of one shape family on a set of teeth, each at a requested severity.

    Parameters
    ----------
    grid : FlankGrid
    shape : {"ellipse", "rectangle", "cluster"}
        ``ellipse``/``rectangle``: one pit sized by :func:`sized_pit`;
        ``cluster``: progressive pitting by :func:`cluster`.
    severity : float or mapping tooth -> float
        Pitted fraction of each tooth's flank; a mapping gives each tooth its
        own severity (then ``teeth`` must be omitted or list the same teeth).
    teeth : sequence of int, optional
        Teeth to pit (numbered in mesh order, 0 first); required with a
        single ``severity``.
    gear : {"pinion", "wheel"}
    seed : int
        Seed (>= 0). Tooth ``t`` draws from :func:`tooth_rng` ``(seed, t)``, so
        adding or removing a tooth leaves the others unchanged. Ellipses and
        rectangles are deterministic and ignore it.
    depth_m : float
        Pit depth (m), default 0.2 mm [1]_, in :data:`DEPTH_RANGE_M` (1 um .. 5 mm).
    tolerance : float, optional
        Allowed |achieved - target| severity, default :func:`default_tolerance`.
    aspect_w_to_s : float, optional
        ``axis_w / axis_s`` of ellipses and rectangles (default: flank proportions).
    profile : {"flat", "bowl"}
        Depth profile of every pit.
    pit_diameter_m, spread_s_m : float, optional
        Cluster pit size and spread about the pitch line (m), see :func:`cluster`.
    subpixel : bool
        Ellipses and rectangles with their outline at sub-pixel resolution (:func:`subpixel_pit`: sized by area,
        each pixel pitted over the share the outline covers, the map's ``coverage``), so that the record moves
        continuously with the severity; default False (whole pixels, :func:`sized_pit`). Not for clusters.

    Raises
    ------
    InputError
        Unknown shape, bad teeth, or a severity outside
        ``[0, max_severity(grid, shape, aspect_w_to_s)]``.
    """
    require(shape in SHAPES, "pits.shape", shape, f"one of: {', '.join(SHAPES)}")
    per_tooth = _per_tooth_severity(severity, teeth)
    _check_options(seed, depth_m, tolerance, aspect_w_to_s, profile, pit_diameter_m, spread_s_m)
    top = max_severity(grid, shape, aspect_w_to_s)
    tol = default_tolerance(grid) if tolerance is None else tolerance
    hi, why = (top, "progressive cluster limit") if shape == "cluster" else (min(1.0, top + tol),
                                                                            f"largest {shape} that fits this flank")
    for tooth, sev in per_tooth.items():
        require(0.0 <= sev <= hi, f"pits.severity[tooth {tooth}]", sev, f"a number in [0, {hi:.4f}] ({why})")
    _check_subpixel(shape, subpixel)
    depth, coverage = {}, {}
    for tooth, sev in per_tooth.items():
        if subpixel:
            d, c = subpixel_pit(grid, shape=shape, severity=min(sev, top), depth_m=depth_m, aspect_w_to_s=aspect_w_to_s,
                                profile=profile)
            if np.any(d > 0):
                depth[tooth], coverage[tooth] = d, c
        elif shape == "cluster":
            depth[tooth] = cluster(grid, target_severity=sev, rng=tooth_rng(seed, tooth), depth_m=depth_m,
                                   tolerance=tol, pit_diameter_m=pit_diameter_m, spread_s_m=spread_s_m,
                                   profile=profile)
        else:
            depth[tooth] = sized_pit(grid, shape=shape, severity=sev, depth_m=depth_m,
                                     aspect_w_to_s=aspect_w_to_s, profile=profile, tolerance=tol)
    return PitMap(grid=grid, depth_m=depth, gear=gear, coverage=coverage)


def _check_subpixel(shape: str, subpixel) -> None:
    require(subpixel in (True, False), "pits.subpixel", subpixel, "true or false")
    require(not (subpixel and shape == "cluster"), "pits.subpixel", subpixel,
            "false for clusters (sub-pixel outlines are drawn for ellipses and rectangles)")


def _check_options(seed, depth_m, tolerance, aspect_w_to_s, profile, pit_diameter_m, spread_s_m) -> None:
    require(isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0,
            "pits.seed", seed, "an integer >= 0")
    require_depth("pits.depth_m", depth_m)
    if tolerance is not None:
        require_range("pits.tolerance", tolerance, 0.0, 0.1, lo_open=True)
    for name, v in (("aspect_w_to_s", aspect_w_to_s), ("pit_diameter_m", pit_diameter_m),
                    ("spread_s_m", spread_s_m)):
        if v is not None:
            require_positive(f"pits.{name}", v)
    require(profile in DEPTH_PROFILES, "pits.profile", profile, f"one of: {', '.join(DEPTH_PROFILES)}")


def _is_number(v) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)


def _is_tooth(t) -> bool:
    return isinstance(t, (int, np.integer)) and not isinstance(t, bool) and t >= 0


def _per_tooth_severity(severity, teeth) -> dict[int, float]:
    if isinstance(severity, Mapping):
        require(len(severity) > 0, "pits.severity", dict(severity), "at least one tooth")
        for t, v in severity.items():
            require(_is_tooth(t), "pits.tooth", t, "an integer >= 0")
            require(_is_number(v), f"pits.severity[tooth {t}]", v, "a number in [0, 1]")
        if teeth is not None:
            require(sorted(int(t) for t in teeth) == sorted(int(t) for t in severity), "pits.teeth", list(teeth),
                    f"omitted, or the teeth of the severity mapping {sorted(severity)}")
        return {int(t): float(v) for t, v in severity.items()}
    require(_is_number(severity), "pits.severity", severity, "a number in [0, 1] or a mapping tooth -> severity")
    require(teeth is not None and len(teeth) > 0, "pits.teeth", teeth, "a non-empty list of tooth indices")
    for t in teeth:
        require(_is_tooth(t), "pits.tooth", t, "an integer >= 0")
    require(len(set(int(t) for t in teeth)) == len(teeth), "pits.teeth", list(teeth), "distinct tooth indices")
    return {int(t): float(severity) for t in teeth}


#: TOML key of a ``[pits]`` table -> (PitSpec field, factor to SI or None); lengths are in mm in files
TOML_KEYS = {"shape": ("shape", None), "teeth": ("teeth", None), "severity": ("severity", None),
             "depth_mm": ("depth_m", 1e-3), "seed": ("seed", None), "aspect_w_to_s": ("aspect_w_to_s", None),
             "tolerance": ("tolerance", None), "profile": ("profile", None),
             "pit_diameter_mm": ("pit_diameter_m", 1e-3), "spread_s_mm": ("spread_s_m", 1e-3),
             "subpixel": ("subpixel", None)}


@dataclass(frozen=True)
class PitSpec:
    """Description of procedural pits, as given in a TOML ``[pits]`` table.

    Parameters
    ----------
    shape : {"ellipse", "rectangle", "cluster"}
    teeth : tuple of int
        Pitted teeth (mesh order, 0 first).
    severity : tuple of float
        Pitted fraction of each tooth's flank, in the order of ``teeth``; a
        single number is broadcast to every tooth.
    depth_m : float
        Pit depth (m).
    seed : int
        Seed of the cluster generator (>= 0).
    aspect_w_to_s, tolerance, profile, pit_diameter_m, spread_s_m, subpixel
        As in :func:`make_pit_map` (``subpixel``: an ellipse's or rectangle's outline at sub-pixel resolution; the
        pit of the ``tooth_pit`` effect is drawn so).
    """

    shape: str
    teeth: tuple[int, ...]
    severity: tuple[float, ...]
    depth_m: float = DEFAULT_DEPTH_M
    seed: int = 0
    aspect_w_to_s: float | None = None
    tolerance: float | None = None
    profile: str = "flat"
    pit_diameter_m: float | None = None
    spread_s_m: float | None = None
    subpixel: bool = False

    def __post_init__(self):
        require(self.shape in SHAPES, "pits.shape", self.shape, f"one of: {', '.join(SHAPES)}")
        teeth = self.teeth if isinstance(self.teeth, (list, tuple)) else [self.teeth]
        require(len(teeth) > 0 and all(_is_tooth(t) for t in teeth), "pits.teeth", self.teeth,
                "a non-empty list of integers >= 0")
        require(len(set(teeth)) == len(teeth), "pits.teeth", self.teeth, "distinct tooth indices")
        sev = self.severity if isinstance(self.severity, (list, tuple)) else [self.severity] * len(teeth)
        require(len(sev) == len(teeth) and all(_is_number(v) and 0 <= v <= 1 for v in sev), "pits.severity",
                self.severity, f"a number in [0, 1] or a list of {len(teeth)} such numbers (one per tooth)")
        _check_options(self.seed, self.depth_m, self.tolerance, self.aspect_w_to_s, self.profile,
                       self.pit_diameter_m, self.spread_s_m)
        _check_subpixel(self.shape, self.subpixel)
        object.__setattr__(self, "teeth", tuple(int(t) for t in teeth))
        object.__setattr__(self, "severity", tuple(float(v) for v in sev))

    @property
    def severity_by_tooth(self) -> dict[int, float]:
        return dict(zip(self.teeth, self.severity))

    @classmethod
    def from_dict(cls, table: Mapping, where: str = "pits") -> "PitSpec":
        """Build from a TOML table; lengths are given in mm (``depth_mm``, ...).

        Required keys: ``shape``, ``teeth``, ``severity`` (a fraction, one
        number or one per tooth). Optional: ``depth_mm`` (default 0.2, in [0.001, 5]),
        ``seed``, ``aspect_w_to_s``, ``tolerance``, ``profile``,
        ``pit_diameter_mm``, ``spread_s_mm``, ``subpixel`` (true: an ellipse's or rectangle's outline at
        sub-pixel resolution). Unknown keys raise InputError.

        Example TOML::

            [pits]
            shape = "cluster"
            teeth = [0, 7]
            severity = [0.15, 0.25]
            depth_mm = 0.2
            seed = 3
        """
        require(isinstance(table, Mapping), where, table, "a table of pit settings")
        check_keys(dict(table), set(TOML_KEYS), where, required={"shape", "teeth", "severity"})
        kwargs = {}
        for key, value in table.items():
            name, factor = TOML_KEYS[key]
            if key == "depth_mm":
                require_depth(f"{where}.{key}", value, "mm")
            if factor is not None:
                require(_is_number(value) and value > 0, f"{where}.{key}", value, "a finite number > 0 (mm)")
                value = float(value) * factor
            kwargs[name] = value
        return cls(**kwargs)

    def build(self, grid: FlankGrid, gear: str = "pinion") -> PitMap:
        """The pit map this spec describes on ``grid`` (see :func:`make_pit_map`)."""
        return make_pit_map(grid, shape=self.shape, severity=self.severity_by_tooth, gear=gear, seed=self.seed,
                            depth_m=self.depth_m, tolerance=self.tolerance, aspect_w_to_s=self.aspect_w_to_s,
                            profile=self.profile, pit_diameter_m=self.pit_diameter_m, spread_s_m=self.spread_s_m,
                            subpixel=self.subpixel)
