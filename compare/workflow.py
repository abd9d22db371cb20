"""The user's loop in one call: load, (extend the model), compare, attribute, append to the ledger, report.

Used by ``gearpit compare`` and by ``experiments/compare_walkthrough.py``.

- the model file defaults to ``<measurement stem>.model.toml`` beside the
  measurement; a missing file is the baseline and is written, so the user has
  something to edit;
- ``add`` items are ``EFFECT[:key=value,...]``; without values the parameters
  fitted by the latest comparison in the ledger are used (else the defaults),
  and when that comparison calibrated the nuisances, the drive-train values
  the effect was fitted with go into the model's ``[drivetrain]`` too (the
  next calibration starts there: a calibration is a local search, and
  started from the defaults with a housing mode in the model it settled
  worse than the joint fit had); the model file is rewritten with the effect
  added;
- ``refit`` (True: every effect of the model, or a list of names) fits those effects again, each against
  the model without it (:mod:`compare.refit`: an effect fitted before a later one was found leans on its
  absence), after the ``add`` items; a refit that lowers the error is kept and the model file rewritten;
- ``plugins`` are Python files with user effects; they are recorded in the model;
- with ``calibrate=True`` (or the model's ``[calibration] enabled = true``) the drive-train nuisances are
  calibrated to the measurement before the comparison (:mod:`compare.calibration`): the calibrated model is
  then the baseline the attribution measures every candidate against; by default (``"auto"``) only when the
  attribution against the model as written explains nothing (:mod:`compare.escalation`); then both passes go
  into the ledger, the model as written first.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from compare.candidates import Attribution, AttributionSettings, within_noise
from compare.caveats import claim_caveats
from compare.calibration import calibration_message
from compare.channels import resolution_message
from compare.comparison import Comparison, below_shafts_message, prepare_reference
from compare.disagreements import local_fault_note
from compare.escalation import compare_and_attribute, reason_text
from compare.fitspace import CHAIN_EFFECTS
from compare.joint_refit import joint_refit_message
from compare.ledger import append_row, fit_provenance_warnings, last_fit, ledger_path, make_row, read_ledger
from compare.measurement import load_measurement
from compare.model import ComparisonModel, parse_add
from compare.model_lock import lock_path, model_lock
from compare.pair_check import check_pair, pair_message
from compare.quality import clipping_message
from compare.report import document, write_html, write_json
from compare.response import attach_responses
from compare.sideband_fit import sideband_fit_message
from compare.sidecar import find_sidecar
from compare.speed import speed_message
from datagen.effects import EffectSpec, get, load_plugin
from gearpit.atomic import check_output_path
from gearpit.errors import InputError, require


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


def settled_path(model_path: Path) -> Path:
    """Where the settled model of a calibrated pass goes: ``<model stem>.settled.toml``."""
    return model_path.with_name(model_path.stem + ".settled" + model_path.suffix)


def check_outputs(measurement_path, meta, model_path: Path, *, report=None, json_path=None) -> None:
    """Check ``--report`` and ``--json`` before any work (:func:`gearpit.atomic.check_output_path`): writable
    regular-file paths, none of them one of the run's own files (the measurement, its sidecar, the model, its
    ledger and settled model) nor both the same file."""
    m = Path(measurement_path)
    inputs = [m, meta, model_path, ledger_path(model_path), settled_path(model_path), lock_path(model_path)]
    if meta is None:   # the sidecar found beside the measurement (compare.sidecar.find_sidecar)
        try:
            inputs.append(find_sidecar(m))
        except InputError:
            pass
    seen = {}
    for flag, out in (("--json", json_path), ("--report", report)):
        if out is None:
            continue
        target = check_output_path(out, flag, inputs=inputs)
        other = seen.get(os.path.realpath(target))
        if other is not None:
            raise InputError(flag, str(out), f"a file other than the {other} output")
        seen[os.path.realpath(target)] = flag


def extend_model(model: ComparisonModel, add: list[str], rows: list[dict], messages: list, *,
                 measurement_path: str | Path | None = None) -> ComparisonModel:
    """Apply ``--add`` items (module docstring). A fit taken from the ledger is named by its run and
    measurement, with a warning when that run's measurement or model differ from this comparison's."""
    as_loaded = model.describe()
    named: set[str] = set()
    for item in add:
        name, params = parse_add(item)
        require(name != "noise", "--add", item,
                "an effect other than noise: every comparison matches the measurement's noise floor itself (the "
                "model's noise is set from the floor between the orders)")
        if name in named:
            messages.append(f"--add {name} given again: this one replaces the earlier {name}")
        elif name in model.effect_names:
            messages.append(f"--add {name}: replaces the model's {name}")
        named.add(name)
        if params is None:
            found = last_fit(rows, name)
            cls = get(name)
            if found is not None:
                row, fitted = found
                allowed = {k: v for k, v in fitted["params"].items() if k in {f for f in cls().params()}}
                params = allowed
                messages.append(f"added {name} with the parameters fitted by run {row['run']} of the ledger (on "
                                f"{row.get('measurement')}, model {row.get('model')}): {params}")
                messages += fit_provenance_warnings(row, measurement_path=measurement_path,
                                                    model_description=as_loaded)
                if fitted.get("nuisance"):   # fitted jointly with the calibrated nuisances: keep them together
                    model = model.with_drivetrain(fitted["nuisance"])
                    messages.append(f"drive train set to the nuisances it was fitted with: {fitted['nuisance']}")
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
        settings: AttributionSettings | None = None, parallel: bool = True,
        calibrate: bool | str | None = None, refit: bool | list[str] | None = None) -> Outcome:
    """The whole loop (module docstring); returns everything it computed. ``calibrate``: True, False or "auto"
    (None: as the model file says, default "auto")."""
    mpath = Path(model_path) if model_path is not None else default_model_path(measurement_path)
    check_outputs(measurement_path, meta, mpath, report=report, json_path=json_path)
    measurement = load_measurement(measurement_path, meta)
    with model_lock(mpath):    # from reading the model and ledger to writing them (compare.model_lock)
        return _run_locked(measurement, measurement_path, mpath, add=add, plugins=plugins, attribution=attribution,
                           candidates=candidates, report=report, json_path=json_path, seed=seed, settings=settings,
                           parallel=parallel, calibrate=calibrate, refit=refit)


def candidate_notes(model: ComparisonModel, candidates: list[str]) -> list[str]:
    """Check ``--candidates`` (each a registered effect, named as ``--candidates`` when not) and say which of them
    the attribution does not try: the measurement chain's effects (:data:`compare.fitspace.CHAIN_EFFECTS`) and
    the model's own."""
    from datagen.effects import names

    known = names()
    notes = []
    for c in candidates:
        require(c in known, "--candidates", c, f"one of: {', '.join(sorted(known))}")
        if c in CHAIN_EFFECTS:
            notes.append(f"--candidates {c}: not tried (the measurement chain's effect, which every comparison "
                         "matches itself)")
        elif c in model.effect_names:
            notes.append(f"--candidates {c}: not tried (already in the model; --refit {c} refits it)")
    return notes


