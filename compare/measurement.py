"""A measured vibration record and its operating point: loading and validation.

A measurement is a file (any layout of :mod:`compare.formats`) plus a *sidecar* (JSON or TOML) that says what the
file cannot: its keys, how it is read and where it is found are in :mod:`compare.sidecar`.
:func:`load_measurement` reads both and :func:`measurement_from_arrays` validates them into a :class:`Measurement`.

Refused with :class:`gearpit.errors.InputError` naming the field: a sidecar's own refusals
(:mod:`compare.sidecar`), a missing fs, NaN or infinite samples (first bad sample named), a wrong column count,
two columns of one name, a constant sensor channel, a record shorter than two revolutions of the slower shaft.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from compare.array_files import FS_KEYS
from compare.formats import read_record
from compare.sidecar import (SENSOR_QUANTITIES, NoSidecarError, Sidecar, check_torque, find_sidecar,
                             read_sidecar)
from compare.text_records import MIN_FS_HZ
from gearpit.errors import InputError, require, require_positive

MIN_REVOLUTIONS = 2.0


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
    check_torque("torque_nm", torque)
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
