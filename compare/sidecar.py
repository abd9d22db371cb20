"""The sidecar of a measurement file: what the file cannot say about itself, read, checked and found beside it.

A measurement is a file (any layout of :mod:`compare.formats`) plus a *sidecar*
(JSON or TOML, same keys) that says what the file cannot; :mod:`compare.measurement` loads and validates the two:

=========================  ========  ==========================================================
key                        required  meaning
=========================  ========  ==========================================================
``fs_hz``                  [1]_      sampling rate (Hz)
``speed_rpm``              [2]_      nominal pinion (input) speed (rpm); refined from the data
``torque_nm``              [2]_      pinion (input) torque (N m)
``pair``                   yes       preset name (``"spur-gds"``) or a pair table as in a pair TOML
``sensor``                 [2]_      the vibration channel: name or 0-based index in the file's order
                                     (README, "A channel index")
``sensor_quantity``        no        what the sensor measures: ``"acceleration"`` (default),
                                     ``"velocity"`` or ``"displacement"`` (read as acceleration:
                                     :func:`features.derivative.derivative`)
``sensor_unit``            no        the unit of the sensor channel's numbers (:mod:`compare.sensor_units`):
                                     a unit of ``sensor_quantity`` (``"m/s^2"``, ``"mm/s^2"``, ``"g"``;
                                     ``"m/s"``, ``"mm/s"``, ``"in/s"``; ``"m"``, ``"mm"``, ``"um"``) or
                                     ``"V"``, ``"mV"``, ``"counts"``, ``"fullscale"`` with the two keys
                                     below; brought to SI on loading. None: the numbers as they are
``sensor_sensitivity``     no        with a signal unit: the file's units per one
                                     ``sensor_sensitivity_unit`` (100 mV/g in mV: ``100``, ``"g"``)
``sensor_sensitivity_unit`` no       a unit of ``sensor_quantity`` (above)
``tacho``                  no        tachometer channel (name or index); none: speed from the spectrum
``tacho_pulses_per_rev``   no        pulses per revolution of ``tacho_shaft`` (default 1)
``tacho_shaft``            no        ``"pinion"`` (default) or ``"wheel"``
``fault``                  no        free label (``"healthy"``, ``"pitting_L"``, ...)
``secondary``              no        further channels: a table {column: simulated channel}, e.g.
                                     ``{te_um = "dte_m"}`` (:mod:`compare.channels`: they settle effects
                                     the sensor cannot tell apart); each column's gain is fitted
``channels``               no        names of the columns of a file without names
``time_column``            no        CSV column holding time (s) (default: one named ``time``/``t``,
                                     also among ``channels``; a unit in the name: ``time_ms``)
``variable``               no        NPZ/MAT variable to read when the file holds several
``format``                 no        one of :data:`compare.formats.FORMATS` (default ``"auto"``)
``start_s``, ``duration_s`` no       keep only this part of the record (s)
``reference``              no        a healthy recording of the same machine at the same operating
                                     point (a measurement file with its own sidecar, path relative
                                     to this file's folder), for classifiers read against a
                                     reference (:mod:`models.representations`, ``reference = true``)
=========================  ========  ==========================================================

.. [1] unless the file gives it (time column, WAV header, ``fs`` variable, a public layout).
.. [2] unless the public layout's file name or format gives it.

Refused with :class:`gearpit.errors.InputError` naming the field: unknown keys, a missing ``pair``, a value of the
wrong type or outside its range, a JSON file that is ``gearpit simulate``'s metadata; beside a measurement, two
sidecars (:func:`find_sidecar`).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from glob import escape as glob_escape
from pathlib import Path
from typing import Any

from compare.formats import FORMATS
from compare.sensor_units import check_sensor_unit, unit_factor
from gearpit.errors import InputError, require, require_positive
from gearpit.tomlio import check_keys, read_toml

SIDECAR_KEYS = ("fs_hz", "speed_rpm", "torque_nm", "pair", "sensor", "sensor_quantity", "sensor_unit",
                "sensor_sensitivity", "sensor_sensitivity_unit", "tacho", "tacho_pulses_per_rev", "tacho_shaft",
                "fault", "channels", "time_column", "variable", "format", "start_s", "duration_s",
                "secondary", "reference")
SIDECAR_SUFFIXES = (".toml", ".json", ".meta.toml", ".meta.json")
#: keys that mark a JSON file as the metadata ``gearpit simulate`` writes beside its record
#: (:attr:`datagen.simulate.Signals.metadata`), which is never a sidecar
SIMULATE_METADATA_KEYS = frozenset({"case", "software_version", "mesh_frequency_hz"})
#: sidecar ``sensor_quantity`` -> times the record is differentiated to read it as acceleration
SENSOR_QUANTITIES = {"acceleration": 0, "velocity": 1, "displacement": 2}


@dataclass(frozen=True)
class Sidecar:
    """The sidecar's content, validated (module docstring; SI, speeds in rpm as named)."""

    pair: Any
    speed_rpm: float | None = None
    torque_nm: float | None = None
    fs_hz: float | None = None
    sensor: str | int | None = None
    sensor_quantity: str = "acceleration"
    #: the unit of the sensor's numbers (:mod:`compare.sensor_units`); None: not declared
    sensor_unit: str | None = None
    sensor_sensitivity: float | None = None
    sensor_sensitivity_unit: str | None = None
    tacho: str | int | None = None
    tacho_pulses_per_rev: int = 1
    tacho_shaft: str = "pinion"
    fault: str | None = None
    channels: tuple | None = None
    time_column: str | None = None
    variable: str | None = None
    format: str = "auto"
    start_s: float = 0.0
    duration_s: float | None = None
    secondary: dict | None = None
    reference: str | None = None

    @classmethod
    def from_dict(cls, d: dict, where: str = "sidecar") -> "Sidecar":
        """Build from the parsed JSON/TOML; unknown keys and bad values raise :class:`InputError`."""
        require(isinstance(d, dict), where, type(d).__name__, "a table of sidecar keys")
        d = {k: v for k, v in d.items() if v is not None}     # JSON null: absent, as the key left out
        check_keys(d, SIDECAR_KEYS, where, required={"pair"})
        pair = _pair(d["pair"], f"{where}.pair")
        kw: dict[str, Any] = {"pair": pair}
        for key in ("speed_rpm", "torque_nm", "fs_hz", "start_s", "duration_s"):
            if key in d:
                v = d[key]
                ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                require(ok, f"{where}.{key}", v, "a finite number")
                if key not in ("start_s", "torque_nm"):
                    require_positive(f"{where}.{key}", float(v))
                if key == "start_s":
                    require(v >= 0, f"{where}.{key}", v, "a number >= 0")
                if key == "torque_nm":
                    check_torque(f"{where}.{key}", v)
                kw[key] = float(v)
        for key in ("sensor", "tacho"):
            if key in d:
                v = d[key]
                require((isinstance(v, str) and v != "") or (isinstance(v, int) and not isinstance(v, bool) and v >= 0),
                        f"{where}.{key}", v, "a channel name or a 0-based column index")
                kw[key] = v
        if "tacho_pulses_per_rev" in d:
            v = d["tacho_pulses_per_rev"]
            require(isinstance(v, int) and not isinstance(v, bool) and v >= 1, f"{where}.tacho_pulses_per_rev", v,
                    "an integer >= 1")
            kw["tacho_pulses_per_rev"] = v
        if "tacho_shaft" in d:
            require(d["tacho_shaft"] in ("pinion", "wheel"), f"{where}.tacho_shaft", d["tacho_shaft"],
                    "pinion or wheel")
            kw["tacho_shaft"] = d["tacho_shaft"]
        if "channels" in d:
            ch = d["channels"]
            require(isinstance(ch, list) and ch and all(isinstance(c, str) and c for c in ch)
                    and len(set(ch)) == len(ch), f"{where}.channels", ch, "a list of distinct channel names")
            kw["channels"] = tuple(ch)
        for key in ("fault", "time_column", "variable", "reference"):
            if key in d:
                require(isinstance(d[key], str) and d[key] != "", f"{where}.{key}", d[key], "a non-empty string")
                kw[key] = d[key]
        if "sensor_quantity" in d:
            require(d["sensor_quantity"] in SENSOR_QUANTITIES, f"{where}.sensor_quantity", d["sensor_quantity"],
                    "one of: " + ", ".join(SENSOR_QUANTITIES))
            kw["sensor_quantity"] = d["sensor_quantity"]
        unit_keys = ("sensor_unit", "sensor_sensitivity", "sensor_sensitivity_unit")
        check_sensor_unit(*(d.get(k) for k in unit_keys), kw.get("sensor_quantity", "acceleration"), where)
        kw.update({k: (float(d[k]) if k == "sensor_sensitivity" else d[k]) for k in unit_keys if k in d})
        if "format" in d:
            require(d["format"] in FORMATS, f"{where}.format", d["format"], "one of: " + ", ".join(FORMATS))
            kw["format"] = d["format"]
        if "secondary" in d:
            kw["secondary"] = _secondary(d["secondary"], f"{where}.secondary")
        return cls(**kw)

    def unit_factor(self) -> float:
        """The factor that brings the sensor channel's numbers to SI (:func:`compare.sensor_units.unit_factor`;
        1 when no unit is declared)."""
        if self.sensor_unit is None:
            return 1.0
        return unit_factor(self.sensor_unit, self.sensor_quantity, sensitivity=self.sensor_sensitivity,
                           sensitivity_unit=self.sensor_sensitivity_unit)

    def to_dict(self) -> dict:
        """JSON-able form (the pair as its table)."""
        out = {k: getattr(self, k) for k in SIDECAR_KEYS if k != "pair" and getattr(self, k) is not None}
        if self.channels is not None:
            out["channels"] = list(self.channels)
        if self.secondary is not None:
            out["secondary"] = dict(self.secondary)
        out["pair"] = self.pair.to_dict()
        return out


