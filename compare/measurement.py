"""A measured vibration record and its operating point: sidecar, loading, validation.

A measurement is a file (any layout of :mod:`compare.formats`) plus a *sidecar*
(JSON or TOML, same keys) that says what the file cannot:

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
                                     below; brought to SI here. None: the numbers as they are
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

Refused with :class:`gearpit.errors.InputError` naming the field: unknown keys, a
missing fs, NaN or infinite samples (first bad sample named), a wrong column count, two columns of one name,
a constant sensor channel, a record shorter than two revolutions of the slower shaft.
"""
from __future__ import annotations

import json
import math
from glob import escape as glob_escape
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from compare.array_files import FS_KEYS
from compare.formats import FORMATS, read_record
from compare.sensor_units import check_sensor_unit, unit_factor
from compare.text_records import MIN_FS_HZ
from gearpit.errors import InputError, require, require_positive
from gearpit.tomlio import check_keys, read_toml

SIDECAR_KEYS = ("fs_hz", "speed_rpm", "torque_nm", "pair", "sensor", "sensor_quantity", "sensor_unit",
                "sensor_sensitivity", "sensor_sensitivity_unit", "tacho", "tacho_pulses_per_rev", "tacho_shaft",
                "fault", "channels", "time_column", "variable", "format", "start_s", "duration_s",
                "secondary", "reference")
SIDECAR_SUFFIXES = (".toml", ".json", ".meta.toml", ".meta.json")
MIN_REVOLUTIONS = 2.0
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
                    _check_torque(f"{where}.{key}", v)
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


def _check_torque(field: str, value) -> None:
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


@dataclass(frozen=True, eq=False)
class Measurement:
    """A validated record: all channels, the sensor and tacho names, fs and the operating point.

    Attributes
    ----------
    channels : dict of str -> ndarray (n,)
    fs_hz : float
    sensor, tacho : str, str or None
        Channel names.
    speed_rpm, torque_nm : float
        Nominal pinion speed (rpm) and torque (N m) from the sidecar (or file name).
    pair : GearPair
    sidecar : Sidecar
    source : str
        Where it came from.
    """

    channels: dict
    fs_hz: float
    sensor: str
    tacho: str | None
    speed_rpm: float
    torque_nm: float
    pair: Any
    sidecar: Sidecar
    source: str = ""
    fault: str | None = None
    #: further channels: measured column -> the simulated channel it corresponds to (sidecar ``secondary``)
    secondary: dict = field(default_factory=dict)
    #: the sidecar file read (found beside the file or given with ``--meta``); None: given as a :class:`Sidecar`
    sidecar_path: str | None = None

    @property
    def signal(self) -> np.ndarray:
        """The sensor channel."""
        return self.channels[self.sensor]

    @property
    def n_samples(self) -> int:
        return int(self.signal.size)

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.fs_hz

    @property
    def tacho_signal(self) -> np.ndarray | None:
        return None if self.tacho is None else self.channels[self.tacho]


def _channel(ref, names: tuple, where: str, no_index: str = "", columns: tuple = ()) -> str:
    """The channel ``ref`` (a name, or a 0-based index in the file's order) names. ``columns``: the file's columns
    as written, a time column included (:attr:`compare.raw_record.RawRecord.columns`; empty: ``names``), which an
    index counts, and an index at the time column is refused; ``no_index``: why the file's order is not known
    (:attr:`compare.raw_record.RawRecord.no_index`), which refuses an index."""
    if isinstance(ref, int):
        require(not no_index, where, ref, f"a channel name ({no_index}, so a column index could name the wrong "
                "channel): one of " + ", ".join(names))
        cols = tuple(columns) or names
        require(ref < len(cols), where, ref, f"a column index in [0, {len(cols) - 1}] (the file's columns as "
                "written: " + ", ".join(cols) + ")")
        require(cols[ref] in names, where, ref, f"a data column: column {ref} ({cols[ref]}) is the time column, "
                "read as the time axis, not a channel; one of " + ", ".join(f"{cols.index(n)} ({n})" for n in names))
        return cols[ref]
    require(ref in names, where, ref, "one of: " + ", ".join(names))
    return ref