def _run_locked(measurement, measurement_path, mpath: Path, *, add, plugins, attribution, candidates, report,
                json_path, seed, settings, parallel, calibrate, refit) -> Outcome:
    """:func:`run` once the model's lock is held."""
    messages: list[str] = []
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
    model = extend_model(model, list(add), rows, messages, measurement_path=measurement_path)
    if candidates is not None:
        messages += candidate_notes(model, candidates)
    if measurement.sidecar_path is not None:
        messages.append(f"sidecar: {measurement.sidecar_path}")
    ref = prepare_reference(measurement)
    if (msg := speed_message(ref.speed)) is not None:
        messages.append(msg)
    if ref.speed.tracked:
        source = ("the tachometer's pulses" if ref.speed.method == "tacho"
                  else "two mesh harmonics that agree")
        messages.append(f"the speed drifts within the record ({ref.speed.drift_rad:.2f} rad RMS of the mesh phase, "
                        f"slower than half the wheel's rotation; read from {source}): the "
                        "measurement's views follow it, the model runs at the mean speed")
    if measurement.sidecar.sensor_quantity != "acceleration":
        messages.append(f"the sensor measures {measurement.sidecar.sensor_quantity}: read as acceleration "
                        "(differentiated, features.derivative), as the model's housing channel is")
    if (msg := below_shafts_message(ref)) is not None:
        messages.append(msg)
    if (msg := clipping_message(ref.clipping, measurement.sensor)) is not None:
        messages.append(msg)
    pair_check = check_pair(measurement, ref.speed)
    if (msg := pair_message(pair_check)) is not None:
        messages.append(msg)
    if refit:
        from compare.refit import refit_effects, refit_message

        model, notes = refit_effects(measurement, model, names=None if refit is True else list(refit), reference=ref,
                                     parallel=parallel)
        messages += [refit_message(r) for r in notes]
        changed = changed or any(r["kept"] for r in notes)
    staged = compare_and_attribute(measurement, model, reference=ref, calibrate=calibrate, attribution=attribution,
                                   candidates=candidates, settings=settings or AttributionSettings(seed=seed),
                                   seed=seed, parallel=parallel)
    comparison, att = staged.comparison, staged.attribution
    if att is not None:
        attach_responses(att.candidates, comparison.model, measurement.pair, speed_rpm=ref.speed.speed_rpm,
                         torque_nm=measurement.torque_nm, reference=ref)
    escalation = staged.summary()
    new_rows: list[dict] = []      # appended to the ledger last, once the outputs are written
    if staged.escalated:
        messages.append(f"model as written: error {escalation['as_written_error_db']:.2f} dB; "
                        + reason_text(escalation) + ", so the drive-train nuisances were calibrated and the "
                        "attribution repeated")
        row = make_row(*staged.as_written, run=len(rows) + 1, measurement_path=str(measurement_path))
        rows = rows + [row]
        new_rows.append(row)
    rej = escalation.get("calibration_rejected")
    if rej is not None:
        messages.append(reason_text(escalation) + ", so the drive-train "
                        "nuisances were calibrated and the attribution repeated, but that pass ended higher ("
                        f"{rej['error_db']:.2f} dB with " + (rej.get("claimed") or "no claim")
                        + f", against {rej['as_written_error_db']:.2f} dB as written); the model as written is kept")
    settled_model = None
    if staged.settled:
        from compare.refit import refit_message

        messages += ["the calibrated pass claims nothing more; at its drive train " + refit_message(n)
                     for n in staged.settled]
        if staged.settled_model is not None:
            spath = settled_path(mpath)
            settled_model = staged.settled_model
            messages.append(f"settled model written: {spath} (the calibrated drive train and the kept refits; "
                            f"compare with --model {spath} to take it)")
    cal = comparison.calibration
    if cal is not None:
        messages.append(calibration_message(cal))
    if att is not None and att.resolution is not None:
        messages.append(resolution_message(att.resolution))
    if att is not None and att.claimed and att.claimed[0].joint_refit is not None:
        top = att.claimed[0]
        messages.append(joint_refit_message(top.effect, top.joint_refit, top.params, top.nuisance))
    elif att is not None and att.candidates and (att.candidates[0].joint_refit or {}).get("reexamined"):
        top = att.candidates[0]         # a re-examined leader that stayed unclaimed (compare.joint_refit)
        messages.append(joint_refit_message(top.effect, top.joint_refit, top.params, top.nuisance))
    if att is not None and att.claimed and att.claimed[0].sideband_fit is not None:
        messages.append(sideband_fit_message(att.claimed[0].effect, att.claimed[0].sideband_fit))
    res = comparison.evaluation.residuals
    if att is not None and not att.claimed and within_noise(res.excess_total_db, res.noise_total_db,
                                                            settings or AttributionSettings()):
        messages.append(f"the model agrees with the measurement within the noise (excess error "
                        f"{res.excess_total_db:.2f} dB, below the noise error {res.noise_total_db:.2f} dB): "
                        "there is nothing to attribute, and no effect is claimed")
    if (msg := local_fault_note(comparison, att)) is not None:
        messages.append(msg)
    if att is not None and att.claim_order:
        messages.append(att.claim_order)
    if att is not None and att.claimed and att.rivals:
        messages.append(f"claimed {att.claimed[0].effect}, but {', '.join(att.rivals)} lowers the error almost as "
                        "much: these views cannot tell them apart")
    if att is not None and att.claimed and (att.claimed[0].response or {}).get("contact") == "tension":
        top = att.claimed[0]
        messages.append(f"claimed {top.effect}, but its fitted swing drives the model's mesh force below zero "
                        f"({100 * top.response['mesh_force_min_fraction']:.3g} % of its mean): the teeth would "
                        "separate, which the model without backlash cannot show; the claim says the sidebands are "
                        "stronger than a fluctuation keeping the teeth in contact makes, not how large the rig's "
                        "swing is")
    messages += claim_caveats(att)
    row = make_row(comparison, att, run=len(rows) + 1, measurement_path=str(measurement_path))
    rows = rows + [row]
    new_rows.append(row)
    doc = document(comparison, att, rows, measurement_path=str(measurement_path), model_path=str(mpath),
                   escalation=escalation, pair_check=pair_check)
    if json_path is not None:
        write_json(doc, json_path)
        messages.append(f"JSON written: {json_path}")
    if report is not None:
        write_html(comparison, doc, report)
        messages.append(f"report written: {report}")
    # the model and the ledger last: a run that fails before here leaves both as they were
    if settled_model is not None:
        settled_model.save(settled_path(mpath))
    if changed:
        model.save(mpath)
        messages.append(f"model written: {mpath}")
    for r in new_rows:
        append_row(lpath, r)
    return Outcome(comparison=comparison, attribution=att, ledger=rows, model_path=mpath, messages=messages,
                   document=doc)


