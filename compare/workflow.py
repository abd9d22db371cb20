"""The user's loop in one call: load, (extend the model), compare, attribute, append to the ledger, report.

Used by ``gearpit compare`` and by ``experiments/compare_walkthrough.py``.

- the model file defaults to ``<measurement stem>.model.toml`` beside the
  measurement; a missing file is the baseline and is written, so the user has
  something to edit;
- ``add`` items are ``EFFECT[:key=value,...]``; without values the parameters
  fitted by the latest comparison in the ledger are used (else the defaults);
  the model file is rewritten with the effect added;
- ``plugins`` are Python files with user effects; they are recorded in the model.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from compare.attribution import Attribution, AttributionSettings, attribute
from compare.comparison import Comparison, compare, prepare_reference
from compare.ledger import append_row, last_fit, ledger_path, make_row, read_ledger
from compare.measurement import load_measurement
from compare.model import ComparisonModel, parse_add
from compare.report import document, write_html, write_json
from datagen.effects import EffectSpec, get, load_plugin


@dataclass
class Outcome:
    comparison: Comparison
    attribution: Attribution | None
    ledger: list
    model_path: Path
    messages: list = field(default_factory=list)
    document: dict | None = None


def default_model_path(measurement_path: str | Path) -> Path:
    p = Path(measurement_path)
    return p.with_name(p.stem + ".model.toml")


def extend_model(model: ComparisonModel, add: list[str], rows: list[dict], messages: list) -> ComparisonModel:
    """Apply ``--add`` items (module docstring)."""
    for item in add:
        name, params = parse_add(item)
        if params is None:
            fitted = last_fit(rows, name)
            cls = get(name)
            if fitted is not None:
                allowed = {k: v for k, v in fitted.items() if k in {f for f in cls().params()}}
                params = allowed
                messages.append(f"added {name} with the parameters fitted by the last comparison: {params}")
            else:
                params = {}
                messages.append(f"added {name} with its default parameters (no fit in the ledger yet)")
        else:
            messages.append(f"added {name} with {params}")
        model = model.with_effect(EffectSpec.from_dict({"name": name, **params}).build())
    return model


def run(measurement_path: str | Path, *, meta: str | Path | None = None, model_path: str | Path | None = None,
        add: list[str] = (), plugins: list[str] = (), attribution: bool = True, candidates: list[str] | None = None,
        report: str | Path | None = None, json_path: str | Path | None = None, seed: int = 0,
        settings: AttributionSettings | None = None, parallel: bool = True) -> Outcome:
    """The whole loop (module docstring); returns everything it computed."""
    messages: list[str] = []
    measurement = load_measurement(measurement_path, meta)
    mpath = Path(model_path) if model_path is not None else default_model_path(measurement_path)
    for p in plugins:
        added = load_plugin(p)
        messages.append(f"plugin {p}: registered {', '.join(added) or 'nothing new'}")
    model = ComparisonModel.load(mpath)
    for p in plugins:
        rel = str(Path(p).resolve())
        model = model.with_plugin(rel)
    lpath = ledger_path(mpath)
    rows = read_ledger(lpath)
    changed = bool(add) or bool(plugins) or not mpath.exists()
    model = extend_model(model, list(add), rows, messages)
    if candidates is not None:
        for c in candidates:
            get(c)
    if changed:
        model.save(mpath)
        messages.append(f"model written: {mpath}")
    ref = prepare_reference(measurement)
    comparison = compare(measurement, model, seed=seed, reference=ref)
    att = None
    if attribution:
        att = attribute(ref, model, comparison.evaluation.residuals.residual_db, candidates=candidates,
                        settings=settings or AttributionSettings(seed=seed), disagreements=comparison.disagreements,
                        parallel=parallel)
    row = make_row(comparison, att, run=len(rows) + 1, measurement_path=str(measurement_path))
    append_row(lpath, row)
    rows = rows + [row]
    doc = document(comparison, att, rows, measurement_path=str(measurement_path), model_path=str(mpath))
    if json_path is not None:
        write_json(doc, json_path)
        messages.append(f"JSON written: {json_path}")
    if report is not None:
        write_html(comparison, doc, report)
        messages.append(f"report written: {report}")
    return Outcome(comparison=comparison, attribution=att, ledger=rows, model_path=mpath, messages=messages,
                   document=doc)
