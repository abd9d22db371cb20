"""Readers of measurement files: generic CSV/TXT, NPY, NPZ, WAV, MAT (v5 and v7.3) and three public layouts.

Every reader returns a :class:`compare.raw_record.RawRecord`: channel names, a (n_samples, n_channels)
float array and, when the file says so, the sampling rate and what its name tells
about the operating point. Validation (NaN, length, fs) is done once, afterwards,
by :func:`compare.measurement.load_measurement`.

Generic layouts
---------------
- CSV/TXT: :mod:`compare.text_records` (header, delimiter, comment lines, a decimal
  comma, a byte-order mark, a time column in s/ms/us).
- NPY, NPZ, WAV, MAT (v5 and v7.3/HDF5): :mod:`compare.array_files` (the array layouts, structs, the sampling
  rate's entries :data:`compare.array_files.FS_KEYS`).

Public layouts (``format`` in the sidecar, or recognised by the file name)
-------------------------------------------------------------------------
- ``mcc5_thu``: MCC5-THU gearbox (Mendeley doi:10.17632/p92gj2732w): CSV with header
  ``speed,torque,motor_vibration_x,...,gearbox_vibration_z``, fs 12.8 kHz.
- ``phm2023``: PHM Society 2023 gearbox challenge: ``V<rpm>_<torque>N_<run>.txt``,
  four whitespace-separated columns (three accelerations, tachometer), fs 20480 Hz
  (as used by participants; not in an official document we have).
- ``seu``: Southeast University gearset (``gearbox/gearset/<Label>_<speed Hz>_<load V>.csv``):
  up to ~16 free-text header lines, then 8 columns (motor vibration, planetary
  gearbox x/y/z, motor torque, parallel gearbox x/y/z), comma or tab separated;
  fs not documented by the authors (the sidecar must give it).

References
----------
../shared/data/spectraquest_gfd/README.md, section "Why this dataset" (the three layouts).
"""
from __future__ import annotations

import re
from pathlib import Path

from compare.array_files import read_mat, read_npy, read_npz, read_wav
from compare.raw_record import RawRecord
from compare.text_records import read_table
from gearpit.errors import InputError, require

#: accepted values of the sidecar's ``format``
FORMATS = ("auto", "csv", "npy", "npz", "wav", "mat", "mcc5_thu", "phm2023", "seu")

MCC5_COLUMNS = ("speed", "torque", "motor_vibration_x", "motor_vibration_y", "motor_vibration_z",
                "gearbox_vibration_x", "gearbox_vibration_y", "gearbox_vibration_z")
PHM2023_COLUMNS = ("acc_1", "acc_2", "acc_3", "tacho")
SEU_COLUMNS = ("motor_vibration", "planetary_x", "planetary_y", "planetary_z", "motor_torque",
               "parallel_x", "parallel_y", "parallel_z")

_PHM_NAME = re.compile(r"^V(?P<rpm>\d+(?:\.\d+)?)_(?P<torque>\d+(?:\.\d+)?)N_(?P<run>\d+)\.txt$", re.IGNORECASE)
_SEU_NAME = re.compile(r"^(?P<label>health|chipped|miss|root|surface)_(?P<hz>\d+)_(?P<load>\d+)\.csv$",
                       re.IGNORECASE)


def detect_format(path: Path) -> str:
    """The layout of ``path`` from its name and extension (module docstring)."""
    name = path.name
    if _PHM_NAME.match(name):
        return "phm2023"
    if _SEU_NAME.match(name):
        return "seu"
    ext = path.suffix.lower()
    if ext in (".csv", ".txt", ".tsv", ".dat"):
        with open(path, "r", encoding="utf-8", errors="replace") as fh:
            first = fh.readline().strip().lower()
        if "gearbox_vibration" in first:
            return "mcc5_thu"
        return "csv"
    table = {".npy": "npy", ".npz": "npz", ".wav": "wav", ".mat": "mat"}
    if ext not in table:
        raise InputError("measurement", str(path), "a .csv/.txt/.tsv, .npy, .npz, .wav or .mat file")
    return table[ext]