def fs_source(sidecar: Sidecar, source: str) -> str:
    """Where the sampling rate of a measurement read from ``source`` with ``sidecar`` came from, for the messages
    that question it (a rate below :data:`MIN_FS_HZ`, a mesh frequency above the Nyquist frequency)."""
    if sidecar.fs_hz is not None:
        return "the sidecar's fs_hz"
    p = Path(source)
    suffix = p.suffix.lower()
    if suffix == ".wav":
        return f"the WAV header of {p.name}"
    if suffix in (".npz", ".mat"):
        return f"{p.name}'s own rate (its scalar {'/'.join(FS_KEYS[:3])}, read as Hz, or its time vector)"
    if suffix:
        column = f" {sidecar.time_column}" if sidecar.time_column else ""
        return f"{p.name}'s own rate (its time column{column}, or its layout's)"
    return "the rate given with the records"


def measurement_from_arrays(channels: dict, sidecar: Sidecar, *, source: str = "arrays",
                            hints: dict | None = None, read_as: str = "acceleration",
                            no_index: str = "", columns: tuple = ()) -> Measurement:
    """Validate channels (name -> 1-D array) against a sidecar; the one place all checks live. ``read_as``: the
    quantity the sensor channel is brought to (one of :data:`SENSOR_QUANTITIES`, differentiated from the sidecar's
    ``sensor_quantity``; never integrated). A channel index counts ``columns`` (the file's columns as written, a
    time column included; empty: ``channels`` in their order); ``no_index``: why it cannot (:func:`_channel`)."""
    hints = hints or {}
    names = tuple(channels)
    require(names, "channels", "none", "at least one channel")
    n = {np.asarray(v).size for v in channels.values()}
    require(len(n) == 1, "channels", {k: np.asarray(v).size for k, v in channels.items()}, "equal lengths")
    fs = sidecar.fs_hz if sidecar.fs_hz is not None else hints.get("fs_hz")
    require(fs is not None, "fs_hz", None, "a sampling rate: give fs_hz in the sidecar (or a time column)")
    require_positive("fs_hz", float(fs))
    require(float(fs) >= MIN_FS_HZ, "fs_hz", f"{float(fs):.4g} Hz from {fs_source(sidecar, source)}",
            f"a vibration record's rate (>= {MIN_FS_HZ:g} Hz; a rate in kHz? write it in Hz)")
    speed = sidecar.speed_rpm if sidecar.speed_rpm is not None else hints.get("speed_rpm")
    require(speed is not None, "speed_rpm", None, "the nominal pinion speed in the sidecar")
    require_positive("speed_rpm", float(speed))
    torque = sidecar.torque_nm if sidecar.torque_nm is not None else hints.get("torque_nm", None)
    require(torque is not None, "torque_nm", None, "the pinion torque in the sidecar")
    _check_torque("torque_nm", torque)
    sensor_ref = sidecar.sensor if sidecar.sensor is not None else hints.get("sensor")
    if sensor_ref is None and len(names) == 1:
        sensor_ref = names[0]
    require(sensor_ref is not None, "sensor", None, "which channel is the sensor: one of " + ", ".join(names))
    sensor = _channel(sensor_ref, names, "sensor", no_index, columns)
    tacho_ref = sidecar.tacho if sidecar.tacho is not None else hints.get("tacho")
    tacho = _channel(tacho_ref, names, "tacho", no_index, columns) if tacho_ref is not None else None
    require(tacho != sensor, "tacho", tacho, "a channel other than the sensor")
    data = {k: np.asarray(v, dtype=float).ravel() for k, v in channels.items()}
    pair = sidecar.pair
    slow_hz = pair.shaft_frequency_hz("wheel" if pair.wheel.teeth >= pair.pinion.teeth else "pinion", float(speed))
    n_min = int(math.ceil(MIN_REVOLUTIONS * fs / slow_hz))
    length_s = data[sensor].size / fs
    latest_s = (data[sensor].size - n_min) / fs
    require(sidecar.start_s == 0.0 or sidecar.start_s <= latest_s, "start_s", sidecar.start_s,
            f"<= {max(latest_s, 0.0):.4g} s: the record length {length_s:.4g} s minus two revolutions of the slower "
            f"shaft ({MIN_REVOLUTIONS / slow_hz:.3g} s at {float(speed):g} rpm)")
    i0 = int(round(sidecar.start_s * fs))
    i1 = data[sensor].size if sidecar.duration_s is None else i0 + int(round(sidecar.duration_s * fs))
    require(i1 <= data[sensor].size, "start_s + duration_s", sidecar.start_s + (sidecar.duration_s or 0.0),
            f"<= the record length {data[sensor].size / fs:.4g} s")
    data = {k: v[i0:i1] for k, v in data.items()}
    secondary = dict(sidecar.secondary or {})
    for col in secondary:
        require(col in names, f"secondary.{col}", col, "a column of the file: " + ", ".join(names))
        require(col not in (sensor, tacho), f"secondary.{col}", col, "a channel other than the sensor and the tacho")
    for key in (sensor,) + ((tacho,) if tacho else ()) + tuple(secondary):
        bad = np.nonzero(~np.isfinite(data[key]))[0]
        require(bad.size == 0, f"channel {key}", f"{bad.size} NaN/inf samples, first at index {bad[:1].tolist()}",
                "finite samples only (an empty cell of a text file is read as NaN)")
    for key in (sensor,) + tuple(secondary):
        require(float(np.ptp(data[key])) > 0, f"channel {key}", "constant", "a varying signal")
    data[sensor] = data[sensor] * sidecar.unit_factor()      # SI from here on (sidecar sensor_unit)
    require(read_as in SENSOR_QUANTITIES, "read_as", read_as, "one of: " + ", ".join(SENSOR_QUANTITIES))
    order = SENSOR_QUANTITIES[sidecar.sensor_quantity] - SENSOR_QUANTITIES[read_as]
    require(order >= 0, "sensor_quantity", sidecar.sensor_quantity,
            f"a quantity that can be differentiated to {read_as} (integration is not offered)")
    if order:      # read as read_as; every channel loses the samples the derivative cannot form
        from features.derivative import HALF_TAPS, derivative

        cut = order * HALF_TAPS
        require(data[sensor].size > 2 * cut + 1, "measurement length", data[sensor].size,
                f"> {2 * cut + 1} samples to read the {sidecar.sensor_quantity} as {read_as}")
        data = {k: (derivative(v, float(fs), order) if k == sensor else v[cut:-cut]) for k, v in data.items()}
    require(data[sensor].size >= n_min, "measurement length", f"{data[sensor].size} samples "
            f"({data[sensor].size / fs:.3g} s)", f">= {n_min} samples: two revolutions of the slower shaft "
            f"({MIN_REVOLUTIONS / slow_hz:.3g} s at {float(speed):g} rpm)")
    fault = sidecar.fault if sidecar.fault is not None else hints.get("fault")
    return Measurement(channels=data, fs_hz=float(fs), sensor=sensor, tacho=tacho, speed_rpm=float(speed),
                       torque_nm=float(torque), pair=pair, sidecar=sidecar, source=source, fault=fault,
                       secondary=secondary)


