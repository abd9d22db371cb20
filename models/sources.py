"""Where labelled records come from: a generated dataset or measurement files.

- :func:`load_dataset`: a dataset directory of :mod:`datagen.dataset` (one
  channel, one gear pair, optionally a subset of rows; the channel's healthy twins
  as references where the dataset stores them, ``[sweep] healthy_reference``);
- measurement files with sidecars (:mod:`models.measurement_files`: which files of a folder, their labels from
  ``labels.csv`` or the sidecars' ``fault`` (:mod:`models.labels_file`), the sensor's quantity brought to the
  model's, each record cut to the model's trained length, a sidecar's ``reference`` loaded as that record's healthy
  reference and resampled to its measured speed);
- :func:`load_data`: either of the two, by looking at the path.

The speed of a measurement (:func:`measured_speed`): the TSA and order representations average the record
over revolutions, so the speed must be right to a small fraction of a shaft order over the record (a 1 %
error turns the 29th order by 3.5 cycles over 12 revolutions), and a sidecar often holds a nominal speed (a
motor's nameplate, a set point). So the speed is measured: from the tachometer channel when the sidecar names
one, else from the mesh harmonics near the sidecar's value (:func:`compare.speed.speed_from_spectrum`),
searched within half a pinion order at the mesh, ``1 / (2 z1)`` of it: beyond that a mesh harmonic could
align with a sideband of its neighbour. The spectrum's estimate is kept only when the strongest line of a search
three times as wide lies within that half order (one search, ~40 ms for a 1 s record at 12.8 kHz). Otherwise the
comparison's widened search decides (:func:`compare.speed.widened_speed`: +/- 25 %, its maxima ranked by how far
their harmonic family stands out of the families beside it, taken only where the family stands out on all its
harmonics and on its odd ones): a sidecar holding a set point or a nameplate speed a few percent off is read at
the measured speed, with a warning (``speed_note``) naming both; when no family stands out, the sidecar's speed
is used and the warning says a tachometer or the measured speed is needed. The labels keep
``speed_rpm_sidecar`` and ``speed_method`` (``tacho``, ``spectrum`` or ``sidecar``). A speed that varies within
the record is then followed: the record is resampled to its constant mean speed (:mod:`models.order_tracking`)
where its mesh phase strays from the constant-speed line by more than
:data:`~models.order_tracking.TRACK_MIN_RAD` (labels ``mesh_phase_dev_rad``, ``order_tracked``). At a measured
speed the sidecar's pair is checked too (:func:`pair_warning`, :mod:`compare.pair_check`): a record with no mesh
line at ``z1`` x its speed, or whose strongest sideband comb is no shaft of the pair, carries a warning
(``pair_note``) into every prediction made from it; a record read at its sidecar's speed (not confirmed by the
spectrum, or taken as it is) is checked for a mesh line at or near that speed instead (:func:`mesh_line_note`, also
``pair_note``): without one the prediction is not about a gear mesh; so does a clipped sensor channel (``clip_note``,
:mod:`compare.quality`). A record whose content below every shaft order exceeds 5 % of its RMS has it removed
and says so (``drift_note``, :func:`without_drift`).
"""
from __future__ import annotations

from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from gearpit.errors import InputError, require
from models.data import PairInfo, SignalSet, teeth_class_of
from models.order_tracking import (TRACK_MIN_RAD, mesh_angle, phase_deviation_rad, resample_to_constant_speed,
                                   tacho_angle)

if TYPE_CHECKING:
    from models.record_groups import RecordGroups