def write_rig_files(measurement, out: str | Path, *, stem: str = "rig") -> Path:
    """Write a measurement (sensor ``acc``, ``tacho`` and any further channels) as ``stem.csv`` + ``stem.toml`` in
    ``out``, the way a rig would deliver it; returns the CSV path."""
    import numpy as np

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t = np.arange(measurement.n_samples) / measurement.fs_hz
    csv = out / f"{stem}.csv"
    more = list(measurement.secondary)
    np.savetxt(csv, np.column_stack([t, measurement.channels["acc"], measurement.channels["tacho"]]
                                    + [measurement.channels[c] for c in more]), delimiter=",",
               header=",".join(["time_s", "acc_x", "tacho"] + more), comments="", fmt="%.10g")
    from compare.model import to_toml
    from datagen.geometry import PRESETS, preset

    pair = measurement.pair
    known = pair.name in PRESETS and preset(pair.name) == pair
    side = {"speed_rpm": measurement.speed_rpm, "torque_nm": measurement.torque_nm, "sensor": "acc_x",
            "tacho": "tacho", "pair": pair.name if known else pair.to_dict()}
    if more:
        side["secondary"] = dict(measurement.secondary)
    (out / f"{stem}.toml").write_text(to_toml(side), encoding="utf-8")
    return csv


