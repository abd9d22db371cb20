"""Measurement files (with sidecars) as records a classifier reads, each file on its own.

- **Which files.** A folder's data files (:data:`MEASUREMENT_SUFFIXES`) with a sidecar beside them; a file listed in
  ``labels.csv`` without one is refused by name (and a sidecar template written beside it,
  :mod:`compare.sidecar_template`); an unlisted one is skipped and reported. A file that another file's sidecar
  names as its ``reference`` is loaded as that reference only, not as a record of the run, so records and their
  references can share a folder.
- **Labels** (:mod:`models.labels_file`): ``labels.csv`` beside the files (every record a row, every row a file on
  disk), else each sidecar's ``fault``; checked before any record is read.
- **Physical quantity.** A sidecar's ``sensor_quantity`` (default acceleration) is brought to the quantity of the
  model's trained channel (:func:`models.spec.channel_quantity`, the check of datasets): a velocity or a
  displacement is differentiated for an acceleration model (:mod:`features.derivative`), a displacement stays
  one for a displacement model (a transmission error, ``dte_m``); what only integration could give (an
  acceleration or a velocity for a displacement model) is refused, naming the file. A sensor channel whose name
  carries another quantity's unit (``dte_m`` declared an acceleration) is read as declared, with a warning.
- **Unit.** A sidecar's ``sensor_unit`` brings the record to SI where it is read (:mod:`compare.sensor_units`),
  the unit of the simulated training records. A file without one is read as it is written, which a model that
  reads absolute levels (:func:`models.spec.absolute_level_inputs`: the feature baselines, a CNN with a level side
  input) takes for SI: each such record carries a warning naming the file (:func:`unit_note`); a level-free model
  gets none. A record and its reference declare a unit both or neither.
- **Length.** Every record is cut to the model's trained record length from its start (``spec.n_samples``), so a
  prediction does not depend on the other files of the call; a shorter one is left as it is for
  :func:`models.spec.check_input` (refused, or a warning with ``allow_mismatch``). A reference is resampled to its
  record's measured speed and cut to the record's length; one that falls short is refused (with
  ``allow_mismatch`` the record is cut to it, with a warning). Without a model the records of a call are cut to
  the shortest one (:func:`load_measurements`).
- **Errors** name the file.

Files of another rate or, with ``allow_mismatch``, length are read on their own
(:class:`models.record_groups.RecordGroups`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from gearpit.errors import InputError, require
from models.data import PairInfo, SignalSet, teeth_class_of
from models.labels_file import LABELS_FILE, class_name, read_labels
from models.order_tracking import TRACK_MIN_RAD
from models.record_groups import RecordGroups, named
from models.spec import absolute_level_inputs, channel_quantity

MEASUREMENT_SUFFIXES = (".csv", ".txt", ".npy", ".npz", ".wav", ".mat")
#: largest speed difference between a record and its healthy reference (fraction)
MAX_REFERENCE_SPEED_OFFSET = 0.05


def folder_files(folder: str | Path) -> tuple[list[Path], list[str]]:
    """``(files, skipped)``: the data files of ``folder`` to read (a sidecar beside them, or listed in
    ``labels.csv``: refused later by name), and one line per data file skipped (no sidecar, not listed)."""
    from compare.sidecar import NoSidecarError, find_sidecar

    root = Path(folder)
    table = read_labels(root)
    listed = set() if table is None else set(table.index)
    files, skipped = [], []
    for p in sorted(root.iterdir()):
        if not p.is_file() or p.suffix.lower() not in MEASUREMENT_SUFFIXES or p.name == LABELS_FILE:
            continue
        try:
            find_sidecar(p)
        except NoSidecarError:
            if p.name not in listed:
                skipped.append(f"{p.name}: skipped (no sidecar beside it, and not in {LABELS_FILE})")
                continue
        files.append(p)
    return files, skipped


def _sidecar(f: Path):
    """The sidecar of ``f``; none: refused by name, a template written beside it (as ``gearpit compare`` does)."""
    from compare.measurement import load_measurement
    from compare.sidecar import NoSidecarError, find_sidecar, read_sidecar

    try:
        path = find_sidecar(f)
    except NoSidecarError:
        try:
            load_measurement(f)        # writes the template and says so
        except InputError as exc:
            made = exc.allowed[exc.allowed.index(";"):] if ";" in exc.allowed else ""
            raise InputError(f"{f.name}: sidecar", None,
                             f"a sidecar beside it ({f.stem}.toml or {f.stem}.json){made}") from None
        raise
    try:
        return read_sidecar(path)
    except InputError as exc:
        raise named(exc, [f.name]) from None


def read_as(f: Path, sidecar, spec) -> str:
    """The quantity ``f``'s sensor channel is read as for ``spec``'s model (module docstring); refused where only
    integration could give it."""
    from compare.sidecar import SENSOR_QUANTITIES

    trained = channel_quantity(spec.channel) if spec is not None else None
    given = sidecar.sensor_quantity
    if trained is None or trained == "acceleration":
        return "acceleration"
    if trained in SENSOR_QUANTITIES and SENSOR_QUANTITIES[given] >= SENSOR_QUANTITIES[trained]:
        return trained
    hint = ""
    if isinstance(sidecar.sensor, str) and channel_quantity(sidecar.sensor) == trained:
        hint = (f"; the channel name {sidecar.sensor} suggests a {trained}: if it is one, say so in the sidecar "
                f"(sensor_quantity = \"{trained}\")")
    raise InputError(f"{f.name}: sensor_quantity", given,
                     f"a quantity this model reads: it was trained on {spec.channel} ({trained}), and {given} is not "
                     f"brought to {trained} (records are differentiated, never integrated){hint}")


def quantity_note(measurement) -> str:
    """A warning when the sensor channel's name carries the unit of another quantity than its sidecar's
    ``sensor_quantity`` (:func:`models.spec.channel_quantity`), else "" ."""
    named_q = channel_quantity(measurement.sensor)
    given = measurement.sidecar.sensor_quantity
    if named_q is None or named_q == given:
        return ""
    return (f"channel {measurement.sensor}'s name suggests a {named_q} (its unit suffix), but the sidecar's "
            f"sensor_quantity is {given!r} (the default is acceleration): read as {given}; set sensor_quantity if "
            "the name is right")


def unit_note(measurement, f: Path, spec) -> str:
    """A warning when ``spec``'s model reads absolute levels (:func:`models.spec.absolute_level_inputs`) and
    ``f``'s sidecar declares no ``sensor_unit``, else "" ."""
    from compare.sensor_units import SI_UNITS

    reads = absolute_level_inputs(spec) if spec is not None else ""
    if not reads or measurement.sidecar.sensor_unit is not None:
        return ""
    si = SI_UNITS.get(channel_quantity(spec.channel) or "", "SI units")
    return (f"no sensor_unit in the sidecar of {f.name}, and this model reads absolute levels ({reads}, trained in "
            f"{si}): the file's numbers are taken as {si}, so the prediction depends on the unit they are written "
            "in; declare sensor_unit (and sensor_sensitivity for V, mV, counts, fullscale)")


