"""Delimited text records (CSV/TXT/TSV/DAT) as data loggers and spreadsheets write them.

What a logger or a spreadsheet export puts around the numbers, and how it is read:

- a byte-order mark (Excel's "CSV UTF-8"): dropped; UTF-16 (Excel's "Unicode text", by its byte-order mark or
  NUL bytes) read as such; a file that is not valid UTF-8 read as cp1252 (a Windows export's ``µ``, ``²``),
  and its errors say so;
- comment lines (``#``, ``%``, ``//``), before the header or among the rows (a logger's preamble: rig, date,
  channel units): skipped, and named in no error;
- an optional header line (the first non-comment line that is not all numbers), cells optionally quoted, as
  the numbers may be (``"0.125"``, ``"0,125"``); an unnamed first header cell over a column counting 0, 1, 2 ...
  (pandas' ``to_csv`` index) is no channel and dropped;
- an empty cell: NaN (refused if it is in a channel that is read), the last cell of a row too;
- the delimiter ``,`` ``;`` tab or whitespace, sniffed from the first data line;
- a decimal comma (German or French locale exports: ``0,125;-3,5``): read as a decimal point when the
  delimiter is not the comma itself;
- a time column: named ``time``, ``time_s``, ``t`` (or the sidecar's ``time_column``, whatever its name), with its
  unit in the name where it is not seconds (``time_ms``, ``Time [ms]``, ``t (us)``; for the sidecar's column any
  name's suffix: ``Zeit_ms``, ``Zeit [ms]``), converted to seconds here (a rate below :data:`MIN_FS_HZ` is refused
  naming the column and the unit it was read in: a column of ms read as seconds): fs = 1 / the
  least-squares step over all samples (:func:`times_to_fs`), refused unless every step lies within the column's
  written resolution of it (a repeated or jittering time) - unless the sidecar gives ``fs_hz``, which is then the
  rate and the column is only dropped. A gap (a step longer than :data:`GAP_STEPS` sample periods beyond the
  written resolution: samples missing) is refused in every case, naming its time and size: the record on either
  side of it is out of phase, and no rate bridges it (:class:`TimeGapError`).

Anything else that is not a number (a unit row under the header, a text cell among the data) is refused with
the line and what was found, never guessed at.
"""
from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np

from gearpit.errors import InputError, require

#: column names read as the time axis in seconds (lower-cased)
TIME_COLUMNS = ("time", "time_s", "t", "times", "time_sec")
_UNITS = r"(s|sec|ms|msec|us|usec|µs|μs|ns)"
#: a time column's unit, from its name: ``time_ms``, ``Time [ms]``, ``t (us)``, ``time/s``
_TIME_UNIT = re.compile(r"^(?:time|t)\s*(?:[_/]\s*|\[\s*|\(\s*)" + _UNITS + r"\s*[\])]?$", re.IGNORECASE)
#: ... and from any name the sidecar gives as ``time_column``: ``Zeit_ms``, ``Zeit [ms]``, ``Temps (s)``
_ANY_TIME_UNIT = re.compile(r"(?:[_/\s]\s*|\[\s*|\(\s*)" + _UNITS + r"\s*[\])]?$", re.IGNORECASE)
_SECONDS = {"s": 1.0, "sec": 1.0, "ms": 1e-3, "msec": 1e-3, "us": 1e-6, "usec": 1e-6, "µs": 1e-6, "μs": 1e-6,
            "ns": 1e-9}
#: a rate below this (Hz) is no vibration record's: what a time column in ms read as seconds, or a rate given in
#: kHz, gives for every rate from 1 to 100 kHz; data acquisition for vibration samples at 1 kHz and more, and
#: a 100 Hz record would hold the mesh of a 20-tooth pinion only below 135 rpm (first harmonic under 0.45 fs)
MIN_FS_HZ = 100.0
_UNIT_WORDS = {1.0: "seconds", 1e-3: "ms", 1e-6: "us", 1e-9: "ns"}
_COMMENT = ("#", "%", "//")
#: a step of the time column longer than this many sample periods (beyond its written resolution) is a gap:
#: at least one sample is missing there (half a period more than one: a jitter, however large, stays below it)
GAP_STEPS = 1.5
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$")


class TimeGapError(InputError):
    """A time column with a gap: samples are missing (:func:`times_to_fs`); refused even where the sidecar gives
    ``fs_hz`` (:func:`column_fs`)."""


