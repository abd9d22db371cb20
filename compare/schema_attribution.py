"""The ``attribution`` entry of the comparison's JSON schema (:data:`compare.schema.SCHEMA`): the candidates,
their fits and checks, the claim, rivals and unexplained disagreements
(:meth:`compare.attribution.Attribution.to_dict`); and the small pieces both modules use (``NUM``, ``STR``,
``ERRORS``)."""
from __future__ import annotations

NUM = {"type": ["number", "null"]}
STR = {"type": ["string", "null"]}
ERRORS = {"type": "object", "required": ["total"], "additionalProperties": {"type": "number"}}

_TRIAL = {"type": "object", "properties": {
    "effect": {"type": "string"}, "motor_inertia_kg_m2": {"type": "number"},
    "input_shaft_nm_per_rad": {"type": "number"},
    "trial_amplitude_fraction": {"type": "number"}, "amplitude_fraction": NUM,
    "type": {"enum": ["amplitude", "frequency", "mixed", "none"]}, "balance": {"type": "number"},
    "profile_scatter": NUM, "harmonics": {"type": "integer"}}}
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


ATTRIBUTION = {
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
                                                          "additionalProperties": NUM,
                                                          "description": "1-sigma, null: not identifiable"},
                                                "error_db": NUM, "baseline_error_db": {"type": "number"},
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
                                                "raw_error_db": NUM,
                                                "raw_baseline_error_db": NUM,
                                                "noise_error_db": {"type": "number"},
                                                "interval": {"type": "object",
                                                             "additionalProperties": {
                                                                 "type": "array", "items": NUM,
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
                                                                        "items": NUM}}}}},
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
                                                                       "additionalProperties": NUM,
                                                                       "description": "excess error (dB) "
                                                                       "with the mode moved onto each "
                                                                       "asymptote (mass_line, "
                                                                       "stiffness_line)"},
                                                        "fitted_excess_db": NUM,
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
                                                                          "items": NUM,
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
                                      "note": {"type": "string"}}}}}


__all__ = ["ATTRIBUTION", "ERRORS", "NUM", "STR"]