def _file_labels(records: list[Path], sidecars: dict, refs: set, classes) -> list[dict] | None:
    """One label dict per record (``labels.csv``, else sidecar ``fault``), checked; None: not labelled."""
    tables = {}
    for f in records:
        if f.parent not in tables:
            tables[f.parent] = read_labels(f.parent)
    if all(t is not None for t in tables.values()):
        for folder, t in tables.items():
            missing = [n for n in t.index if not (folder / n).is_file()]
            require(not missing, f"{folder / LABELS_FILE}: file", missing,
                    "rows for files of the folder only (these are not on disk)")
            as_ref = [n for n in t.index if (folder / n).resolve() in refs]
            require(not as_ref, f"{folder / LABELS_FILE}: file", as_ref,
                    "rows for records only (these are other files' references, read as references, not scored)")
        out = []
        for f in records:
            t = tables[f.parent]
            require(f.name in t.index, f"{f.name}: {LABELS_FILE}", "no row",
                    f"a row for every file ({LABELS_FILE} has {t.index.size} rows)")
            row = t.loc[f.name].to_dict()
            row["severity_class"] = class_name(row["severity_class"], classes,
                                               f"{LABELS_FILE} row {f.name}: severity_class")
            out.append(row)
        return out
    faults = [sidecars[f].fault for f in records]
    for f, v in zip(records, faults):
        if v is not None:
            class_name(v, classes, f"{f.name}: fault")
    return None


def _fault_labels(ms: list, records: list[Path], classes) -> list[dict] | None:
    """Labels from each measurement's ``fault`` (sidecar, or the public layout's file name); None unless all have
    one."""
    if not all(m.fault is not None for m in ms):
        return None
    out = []
    for m, f in zip(ms, records):
        cls = class_name(m.fault, classes, f"{f.name}: fault")
        out.append({"severity_class": cls, "severity": 0.0 if cls == "healthy" else np.nan})
    if all(r["severity_class"] == "healthy" for r in out):
        for r in out:
            r.update(n_pitted_teeth=0.0, teeth_class="0")
    return out