def seconds_per_unit(name: str, *, named: bool = False) -> float | None:
    """Seconds per unit of a column named ``name`` if it is a time column (module docstring), else None.
    ``named``: the sidecar gives ``name`` as its ``time_column``, so it is one whatever it is called; its unit is
    then read from the end of any name (``Zeit_ms``, ``Zeit [ms]``, ``Temps (us)``), seconds where none is
    written (and :func:`column_fs` refuses a rate that reading makes implausible)."""
    n = name.strip().lower()
    if n in TIME_COLUMNS:
        return 1.0
    m = (_ANY_TIME_UNIT.search if named else _TIME_UNIT.match)(n)
    if m:
        return _SECONDS[m.group(1).lower()]
    return 1.0 if named else None


def written_resolution(t: np.ndarray) -> float:
    """The step of the last digit the values ``t`` are written to: ``10**-d`` for the fewest decimals ``d`` (at
    most 12) that write every value exactly (``0.0000781`` -> 1e-07), else 0 (full binary precision)."""
    t = np.asarray(t, dtype=float).ravel()
    top = float(np.max(np.abs(t))) if t.size else 0.0
    for d in range(13):
        q = t * 10.0 ** d
        if float(np.max(np.abs(q - np.round(q)))) <= 1e-6 + 8 * np.finfo(float).eps * top * 10.0 ** d:
            return 10.0 ** -d
    return 0.0


def written_resolutions(t: np.ndarray) -> np.ndarray:
    """The step of the last digit each value of ``t`` is written to: the larger of the column's fixed-decimal
    resolution (:func:`written_resolution`) and the relative one of E-notation, ``10**(e - s + 1)`` for the value's
    exponent ``e`` and the fewest significant digits ``s`` (at most 17) that write every value exactly: a column
    written ``%.6E`` holds 9.999219E-01 and 5.000000E-01 to 1e-07 and 7.812500E-05 to 1e-11 (here read to 1e-09,
    the decimals the column's values need: a fixed-decimal reading never gives a value a resolution coarser than
    the coarsest the column truly has, nor an E-notation reading one coarser than the value's own, so the larger
    of the two is the value's, or at worst within the column's).

    Examples
    --------
    >>> written_resolutions(np.array([7.8125e-05, 0.5, 0.9999219])).tolist()
    [1e-09, 1e-07, 1e-07]
    """
    t = np.asarray(t, dtype=float).ravel()
    res = np.full(t.size, written_resolution(t))
    nz = t != 0
    if not np.any(nz):
        return res
    exp = np.floor(np.log10(np.abs(t[nz])))
    for digits in range(1, 18):
        unit = 10.0 ** (exp - digits + 1)
        q = t[nz] / unit
        if bool(np.all(np.abs(q - np.round(q)) <= 16 * np.finfo(float).eps * np.abs(q))):     # the float's own error
            res[nz] = np.maximum(res[nz], unit)
            return res
    return res


