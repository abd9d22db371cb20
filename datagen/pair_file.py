"""Gear pairs at the file boundary: TOML / dict with units in the key names (mm, deg, GPa).

``pair_from_dict`` and ``load_pair`` are re-exported by :mod:`datagen.geometry`.
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from datagen.geometry import FIELD_RANGES, Gear, GearPair, Material, preset
from gearpit.errors import DesignError, DesignLimitError, InputError
from gearpit.tomlio import check_keys, read_toml

_PAIR_KEYS = {"name", "preset", "module_n_mm", "pressure_angle_n_deg", "helix_angle_deg", "addendum_coef",
              "dedendum_coef", "pinion", "wheel", "material"}
_GEAR_KEYS = {"teeth", "face_width_mm", "profile_shift", "bore_radius_mm"}
_MAT_KEYS = {"youngs_modulus_gpa", "poisson", "density_kg_m3"}


_POSITIVE_KEYS = {"face_width_mm", "bore_radius_mm", "module_n_mm", "youngs_modulus_gpa", "density_kg_m3"}
#: key of a pair file -> (field of the SI objects, factor from the key's unit to SI, the key's unit): the one place
#: where a pair's units are converted, and where errors are named as the file gives them
FILE_UNITS = {"module_n_mm": ("module_n_m", 1e-3, "mm"), "face_width_mm": ("face_width_m", 1e-3, "mm"),
              "bore_radius_mm": ("bore_radius_m", 1e-3, "mm"), "youngs_modulus_gpa": ("youngs_modulus_pa", 1e9, "GPa"),
              "pressure_angle_n_deg": ("pressure_angle_n_rad", math.pi / 180.0, "deg"),
              "helix_angle_deg": ("helix_angle_rad", math.pi / 180.0, "deg")}
_SI_KEYS = {si: (key, factor, unit) for key, (si, factor, unit) in FILE_UNITS.items()}


def _num(table: dict, key: str, where: str, default=None) -> float:
    """``table[key]`` (or ``default``) checked in the key's unit against :data:`datagen.geometry.FIELD_RANGES`,
    returned in SI."""
    v = table.get(key, default)
    name = f"{where}.{key}" if where else key
    if v is None:
        raise InputError(name, None, "a value (this key is required)")
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(name, v, "a finite number")
    if key in _POSITIVE_KEYS and v <= 0:
        raise InputError(name, v, "a number > 0")
    si_name, factor, unit = FILE_UNITS.get(key, (key, 1.0, ""))
    if si_name in FIELD_RANGES:
        lo, hi = FIELD_RANGES[si_name]
        if not lo <= v * factor <= hi:
            raise InputError(name, v, f"a number in [{lo / factor:g}, {hi / factor:g}]" + (f" {unit}" if unit else ""))
    return v * factor


def pair_from_dict(d: dict, where: str = "pair") -> GearPair:
    """Build a :class:`GearPair` from its TOML form (units in key names: mm, deg, GPa).

    A ``preset = "name"`` key starts from a preset; other keys override it. Every error names the key as the
    file gives it, under ``where`` (``pair.helix_angle_deg``, ``sweep.pairs[0].pinion.bore_radius_mm``), with
    values and limits in its unit.
    """
    if not isinstance(d, dict):
        raise InputError(where, d, "a table of gear-pair keys")
    check_keys(d, _PAIR_KEYS, where)
    base = preset(d["preset"]).to_dict() if "preset" in d else {}
    merged = {**base, **{k: v for k, v in d.items() if k not in ("preset", "pinion", "wheel", "material")}}
    for sub in ("pinion", "wheel", "material"):
        if sub in d:
            if not isinstance(d[sub], dict):
                raise InputError(f"{where}.{sub}", d[sub], "a table")
            merged[sub] = {**base.get(sub, {}), **d[sub]}
    gears = {}
    for w in ("pinion", "wheel"):
        t = merged.get(w)
        if t is None:
            raise InputError(f"{where}.{w}", None, "a table with teeth, face_width_mm (required)")
        check_keys(t, _GEAR_KEYS, f"{where}.{w}", required={"teeth", "face_width_mm"})
        teeth = t["teeth"]
        if isinstance(teeth, bool) or not isinstance(teeth, int):
            raise InputError(f"{where}.{w}.teeth", teeth, "an integer >= 5")
        gears[w] = Gear(teeth=teeth, face_width_m=_num(t, "face_width_mm", f"{where}.{w}"),
                        profile_shift=_num(t, "profile_shift", f"{where}.{w}", 0.0),
                        bore_radius_m=_num(t, "bore_radius_mm", f"{where}.{w}", 10.0))
    m = merged.get("material", {})
    check_keys(m, _MAT_KEYS, f"{where}.material")
    kwargs = dict(module_n_m=_num(merged, "module_n_mm", where),
                  pressure_angle_n_rad=_num(merged, "pressure_angle_n_deg", where, 20.0),
                  helix_angle_rad=_num(merged, "helix_angle_deg", where, 0.0),
                  addendum_coef=_num(merged, "addendum_coef", where, 1.0),
                  dedendum_coef=_num(merged, "dedendum_coef", where, 1.25))
    try:
        mat = Material(youngs_modulus_pa=_num(m, "youngs_modulus_gpa", f"{where}.material", 210.0),
                       poisson=_num(m, "poisson", f"{where}.material", 0.3),
                       density_kg_m3=_num(m, "density_kg_m3", f"{where}.material", 7850.0))
        pair = GearPair(pinion=gears["pinion"], wheel=gears["wheel"], material=mat,
                        name=str(merged.get("name", "custom")), **kwargs)
    except (InputError, DesignLimitError) as e:      # the checks of the SI objects, named as the file names them
        raise _as_written(e, where) from None
    except DesignError as e:
        raise DesignError(f"{where}: {e}") from None
    if "preset" in d and "name" not in d:
        pair = replace(pair, name=_overridden_name(d["preset"], base, pair))
    return pair


def _overridden_name(preset_name: str, base: dict, pair: GearPair) -> str:
    """The name of a preset with overrides: the preset's own when nothing changed, else ``preset[key=value,...]``
    listing every key (as the file writes it) whose value differs, so that two pairs made from one preset never
    share a name (class keys, dataset indexes and model specs tell pairs apart by it)."""
    got = pair.to_dict()
    diffs = []
    for key, value in got.items():
        if key == "name":
            continue
        if isinstance(value, dict):
            diffs += [f"{key}.{k}={v:g}" for k, v in value.items() if base.get(key, {}).get(k) != v]
        elif base.get(key) != value:
            diffs.append(f"{key}={value:g}")
    return f"{preset_name}[{','.join(diffs)}]" if diffs else preset_name


def _as_written(e, where: str):
    """``e`` (an :class:`InputError` or :class:`DesignLimitError` of the SI objects) under ``where``, its field the
    file's key and its numbers in that key's unit (:data:`FILE_UNITS`)."""
    head, _, last = e.field.rpartition(".")
    key, factor, unit = _SI_KEYS.get(last, (last, 1.0, getattr(e, "unit", "")))
    field = f"{where}.{head}.{key}" if head else f"{where}.{key}"
    if isinstance(e, InputError):
        return InputError(field, e.value / factor if factor != 1.0 else e.value, e.allowed)
    return e.in_units(field, factor, unit)


def load_pair(path: str | Path) -> GearPair:
    """Read a gear pair from a TOML file (a ``[pair]`` table or top-level keys)."""
    d = read_toml(path)
    return pair_from_dict(d["pair"] if "pair" in d else d)