def load_dataset(path: str | Path, *, channel: str | None = None, pair: str | None = None,
                 rows: np.ndarray | None = None) -> SignalSet:
    """Records of one channel of a generated dataset.

    Parameters
    ----------
    path : str or Path
        Dataset directory (:mod:`datagen.dataset`).
    channel : str, optional
        Stored channel (default: the first stored one).
    pair : str, optional
        Gear pair name; required when the dataset holds several pairs.
    rows : array of bool or int, optional
        Subset of the index rows (mask or positions), e.g. from a query on the index.
    """
    from datagen.dataset import load_index, load_signals, read_metadata
    from datagen.sweep import REFERENCE_SUFFIX

    root = Path(path)
    meta = read_metadata(root)
    index = load_index(root).reset_index(drop=True)
    require(len(index) > 0, "DATASET", str(root), "a dataset with finished samples")
    pairs = meta["pairs"]
    if pair is None:
        require(len(pairs) == 1, "pair", None, "one of: " + ", ".join(pairs) + " (the dataset holds several pairs)")
        pair = next(iter(pairs))
    require(pair in pairs, "pair", pair, "one of: " + ", ".join(pairs))
    keep = (index["pair"] == pair).to_numpy() if "pair" in index else np.ones(len(index), bool)
    if rows is not None:
        r = np.asarray(rows)
        sel = np.zeros(len(index), bool)
        if r.dtype == bool:
            require(r.size == len(index), "rows", r.size, f"a mask of {len(index)} rows")
            sel = r
        else:
            sel[r] = True
        keep &= sel
    index = index[keep].reset_index(drop=True)
    require(len(index) > 0, "rows", 0, "at least one record of the selection")
    x = load_signals(root, index["sample_index"].to_numpy(), channel)
    ch = channel if channel is not None else meta["channels"][0]
    twin = ch + REFERENCE_SUFFIX
    reference = load_signals(root, index["sample_index"].to_numpy(), twin) if twin in meta["channels"] else None
    labels = index.copy()
    if "teeth_class" not in labels and "n_pitted_teeth" in labels:
        labels["teeth_class"] = teeth_class_of(labels["n_pitted_teeth"])
    return SignalSet(x, float(meta["fs_hz"]), PairInfo(pair, int(pairs[pair]["z_pinion"]), int(pairs[pair]["z_wheel"])),
                     labels, source=f"{root} [{ch}]", channel=ch, reference=reference)


#: the wider search that confirms the spectrum's speed, in units of the search half-width ``1 / (2 z1)``
CONFIRM_WIDTH = 3.0


def measured_speed(measurement) -> tuple[float, str, str]:
    """``(speed_rpm, method, note)`` of a :class:`compare.measurement.Measurement` (module docstring): method
    ``tacho``, ``spectrum`` or ``sidecar``; ``note`` is a warning, or "" ."""
    from compare.speed import WIDE_SEARCH_FRACTION, is_mesh_line, refine_speed, speed_from_spectrum, widened_speed

    nominal = float(measurement.speed_rpm)
    if measurement.tacho is not None:
        return float(refine_speed(measurement).speed_rpm), "tacho", ""
    z = int(measurement.pair.pinion.teeth)
    half = min(0.05, 0.5 / z)
    kw = dict(z_pinion=z, nominal_rpm=nominal)
    try:
        # the strongest line of the wide search, if it lies in the narrow one, is also the narrow search's
        wide = speed_from_spectrum(measurement.signal, measurement.fs_hz, search_fraction=CONFIRM_WIDTH * half,
                                   **kw).speed_rpm
    except InputError:      # no mesh harmonic below 0.45 fs
        return nominal, "sidecar", (f"speed not measured: no mesh harmonic of {nominal:g} rpm x {z} teeth below "
                                    f"0.45 fs ({0.45 * measurement.fs_hz:g} Hz)")
    if abs(wide / nominal - 1) < 0.98 * half and is_mesh_line(
            np.asarray(measurement.signal, float) - np.mean(measurement.signal), measurement.fs_hz, z * wide / 60.0,
            z, int(measurement.pair.wheel.teeth)):
        return float(wide), "spectrum", ""
    found = widened_speed(measurement.signal, measurement.fs_hz, z_wheel=int(measurement.pair.wheel.teeth), **kw)
    if found is not None:
        rpm = float(found.speed_rpm)
        return rpm, "spectrum", off_sidecar_note(measurement, rpm)
    return nominal, "sidecar", (f"speed not confirmed by the spectrum: no mesh line within "
                                f"+/-{100 * WIDE_SEARCH_FRACTION:g} % of the sidecar's {nominal:g} rpm passes the "
                                "tests of compare.speed.widened_speed (its strongest harmonic family within "
                                f"+/-{100 * CONFIRM_WIDTH * half:.1f} %: {wide:.1f} rpm); the sidecar's speed is used "
                                "(give a tachometer channel or the measured speed)")


def off_sidecar_note(measurement, speed_rpm: float) -> str:
    """The warning of a measured speed (the spectrum's, ``method`` ``spectrum``) further than the first search's
    half order from the sidecar's (:func:`compare.speed.off_sidecar_message`), else "". Called again with the mean
    speed of a followed record (:func:`tracked_record`), so that the note names the speed the model reads."""
    from compare.speed import off_sidecar_message

    nominal = float(measurement.speed_rpm)
    half = min(0.05, 0.5 / int(measurement.pair.pinion.teeth))
    if abs(speed_rpm / nominal - 1) < 0.98 * half:
        return ""
    return off_sidecar_message(speed_rpm, nominal, CONFIRM_WIDTH * half)