def times_to_fs(t: np.ndarray, where: str, *, unit_s: float = 1.0) -> float:
    """The sampling rate (Hz) of the sample times ``t`` (in units of ``unit_s`` seconds).

    The rate is ``1 / T`` with ``T`` the least-squares step over all samples (not the median step: a column
    written to 7 decimals at 12.8 kHz has steps of 78 and 79 us, median 78). Refused unless finite, increasing and
    uniform to the column's written resolution: every step within the resolution of the last printed digit
    (:func:`written_resolutions`, per sample: E-notation is written to a number of significant digits, fixed
    notation to a number of decimals; two roundings of half a digit each) plus the float rounding of ``t``, of
    ``T``; a jitter beyond it is refused, with the advice to give ``fs_hz`` in the sidecar. A gap (a step over
    :data:`GAP_STEPS` periods, the period being the median step, or ``T`` where the median step is within the
    resolution, beyond the resolution) is refused as :class:`TimeGapError`, naming where it starts (in the
    column's unit and in s) and how many samples are missing there. A column
    written to ``d`` decimals gives the rate to ``fs res / duration`` at worst; it is rounded to the power of ten
    below that (``12799.99964`` from a 0.5 s column written to 10 us -> 12800.0), so that the digits beyond what
    the column holds do not count as a different rate.

    Examples
    --------
    >>> round(times_to_fs(np.round(np.arange(6400) / 12800.0, 7), "time_s"), 6)
    12800.0
    """
    raw = np.asarray(t)
    eps = float(np.finfo(raw.dtype).eps) if raw.dtype.kind == "f" else float(np.finfo(float).eps)
    t = raw.astype(float).ravel()
    require(t.size >= 3 and bool(np.all(np.isfinite(t))), where, "non-finite or fewer than 3 times",
            "finite times")
    k = np.arange(t.size, dtype=float) - 0.5 * (t.size - 1)
    step = float(np.dot(k, t - t.mean()) / np.dot(k, k))          # least squares: t = t0 + step k
    res_each = written_resolutions(t)
    tol = 0.5 * (res_each[:-1] + res_each[1:]) + 8 * eps * float(np.max(np.abs(t)))     # per step
    dt = np.diff(t)
    _refuse_gaps(t, dt, step, tol, where, unit_s)
    worst = int(np.argmax(np.abs(dt - step) - tol))
    if not (step > 0 and float(np.min(dt)) > 0 and abs(dt[worst] - step) <= tol[worst] + 1e-9 * step):
        bad = int(np.argmin(dt)) if step <= 0 or float(np.min(dt)) <= 0 else worst
        raise InputError(where, f"non-uniform or decreasing times (step {bad} -> {bad + 1}: {dt[bad]:.9g} against "
                         f"the mean step {step:.9g})",
                         f"uniform sampling: every step within the column's written resolution ({tol[bad]:.3g}) of "
                         "the mean step; for a logger whose clock is not uniform give fs_hz in the sidecar")
    fs = 1.0 / (step * unit_s)
    res = float(np.max(res_each))
    if res > 0:   # known to fs res / duration at worst: rounded to the power of ten below that, not to noise
        grid = 10.0 ** np.floor(np.log10(fs * res / (t[-1] - t[0])))
        fs = float(np.round(fs / grid) * grid)
    return fs


def _refuse_gaps(t: np.ndarray, dt: np.ndarray, step: float, tol: np.ndarray, where: str, unit_s: float) -> None:
    """Raise :class:`TimeGapError` at the first step of ``t`` longer than :data:`GAP_STEPS` sample periods plus
    its tolerance ``tol`` (:func:`times_to_fs`)."""
    median = float(np.median(dt))
    period = median if median > float(np.max(tol)) else step
    if not period > 0:
        return
    gaps = np.flatnonzero(dt > GAP_STEPS * period + tol)
    if gaps.size == 0:
        return
    i = int(gaps[0])
    missing = int(round(dt[i] / period)) - 1
    more = f"; {gaps.size} gaps in all" if gaps.size > 1 else ""
    at = f"t = {t[i]:.9g}" + (" s" if unit_s == 1.0 else f" ({t[i] * unit_s:.9g} s)")
    raise TimeGapError(where, f"a gap after {at} (step {i} -> {i + 1}): {dt[i] * unit_s * 1e3:.6g} ms, i.e. about "
                       f"{missing} missing sample{'s' if missing != 1 else ''} at the period {period * unit_s:.6g} s"
                       f"{more}",
                       "a record without gaps: samples are missing there, so the record after it is out of phase "
                       "with the one before (not clock jitter; fs_hz in the sidecar does not bridge it): keep the "
                       "part before or after the gap in the file, or fill it at the acquisition")


