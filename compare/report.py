"""The comparison report: a JSON document (schema in :mod:`compare.schema`) and a self-contained HTML page.

:func:`document` gathers everything a reader needs - operating point, sensor
gain, error per view and in total, every location's measured and model level
and residual (the residual map), the ranked disagreements, the candidate
effects with fitted parameters and uncertainty, the unexplained disagreements
the nuisance calibration and the ledger - as plain JSON. :func:`write_html` renders the same document,
plus the measured-versus-model overlays of each view, as one HTML file whose
figures are embedded PNGs (base64): no external files, no network.
"""
from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

import numpy as np

from compare.candidates import bound_note
from compare.path_regime import path_regime_text
from compare.response import response_text
from compare.sensor_units import describe_unit
from compare.chaos import describe_interval, drivetrains_message
from compare.escalation import reason_text
from gearpit import __version__
from gearpit.atomic import atomic_path

SCHEMA_ID = "gearpit.compare/2"


def _num(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def gain_factor(measurement, gain_db: float) -> float | None:
    """The fitted sensor gain as a dimensionless factor, measured over model, when the measurement's sidecar
    declares its ``sensor_unit`` (both are then in SI: ~1 for a calibrated sensor on a model of the right level);
    None without one (the gain then also carries the file's unit)."""
    if measurement.sidecar.sensor_unit is None:
        return None
    return float(10.0 ** (gain_db / 20.0))


def gain_text(measurement, gain_db: float) -> str:
    """The fitted sensor gain for the CLI and the report: a dimensionless correction with a declared unit
    (:func:`gain_factor`), else in dB as fitted."""
    f = gain_factor(measurement, gain_db)
    if f is None:
        return f"sensor gain {gain_db:+.2f} dB"
    sc = measurement.sidecar
    unit = describe_unit(sc.sensor_unit, sc.sensor_quantity, sensitivity=sc.sensor_sensitivity,
                         sensitivity_unit=sc.sensor_sensitivity_unit)
    return (f"sensor gain x {f:#.3g} ({gain_db:+.2f} dB; a dimensionless correction: the measurement, read in SI "
            f"from its declared unit {unit}, over the model; ~1 for a calibrated sensor)")


def document(comparison, attribution=None, ledger_rows=(), *, measurement_path: str | None = None,
             model_path: str | None = None, escalation: dict | None = None, pair_check: dict | None = None) -> dict:
    """The JSON document of a comparison (schema: :data:`compare.schema.SCHEMA`); ``escalation``: how the
    calibration mode played out (:meth:`compare.escalation.Staged.summary`); ``pair_check``: the measurement
    against the sidecar's pair (:func:`compare.pair_check.check_pair`)."""
    ref, ev = comparison.reference, comparison.evaluation
    m = ref.measurement
    plan = ref.plan
    w = ev.residuals.weights
    g = ev.residuals.gain_db
    locations = []
    for i, loc in enumerate(plan.locations):
        locations.append({"key": loc.key, "view": loc.view, "group": loc.group, "label": loc.label,
                          "freq_hz": _num(loc.freq_hz), "weight": float(w[i]),
                          "measured_db": _num(ref.views.levels[i]),
                          "model_db": _num(ev.views.levels[i] + (g if loc.gain else 0.0)),
                          "floor_db": _num(np.fmax(ref.views.floors[i], ev.views.floors[i] + (g if loc.gain else 0.0))),
                          "residual_db": _num(ev.residuals.residual_db[i])})
    doc = {
        "schema": SCHEMA_ID,
        "software_version": __version__,
        "measurement": {"path": measurement_path or m.source, "sidecar": m.sidecar_path,
                        "fs_hz": m.fs_hz, "n_samples": m.n_samples,
                        "sensor": m.sensor, "sensor_quantity": m.sidecar.sensor_quantity,
                        "sensor_unit": m.sidecar.sensor_unit, "tacho": m.tacho,
                        "fault": m.fault,
                        "speed_rpm_nominal": m.speed_rpm, "speed_rpm": ref.speed.speed_rpm,
                        "speed_method": ref.speed.method, "speed_drift_rad": _num(ref.speed.drift_rad),
                        "speed_tracked": bool(ref.speed.tracked),
                        "speed_search_fraction": _num(ref.speed.search_fraction), "torque_nm": m.torque_nm, "pair": m.pair.to_dict(),
                        "low_cut_hz": float(plan.low_cut_hz), "below_shafts_ratio": float(ref.below_shafts_ratio),
                        "clipping": dict(ref.clipping)},
        "model": {"path": model_path, "description": comparison.model.describe(),
                  "user_description": comparison.model.description or None, "sensor": comparison.model.sensor,
                  "effects": [e.to_dict() for e in comparison.model.effects]},
        "gain_db": g,
        "gain_factor": gain_factor(m, g),
        "calibration": comparison.calibration.to_dict() if comparison.calibration is not None else None,
        "noise_added_rms": ev.noise_added_rms,
        "error_db": {k: float(v) for k, v in comparison.error_db.items()},
        "raw_error_db": {k: float(v) for k, v in comparison.raw_error_db.items()},
        "noise_error_db": {k: float(v) for k, v in comparison.noise_error_db.items()},
        "locations": locations,
        "disagreements": [d.to_dict() for d in comparison.disagreements],
        "attribution": attribution.to_dict() if attribution is not None else None,
        "ledger": list(ledger_rows),
    }
    if escalation is not None:
        doc["escalation"] = escalation
    if pair_check is not None:
        doc["pair_check"] = pair_check
    from compare.disagreements import local_fault_note

    if (note := local_fault_note(comparison, attribution)) is not None:
        doc["local_fault_note"] = note
    from compare.caveats import claim_caveats

    if caveats := claim_caveats(attribution):
        doc["claim_caveats"] = caveats
    return json.loads(json.dumps(doc, default=_default))


def _default(v):
    if hasattr(v, "item"):
        return v.item()
    if isinstance(v, (tuple, set)):
        return list(v)
    return str(v)


def write_json(doc: dict, path: str | Path) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(doc, indent=1, allow_nan=False), encoding="utf-8")
    return Path(path)