def pair_warning(measurement, speed_rpm: float, method: str) -> str:
    """The pair check of :mod:`compare.pair_check` at a measured speed: its message (a mesh line missing where the
    sidecar's pair puts it, or a sideband family that is no shaft of the pair), or "" ."""
    from compare.pair_check import check_pair, pair_message
    from compare.speed import SpeedEstimate, constant_track

    fr = speed_rpm / 60.0
    est = SpeedEstimate(speed_rpm, float(measurement.speed_rpm), method,
                        constant_track(measurement.n_samples, measurement.fs_hz, fr))
    return pair_message(check_pair(measurement, est)) or ""


def mesh_line_note(measurement) -> str:
    """For a record read at its sidecar's speed (the spectrum did not confirm it, or ``--sidecar-speed``): a
    warning when no mesh line of the sidecar's pair stands out at that speed nor at the strongest harmonic family
    within :data:`CONFIRM_WIDTH` half pinion orders of it (the pair check's test,
    :func:`compare.pair_check.mesh_line_db` >= :data:`~compare.pair_check.MESH_FAMILY_DB`), else "" (also when no
    mesh harmonic lies below 0.45 fs: nothing to check). Without a mesh line the record holds no mesh of this pair
    at this speed (white noise, another machine, a pair or speed wrong beyond every search), and a classifier
    trained on gear meshes still answers with one of its classes."""
    from compare.pair_check import MESH_FAMILY_DB, PAD, log_power, mesh_line_db
    from compare.speed import speed_from_spectrum

    nominal = float(measurement.speed_rpm)
    z = int(measurement.pair.pinion.teeth)
    fs = float(measurement.fs_hz)
    width = CONFIRM_WIDTH * min(0.05, 0.5 / z)
    try:
        near = speed_from_spectrum(measurement.signal, fs, search_fraction=width, z_pinion=z,
                                   nominal_rpm=nominal).speed_rpm
    except InputError:      # no mesh harmonic below 0.45 fs
        return ""
    x = np.asarray(measurement.signal, float)
    logp, n_fft = log_power(x - np.mean(x), PAD)
    db = [mesh_line_db(logp, n_fft, z * rpm / 60.0 / fs) for rpm in (nominal, near)]
    if not np.isfinite(db[0]) or max(db) >= MESH_FAMILY_DB:
        return ""
    return (f"no mesh line of the sidecar's pair stands out at or near its {nominal:g} rpm ({z} teeth x the speed, "
            f"{z * nominal / 60.0:.1f} Hz: {db[0]:.1f} dB above the harmonic families beside it; the strongest "
            f"family within +/-{100 * width:.1f} %, at {near:.1f} rpm: {db[1]:.1f} dB; a mesh line stands out by "
            f"{MESH_FAMILY_DB:g} dB): the record shows no mesh of this gear pair (no gear, another machine, or a "
            "pair or speed wrong beyond the search), so the prediction is not about a gear mesh")


def tracked_record(measurement, speed_rpm: float, method: str) -> tuple[np.ndarray, float, float]:
    """``(record, speed_rpm, mesh phase deviation in rad)`` of a measurement whose mean speed was measured by
    ``method`` (:func:`measured_speed`): resampled to its constant mean speed where its mesh phase strays more
    than :data:`models.order_tracking.TRACK_MIN_RAD` from it (:mod:`models.order_tracking`), else as it is.
    A speed the spectrum did not confirm (``sidecar``) is not tracked (deviation NaN)."""
    x = measurement.signal
    if method == "sidecar":
        return x, speed_rpm, float("nan")
    z1, z2 = int(measurement.pair.pinion.teeth), int(measurement.pair.wheel.teeth)
    if method == "tacho":
        sc = measurement.sidecar
        angle = tacho_angle(measurement.tacho_signal, measurement.fs_hz, pulses_per_rev=sc.tacho_pulses_per_rev,
                            per_rev=1.0 if sc.tacho_shaft == "pinion" else z2 / z1, nominal_rpm=speed_rpm)
    else:
        try:
            angle = mesh_angle(x, measurement.fs_hz, speed_rpm / 60.0, z1)[0]
        except InputError:  # its harmonic and half a shaft order beside it do not fit below 0.45 fs
            return x, speed_rpm, float("nan")
    dev = phase_deviation_rad(angle, measurement.fs_hz, z1)
    if dev <= TRACK_MIN_RAD:
        return x, speed_rpm, dev
    y, fr = resample_to_constant_speed(x, measurement.fs_hz, angle)
    return y, 60.0 * fr, dev