def read_table(path: Path, *, time_column: str | None = None, skip_text_lines: bool = False,
               fs_hz: float | None = None) -> tuple[tuple, np.ndarray, float | None, tuple]:
    """``(names, data, fs_hz, columns)`` of a delimited text file (module docstring): ``columns`` the names of its
    columns as written, the time column included (what a 0-based column index counts); ``skip_text_lines`` drops every
    leading line that is not a row of at least two numbers (layouts with free-text preambles); ``fs_hz``: the
    sidecar's rate, which a time column that is not uniform leaves in place of refusing the file."""
    text, encoding = _decoded(path)
    where = str(path) if encoding == "UTF-8" else f"{path} (read as {encoding}: not UTF-8)"
    lines = text.splitlines()
    lines = ["" if ln.lstrip().startswith(_COMMENT) else ln for ln in lines]     # keeps the line numbers
    start = 0
    while start < len(lines) and not lines[start].strip():
        start += 1
    require(start < len(lines), where, "empty file", "a file with rows of numbers")
    header, unnamed_first = None, False
    if skip_text_lines:
        while start < len(lines):
            cells = [c for c in _split(lines[start], _sniff_delimiter(lines[start])) if c]
            if cells and all(_is_number(c) for c in cells) and len(cells) >= 2:
                break
            start += 1
        require(start < len(lines), where, "no numeric rows", "rows of numbers after the header text")
    else:
        delim = _sniff_delimiter(lines[start])
        first = _quoted_cells(lines[start], delim)
        if not all(_is_number(c) or c.lower() == "nan" or _DECIMAL_COMMA.match(c) for c in first if c):
            header = _quoted_cells(lines[start], delim)
            unnamed_first = len(header) > 1 and header[0] == ""      # pandas' to_csv: its index column
            header = [h for h in header if h != ""]
            start += 1
            while start < len(lines) and not lines[start].strip():
                start += 1
    require(start < len(lines), where, "a header and no rows", "rows of numbers")
    delim = _sniff_delimiter(lines[start])
    body = lines[start:]
    if '"' in body[0]:           # quoted cells ("0.125", or "0,125" beside a comma delimiter): unquoted
        body = [";".join(c.replace(",", ".") if _DECIMAL_COMMA.match(c) else c for c in _quoted_cells(ln, delim))
                if ln.strip() else ln for ln in body]
        delim = ";"
    elif delim != "," and any(_DECIMAL_COMMA.match(c) for c in _split(lines[start], delim)):
        body = [ln.replace(",", ".") for ln in body]
    width = None if header is None else len(header) + unnamed_first
    try:  # numpy's C parser first (fast on 10^6 rows); ours for a precise message or ragged trailing separators
        data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=delim, ndmin=2, dtype=float, comments=_COMMENT)
        if data.size == 0:
            raise ValueError("no rows")
    except ValueError:
        data = _parse_rows(body, delim, where, start + 1, width)
    if header is not None:
        counter = data.shape[0] > 1 and bool(np.all(data[:, 0] == np.arange(data.shape[0]) + data[0, 0]))
        if unnamed_first and counter and data.shape[1] == len(header) + 1:      # pandas' index: no channel
            data = data[:, 1:]
        index_note = (" (its first column counts 0, 1, 2, ...: an index column without a name? name it or "
                      "remove it)" if counter and data.shape[1] == len(header) + 1 else "")
        require(len(header) == data.shape[1], f"{where}: header", len(header),
                f"{data.shape[1]} names, one per data column{index_note}")
        names = tuple(header)
    else:
        names = tuple(f"ch{i}" for i in range(data.shape[1]))
    if time_column is not None:
        require(time_column in names, "time_column", time_column, "a column name: " + ", ".join(names))
        tcol, scale = names.index(time_column), seconds_per_unit(time_column, named=True)
    else:
        tcol = next((i for i, n in enumerate(names) if seconds_per_unit(n) is not None), None)
        scale = seconds_per_unit(names[tcol]) if tcol is not None else None
    fs, columns = None, names
    if tcol is not None:
        fs = column_fs(data[:, tcol], f"{where}: column {names[tcol]}", unit_s=scale, fs_hz=fs_hz)
        data = np.delete(data, tcol, axis=1)
        names = names[:tcol] + names[tcol + 1:]
    return names, data, fs, columns


def column_fs(t: np.ndarray, where: str, *, unit_s: float = 1.0, fs_hz: float | None = None) -> float | None:
    """:func:`times_to_fs` of a time column; where it is refused for a jitter and the sidecar gives ``fs_hz``, None
    (the sidecar's rate is used); a gap is refused in every case (:class:`TimeGapError`). A rate below
    :data:`MIN_FS_HZ` is refused naming the column and the unit it was read in (a column of ms read as seconds
    gives 12.8 Hz for 12.8 kHz, and the error came later, about speed_rpm), unless the sidecar gives ``fs_hz``:
    its rate is then used and the column only dropped."""
    try:
        fs = times_to_fs(t, where, unit_s=unit_s)
    except TimeGapError:
        raise
    except InputError:
        if fs_hz is None:
            raise
        return None
    if fs < MIN_FS_HZ:
        if fs_hz is not None:
            return None
        unit = _UNIT_WORDS.get(unit_s, f"units of {unit_s:g} s")
        hint = ("if it holds ms, name it time_ms (or 'Time [ms]'; us: time_us)" if unit_s == 1.0 else
                "if its unit is another, name it so (time_s, time_ms, time_us)")
        raise InputError(where, f"fs {fs:.4g} Hz from this time column read as {unit}",
                         f"a vibration record's rate (>= {MIN_FS_HZ:g} Hz): {hint}, or give fs_hz in the sidecar")
    return fs