# ---------------------------------------------------------------------- HTML
_CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;color:#222}
table{border-collapse:collapse;font-size:13px;margin:.5em 0}td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}
th{background:#eee}.pos{color:#1f4e9c}.neg{color:#d9541e}.claimed{background:#e8f5e1}.flag{background:#fbe9e7}
img{max-width:100%}h2{border-bottom:1px solid #ccc}code{background:#f4f4f4}"""


def _img(png: bytes, alt: str) -> str:
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'


def _table(head: list, rows: list, cls=None) -> str:
    out = ["<table><tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in head) + "</tr>"]
    for i, r in enumerate(rows):
        c = f' class="{cls[i]}"' if cls and cls[i] else ""
        out.append(f"<tr{c}>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in r) + "</tr>")
    return "".join(out) + "</table>"


def _fmt(v, nd=3):
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{nd}g}"
    return str(v)


def _pair_html(check: dict | None) -> list[str]:
    """The pair check's message (compare.pair_check), when it has one."""
    from compare.pair_check import pair_message

    msg = pair_message(check) if check else None
    return [] if msg is None else [f"<p><b>Gear pair:</b> {html.escape(msg)}</p>"]


def _below_shafts_html(ref) -> list[str]:
    """What the measurement's own recording says (compare.speed: a sidecar speed further off than the first search;
    compare.quality: clipping) and the content below every shaft order that was removed
    (compare.comparison.below_shafts_message)."""
    from compare.comparison import below_shafts_message

    from compare.quality import clipping_message

    from compare.speed import speed_message

    out = []
    if (msg := speed_message(ref.speed)) is not None:
        out.append(f"<p class='flag'><b>Speed:</b> {html.escape(msg)}.</p>")
    if (msg := clipping_message(ref.clipping, ref.measurement.sensor)) is not None:
        out.append(f"<p class='flag'><b>Clipped:</b> {html.escape(msg)}.</p>")
    if (msg := below_shafts_message(ref)) is not None:
        out.append(f"<p><b>Below the shaft orders:</b> {html.escape(msg)}.</p>")
    return out


def _calibration_html(cal: dict | None, escalation: dict | None = None) -> list[str]:
    """The nuisance-calibration section (compare.calibration; why it ran: compare.escalation)."""
    why = []
    if escalation and escalation.get("escalated"):
        why = [f"<p>Calibrated because the model as written (error {escalation['as_written_error_db']:.2f} dB) left "
               f"the mismatch open: {html.escape(reason_text(escalation))}. Its row is in the ledger below.</p>"]
    rej = (escalation or {}).get("calibration_rejected")
    if rej is not None:
        why = [f"<p>As written, {html.escape(reason_text(escalation))}, so the drive-train nuisances "
               f"were calibrated and the attribution repeated; that pass ended at {rej['error_db']:.2f} dB (with "
               f"{html.escape(rej.get('claimed') or 'no claim')}), above the model as written's "
               f"{rej['as_written_error_db']:.2f} dB, so the calibration was not used: "
               + ", ".join(f"{html.escape(k)} {v:.4g}" for k, v in rej["parameters"].items()) + ".</p>"]
    for n in (escalation or {}).get("settled", []):      # compare.refit.settle
        why.append(f"<p>The calibrated pass claimed nothing more, so {html.escape(n['effect'])} was refitted at "
                   f"its drive train: {html.escape(str(n['before']))} -> {html.escape(str(n['after']))}, error "
                   f"{n['error_before_db']:.2f} -> {n['error_after_db']:.2f} dB"
                   + (" (kept: the settled model is written beside the model file)." if n["kept"] else
                      " (not kept: it lowered the error by less than 10 %).") + "</p>")
    if cal is None:
        return why + ["<p>Nuisance calibration: off (the drive train as the model file gives it).</p>"]
    at_bound = cal.get("at_bound", {})
    rows = [[k, _fmt(cal["start"].get(k), 4), _fmt(v, 4) + bound_note(k, at_bound, ()),
             _fmt(cal["sigma"].get(k), 2) if cal["sigma"].get(k) is not None or k not in at_bound else
             "- (on a bound: the error still falls towards it)"]
            for k, v in cal["parameters"].items()]
    return ["<h2>Nuisance calibration</h2>",
            "<p>Drive-train parameters nobody measures, fitted to the measurement before the attribution together "
            "with the sensor gain (module <code>compare.calibration</code>); the calibrated model is the baseline "
            "every candidate effect is measured against.</p>",
            _table(["parameter", "model file / default", "calibrated",
                    "1 sigma ('-': not identifiable, or on a bound of its search)"], rows),
            f"<p>Raw total error (before the noise correction) {cal['error_before_db']:.3f} dB before, "
            f"{cal['error_db']:.3f} dB after "
            f"({cal['n_simulations']} simulations, {cal['elapsed_s']:.1f} s).</p>", *why]


def write_html(comparison, doc: dict, path: str | Path) -> Path:
    """Render ``doc`` (from :func:`document`) and the overlays of ``comparison`` as one HTML file."""
    from compare import plots

    e = doc["error_db"]
    m = doc["measurement"]
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>gearpit compare</title><style>{_CSS}</style>"
             "</head><body>",
             "<h1>Model versus measurement</h1>",
             f"<p>Measurement <code>{html.escape(str(m['path']))}</code>"
             + ("" if not m.get("sidecar") else f" (sidecar <code>{html.escape(str(m['sidecar']))}</code>)")
             + f": sensor <code>{html.escape(m['sensor'])}</code>"
             + ("" if m.get("sensor_quantity", "acceleration") == "acceleration" else
                f" (a {html.escape(m['sensor_quantity'])}, read as acceleration)") + ", "
             f"fs {m['fs_hz']:g} Hz, {m['n_samples']} samples; speed {m['speed_rpm']:.3f} rpm "
             f"(nominal {m['speed_rpm_nominal']:g}, refined from the {m['speed_method']}), torque {m['torque_nm']:g} N m.</p>",
             f"<p>Model: <code>{html.escape(doc['model']['description'])}</code>"
             + (f" ({html.escape(doc['model']['user_description'])})" if doc['model'].get('user_description') else "")
             + ". Sensor gain fitted: "
             + (f"{doc['gain_db']:+.2f} dB" if doc.get("gain_factor") is None else
                f"x {doc['gain_factor']:#.3g} ({doc['gain_db']:+.2f} dB; the measurement read in SI from its declared "
                f"unit {html.escape(m['sensor_unit'])}: ~1 for a calibrated sensor)") + ".</p>",
             *_pair_html(doc.get("pair_check")),
             *_below_shafts_html(comparison.reference),
             *_calibration_html(doc.get("calibration"), doc.get("escalation")),
             "<h2>Error</h2>",
             _table(["view", "error (dB)", "raw error E (dB)", "noise error N (dB)"],
                    [[k, f"{v:.3f}", f"{doc['raw_error_db'].get(k, float('nan')):.3f}",
                      f"{doc['noise_error_db'].get(k, float('nan')):.3f}"] for k, v in e.items()]),
             "<p>Definition: the raw error E is the weighted RMS of the residuals in dB after the gain fit and the "
             "noise floors; the noise error N is E between the model record and itself with independent noise "
             "draws at the measured floor; the error is the excess sqrt(max(0, E^2 - N^2)) (module "
             "<code>compare.error</code>): 0 for identical signals, near 0 for a model at the noise floor.</p>",
             "<h2>Views: measured versus model</h2>",
             _img(plots.order_spectrum(comparison), "order spectrum"),
             _img(plots.location_levels(comparison, "order", "order view: mesh harmonics, sidebands, shaft orders"),
                  "order levels"),
             _img(plots.location_levels(comparison, "band", "band view: content at no shaft order"), "band levels"),
             _img(plots.envelope_spectrum(comparison), "envelope spectrum"),
             _img(plots.location_levels(comparison, "envelope", "envelope view"), "envelope levels"),
             _img(plots.tsa(comparison), "TSA"),
             _img(plots.location_levels(comparison, "tsa", "TSA view: tooth segments"), "tsa levels"),
             _img(plots.location_levels(comparison, "stats", "statistics and condition indicators"), "stats"),
             "<h2>Residual map</h2>", _img(plots.residual_map(comparison), "residual map"),
             "<h2>Largest disagreements</h2>"]
    dis = doc["disagreements"]
    unexplained = {u["key"] for u in (doc["attribution"] or {}).get("unexplained", [])}
    parts.append(_table(["#", "where it fails", "residual (dB)", "view", "unexplained"],
                        [[i + 1, d["text"], f"{d['residual_db']:+.1f}", d["view"], "yes" if d["key"] in unexplained else ""]
                         for i, d in enumerate(dis)],
                        cls=["flag" if d["key"] in unexplained else "" for d in dis]) if dis else
                 "<p>No disagreement above the threshold.</p>")
    att = doc["attribution"]
    if att is not None:
        parts.append("<h2>Candidate effects</h2>")
        rows, cls = [], []
        for c in att["candidates"]:
            ps = ", ".join(f"{k}={_fmt(v)}" + (describe_interval(c["interval"][k]) if k in c.get("interval", {}) else
                                                (f" \u00b1 {_fmt(c['sigma'].get(k))}" if k in c["sigma"] else ""))
                           + bound_note(k, c.get("at_bound", {}), c.get("pinned", ()))
                           for k, v in c["params"].items())
            if c.get("response"):
                ps += "; " + response_text(c["response"], c["effect"])
            if path_regime_text(c.get("path_regime", {})):
                ps += "; " + path_regime_text(c["path_regime"])
            rows.append([c["effect"], f"{100 * c['reduction']:.1f} %", _fmt(c["error_db"]), _fmt(c["baseline_error_db"]),
                         _fmt(c.get("worst_view_rise_db")), ps, c["window"], "claimed" if c["claimed"] else "",
                         c["signature"]])
            cls.append("claimed" if c["claimed"] else "")
        table = _table(["effect", "error reduction", "error after (dB)", "before (dB)", "worst view rise (dB)",
                        "fitted parameters (1 sigma)", "window", "", "signature"], rows, cls)
        parts.append(table)
        if doc.get("local_fault_note"):
            parts.append(f"<p class=\"flag\">{html.escape(doc['local_fault_note'])}</p>")
        parts += [f"<p class=\"flag\">{html.escape(c)}</p>" for c in doc.get("claim_caveats", [])]
        parts.append(f"<p>{att['n_simulations']} simulations in {att['elapsed_s']:.1f} s. Sigma '-' means not "
                     "identifiable from these views. An effect is claimed when it lowers the error by 30 % or more "
                     "and raises no view's error by more than 1 dB (or a quarter of its fall of the total, when "
                     "larger), unless the model already agrees with the measurement within the noise (excess "
                     "error below the noise error); a time-stepped effect is fitted on a window and measured on "
                     "the whole record before it is ranked, and must lower the comparison's own error by 30 % "
                     "too. A parameter pinned on a bound of its search (its error still falls towards it) asks for "
                     "a value the effect's range does not allow; among effects that lower the error alike (within "
                     "5 %), one with no parameter pinned is claimed before one with a pinned parameter.</p>")
        top = next((c for c in att["candidates"] if c["claimed"]), None)
        for c in att["candidates"][:3]:
            if c.get("drivetrain_intervals"):
                parts.append("<p><b>Chaotic record:</b> " + html.escape(drivetrains_message(
                    c["effect"], c["drivetrain_intervals"])) + ".</p>")
        lead = top if top is not None else (att["candidates"][0] if att["candidates"] else None)
        if lead is not None and lead.get("joint_refit") and (top is not None or lead["joint_refit"].get("reexamined")):
            from compare.joint_refit import joint_refit_message

            parts.append("<p><b>Joint refit:</b> " + html.escape(joint_refit_message(
                lead["effect"], lead["joint_refit"], lead["params"], lead.get("nuisance") or {})) + ".</p>")
        if top is not None and top.get("sideband_fit"):
            from compare.sideband_fit import sideband_fit_message

            parts.append("<p><b>Sideband refit:</b> " + html.escape(sideband_fit_message(
                top["effect"], top["sideband_fit"])) + ".</p>")
        if att.get("resolution"):
            from compare.channels import resolution_message

            parts.append("<p><b>Further channels:</b> " + html.escape(resolution_message(att["resolution"])) + ".</p>")
        if att.get("claim_order"):
            parts.append("<p><b>Claim order:</b> " + html.escape(att["claim_order"]) + ".</p>")
        if att.get("rivals"):
            parts.append("<p><b>Not distinguishable from the claimed " + html.escape(", ".join(att["claimed"]))
                         + ":</b> " + html.escape(", ".join(att["rivals"])) + " lowers the error almost as much "
                         "(within 5 % of the baseline); these views cannot tell them apart. Check with another "
                         "sensor (an encoder on a shaft) before acting on the claim.</p>")
        if att["unexplained"]:
            parts.append("<p><b>Unexplained by every registered effect:</b></p><ul>"
                         + "".join(f"<li>{html.escape(u['text'])}</li>" for u in att["unexplained"]) + "</ul>")
    rows = doc["ledger"]
    if rows:
        parts.append("<h2>Ledger</h2>")
        parts.append(_img(plots.ledger_history(rows), "ledger"))
        parts.append(_table(["run", "time (UTC)", "model", "total (dB)", "claimed"],
                            [[r.get("run"), r.get("time_utc"), r.get("model"), _fmt(r["error_db"].get("total")),
                              r.get("claimed") or ""] for r in rows]))
    parts.append(f"<p style='color:#888'>gearpit {html.escape(doc['software_version'])}, schema {doc['schema']}</p>"
                 "</body></html>")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(parts), encoding="utf-8")
    return Path(path)