def check_torque(field: str, value) -> None:
    """The pinion torque in :data:`datagen.case_options.TORQUE_RANGE_NM` (an unloaded pair cannot be simulated)."""
    from datagen.case_options import TORQUE_RANGE_NM

    lo, hi = TORQUE_RANGE_NM
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and lo <= value <= hi
    require(ok, field, value, f"a number in [{lo:g}, {hi:g}] N m (> 0: a loaded pair; the pinion torque)")


def simulated_channels() -> tuple[str, ...]:
    """Names of the channels a simulation outputs (:mod:`datagen.output_channels`; axial ones for helical pairs
    only), the tacho pulses excepted."""
    from datagen.output_channels import channel_names

    return tuple(c for c in channel_names(8) if not c.startswith("_"))


def _secondary(value, where: str) -> dict:
    sim = simulated_channels()
    require(isinstance(value, dict) and value, where, value, "a table {measured column: simulated channel}")
    for col, ch in value.items():
        require(isinstance(col, str) and col, where, col, "column names")
        require(ch in sim, f"{where}.{col}", ch, "a simulated channel: " + ", ".join(sim))
    return {str(k): str(v) for k, v in value.items()}


def _pair(value, where: str):
    from datagen.geometry import preset
    from datagen.pair_file import pair_from_dict

    if isinstance(value, str):
        from datagen.geometry import PRESETS

        require(value in PRESETS, where, value, f"a preset ({', '.join(PRESETS)}) or a [pair] table")
        return preset(value)
    require(isinstance(value, dict), where, value, "a preset name or a pair table")
    return pair_from_dict(value, where=where)


