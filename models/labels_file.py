"""The labels of measurement files: a ``labels.csv`` beside them, or each sidecar's ``fault``.

``labels.csv`` has a header line with the columns ``file`` and ``severity_class`` and any of ``severity``,
``n_pitted_teeth``, ``teeth_class``; the delimiter ``,`` ``;`` or tab, a decimal comma where the delimiter is not
the comma (``0,046``), a byte-order mark, comment lines (``#``) and blanks around cells are accepted, as in the
measurement CSVs (:mod:`compare.text_records`). Everything is checked before any record is read, and each problem
is an :class:`~gearpit.errors.InputError` naming the row (its file), the column, the value and what is allowed:

- ``file``: a name, each once;
- ``severity_class``: a name; for scoring (``gearpit evaluate``) one of the model's classes, matched regardless
  of case (``Healthy`` is ``healthy``), or ``unknown``: not labelled (predicted, not scored);
- ``severity``: a number in [0, 1]; 0 for the healthy class, above 0 for any other;
- ``n_pitted_teeth``: an integer >= 0, 0 for the healthy class;
- ``teeth_class``: one of ``0``, ``1``, ``2``, ``3+``.

A sidecar's ``fault`` is the same vocabulary: ``healthy`` (severity 0, no pitted teeth), another class of the
model, or ``unknown`` (not labelled).
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
import pandas as pd

from gearpit.errors import InputError, require
from models.data import BINARY_CLASSES, TEETH_CLASSES

LABELS_FILE = "labels.csv"
LABEL_COLUMNS: tuple[str, ...] = ("file", "severity_class", "severity", "n_pitted_teeth", "teeth_class")
#: a ``severity_class`` or sidecar ``fault`` that labels nothing: the file is predicted, not scored
UNLABELLED = "unknown"
HEALTHY = "healthy"


def _cells(line: str, delim: str) -> list[str]:
    return [c.strip() for c in next(csv.reader(io.StringIO(line), delimiter=delim, skipinitialspace=True))]


def read_labels(folder: str | Path) -> pd.DataFrame | None:
    """The validated ``labels.csv`` of ``folder`` (module docstring), indexed by file name; None if there is none.
    Numbers are floats (NaN where a cell is empty or the column absent)."""
    from compare.text_records import parse_number

    path = Path(folder) / LABELS_FILE
    if not path.is_file():
        return None
    lines = [(i + 1, ln) for i, ln in enumerate(path.read_text(encoding="utf-8-sig", errors="replace").splitlines())
             if ln.strip() and not ln.lstrip().startswith("#")]
    require(bool(lines), str(path), "empty file", "a header line (file, severity_class, ...) and one row per file")
    header_line = lines[0][1]
    delim = next((d for d in (";", "\t", ",") if d in header_line and "file" in _cells(header_line, d)), ",")
    header = _cells(header_line, delim)
    require("file" in header and "severity_class" in header, LABELS_FILE, header,
            "columns file, severity_class (and optionally severity, n_pitted_teeth, teeth_class)")
    extra = [c for c in header if c not in LABEL_COLUMNS]
    require(not extra, f"{LABELS_FILE}: column", extra[0] if extra else "", "one of: " + ", ".join(LABEL_COLUMNS))
    require(len(set(header)) == len(header), f"{LABELS_FILE}: header", header, "each column once")
    rows, seen = [], {}
    for line_no, line in lines[1:]:
        cells = _cells(line, delim)
        while len(cells) > len(header) and cells[-1] == "":
            cells.pop()
        require(len(cells) == len(header), f"{LABELS_FILE} line {line_no}", line.strip()[:60],
                f"{len(header)} cells ({', '.join(header)}), separated by {delim!r}")
        row = dict(zip(header, cells))
        name = row["file"]
        require(name != "", f"{LABELS_FILE} line {line_no}: file", name, "a file name")
        require(name not in seen, f"{LABELS_FILE} row {name}: file", name,
                f"each file once (also on line {seen.get(name)})")
        seen[name] = line_no
        rows.append(_row(row, f"{LABELS_FILE} row {name}", parse_number))
    require(bool(rows), str(path), "a header and no rows", "one row per labelled file")
    table = pd.DataFrame(rows).set_index("file")
    for col in ("severity", "n_pitted_teeth"):
        if col in table and table[col].isna().all():
            table = table.drop(columns=col)
    if "teeth_class" in table and table["teeth_class"].isna().all():
        table = table.drop(columns="teeth_class")
    return table


def _row(row: dict, where: str, parse_number) -> dict:
    out = {"file": row["file"]}
    cls = row["severity_class"]
    require(cls != "", f"{where}: severity_class", cls, f"a class name (or {UNLABELLED!r}: not labelled)")
    out["severity_class"] = cls
    healthy = cls.lower() == HEALTHY
    labelled = cls.lower() != UNLABELLED
    sev = row.get("severity", "")
    if sev != "":
        v = parse_number(sev)
        require(v is not None and math.isfinite(v) and 0.0 <= v <= 1.0, f"{where}: severity", sev,
                "a number in [0, 1] (the pitted fraction)")
        require(not labelled or (v == 0.0) == healthy, f"{where}: severity", sev,
                f"0 for class {HEALTHY!r} and above 0 for any other (class {cls!r})")
        out["severity"] = v
    else:
        out["severity"] = np.nan
    teeth = row.get("n_pitted_teeth", "")
    if teeth != "":
        v = parse_number(teeth)
        require(v is not None and math.isfinite(v) and v >= 0 and float(v).is_integer(), f"{where}: n_pitted_teeth",
                teeth, "an integer >= 0")
        require(not healthy or v == 0, f"{where}: n_pitted_teeth", teeth, f"0 for class {HEALTHY!r}")
        out["n_pitted_teeth"] = float(v)
    else:
        out["n_pitted_teeth"] = np.nan
    tc = row.get("teeth_class", "")
    require(tc == "" or tc in TEETH_CLASSES, f"{where}: teeth_class", tc, "one of: " + ", ".join(TEETH_CLASSES))
    out["teeth_class"] = tc if tc != "" else np.nan
    return out


def class_name(value: str, classes: list[str] | None, where: str) -> str | None:
    """``value`` (a ``severity_class`` or sidecar ``fault``) as a class of the model: one of ``classes`` matched
    regardless of case; None for :data:`UNLABELLED`. A binary model (healthy / damaged) scores every class other
    than healthy as damaged, so any name is taken. ``classes`` None: no model to match (the value as written,
    ``healthy`` lower-cased)."""
    v = str(value).strip()
    if v.lower() == UNLABELLED:
        return None
    if v.lower() == HEALTHY:
        return HEALTHY
    if classes is None or list(classes) == list(BINARY_CLASSES):
        return v
    match = {c.lower(): c for c in classes}
    if v.lower() not in match:
        raise InputError(where, v, "one of the model's classes: " + ", ".join(classes)
                         + f" (any case), or {UNLABELLED!r}: predicted, not scored")
    return match[v.lower()]


__all__ = ["LABELS_FILE", "UNLABELLED", "class_name", "read_labels"]