def load_measurement_groups(paths: list[str | Path], *, refine_speed: bool = True, spec=None,
                            allow_mismatch: bool = False, classes: list[str] | None = None,
                            skipped: tuple = ()) -> RecordGroups:
    """Records of measurement files, each read on its own (module docstring), grouped by rate, pair, length and
    reference.

    Parameters
    ----------
    paths : list of path
        Measurement files (with sidecars).
    refine_speed : bool
        Measure each record's speed (:func:`models.sources.measured_speed`) instead of taking the sidecar's.
    spec : ModelSpec, optional
        The model the records are for: its channel's quantity and its record length (none: the records are read
        as acceleration and cut to the shortest).
    allow_mismatch : bool
        A reference shorter than its record cuts the record (a warning) instead of being refused.
    classes : list of str, optional
        The classes labels must name (``gearpit evaluate``): :func:`models.labels_file.class_name`.
    skipped : tuple of str
        Files of the folder that were skipped, carried into the result for the report.
    """
    from compare.measurement import load_measurement

    files = [Path(p) for p in paths]
    require(len(files) >= 1, "FILES", 0, "at least one measurement file")
    sidecars = {f: _sidecar(f) for f in files}
    refs = {(f.parent / sc.reference).resolve() for f, sc in sidecars.items() if sc.reference}
    records = [f for f in files if f.resolve() not in refs]
    require(bool(records), "FILES", [f.name for f in files], "at least one record that is no other file's reference")
    modes = {f: read_as(f, sidecars[f], spec) for f in records}
    labels = _file_labels(records, sidecars, refs, classes)
    ms = []
    for f in records:
        try:
            ms.append(load_measurement(f, sidecars[f], read_as=modes[f]))
        except InputError as exc:
            raise named(exc, [f.name]) from None
    if labels is None:
        labels = _fault_labels(ms, records, classes)
    has_ref = [sidecars[f].reference is not None for f in records]
    for f, h in zip(records, has_ref):
        require(h or not any(has_ref), f"{f.name}: reference", None,
                "a reference in every sidecar or in none (records read against a reference need one each)")
    items = []
    for i, (m, f) in enumerate(zip(ms, records)):
        try:
            items.append(_record(m, f, spec, refine_speed, allow_mismatch, modes[f]))
        except InputError as exc:
            raise named(exc, [f.name]) from None
    label_cols = _label_columns(labels)
    groups: dict = {}
    for i, (x, ref, row) in enumerate(items):
        for col in label_cols:
            row[col] = labels[i].get(col, np.nan)
        pair = _pair_info(ms[i].pair)
        key = (ms[i].fs_hz, pair, x.size if spec is not None else None, ref is not None)
        groups.setdefault(key, []).append((i, x, ref, row))
    sets, positions = [], []
    for (fs, pair, _, with_ref), members in groups.items():
        n = min(min(x.size, np.inf if r is None else r.size) for _, x, r, _ in members)
        lab = pd.DataFrame([row for *_, row in members])
        if "n_pitted_teeth" in lab and "teeth_class" not in label_cols:
            k = lab["n_pitted_teeth"].to_numpy(dtype=float)
            lab["teeth_class"] = [teeth_class_of([v])[0] if np.isfinite(v) else np.nan for v in k]
        sets.append(SignalSet(np.stack([np.asarray(x[:n], np.float32) for _, x, _, _ in members]), float(fs), pair,
                              lab, source=_source([records[i] for i, *_ in members]),
                              reference=np.stack([np.asarray(r[:n], np.float32) for *_, r, _ in members])
                              if with_ref else None))
        positions.append(np.array([i for i, *_ in members]))
    return RecordGroups(tuple(sets), tuple(positions), tuple(skipped), _source(records))


def _label_columns(labels: list[dict] | None) -> list[str]:
    if labels is None:
        return []
    cols = []
    for col in ("severity_class", "severity", "n_pitted_teeth", "teeth_class"):
        vals = [r.get(col, np.nan) for r in labels]
        if col == "severity_class" or not all(v is None or (isinstance(v, float) and np.isnan(v)) for v in vals):
            cols.append(col)
    return cols


def _source(files: list[Path]) -> str:
    return ", ".join(f.name for f in files[:3]) + (f" (+{len(files) - 3})" if len(files) > 3 else "")


