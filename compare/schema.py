"""JSON Schema (draft 2020-12) of the document ``gearpit compare --json`` writes (:func:`compare.report.document`).

Units are in the key names (``_db``, ``_hz``, ``_rpm``, ``_nm``, ``_s``). Levels
are dB (20 log10 of amplitudes, 10 log10 of powers and of moment ratios, see
:mod:`compare.views`); ``residual_db`` is measured minus model after the sensor
gain fit and the noise floors (:mod:`compare.error`); ``null`` stands for a
value that does not exist (a floor of a statistic, an unbounded uncertainty).

Version 2 (``gearpit.compare/2``): ``error_db`` is the excess over the noise error, with ``raw_error_db`` (the
version-1 ``error_db``) and ``noise_error_db`` beside it; candidates carry their raw and noise errors too.
"""
from __future__ import annotations

from compare.schema_attribution import ATTRIBUTION, ERRORS, NUM, STR

SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "gearpit.compare/2",
    "title": "gearpit model-versus-measurement comparison",
    "type": "object",
    "required": ["schema", "software_version", "measurement", "model", "gain_db", "calibration", "error_db",
                 "raw_error_db", "noise_error_db", "locations", "disagreements", "attribution", "ledger"],
    "additionalProperties": False,
    "properties": {
        "schema": {"const": "gearpit.compare/2"},
        "local_fault_note": {"type": "string",
                             "description": "present when nothing is claimed but one gear's TSA carries a local "
                                            "tooth fault's signature the model lacks, on the gear the leading "
                                            "candidate names (compare.disagreements.local_fault_note)"},
        "claim_caveats": {"type": "array", "items": {"type": "string"}, "minItems": 1,
                          "description": "present when the claimed effect's fitted values need a caveat: an effect "
                                         "that changes only the mesh harmonics' levels, or a local tooth fault "
                                         "whose size is its own shape's (compare.caveats)"},
        "software_version": {"type": "string"},
        "measurement": {
            "type": "object",
            "required": ["path", "fs_hz", "n_samples", "sensor", "speed_rpm", "speed_rpm_nominal", "speed_method",
                         "torque_nm", "pair"],
            "properties": {"path": {"type": "string"},
                           "sidecar": {"type": ["string", "null"],
                                       "description": "the sidecar file read (found beside the measurement or given "
                                                      "with --meta); null: given in Python as a Sidecar"},
                           "fs_hz": {"type": "number"}, "n_samples": {"type": "integer"},
                           "sensor": {"type": "string"},
                           "sensor_quantity": {"enum": ["acceleration", "velocity", "displacement"],
                                               "description": "what the sensor measures (sidecar); a velocity or "
                                                              "displacement is differentiated to acceleration "
                                                              "(features.derivative) before every view"},
                           "sensor_unit": {"type": ["string", "null"],
                                           "description": "the unit of the sensor's numbers (sidecar sensor_unit, "
                                                          "compare.sensor_units), brought to SI when read; null: "
                                                          "not declared, the numbers as written"},
                           "tacho": STR, "fault": STR,
                           "speed_rpm": {"type": "number", "description": "refined mean pinion speed"},
                           "speed_rpm_nominal": {"type": "number"},
                           "speed_method": {"enum": ["tacho", "spectrum", "nominal"]},
                           "speed_drift_rad": {"type": ["number", "null"],
                                               "description": "RMS deviation of the slow mesh phase from a "
                                                              "constant speed (rad, first mesh harmonic): from the "
                                                              "tachometer's pulses, or without one from two mesh "
                                                              "harmonics (compare.speed_track.drift_track); null: not "
                                                              "measured (no two clear harmonics)"},
                           "speed_tracked": {"type": "boolean",
                                             "description": "the measurement's views follow that drift"},
                           "speed_search_fraction": {"type": ["number", "null"],
                                                     "description": "without a tachometer: the half-width (fraction "
                                                                    "of speed_rpm_nominal) of the search that found "
                                                                    "the mesh line: 0.05, or 0.25 when none stood "
                                                                    "out within 0.05 (compare.speed.spectrum_speed); "
                                                                    "null: tachometer"},
                           "torque_nm": {"type": "number"}, "pair": {"type": "object"},
                           "low_cut_hz": {"type": "number",
                                          "description": "content below this frequency (half the slower shaft's "
                                                         "rate: no shaft order) was removed from measurement and "
                                                         "model before every view; 0: nothing removed, the "
                                                         "measurement held too little there "
                                                         "(compare.comparison.BELOW_SHAFTS_REMOVED)"},
                           "below_shafts_ratio": {"type": "number",
                                                  "description": "RMS of the measurement's content there (its mean "
                                                                 "left out) over the RMS of the rest"},
                           "clipping": {"type": "object",
                                        "description": "whether the sensor channel is clipped (compare.quality): "
                                                       "samples piled up on its extremes",
                                        "required": ["clipped", "fraction", "low", "high", "limits"],
                                        "properties": {"clipped": {"type": "boolean"},
                                                       "fraction": {"type": "number",
                                                                    "description": "share of samples on a clipped "
                                                                                   "extreme"},
                                                       "low": {"type": "boolean"}, "high": {"type": "boolean"},
                                                       "limits": {"type": "array", "items": {"type": "number"},
                                                                  "minItems": 2, "maxItems": 2}}}}},
        "model": {"type": "object", "required": ["description", "sensor", "effects"],
                  "properties": {"path": STR, "description": {"type": "string"},
                                 "user_description": {"type": ["string", "null"],
                                                      "description": "the model file's own description key (free "
                                                                     "text; also in the ledger rows)"},
                                 "sensor": {"type": "string"},
                                 "effects": {"type": "array", "items": {"type": "object", "required": ["name"]}}}},
        "gain_db": {"type": "number", "description": "fitted sensor gain, model -> measurement"},
        "gain_factor": {"type": ["number", "null"],
                        "description": "with a declared measurement.sensor_unit: the fitted gain as a dimensionless "
                                       "factor, measured (read in SI) over model, ~1 for a calibrated sensor; null "
                                       "without one (gain_db then also carries the file's unit)"},
        "calibration": {
            "type": ["object", "null"],
            "description": "nuisance calibration (compare.calibration); null: not calibrated",
            "required": ["parameters", "sigma", "start", "error_before_db", "error_db"],
            "properties": {"parameters": {"type": "object", "additionalProperties": {"type": "number"},
                                          "description": "calibrated drive-train fields (SI)"},
                           "sigma": {"type": "object", "additionalProperties": NUM,
                                     "description": "1-sigma (SI), null: not identifiable, or on a bound (at_bound)"},
                           "at_bound": {"type": "object", "additionalProperties": {"enum": ["lower", "upper"]},
                                        "description": "calibrated fields on a bound of their search "
                                                       "(compare.calibration.NUISANCES): lower or upper"},
                           "start": {"type": "object", "additionalProperties": {"type": "number"}},
                           "error_before_db": {"type": "number", "description": "raw total error E at the start"},
                           "error_db": {"type": "number", "description": "raw total error E calibrated"},
                           "gain_db": {"type": "number"}, "n_simulations": {"type": "integer"},
                           "elapsed_s": {"type": "number"},
                           "held_out": {"type": "array", "items": {"type": "string"},
                                        "description": "time-stepped effects left out of the calibration"},
                           "views": {"type": "array", "items": {"type": "string"},
                                     "description": "views whose error the calibration minimises"},
                           "objective_before_db": {"type": "number"}, "objective_db": {"type": "number"}}},
        "noise_added_rms": {"type": "number", "description": "white noise added to the model to match the floor"},
        "error_db": {**ERRORS, "description": "the headline error: excess over the noise error, "
                                                "sqrt(max(0, E_v^2 - N_v^2)) per view (compare.error, step 7)"},
        "raw_error_db": {**ERRORS, "description": "E: the weighted RMS of the residuals (compare.error, step 6)"},
        "noise_error_db": {**ERRORS, "description": "N: E between the model with independent noise draws at the "
                                                      "measured floor (0: no noise drawn)"},
        "locations": {
            "type": "array",
            "description": "the residual map: every compared location",
            "items": {"type": "object",
                      "required": ["key", "view", "group", "label", "weight", "measured_db", "model_db", "residual_db"],
                      "properties": {"key": {"type": "string"},
                                     "view": {"enum": ["order", "band", "envelope", "tsa", "stats"]},
                                     "group": {"type": "string"}, "label": {"type": "string"}, "freq_hz": NUM,
                                     "weight": {"type": "number",
                                                "description": "w_i of compare.error step 5: the group weight "
                                                               "times the reliability (line views)"},
                                     "measured_db": NUM, "model_db": NUM,
                                     "floor_db": NUM, "residual_db": NUM}}},
        "disagreements": {
            "type": "array",
            "description": "ranked by |residual_db|",
            "items": {"type": "object", "required": ["key", "view", "label", "residual_db", "text"],
                      "properties": {"key": {"type": "string"}, "view": {"type": "string"}, "label": {"type": "string"},
                                     "residual_db": {"type": "number"}, "measured_db": {"type": "number"},
                                     "model_db": {"type": "number"}, "freq_hz": NUM, "weight": {"type": "number"},
                                     "text": {"type": "string"}}}},
        "attribution": ATTRIBUTION,
        "pair_check": {
            "type": "object",
            "description": "the measurement against the sidecar's gear pair (compare.pair_check): whether a mesh "
                           "line stands out where the comparison reads it, and the tooth count whose shaft "
                           "sidebands the spectrum carries most strongly; absent from documents written before it",
            "required": ["mesh_hz", "mesh_family_db", "questioned"],
            "properties": {"mesh_hz": {"type": "number", "description": "pinion teeth x the refined speed"},
                           "mesh_family_db": {"type": "number",
                                              "description": "how much more the harmonic family there stands out "
                                                             "than families 1-6 % beside it (dB); below "
                                                             "compare.pair_check.MESH_FAMILY_DB: no mesh line"},
                           "speed_method": {"type": "string"},
                           "sidecar": {"type": "object", "description": "pinion and wheel teeth of the sidecar"},
                           "z_measured": {"type": ["integer", "null"],
                                          "description": "the count of the strongest sideband comb (null: no mesh "
                                                         "line to read it around)"},
                           "score_db": NUM,
                           "sidecar_score_db": {"type": ["object", "null"],
                                                "description": "the comb contrast of each sidecar count (within "
                                                               "the record's resolution)"},
                           "agrees": {"type": "boolean",
                                      "description": "z_measured is one of the sidecar's counts"},
                           "other_family": {"type": "boolean",
                                            "description": "a decisive sideband family that is no shaft of the "
                                                           "pair: a wrong pair, or another modulation (a "
                                                           "fluctuation)"},
                           "questioned": {"type": "boolean",
                                          "description": "no mesh line where the comparison reads it: the pair or "
                                                         "the speed is wrong"}}},
        "escalation": {
            "type": "object",
            "description": "how the calibration mode played out (compare.escalation); absent from documents "
                           "written before the \"auto\" mode",
            "required": ["mode", "escalated"],
            "properties": {"mode": {"enum": [True, False, "auto"]},
                           "escalated": {"type": "boolean",
                                         "description": "the model as written explained nothing, so the nuisances "
                                                        "were calibrated and the attribution repeated"},
                           "explained_reduction": {"type": "number",
                                                   "description": "what 'explains' means: a claimed effect lowering "
                                                                  "the error by at least this fraction"},
                           "reason": {"enum": ["unexplained", "unbounded"],
                                      "description": "why \"auto\" calibrated: no claimed effect lowered the first "
                                                     "pass's error by explained_reduction, or those that did have an "
                                                     "amount the record does not bound (an open interval); absent "
                                                     "when it did not calibrate"},
                           "as_written_error_db": NUM,
                           "as_written_best": {"type": ["object", "null"],
                                               "description": "the first pass's best candidate: effect, reduction, "
                                                              "claimed (whenever \"auto\" calibrated)"},
                           "calibration_rejected": {
                               "type": "object",
                               "description": "\"auto\" calibrated and attributed again, but that pass ended "
                                              "(error of the model with its claimed effect, or of its baseline) at "
                                              "error_db, above the model as written's as_written_error_db; so the "
                                              "first pass is reported and these calibrated values and that claim "
                                              "were not used",
                               "required": ["error_db", "as_written_error_db", "parameters"],
                               "properties": {"error_db": NUM, "as_written_error_db": NUM,
                                              "claimed": {"type": ["string", "null"]},
                                              "parameters": {"type": "object"}}},
                           "settled": {
                               "type": "array",
                               "description": "the calibrated pass claimed nothing more, so each effect of the "
                                              "model was refitted at the calibrated drive train "
                                              "(compare.refit.settle): its parameters before and after, the "
                                              "model's error with each, and whether the refit lowered it enough "
                                              "to be kept (10 %)",
                               "items": {"type": "object",
                                         "required": ["effect", "before", "after", "error_before_db",
                                                      "error_after_db", "kept"],
                                         "properties": {"effect": {"type": "string"}, "before": {"type": "object"},
                                                        "after": {"type": "object"}, "error_before_db": NUM,
                                                        "error_after_db": NUM, "kept": {"type": "boolean"}}}}}},
        "ledger": {"type": "array",
                   "items": {"type": "object", "required": ["run", "model", "error_db"],
                             "properties": {"run": {"type": "integer"}, "model": {"type": "string"},
                                            "error_db": {"type": "object", "required": ["total"],
                                                         "additionalProperties": {"type": ["number", "null"]},
                                                         "description": "null: no finite value (compare.ledger)"}}}},
    },
}
