"""The ledger: an append-only JSON-lines file next to the model, one row per comparison.

``model.toml`` -> ``model.ledger.jsonl``. Each row::

    {"run": 3, "time_utc": "2026-11-21T06:10:00Z", "measurement": "rig.csv", "measurement_sha256": "...",
     "model": "eccentricity_pinion(amplitude_m=0.00015, phase_rad=0.0)", "effects": [{"name": ..., ...}],
     "speed_rpm": 1000.0, "gain_db": 11.3, "error_db": {"order": ..., ..., "total": ...},
     "raw_error_db": {...}, "noise_error_db": {...},
     "claimed": "pitch_error", "candidates": [{"effect": ..., "params": {...}, "reduction": ...}, ...],
     "calibration": {"parameters": {"mesh_damping_ratio": 0.063, ...}, "sigma": {...}, "start": {...},
                     "error_before_db": 0.77, "error_db": 0.65, ...}}

``error_db`` is the excess over the noise error (:mod:`compare.error`, step 7), ``raw_error_db`` the error
before that correction and ``noise_error_db`` the noise error; all three are those of the calibrated model when the nuisances were calibrated (``calibration`` not null).

Rows are only ever appended (one ``write`` of one line per comparison), so the
history of "add an effect, watch the error fall" stays a table.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
import os
from pathlib import Path

from gearpit.errors import InputError


def ledger_path(model_path: str | Path) -> Path:
    p = Path(model_path)
    return p.with_name(p.stem + ".ledger.jsonl")


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def read_ledger(path: str | Path) -> list[dict]:
    """All rows (empty list when the file does not exist yet)."""
    p = Path(path)
    if not p.exists():
        return []
    rows = []
    for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), start=1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError as exc:
            raise InputError(f"{p.name}: line {i}", line[:60], f"one JSON object per line ({exc})") from None
        check_row(row, f"{p}: line {i}")
        rows.append(row)
    return rows


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _check(ok: bool, where: str, field: str, value, allowed: str) -> None:
    if not ok:
        raise InputError(f"{where}: {field}", value, allowed)


def _check_errors(d, where: str, field: str, *, required: bool) -> None:
    """An ``{view: dB}`` table: finite numbers or null (a value that was not a number when written)."""
    if d is None and not required:
        return
    _check(isinstance(d, dict), where, field, d, "an object {view: error in dB}")
    if required:
        _check("total" in d, where, f"{field}.total", None, "a finite number or null (missing)")
    for k, v in d.items():
        _check(v is None or _is_number(v), where, f"{field}.{k}", v, "a finite number or null")


def check_row(row, where: str) -> None:
    """Check one ledger row before anything uses it: a JSON object with ``run`` (integer >= 1), ``model``
    (string) and ``error_db`` (``total`` and the views: finite numbers or null); where present, the other fields
    the code reads with their types (``candidates``: objects with an ``effect`` name and ``params`` /
    ``nuisance`` objects or null). Raises :class:`InputError` naming ``where`` (file and line) and the field."""
    _check(isinstance(row, dict), where, "row", row, "a JSON object (one comparison per line)")
    run = row.get("run")
    _check(isinstance(run, int) and not isinstance(run, bool) and run >= 1, where, "run", run, "an integer >= 1")
    _check(isinstance(row.get("model"), str), where, "model", row.get("model"), "a string (the model's effects)")
    _check_errors(row.get("error_db"), where, "error_db", required=True)
    for k in ("raw_error_db", "noise_error_db"):
        _check_errors(row.get(k), where, k, required=False)
    for k in ("measurement", "measurement_sha256", "claimed", "time_utc", "description"):
        _check(row.get(k) is None or isinstance(row[k], str), where, k, row.get(k), "a string or null")
    for k in ("speed_rpm", "gain_db"):
        _check(row.get(k) is None or _is_number(row[k]), where, k, row.get(k), "a finite number or null")
    for k in ("effects",):
        _check(row.get(k) is None or isinstance(row[k], list), where, k, row.get(k), "an array")
    _check(row.get("calibration") is None or isinstance(row["calibration"], dict), where, "calibration",
           row.get("calibration"), "an object or null")
    cands = row.get("candidates", [])
    _check(isinstance(cands, list), where, "candidates", cands, "an array of objects")
    for j, c in enumerate(cands):
        f = f"candidates[{j}]"
        _check(isinstance(c, dict), where, f, c, "an object {effect, params, reduction, ...}")
        _check(isinstance(c.get("effect"), str), where, f"{f}.effect", c.get("effect"), "an effect name")
        for k in ("params", "nuisance"):
            v = c.get(k)
            _check(v is None or (isinstance(v, dict) and all(isinstance(x, (int, float, str, bool)) and
                                                             (not isinstance(x, float) or math.isfinite(x))
                                                             for x in v.values())),
                   where, f"{f}.{k}", v, "an object {name: value} of finite values, or null")
        for k in ("reduction", "error_db"):
            _check(c.get(k) is None or _is_number(c[k]), where, f"{f}.{k}", c.get(k), "a finite number or null")


def make_row(comparison, attribution=None, *, run: int, measurement_path: str | None = None) -> dict:
    """The ledger row of a comparison (and its attribution, when one was run)."""
    model = comparison.model
    ref = comparison.reference
    row = {"run": run, "time_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
           "measurement": str(measurement_path or ref.measurement.source),
           "measurement_sha256": file_sha256(measurement_path) if measurement_path else None,
           "model": model.describe(), "description": model.description or None,
           "effects": [e.to_dict() for e in model.effects],
           "speed_rpm": ref.speed.speed_rpm, "gain_db": comparison.evaluation.residuals.gain_db,
           "error_db": comparison.error_db, "raw_error_db": comparison.raw_error_db,
           "noise_error_db": comparison.noise_error_db, "claimed": None, "candidates": [],
           "calibration": comparison.calibration.to_dict() if comparison.calibration is not None else None}
    if attribution is not None:
        row["claimed"] = attribution.claimed[0].effect if attribution.claimed else None
        row["candidates"] = [{"effect": c.effect, "params": c.params, "reduction": c.reduction,
                              "error_db": c.error_db, "nuisance": c.nuisance} for c in attribution.candidates]
    return row


def append_row(path: str | Path, row: dict) -> None:
    """Append one row: a single write of one line, flushed to disk."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    line = (json.dumps(_finite(row), default=_jsonable, allow_nan=False) + "\n").encode("utf-8")
    fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    try:
        os.write(fd, line)
        os.fsync(fd)
    finally:
        os.close(fd)