def read_sidecar(path: str | Path) -> Sidecar:
    """Read a JSON (``.json``) or TOML sidecar (UTF-8, a byte-order mark as Windows editors write it skipped; a
    JSON ``null`` is a key left out)."""
    p = Path(path)
    if p.suffix.lower() == ".json":
        try:
            d = json.loads(p.read_text(encoding="utf-8-sig"))
        except OSError as exc:
            raise InputError("sidecar", str(p), f"a readable JSON file ({exc.strerror})") from None
        except json.JSONDecodeError as exc:
            raise InputError("sidecar", str(p), f"valid JSON ({exc})") from None
        require(not is_simulate_metadata(d), "sidecar", str(p), "a sidecar (this is gearpit simulate's metadata, "
                "not a sidecar: write one with fs_hz, speed_rpm, torque_nm, pair, sensor)")
    else:
        d = read_toml(p)
    return Sidecar.from_dict(d, where=p.name)


def is_simulate_metadata(d) -> bool:
    """Whether a parsed JSON file is ``gearpit simulate``'s metadata (:data:`SIMULATE_METADATA_KEYS`)."""
    return isinstance(d, dict) and SIMULATE_METADATA_KEYS <= set(d)


def _is_simulate_metadata_file(path: Path) -> bool:
    if path.suffix.lower() != ".json":
        return False
    try:
        return is_simulate_metadata(json.loads(path.read_text(encoding="utf-8-sig")))
    except (OSError, ValueError):       # unreadable or not JSON: read_sidecar says why
        return False


class NoSidecarError(InputError):
    """No sidecar beside a measurement (:func:`find_sidecar`): the caller may leave a template for it."""


def find_sidecar(measurement_path: str | Path) -> Path:
    """The sidecar beside a measurement: same stem with one of :data:`SIDECAR_SUFFIXES`. A JSON file that is
    ``gearpit simulate``'s metadata (the ``case.json`` beside ``case.csv``) is passed over, and the error when no
    sidecar is found (:class:`NoSidecarError`) says so; two sidecars (``rig.toml`` and ``rig.json``) are refused
    naming both (``--meta`` picks one)."""
    p = Path(measurement_path)
    if p.suffix.lower() in (".toml", ".json"):          # a sidecar (or a model, a case) given as the measurement
        beside = sorted(c.name for c in p.parent.glob(glob_escape(p.name.split(".")[0]) + ".*")
                        if c.suffix.lower() not in (".toml", ".json", ".template", ".jsonl", ".lock") and c.is_file())
        raise InputError("measurement", p.name, f"a measurement file (CSV/TXT, NPY, NPZ, WAV, MAT): {p.name} is a "
                         f"sidecar (or another {p.suffix.lower()[1:].upper()} description), not a measurement; give "
                         "the data file it describes" + (f" ({', '.join(beside)} beside it)" if beside else ""))
    candidates = [p.with_name(p.stem + s) for s in SIDECAR_SUFFIXES] + [p.with_name(p.name + s) for s in (".toml", ".json")]
    found, skipped = [], []
    for c in candidates:
        if c.is_file() and c != p and c not in found:
            (skipped if _is_simulate_metadata_file(c) else found).append(c)
    if len(found) > 1:
        raise InputError("sidecar", " and ".join(c.name for c in found),
                         f"one sidecar beside {p.name} (give the one to use with --meta, or remove the others)")
    if found:
        return found[0]
    note = "".join(f"; {c.name} beside it is gearpit simulate's metadata, not a sidecar" for c in skipped)
    raise NoSidecarError("--meta", None, "a sidecar (JSON/TOML) given with --meta or found beside the file as "
                         + " or ".join(c.name for c in candidates[:2]) + note)
