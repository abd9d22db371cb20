"""compare.path_regime: a fitted housing mode that the mesh harmonics do not locate is reported as such (the
mass or stiffness line it stands for), and one among them is not."""
from __future__ import annotations

import math

import numpy as np
import pytest

from compare.attribution import attribute
from compare.candidates import CandidateResult
from compare.comparison import compare, prepare_reference
from compare.model import ComparisonModel
from compare.path_regime import (ASYMPTOTE_DB, check_asymptotes, corner_ratio, path_regime, path_regime_text)
from compare.synthetic import hidden_effect_measurement, rig_measurement
from datagen.effects import EffectSpec
from datagen.effects.transmission_path import housing_accelerance

MESH_HZ, N_HARM, FS_HZ = 483.3, 12, 20000.0


def _mode(f_hz, zeta):
    return {"housing_frequency_hz": f_hz, "housing_damping_ratio": zeta}


def test_corner_ratio_is_the_one_db_edge_of_the_undamped_mass_line():
    """Analytic (undamped SDOF accelerance, Ewins 2000 ch. 2): |A| m = r^2 / (r^2 - 1) equals 10^(1/20) at the
    corner ratio (3.03); tolerance 1e-12."""
    r = corner_ratio()
    assert abs(r**2 / (r**2 - 1) - 10 ** (ASYMPTOTE_DB / 20)) < 1e-12
    assert 3.0 < r < 3.1


@pytest.mark.parametrize("f_h, zeta, regime", [(MESH_HZ / 5, 0.01, "mass_line"), (MESH_HZ / 5, 0.5, "mass_line"),
                                               (3000.0, 0.05, "resonant"), (MESH_HZ / 2, 0.05, "resonant"),
                                               (5 * 12 * MESH_HZ, 0.05, "stiffness_line")])
def test_regime_against_the_effects_own_accelerance(f_h, zeta, regime):
    """The regime and its deviation from the asymptote, read from datagen's housing_accelerance (the transfer
    function the effect filters with, which path_regime also calls: this checks the classification and the
    asymptote scaling at any mass, the accelerance itself is checked analytically in
    test_effects_transmission_path.py): every harmonic below fs/2 within 1 dB of 1/m (mass line) or of w^2/k
    (stiffness line), else resonant; deviation to 1e-9 dB."""
    r = path_regime(_mode(f_h, zeta), mesh_hz=MESH_HZ, n_harmonics=N_HARM, fs_hz=FS_HZ)
    f = MESH_HZ * np.arange(1, N_HARM + 1)
    f = f[f < FS_HZ / 2]
    m = 5.0                                               # any mass: the ratios do not depend on it
    a = np.abs(housing_accelerance(f, m, f_h, zeta))
    mass_db = 20 * np.log10(a * m)
    stiff_db = 20 * np.log10(a * m * (2 * np.pi * f_h) ** 2 / (2 * np.pi * f) ** 2)
    assert r["regime"] == regime
    want = np.max(np.abs(stiff_db if regime == "stiffness_line" else mass_db))
    assert abs(r["deviation_db"] - want) < 1e-9
    assert r["top_harmonic_hz"] == pytest.approx(f[-1])
    if regime == "mass_line":
        assert r["edge_hz"] == pytest.approx(MESH_HZ / corner_ratio())
    text = path_regime_text(r)
    assert (text == "") == (regime == "resonant")
    assert path_regime({"grade": 5.0}, mesh_hz=MESH_HZ, n_harmonics=N_HARM, fs_hz=FS_HZ) == {}


def test_a_housing_mode_below_the_mesh_is_not_located():
    """A rig whose sensor sits on a housing with its mode at 80 Hz (5 % damping), six times below the mesh (483 Hz):
    the mesh harmonics lie on its mass line. The attribution fits a transmission path, and the check says a mode
    below the mesh fits as well (the mass line) and one above does not. Outside check of that statement: the
    comparison with the true mode at 60, 80 and 150 Hz gives excess errors within 0.1 dB of each other (the data
    really do not locate it), while the mode at 3 kHz is more than 1 dB worse."""
    m = rig_measurement([{"name": "transmission_path", **_mode(80.0, 0.05)}])
    ref = prepare_reference(m)
    c = compare(m, ComparisonModel(), reference=ref)
    a = attribute(ref, c.model, c.evaluation.residuals.residual_db, disagreements=c.disagreements,
                  candidates=["transmission_path"])
    (cand,) = a.candidates
    assert cand.claimed and cand.reduction > 0.5
    reg = cand.path_regime
    assert reg["as_well"] == ["mass_line"]
    assert reg["asymptotes"]["stiffness_line"] > reg["fitted_excess_db"] + 1.0
    text = path_regime_text(reg)
    assert "below about" in text and f"{MESH_HZ / corner_ratio():.4g}"[:3] in text
    assert cand.to_dict()["path_regime"]["as_well"] == ["mass_line"]

    def excess(f_h, zeta=0.05):
        e = EffectSpec.from_dict({"name": "transmission_path", **_mode(f_h, zeta)}).build()
        return compare(m, ComparisonModel().with_effect(e), reference=ref).evaluation.residuals.excess_total_db

    low = [excess(f) for f in (60.0, 80.0, 150.0)]
    assert max(low) - min(low) < 0.1
    assert excess(3000.0) > max(low) + 1.0