def _columns_as_written(rec, names: tuple) -> tuple:
    """The sidecar's ``names`` of ``rec``'s data columns, with a time column the reader took out
    (:attr:`compare.raw_record.RawRecord.columns`) put back in its place: the file's columns as written."""
    if len(rec.columns) <= len(rec.names):
        return tuple(names)
    i = next((j for j, (a, b) in enumerate(zip(rec.columns, rec.names)) if a != b), len(rec.names))
    return tuple(names[:i]) + (rec.columns[i],) + tuple(names[i:])


def _time_from_channels(rec, names: tuple, time_column: str | None, where: str, fs_hz: float | None = None):
    """A file without names whose sidecar ``channels`` name its time column (``time_column``, or a name of
    :mod:`compare.text_records`): the rate from it (the sidecar's ``fs_hz`` where the column is not uniform), and
    it is no channel. ``rec`` with ``names`` otherwise."""
    from dataclasses import replace

    from compare.text_records import column_fs, seconds_per_unit

    col = time_column if time_column in names else next((n for n in names if seconds_per_unit(n) is not None), None)
    if rec.fs_hz is not None or col is None:
        return replace(rec, names=tuple(names))
    i = names.index(col)
    fs = column_fs(rec.data[:, i], f"{where}: column {col}", unit_s=seconds_per_unit(col, named=col == time_column),
                   fs_hz=fs_hz)
    return replace(rec, names=tuple(names[:i] + names[i + 1:]), data=np.delete(rec.data, i, axis=1), fs_hz=fs)