def without_drift(x: np.ndarray, measurement, speed_rpm: float) -> tuple[np.ndarray, str]:
    """``(record, note)``: a measured record without its content below every shaft order when that exceeds
    :data:`compare.comparison.BELOW_SHAFTS_REMOVED` of its RMS (a sensor's drift, an offset, a foundation's sway:
    the comparison's rule, :func:`compare.spectra.high_passed`), with a note saying so; else as it is. Generated
    records hold 0.3-2.2 % there, so the training data are unchanged and a drifting measurement reaches the
    classifier as the drift-free record would."""
    from compare.comparison import BELOW_SHAFTS_REMOVED
    from compare.spectra import LOW_CUT_ORDER, below_shafts_share

    pair = measurement.pair
    fr = speed_rpm / 60.0
    cut = LOW_CUT_ORDER * min(fr, fr * pair.pinion.teeth / pair.wheel.teeth)
    share, rest = below_shafts_share(x, measurement.fs_hz, cut)
    if share <= BELOW_SHAFTS_REMOVED:
        return x, ""
    return rest, (f"content below {cut:.3g} Hz (no shaft order), {share:.3g} times the RMS of the rest, removed "
                  "before the classifier (a sensor's drift, an offset, a foundation's sway)")


def measurement_files(folder: str | Path) -> list[Path]:
    """The measurement files of a folder (:func:`models.measurement_files.folder_files`)."""
    from models.measurement_files import folder_files

    return folder_files(folder)[0]


def load_measurements(paths: list[str | Path], *, refine_speed: bool = True, spec=None) -> SignalSet:
    """Records of measurement files as one signal set (:func:`models.measurement_files.load_measurements`)."""
    from models.measurement_files import load_measurements as load

    return load(paths, refine_speed=refine_speed, spec=spec)


def load_data(paths: list[str | Path], *, channel: str | None = None, pair: str | None = None,
              refine_speed: bool = True, spec=None, allow_mismatch: bool = False,
              classes: list[str] | None = None) -> SignalSet | RecordGroups:
    """A generated dataset directory (one path with ``metadata.json``): its signal set; a folder of measurement
    files, or measurement files and folders of them together: their :class:`~models.record_groups.RecordGroups`, each file read on its own for
    the model of ``spec`` (:func:`models.measurement_files.load_measurement_groups`: ``refine_speed``,
    ``allow_mismatch``, ``classes``)."""
    from models.measurement_files import folder_files, load_measurement_groups

    ps = [Path(p) for p in paths]
    require(len(ps) >= 1, "DATA", 0, "a dataset directory, a folder of measurements or measurement files")
    kw = dict(refine_speed=refine_speed, spec=spec, allow_mismatch=allow_mismatch, classes=classes)
    if len(ps) == 1 and ps[0].is_dir():
        if (ps[0] / "metadata.json").is_file():
            return load_dataset(ps[0], channel=channel, pair=pair)
        files, skipped = folder_files(ps[0])
        require(len(files) >= 1, "DATA", str(ps[0]), "a dataset directory or a folder of measurement files with sidecars")
        return load_measurement_groups(files, skipped=tuple(skipped), **kw)
    # several paths: measurement files and folders of them, a folder read as it is read alone (its files with a
    # sidecar or a labels.csv row, the rest skipped and reported); a file named twice is read once
    files, skipped = [], []
    for p in ps:
        if p.is_dir():
            require(not (p / "metadata.json").is_file(), "DATA", str(p),
                    "measurement files or folders of them (a dataset directory is given alone)")
            found, left = folder_files(p)
            require(len(found) >= 1, "DATA", str(p), "a folder of measurement files with sidecars")
            files += found
            skipped += [f"{p.name}/{line}" for line in left]
        else:
            require(p.is_file(), "DATA", str(p), "an existing file or folder")
            files.append(p)
    seen: set = set()
    files = [f for f in files if not (f.resolve() in seen or seen.add(f.resolve()))]
    return load_measurement_groups(files, skipped=tuple(skipped), **kw)
