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

_NUM = {"type": ["number", "null"]}
_STR = {"type": ["string", "null"]}
_ERRORS = {"type": "object", "required": ["total"], "additionalProperties": {"type": "number"}}

_TRIAL = {"type": "object", "properties": {
    "effect": {"type": "string"}, "motor_inertia_kg_m2": {"type": "number"},
    "input_shaft_nm_per_rad": {"type": "number"},
    "trial_amplitude_fraction": {"type": "number"}, "amplitude_fraction": _NUM,
    "type": {"enum": ["amplitude", "frequency", "mixed", "none"]}, "balance": {"type": "number"},
    "profile_scatter": _NUM, "harmonics": {"type": "integer"}}}
_SIDEBAND_FIT = {
    "type": ["object", "null"],
    "description": "a claimed fluctuation whose sidebands read another modulation type than the measurement's: "
                   "its refit on the sidebands (compare.sideband_fit): the measured and model types, the "
                   "refined and the claimed frequency, the claim before, one entry per trial (effect x drive-train "
                   "values: amplitude from the sideband profile's median, its scatter, its type), the chosen "
                   "trial, the errors "
                   "before and after, kept; set on the claim it produced (kept) or on the claim it left; null: "
                   "not run",
    "required": ["measured_type", "model_type", "frequency_hz", "trials", "kept"],
    "properties": {"measured_type": {"type": "string"}, "model_type": {"type": "string"},
                   "frequency_hz": {"type": "number"}, "claimed_frequency_hz": {"type": "number"},
                   "claimed_before": {"type": "string"},
                   "error_before_db": {"type": "number"}, "error_after_db": {"type": "number"},
                   "trials": {"type": "array", "items": _TRIAL}, "kept": {"type": "boolean"},
                   "chosen": {"type": "object", "description": "the trial compared: effect, its drive-train "
                              "values, amplitude_fraction, the comparison's type, at_bound (drive-train values "
                              "on the ladder's bounds)"},
                   "elapsed_s": {"type": "number"}}}

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
        "software_version": {"type": "string"},
        "measurement": {
            "type": "object",
            "required": ["path", "fs_hz", "n_samples", "sensor", "speed_rpm", "speed_rpm_nominal", "speed_method",
                         "torque_nm", "pair"],
            "properties": {"path": {"type": "string"}, "fs_hz": {"type": "number"}, "n_samples": {"type": "integer"},
                           "sensor": {"type": "string"},
                           "sensor_quantity": {"enum": ["acceleration", "velocity", "displacement"],
                                               "description": "what the sensor measures (sidecar); a velocity or "
                                                              "displacement is differentiated to acceleration "
                                                              "(features.derivative) before every view"},
                           "tacho": _STR, "fault": _STR,
                           "speed_rpm": {"type": "number", "description": "refined mean pinion speed"},
                           "speed_rpm_nominal": {"type": "number"},
                           "speed_method": {"enum": ["tacho", "spectrum", "nominal"]},
                           "speed_drift_rad": {"type": ["number", "null"],
                                               "description": "without a tachometer: RMS deviation of the slow "
                                                              "mesh phase from a constant speed (rad, first mesh "
                                                              "harmonic; compare.speed.drift_track); null: not "
                                                              "measured (tachometer, or no two clear harmonics)"},
                           "speed_tracked": {"type": "boolean",
                                             "description": "the measurement's views follow that drift"},
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
                  "properties": {"path": _STR, "description": {"type": "string"}, "sensor": {"type": "string"},
                                 "effects": {"type": "array", "items": {"type": "object", "required": ["name"]}}}},
        "gain_db": {"type": "number", "description": "fitted sensor gain, model -> measurement"},
        "calibration": {
            "type": ["object", "null"],
            "description": "nuisance calibration (compare.calibration); null: not calibrated",
            "required": ["parameters", "sigma", "start", "error_before_db", "error_db"],
            "properties": {"parameters": {"type": "object", "additionalProperties": {"type": "number"},
                                          "description": "calibrated drive-train fields (SI)"},
                           "sigma": {"type": "object", "additionalProperties": _NUM,
                                     "description": "1-sigma (SI), null: not identifiable"},
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
        "error_db": {**_ERRORS, "description": "the headline error: excess over the noise error, "
                                                "sqrt(max(0, E_v^2 - N_v^2)) per view (compare.error, step 7)"},
        "raw_error_db": {**_ERRORS, "description": "E: the weighted RMS of the residuals (compare.error, step 6)"},
        "noise_error_db": {**_ERRORS, "description": "N: E between the model with independent noise draws at the "
                                                      "measured floor (0: no noise drawn)"},
        "locations": {
            "type": "array",
            "description": "the residual map: every compared location",
            "items": {"type": "object",
                      "required": ["key", "view", "group", "label", "weight", "measured_db", "model_db", "residual_db"],
                      "properties": {"key": {"type": "string"},
                                     "view": {"enum": ["order", "band", "envelope", "tsa", "stats"]},
                                     "group": {"type": "string"}, "label": {"type": "string"}, "freq_hz": _NUM,
                                     "weight": {"type": "number",
                                                "description": "w_i of compare.error step 5: the group weight "
                                                               "times the reliability (line views)"},
                                     "measured_db": _NUM, "model_db": _NUM,
                                     "floor_db": _NUM, "residual_db": _NUM}}},
        "disagreements": {
            "type": "array",
            "description": "ranked by |residual_db|",
            "items": {"type": "object", "required": ["key", "view", "label", "residual_db", "text"],
                      "properties": {"key": {"type": "string"}, "view": {"type": "string"}, "label": {"type": "string"},
                                     "residual_db": {"type": "number"}, "measured_db": {"type": "number"},
                                     "model_db": {"type": "number"}, "freq_hz": _NUM, "weight": {"type": "number"},
                                     "text": {"type": "string"}}}},
        "attribution": {
            "type": ["object", "null"],
            "required": ["candidates", "unexplained", "claimed", "elapsed_s", "n_simulations"],
            "properties": {
                "candidates": {"type": "array", "description": "best first (largest error reduction)",
                               "items": {"type": "object",
                                         "required": ["effect", "params", "sigma", "error_db", "baseline_error_db",
                                                      "reduction", "claimed", "status"],
                                         "properties": {"effect": {"type": "string"}, "signature": {"type": "string"},
                                                        "params": {"type": "object"},
                                                        "sigma": {"type": "object",
                                                                  "additionalProperties": _NUM,
                                                                  "description": "1-sigma, null: not identifiable"},
                                                        "error_db": _NUM, "baseline_error_db": {"type": "number"},
                                                        "reduction": {"type": "number"},
                                                        "view_error_db": {"type": "object"},
                                                        "window": {"type": "string"},
                                                        "n_evaluations": {"type": "integer"},
                                                        "explains": {"type": "array", "items": {"type": "string"}},
                                                        "claimed": {"type": "boolean"},
                                                        "status": {"type": "string"},
                                                        "nuisance": {"type": "object",
                                                                     "description": "drive-train values of the "
                                                                                    "fit (calibrated runs)"},
                                                        "raw_error_db": _NUM,
                                                        "raw_baseline_error_db": _NUM,
                                                        "noise_error_db": {"type": "number"},
                                                        "interval": {"type": "object",
                                                                     "additionalProperties": {
                                                                         "type": "array", "items": _NUM,
                                                                         "minItems": 2, "maxItems": 2},
                                                                     "description": "a chaotic record's fit "
                                                                     "(compare.chaos): per parameter [low, high] "
                                                                     "between the nearest values the measurement "
                                                                     "rejects, null: not bounded on that side; "
                                                                     "empty for a regular record"},
                                                        "at_bound": {"type": "object",
                                                                     "additionalProperties": {
                                                                         "enum": ["lower", "upper"]},
                                                                     "description": "fitted parameters on a "
                                                                     "bound of their search"},
                                                        "pinned": {"type": "array", "items": {"type": "string"},
                                                                   "description": "those of at_bound whose error "
                                                                   "rises off the bound (the fit would go past "
                                                                   "it); among rivals one with none pinned is "
                                                                   "claimed first"},
                                                        "response": {
                                                            "type": "object",
                                                            "properties": {
                                                                "frequency_hz": {"type": "number"},
                                                                "speed_pinion_amplitude_fraction": {"type": "number"},
                                                                "mesh_force_amplitude_fraction": {"type": "number"},
                                                                "reference_amplitude_fraction": {"type": "number"},
                                                                "mesh_force_min_fraction": {
                                                                    "type": "number",
                                                                    "description": "the mesh force's least value "
                                                                    "over its mean; below 0 the mesh pulls (the "
                                                                    "teeth would separate: outside the model "
                                                                    "without backlash)"},
                                                                "contact": {
                                                                    "type": "string",
                                                                    "enum": ["kept", "lost", "tension"],
                                                                    "description": "compare.response.contact_state"},
                                                                "shaft_order": {
                                                                    "type": ["object", "null"],
                                                                    "description": "the shaft order the "
                                                                    "frequency sits on within the record's "
                                                                    "resolution (shaft, order), where a "
                                                                    "once-per-revolution error makes the same "
                                                                    "sidebands; null: none"},
                                                                "modulation": {
                                                                    "type": "object",
                                                                    "description": "compare.modulation: the "
                                                                    "sidebands' modulation type at the frequency "
                                                                    "in the measurement and in the model with "
                                                                    "the candidate",
                                                                    "additionalProperties": {
                                                                        "type": "object",
                                                                        "required": ["type", "read"],
                                                                        "properties": {
                                                                            "type": {"enum": [
                                                                                "amplitude", "frequency",
                                                                                "mixed", "none"]},
                                                                            "balance": {"type": "number"},
                                                                            "amplitude": {"type": "integer"},
                                                                            "frequency": {"type": "integer"},
                                                                            "read": {"type": "integer"},
                                                                            "cos_arg_q": {
                                                                                "type": "array",
                                                                                "items": _NUM}}}}},
                                                            "description": "a fitted fluctuation (hook 5; "
                                                            "compare.response): the amplitude of the pinion speed "
                                                            "and of the mesh force at its frequency in the model, "
                                                            "over their means, what a rig's encoder or torque meter "
                                                            "would show (the fitted amplitude_fraction is the "
                                                            "drive's, before the drive train); empty otherwise"},
                                                        "sideband_fit": _SIDEBAND_FIT,
                                                        "shaft_lock": {
                                                            "type": "object",
                                                            "description": "a fluctuation fitted onto a shaft "
                                                            "order {kind: fluctuation, shaft, order}, or a "
                                                            "once-per-revolution error {kind: revolution, shafts}; "
                                                            "empty otherwise (compare.response.mark_shaft_locks)",
                                                            "properties": {
                                                                "kind": {"enum": ["fluctuation", "revolution"]},
                                                                "shaft": {"enum": ["pinion", "wheel"]},
                                                                "order": {"type": "integer"},
                                                                "shafts": {"type": "array", "items": {
                                                                    "enum": ["pinion", "wheel"]}}}},
                                                        "path_regime": {
                                                            "type": "object",
                                                            "description": "a fitted housing mode: regime "
                                                            "resonant (among the mesh harmonics), mass_line (below "
                                                            "them all: only bounded above by edge_hz, damping not "
                                                            "identified) or stiffness_line (above them all: bounded "
                                                            "below by edge_hz); deviation_db from that asymptote; "
                                                            "empty otherwise (compare.path_regime)",
                                                            "properties": {
                                                                "regime": {"enum": ["resonant", "mass_line",
                                                                                    "stiffness_line"]},
                                                                "housing_frequency_hz": {"type": "number"},
                                                                "housing_damping_ratio": {"type": "number"},
                                                                "mesh_hz": {"type": "number"},
                                                                "top_harmonic_hz": {"type": "number"},
                                                                "deviation_db": {"type": "number"},
                                                                "edge_hz": {"type": ["number", "null"]},
                                                                "asymptotes": {"type": "object",
                                                                               "additionalProperties": _NUM,
                                                                               "description": "excess error (dB) "
                                                                               "with the mode moved onto each "
                                                                               "asymptote (mass_line, "
                                                                               "stiffness_line)"},
                                                                "fitted_excess_db": _NUM,
                                                                "as_well": {"type": "array", "items": {
                                                                    "enum": ["mass_line", "stiffness_line"]},
                                                                    "description": "asymptotes that take 90 % "
                                                                    "of the fit's fall of the error: the mode is "
                                                                    "not located on that side"}}},
                                                        "claimed_over": {
                                                            "type": ["object", "null"],
                                                            "required": ["effect", "rule"],
                                                            "properties": {"effect": {"type": "string"},
                                                                           "rule": {"enum": ["interior",
                                                                                             "shaft_locked"]}},
                                                            "description": "the candidate that ranked first when a "
                                                            "rule claimed this one instead: interior (that one's fit "
                                                            "pinned on a bound), shaft_locked (that one a fluctuation "
                                                            "on this shaft's order); null otherwise"},
                                                        "drivetrain_intervals": {
                                                            "type": "array",
                                                            "description": "a chaotic record's ladders per drive "
                                                            "train (compare.chaos, Nuisances): the model's first, "
                                                            "then the one fitted with the candidate in; interval is "
                                                            "the hull of the model's and those not rejected; empty "
                                                            "for a regular record",
                                                            "items": {"type": "object",
                                                                      "required": ["drivetrain", "best",
                                                                                   "best_error_db", "interval",
                                                                                   "rejected",
                                                                                   "realisation_scatter_db"],
                                                                      "properties": {
                                                                          "drivetrain": {"type": "object",
                                                                                         "additionalProperties":
                                                                                             {"type": "number"}},
                                                                          "best": {"type": "object",
                                                                                   "additionalProperties":
                                                                                       {"type": "number"}},
                                                                          "best_error_db": {
                                                                              "type": "object",
                                                                              "additionalProperties":
                                                                                  {"type": "number"}},
                                                                          "interval": {
                                                                              "type": "object",
                                                                              "description": "null: every value "
                                                                              "at this drive train fits worse than "
                                                                              "the best at another (rejected)",
                                                                              "additionalProperties": {
                                                                                  "type": ["array", "null"],
                                                                                  "items": _NUM,
                                                                                  "minItems": 2, "maxItems": 2}},
                                                                          "rejected": {
                                                                              "type": "object",
                                                                              "description": "per parameter: every "
                                                                              "value at this drive train fits worse "
                                                                              "than the best at the other",
                                                                              "additionalProperties":
                                                                                  {"type": "boolean"}},
                                                                          "realisation_scatter_db": {
                                                                              "type": "number"}}}},
                                                        "realisation_scatter_db": {
                                                            "type": ["number", "null"],
                                                            "description": "1-sigma of the error over "
                                                                           "realisations of a chaotic record; "
                                                                           "null: the record is regular"},
                                                        "model_error_db": {
                                                            "type": ["number", "null"],
                                                            "description": "a time-stepped candidate: the excess "
                                                                           "error of the model as compared, which "
                                                                           "a claim must lower by 30 % too; null: "
                                                                           "not checked (periodic candidates)"},
                                                        "joint_refit": {
                                                            "type": ["object", "null"],
                                                            "description": "the claimed candidate of a calibrated "
                                                            "pass: its joint refit with the nuisances over the whole "
                                                            "box (compare.joint_refit): samples, starts, seed, kept, "
                                                            "chosen (current / refined / searched), error_before_db, "
                                                            "error_after_db, params_before, nuisance_before, "
                                                            "n_simulations, elapsed_s; the leader of a calibrated "
                                                            "pass that claimed nothing "
                                                            "(compare.joint_refit.reexamine_leader) also: reexamined "
                                                            "(true), baseline_before_db, baseline_refitted_db, "
                                                            "baseline_chosen, reduction_before, reduction_after, "
                                                            "claimed; null: not run"}}}},
                "unexplained": {"type": "array", "items": {"type": "object", "required": ["key", "text"]}},
                "claimed": {"type": "array", "items": {"type": "string"}},
                "rivals": {"type": "array", "items": {"type": "string"},
                           "description": "effects that pass the claim rule within 5 % of the claimed one's "
                                          "reduction: these views cannot tell them apart"},
                "claim_order": {"type": ["string", "null"],
                                "description": "why the claim is not the candidate that ranked first (a rule of "
                                               "compare.candidates: interior_rival, shaft_locked_twin); null when "
                                               "it is"},
                "elapsed_s": {"type": "number"}, "n_simulations": {"type": "integer"},
                "group_seconds": {"type": "object"},
                "resolution": {"type": ["object", "null"],
                               "description": "what the measurement's further channels (sidecar secondary) said "
                                              "about the claimed effect and its rivals (compare.channels); null "
                                              "without further channels or rivals",
                               "properties": {"channels": {"type": "object"},
                                              "baseline_error_db": {"type": "object"},
                                              "error_db": {"type": "object",
                                                           "description": "effect -> column -> excess error (dB)"},
                                              "reduction": {"type": "object"},
                                              "claimed": {"type": ["string", "null"]},
                                              "before": {"type": "string"},
                                              "rivals": {"type": "array", "items": {"type": "string"}},
                                              "note": {"type": "string"}}}}},
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
                           "score_db": _NUM,
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
                           "as_written_error_db": _NUM,
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
                               "properties": {"error_db": _NUM, "as_written_error_db": _NUM,
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
                                                        "after": {"type": "object"}, "error_before_db": _NUM,
                                                        "error_after_db": _NUM, "kept": {"type": "boolean"}}}}}},
        "ledger": {"type": "array",
                   "items": {"type": "object", "required": ["run", "model", "error_db"],
                             "properties": {"run": {"type": "integer"}, "model": {"type": "string"},
                                            "error_db": _ERRORS}}},
    },
}