def hidden_effect_loop(out: str | Path, hidden: str = "pitch_error", *, seed: int = 0,
                       calibrate: bool | str | None = None) -> tuple[dict, Outcome, Outcome]:
    """The README's full loop on a simulated rig with a hidden effect (:mod:`compare.synthetic`).

    Writes ``out/rig.csv`` + ``rig.toml``, compares the baseline model (nuisances calibrated with
    ``calibrate``) with attribution over every registered effect (``out/report_1.html``/``.json``), adds the
    claimed effect with its fitted parameters and compares again (``report_2``). Returns a summary dict and
    the two outcomes (the second is the first when nothing was claimed).
    """
    from compare.synthetic import hidden_effect_measurement

    out = Path(out)
    for stale in ("rig.model.toml", "rig.model.ledger.jsonl"):
        (out / stale).unlink(missing_ok=True)
    m, ex = hidden_effect_measurement(hidden)
    csv = write_rig_files(m, out)
    if ex.known:
        # what rig and model both have (e.g. a measured pitch error): the user's model starts with it
        ex.model().save(out / "rig.model.toml")
    first = run(csv, report=out / "report_1.html", json_path=out / "report_1.json", seed=seed, calibrate=calibrate)
    claimed = first.attribution.claimed[0].effect if first.attribution.claimed else None
    second = first
    if claimed is not None:
        second = run(csv, add=[claimed], attribution=False, report=out / "report_2.html",
                     json_path=out / "report_2.json", seed=seed, calibrate=calibrate)
    e0, e1 = first.comparison.error_db["total"], second.comparison.error_db["total"]
    cal0, cal1 = first.comparison.calibration, second.comparison.calibration
    summary = {"hidden": ex.effect, "claimed": claimed,
               "fitted": first.attribution.claimed[0].params if claimed else None,
               "error_before_db": e0, "error_after_db": e1 if claimed else None,
               "attribution_s": first.attribution.elapsed_s,
               "calibration_before": cal0.to_dict() if cal0 is not None else None,
               "calibration_after": cal1.to_dict() if (cal1 is not None and claimed) else None}
    return summary, first, second