def _record(m, f: Path, spec, refine_speed: bool, allow_mismatch: bool, mode: str):
    """``(record, reference or None, label row)`` of one measurement, cut to the model's record length."""
    from compare.quality import clipping, clipping_message
    from models.sources import (measured_speed, mesh_line_note, off_sidecar_note, pair_warning, tracked_record,
                                without_drift)

    speed, method, note = measured_speed(m) if refine_speed else (float(m.speed_rpm), "sidecar", "")
    # at a measured speed the pair check; at the sidecar's, whether there is a mesh line at all near it
    pair_note = pair_warning(m, speed, method) if method != "sidecar" else mesh_line_note(m)
    clip_note = clipping_message(clipping(m.signal), m.sensor) or ""
    x, tracked, dev = tracked_record(m, speed, method) if refine_speed else (m.signal, speed, np.nan)
    if note and method == "spectrum" and tracked != speed:
        note = off_sidecar_note(m, tracked)     # name the followed mean speed, the one the model reads
    speed = tracked
    x, drift_note = without_drift(x, m, speed)
    if spec is not None:
        x = x[:spec.n_samples]
    row = {"file": f.name, "speed_rpm": speed, "torque_nm": float(m.torque_nm), "speed_rpm_sidecar": float(m.speed_rpm),
           "speed_method": method, "speed_note": note, "quantity_note": quantity_note(m),
           "unit_note": unit_note(m, f, spec), "pair_note": pair_note,
           "clip_note": clip_note, "drift_note": drift_note, "length_note": "", "mesh_phase_dev_rad": dev,
           "order_tracked": bool(dev > TRACK_MIN_RAD)}
    ref = None
    if m.sidecar.reference is not None:
        ref = _reference(m, f, speed, refine_speed, spec, mode)
        if spec is not None and ref.size < x.size:
            require(allow_mismatch, f"{m.sidecar.reference} (reference of {f.name}): n_samples", ref.size,
                    f">= {x.size} samples at the record's speed {speed:.2f} rpm (record the reference at least as "
                    "long as the record), or allow_mismatch")
            row["length_note"] = (f"cut to its reference's {ref.size} samples (at the record's speed; the trained "
                                  f"length is {spec.n_samples})")
            x = x[:ref.size]
        ref = ref[:x.size] if spec is not None else ref
    return x, ref, row


def _reference(m, f: Path, speed_rpm: float, refine_speed: bool, spec, mode: str) -> np.ndarray:
    """The healthy reference of a record (sidecar key ``reference``): loaded like the record (same quantity, speed
    measured, tracked, drift removed), then resampled to the record's speed so that their shaft orders fall on the
    same bins."""
    from scipy.signal import resample

    from compare.measurement import load_measurement
    from models.sources import measured_speed, tracked_record, without_drift

    p = f.parent / m.sidecar.reference
    require(p.is_file(), f"{f.name}: reference", m.sidecar.reference,
            f"an existing measurement file (relative to {f.parent})")
    sc = _sidecar(p)
    read_as(p, sc, spec)
    if (sc.sensor_unit is None) != (m.sidecar.sensor_unit is None):
        said = f"declares {m.sidecar.sensor_unit}" if m.sidecar.sensor_unit else "declares none"
        raise InputError(f"{p.name}: sensor_unit", sc.sensor_unit,
                         f"{'a' if m.sidecar.sensor_unit else 'no'} sensor_unit, as its record {f.name} {said}: a "
                         "record and its reference are read in the same unit (declare it in both sidecars or in "
                         "neither)")
    try:
        r = load_measurement(p, sc, read_as=mode)
    except InputError as exc:
        raise named(exc, [p.name]) from None
    require(np.isclose(r.fs_hz, m.fs_hz, rtol=1e-9), f"{p.name}: fs_hz", r.fs_hz, f"{m.fs_hz:g} Hz (the record's)")
    speed, method, _ = measured_speed(r) if refine_speed else (float(r.speed_rpm), "sidecar", "")
    y, speed, _ = tracked_record(r, speed, method) if refine_speed else (r.signal, speed, np.nan)
    y, _ = without_drift(y, r, speed)
    factor = speed / speed_rpm           # > 1: the reference ran faster, stretch it
    require(abs(factor - 1.0) <= MAX_REFERENCE_SPEED_OFFSET, f"{p.name}: speed_rpm", round(speed, 2),
            f"within {100 * MAX_REFERENCE_SPEED_OFFSET:g} % of the record's {speed_rpm:.2f} rpm "
            "(a reference at the same operating point)")
    return resample(y, int(round(y.size * factor))) if abs(factor - 1.0) > 1e-6 else y


def _pair_info(pair) -> PairInfo:
    name = getattr(pair, "name", None) or str(pair)
    try:
        return PairInfo(str(name), int(pair.pinion.teeth), int(pair.wheel.teeth))
    except AttributeError:
        raise InputError("pair", pair, "a gear pair (preset name or pair table) in the sidecar") from None


def load_measurements(paths: list[str | Path], *, refine_speed: bool = True, spec=None) -> SignalSet:
    """Records of measurement files as one signal set (:func:`load_measurement_groups`; refused unless they share
    rate, pair and, with ``spec``, length)."""
    return load_measurement_groups(paths, refine_speed=refine_speed, spec=spec).single()


__all__ = ["MAX_REFERENCE_SPEED_OFFSET", "MEASUREMENT_SUFFIXES", "folder_files", "load_measurement_groups",
           "load_measurements", "quantity_note", "read_as", "unit_note"]