def load_measurement(path: str | Path, sidecar: Sidecar | str | Path | None = None, *,
                     read_as: str = "acceleration") -> Measurement:
    """Load and validate a measurement file with its sidecar (found beside it when not given); ``read_as``: see
    :func:`measurement_from_arrays`."""
    p = Path(path)
    require(p.is_file(), "measurement", str(p), "an existing file")
    if not isinstance(sidecar, Sidecar):
        if sidecar is None:
            try:
                sidecar = find_sidecar(p)
            except NoSidecarError as exc:     # none: leave one to fill in (compare.sidecar_template)
                from compare.sidecar_template import write_template

                made = write_template(p)
                if made is None:
                    raise
                raise InputError(exc.field, exc.value, f"{exc.allowed}; a template with this file's channels was "
                                 f"written: {made} (fill it in, save it as {p.stem}.toml)") from None
        sidecar_path = str(sidecar)
        sidecar = read_sidecar(sidecar)
    else:
        sidecar_path = None
    if sidecar.reference is not None:    # refused now, not when a classifier reads it
        ref = (p.parent / sidecar.reference).resolve()
        require(ref.is_file(), f"{Path(sidecar_path).name}.reference" if sidecar_path else "reference",
                sidecar.reference, f"an existing measurement file, relative to {p.name}'s folder (resolved: {ref})")
    is_wav = sidecar.format == "wav" or (sidecar.format == "auto" and p.suffix.lower() == ".wav")
    require(not (is_wav and sidecar.sensor_unit == "counts"),
            f"{Path(sidecar_path).name}.sensor_unit" if sidecar_path else "sensor_unit", "counts",
            "fullscale for a WAV file (its integer samples are read as fractions of full scale, in [-1, 1)), or a "
            "physical unit")
    named_by_sidecar = sidecar.channels is not None and sidecar.time_column in sidecar.channels
    rec = read_record(p, sidecar.format, time_column=None if named_by_sidecar else sidecar.time_column,
                      variable=sidecar.variable, fs_hz=sidecar.fs_hz)
    names, columns = rec.names, rec.columns or rec.names
    if sidecar.channels is not None:
        require(len(sidecar.channels) == rec.data.shape[1], "channels", list(sidecar.channels),
                f"{rec.data.shape[1]} names, one per data column of {p.name}")
        names = sidecar.channels
        columns = _columns_as_written(rec, names)
        rec = _time_from_channels(rec, names, sidecar.time_column, p.name, sidecar.fs_hz)
        names = rec.names
    hints = dict(rec.hints)
    if rec.fs_hz is not None:
        if sidecar.fs_hz is not None:
            require(abs(rec.fs_hz - sidecar.fs_hz) <= 1e-3 * sidecar.fs_hz, "fs_hz", sidecar.fs_hz,
                    f"the file's own sampling rate {rec.fs_hz:.6g} Hz (or leave fs_hz out)")
        hints["fs_hz"] = rec.fs_hz
    twice = {c: [i for i, d in enumerate(columns) if d == c] for c in columns if columns.count(c) > 1}
    require(not twice, f"{p.name}: column names", ", ".join(f"{c!r} (columns {', '.join(map(str, i))})"
                                                           for c, i in twice.items()),
            "a distinct name for every column, or a channel would be read in another's place: rename them in the "
            "file, or name every data column in the sidecar's channels = [...]")
    channels = {name: rec.data[:, i] for i, name in enumerate(names)}
    m = measurement_from_arrays(channels, sidecar, source=str(p), hints=hints, read_as=read_as,
                                no_index="" if sidecar.channels is not None else rec.no_index, columns=columns)
    return replace(m, sidecar_path=sidecar_path)
