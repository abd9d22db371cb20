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
            rows.append(json.loads(line))
        except json.JSONDecodeError as exc:
            raise InputError(f"{p.name}: line {i}", line[:60], f"one JSON object per line ({exc})") from None
    return rows


def make_row(comparison, attribution=None, *, run: int, measurement_path: str | None = None) -> dict:
    """The ledger row of a comparison (and its attribution, when one was run)."""
    model = comparison.model
    ref = comparison.reference
    row = {"run": run, "time_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
           "measurement": str(measurement_path or ref.measurement.source),
           "measurement_sha256": file_sha256(measurement_path) if measurement_path else None,
           "model": model.describe(), "effects": [e.to_dict() for e in model.effects],
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
    line = (json.dumps(row, default=_jsonable) + "\n").encode("utf-8")
    fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    try:
        os.write(fd, line)
        os.fsync(fd)
    finally:
        os.close(fd)


def _jsonable(v):
    if hasattr(v, "item"):
        return v.item()
    if isinstance(v, float) and v != v:
        return None
    return str(v)


def last_candidate(rows: list[dict], effect: str) -> dict | None:
    """The latest ledger entry of candidate ``effect`` with fitted parameters (``params``, and ``nuisance``:
    the drive-train values they were fitted with, in calibrated runs)."""
    for row in reversed(rows):
        for c in row.get("candidates", []):
            if c.get("effect") == effect and c.get("params") is not None:
                return c
    return None



def history_table(rows: list[dict]) -> str:
    """Plain-text table: run, model, total error and per view."""
    views = ("order", "band", "envelope", "tsa", "stats")
    head = f"{'run':>3}  {'total dB':>8}  " + "  ".join(f"{v:>8}" for v in views) + "  model"
    lines = [head]
    for r in rows:
        e = r.get("error_db", {})
        vals = "  ".join(f"{e.get(v, float('nan')):8.2f}" for v in views)
        lines.append(f"{r.get('run', 0):>3}  {e.get('total', float('nan')):8.2f}  {vals}  {r.get('model', '')}")
    return "\n".join(lines)