def read_record(path: str | Path, fmt: str = "auto", *, time_column: str | None = None,
                variable: str | None = None, fs_hz: float | None = None) -> RawRecord:
    """Read ``path`` in layout ``fmt`` (one of :data:`FORMATS`); ``fs_hz``: the sidecar's rate, if it gives one
    (a time column that is not uniform is then dropped instead of refused, :func:`compare.text_records.column_fs`)."""
    p = Path(path)
    require(fmt in FORMATS, "format", fmt, "one of: " + ", ".join(FORMATS))
    require(p.is_file(), "measurement", str(p), "an existing file")
    if fmt == "auto":
        fmt = detect_format(p)
    if fmt == "csv":
        return read_delimited(p, time_column=time_column, fs_hz=fs_hz)
    if fmt == "npy":
        return read_npy(p)
    if fmt == "npz":
        return read_npz(p, variable, fs_hz=fs_hz)
    if fmt == "wav":
        return read_wav(p)
    if fmt == "mat":
        return read_mat(p, variable, fs_hz=fs_hz)
    if fmt == "mcc5_thu":
        rec = read_delimited(p, time_column=time_column, fs_hz=fs_hz)
        return RawRecord(rec.names, rec.data, rec.fs_hz,
                         {"fs_hz": 12800.0, "tacho": "speed", "sensor": "gearbox_vibration_x",
                          **_mcc5_name_hints(p.name)}, columns=rec.columns)
    if fmt == "phm2023":
        return read_phm2023(p)
    return read_seu(p)


# ---------------------------------------------------------------------- text
def read_delimited(path: Path, *, time_column: str | None = None, skip_text_lines: bool = False,
                   fs_hz: float | None = None) -> RawRecord:
    """Generic CSV/TXT (:mod:`compare.text_records`); ``skip_text_lines`` drops leading non-numeric lines."""
    names, data, fs, columns = read_table(path, time_column=time_column, skip_text_lines=skip_text_lines,
                                          fs_hz=fs_hz)
    return RawRecord(names, data, fs, columns=columns)


def _mcc5_name_hints(name: str) -> dict:
    hints: dict = {}
    m = re.search(r"(\d+(?:\.\d+)?)Nm-(\d+(?:\.\d+)?)rpm", name)
    if m:
        hints.update(torque_nm=float(m.group(1)), speed_rpm=float(m.group(2)))
    m = re.match(r"^(health|gear_pitting_[LMH]|gear_wear_[LMH]|miss_teeth|teeth_crack_[LMH]|teeth_break_[LMH])",
                 name)
    if m:
        hints["fault"] = m.group(1)
    return hints


def read_phm2023(path: Path) -> RawRecord:
    """PHM 2023 gearbox layout (module docstring); speed and torque from the file name."""
    rec = read_delimited(path)
    require(rec.data.shape[1] == 4, f"{path}: columns", rec.data.shape[1], "4 (three accelerations, tachometer)")
    hints: dict = {"fs_hz": 20480.0, "tacho": "tacho", "sensor": "acc_1"}
    m = _PHM_NAME.match(path.name)
    if m:
        hints.update(speed_rpm=float(m.group("rpm")), torque_nm=float(m.group("torque")))
    level = re.search(r"Pitting_degradation_level_(\d+)", str(path))
    if level:
        hints["fault"] = f"pitting_level_{level.group(1)}"
    return RawRecord(PHM2023_COLUMNS, rec.data, None, hints)


def read_seu(path: Path) -> RawRecord:
    """SEU gearset layout (module docstring); shaft speed (Hz) and label from the file name."""
    rec = read_delimited(path, skip_text_lines=True)
    require(rec.data.shape[1] >= 8, f"{path}: columns", rec.data.shape[1], "8 (SEU gearset layout)")
    hints: dict = {"sensor": "parallel_x"}
    m = _SEU_NAME.match(path.name)
    if m:
        hints.update(speed_rpm=60.0 * float(m.group("hz")), fault=m.group("label").lower())
    return RawRecord(SEU_COLUMNS, rec.data[:, :8], None, hints)