def test_a_housing_mode_among_the_harmonics_is_located():
    """The suite's hidden housing mode (3 kHz, among the mesh harmonics of spur-gds at 1000 rpm): neither
    asymptote fits as well (each leaves at least 1 dB more excess error than the fit), and nothing is said."""
    m, ex = hidden_effect_measurement("transmission_path")
    ref = prepare_reference(m)
    c = compare(m, ex.model(), reference=ref)
    a = attribute(ref, c.model, c.evaluation.residuals.residual_db, disagreements=c.disagreements,
                  candidates=["transmission_path"])
    reg = a.candidates[0].path_regime
    assert reg["regime"] == "resonant" and reg["as_well"] == []
    assert min(reg["asymptotes"].values()) > reg["fitted_excess_db"] + 1.0
    assert path_regime_text(reg) == ""


def test_check_leaves_other_effects_alone_and_the_record_validates():
    """A candidate that is no housing mode gets no path_regime (no simulation); a housing mode's record
    validates under the --json schema, and one with a wrong asymptote name does not."""
    import jsonschema

    from compare.schema import SCHEMA

    c = CandidateResult(effect="pitch_error", signature="", params={"grade": 7.0}, sigma={}, error_db=1.0,
                        baseline_error_db=2.0, view_error_db={}, window="whole record", n_evaluations=3)
    assert check_asymptotes(c, None, None) == {} and c.path_regime == {}
    item = SCHEMA["properties"]["attribution"]["properties"]["candidates"]["items"]
    reg = {**path_regime(_mode(90.0, 0.001), mesh_hz=MESH_HZ, n_harmonics=N_HARM, fs_hz=FS_HZ),
           "asymptotes": {"mass_line": 1.0, "stiffness_line": 3.0}, "fitted_excess_db": 0.9, "as_well": ["mass_line"]}
    d = CandidateResult(effect="transmission_path", signature="", params=_mode(90.0, 0.001), sigma={},
                        error_db=0.9, baseline_error_db=3.0, view_error_db={}, window="whole record",
                        n_evaluations=3, path_regime=reg).to_dict()
    jsonschema.validate(d, item)
    assert "mass line" in path_regime_text(reg) and not math.isnan(reg["deviation_db"])
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**d, "path_regime": {**reg, "as_well": ["sideways"]}}, item)


def test_the_cli_json_and_report_say_the_mode_is_not_located(tmp_path, capsys):
    """``gearpit compare`` on a file of the 80 Hz housing rig (1 s, a tachometer, sidecar 0.5 % off the speed):
    the CLI line under the transmission path, the JSON's ``path_regime`` (valid under the schema) and the HTML
    report all carry the statement."""
    import json

    import jsonschema

    from compare.schema import SCHEMA
    from gearpit.cli import main

    m = rig_measurement([{"name": "transmission_path", **_mode(80.0, 0.05)}], duration_s=1.0)
    t = np.arange(m.n_samples) / m.fs_hz
    np.savetxt(tmp_path / "rig.csv", np.column_stack([t, m.channels["acc"], m.channels["tacho"]]), delimiter=",",
               header="time_s,acc_x,tacho", comments="", fmt="%.10g")
    (tmp_path / "rig.toml").write_text('speed_rpm = 1005.0\ntorque_nm = 50.0\npair = "spur-gds"\nsensor = "acc_x"\n'
                                       'tacho = "tacho"\n')
    assert main(["compare", str(tmp_path / "rig.csv"), "--candidates", "transmission_path", "--no-calibrate",
                 "--json", str(tmp_path / "r.json"), "--report", str(tmp_path / "r.html")]) == 0
    out = capsys.readouterr().out
    assert "the mesh harmonics do not locate this mode" in out and "below the mesh" in out
    doc = json.loads((tmp_path / "r.json").read_text())
    jsonschema.validate(doc, SCHEMA)
    (cand,) = [c for c in doc["attribution"]["candidates"] if c["effect"] == "transmission_path"]
    assert cand["path_regime"]["as_well"] == ["mass_line"]
    assert "the mesh harmonics do not locate this mode" in (tmp_path / "r.html").read_text()