def _decoded(path: Path) -> tuple[str, str]:
    """``(text, encoding)`` of a text file: UTF-8 (a byte-order mark dropped); UTF-16 by its byte-order mark or
    its NUL bytes (Excel's "Unicode text"); else cp1252 (a Windows logger's or spreadsheet's ``µ``, ``²``, ``°``;
    latin-1 for the five bytes cp1252 leaves undefined)."""
    raw = path.read_bytes()
    head = raw[:4096]
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")) or head.count(0) > len(head) // 4:
        enc = ("utf-16" if raw.startswith((b"\xff\xfe", b"\xfe\xff")) else
               "utf-16-le" if head[1::2].count(0) >= head[0::2].count(0) else "utf-16-be")
        try:
            return raw.decode(enc), "UTF-16"
        except UnicodeDecodeError as exc:
            raise InputError(str(path), f"NUL bytes, and no valid UTF-16 ({exc.reason})",
                             "a text file in UTF-8, UTF-16 or cp1252") from None
    try:
        return raw.decode("utf-8-sig"), "UTF-8"
    except UnicodeDecodeError:
        pass
    try:
        return raw.decode("cp1252"), "cp1252"
    except UnicodeDecodeError:
        return raw.decode("latin-1"), "latin-1"


def _quoted_cells(line: str, delim: str | None) -> list[str]:
    """The cells of ``line``, quotes removed (a quoted cell may hold the delimiter: ``"0,5","1,2"``)."""
    return [c.strip() for c in next(csv.reader(io.StringIO(line), delimiter=delim or " ", skipinitialspace=True))]


def parse_number(cell: str) -> float | None:
    """A text cell as a number, a decimal comma read as a point (``"0,125"``, as in the rows above); None when it
    is none (``"abc"``, ``""``)."""
    c = cell.strip()
    if _DECIMAL_COMMA.match(c):
        c = c.replace(",", ".")
    try:
        return float(c)
    except ValueError:
        return None


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def _split(line: str, delim: str | None) -> list[str]:
    parts = line.split(delim) if delim else line.split()
    return [s.strip() for s in parts]


def _sniff_delimiter(line: str) -> str | None:
    """The first of ``;`` ``,`` tab that splits ``line`` into numbers (a decimal comma counts as one: "0,5\t1,5"
    is tab-separated), else the first present; None: whitespace."""
    present = [d for d in (";", ",", "\t") if d in line]
    for d in present:
        cells = _split(line, d)
        cells = [c.strip('"') for c in cells]
        if len(cells) > 1 and all(c == "" or _is_number(c) or _DECIMAL_COMMA.match(c) for c in cells):
            return d
    if not present or all(_is_number(c) or _DECIMAL_COMMA.match(c) for c in line.split()):
        return None
    return present[0]


def _parse_rows(lines: list[str], delim: str | None, where: str, first_line_no: int,
                header_width: int | None = None) -> np.ndarray:
    """The rows of numbers of ``lines``; an empty cell is NaN (the last one too, where the row would otherwise be
    a cell short of ``header_width``, the header's count), a trailing separator is none."""
    rows = []
    width = None
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        cells = _split(line, delim)
        while cells and cells[-1] == "" and (header_width is None or len(cells) > header_width):  # trailing sep.
            cells.pop()
        if width is None:
            width = len(cells)
        if len(cells) != width:
            raise InputError(f"{where}: line {first_line_no + i}", len(cells),
                             f"{width} columns, as in the first data line")
        try:
            rows.append([float(c) if c.lower() not in ("nan", "") else np.nan for c in cells])
        except ValueError:
            raise InputError(f"{where}: line {first_line_no + i}", line.strip()[:60], "numbers only") from None
    require(rows, where, "no data rows", "at least one row of numbers")
    return np.asarray(rows, dtype=float)


__all__ = ["GAP_STEPS", "MIN_FS_HZ", "TIME_COLUMNS", "TimeGapError", "column_fs", "parse_number", "read_table", "seconds_per_unit", "times_to_fs", "written_resolution",
           "written_resolutions"]