def _finite(v):
    """``v`` with every NaN or infinite float (numpy scalars included) replaced by None: JSON has no such numbers
    (Python's json writes ``NaN``, which strict readers and the ``--json`` document refuse)."""
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    if hasattr(v, "item") and getattr(v, "ndim", 1) == 0:
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _jsonable(v):
    if hasattr(v, "item"):
        return v.item()
    if isinstance(v, float) and v != v:
        return None
    return str(v)


def last_candidate(rows: list[dict], effect: str) -> dict | None:
    """The latest ledger entry of candidate ``effect`` with fitted parameters (``params``, and ``nuisance``:
    the drive-train values they were fitted with, in calibrated runs)."""
    found = last_fit(rows, effect)
    return None if found is None else found[1]


def last_fit(rows: list[dict], effect: str) -> tuple[dict, dict] | None:
    """The row and the candidate entry of :func:`last_candidate`: the row says which run, measurement
    (``measurement``, ``measurement_sha256``) and model the fit was made with."""
    for row in reversed(rows):
        for c in row.get("candidates", []):
            if c.get("effect") == effect and c.get("params") is not None:
                return row, c
    return None


def fit_provenance_warnings(row: dict, *, measurement_path: str | Path | None, model_description: str) -> list[str]:
    """Why a fit taken from ledger ``row`` may not fit this comparison: it was made on another measurement (by
    content digest when the row has one, else by path) or against another model (its effects)."""
    out = []
    if measurement_path is not None:
        sha = row.get("measurement_sha256")
        if sha is not None and Path(measurement_path).is_file():
            other = sha != file_sha256(measurement_path)
        else:
            other = row.get("measurement") is not None and (
                os.path.realpath(row["measurement"]) != os.path.realpath(measurement_path))
        if other:
            out.append(f"warning: run {row['run']} fitted it on another measurement ({row.get('measurement')}"
                       + (", other content" if sha is not None else "") + f") than {measurement_path}")
    if row.get("model") != model_description:
        out.append(f"warning: run {row['run']} fitted it against another model ({row.get('model')}) than this "
                   f"one ({model_description})")
    return out



def history_table(rows: list[dict]) -> str:
    """Plain-text table: run, model, total error and per view (and the model's description, shortened)."""
    views = ("order", "band", "envelope", "tsa", "stats")
    head = f"{'run':>3}  {'total dB':>8}  " + "  ".join(f"{v:>8}" for v in views) + "  model"
    lines = [head]
    for r in rows:
        e = r.get("error_db", {})
        vals = "  ".join(_cell(e.get(v)) for v in views)
        note = f"  [{_short(r['description'])}]" if r.get("description") else ""
        lines.append(f"{r.get('run', 0):>3}  {_cell(e.get('total'))}  {vals}  {r.get('model', '')}{note}")
    return "\n".join(lines)


def _short(text: str, n: int = 40) -> str:
    """The model's description in the table: one line, at most ``n`` characters."""
    t = " ".join(str(text).split())
    return t if len(t) <= n else t[:n - 3] + "..."


def _cell(v) -> str:
    """An error in dB for the table: ``-`` where the ledger has none (null)."""
    return f"{'-':>8}" if v is None else f"{v:8.2f}"
