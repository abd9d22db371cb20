"""Physically implausible records are flagged: a pulling mesh without a contact-loss law, an unconverged solution,
a load beyond the teeth's strength (datagen.plausibility); in the result, on the CLI and in a generated dataset."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from datagen import dataset
from datagen.generate import WARNINGS_COLUMN, build_case, generate
from datagen.geometry import spur_pair_example
from datagen.plausibility import FORM_STRESS_FACTOR, ROOT_STRENGTH_PA, deflection_limit_m
from datagen.sampling import build_pit_map, draw_sample
from datagen.simulate import Case, simulate
from datagen.sweep import sweep_from_dict
from gearpit.cli import main

from test_dataset_config import base  # tests/ is on sys.path (conftest.py)


def case_dict(torque_nm=11.3, pits=True, effects=()):
    d = {"duration_s": 0.1, "fs_hz": 12800.0, "seed": 3, "pair": {"preset": "spur-gds"},
         "operating": {"speed_rpm": 1500.0, "torque_nm": torque_nm}, "effects": list(effects)}
    if pits:  # the whole active flank of tooth 0 gone: its mesh stiffness drops, the linear law pulls
        d["pits"] = {"gear": "pinion", "shape": "rectangle", "teeth": [0], "severity": 1.0}
    return d


def codes(sig):
    return [w["code"] for w in sig.metadata["warnings"]]


def test_pulling_mesh_is_flagged_without_backlash_and_not_with_it():
    """A fully pitted tooth at 11.3 N m: the linear law's force falls below zero (the auditor's p_full: -1256 N
    around a mean of 415 N); with the backlash law the same case parts and strikes the back flank (also a
    negative force, which is physics there): no warning."""
    lin, dead = simulate([Case.from_dict(case_dict()),
                          Case.from_dict(case_dict(effects=[{"name": "backlash", "backlash_m": 1e-4}]))])
    assert lin.channels["mesh_force_n"].min() < 0 and dead.channels["mesh_force_n"].min() < 0
    assert codes(lin) == ["mesh_tension"] and codes(dead) == []
    msg = lin.metadata["warnings"][0]["message"]
    assert "backlash" in msg and f"{lin.channels['mesh_force_n'].min():.4g} N" in msg


def test_load_beyond_root_strength_and_unconverged_angle_are_flagged():
    """spur-gds (b 20 mm, m 2 mm): the limit is sigma b m / (Y_F Y_S) / cos(alpha_w) over k; at 1500 N m the
    static deflection F/k is ~146 um > 67 um, at 5000 N m the periodic angle iteration does not settle either
    (the auditor's hightq: angle_converged false, pinion speed -120..2466 rpm); 11.3 N m healthy: nothing."""
    pair = spur_pair_example()
    k = 3.77e8
    f_limit = ROOT_STRENGTH_PA * 0.02 * 0.002 / FORM_STRESS_FACTOR / math.cos(math.radians(20.0))
    assert deflection_limit_m(pair, k) == pytest.approx(f_limit / k, rel=1e-9)
    ok, heavy, extreme = simulate([Case.from_dict(case_dict(t, pits=False)) for t in (11.3, 1500.0, 5000.0)])
    assert codes(ok) == [] and codes(heavy) == ["deflection_beyond_strength"]
    assert codes(extreme) == ["solver_unconverged", "deflection_beyond_strength"]
    assert extreme.metadata["solver"]["angle_converged"] is False
    assert 'method = "transient"' in extreme.metadata["warnings"][0]["message"]


def test_cli_prints_the_warning_and_writes_it_into_the_json(tmp_path, capsys):
    """`gearpit simulate` exits 0, one stderr line per warning, the JSON's ``warnings`` holds them; a channel
    selection without the mesh force still gets the check."""
    p = tmp_path / "p_full.toml"
    p.write_text(_toml(case_dict()))
    assert main(["simulate", str(p), "--out", str(tmp_path / "o"), "--channels", "acc_pinion_loa_m_s2"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("gearpit simulate: warning: the mesh force goes negative")
    meta = json.loads((tmp_path / "o" / "p_full.json").read_text())
    assert [w["code"] for w in meta["warnings"]] == ["mesh_tension"]


def test_generate_flags_and_counts_implausible_samples(tmp_path, capsys):
    """Light loads (0.05-2 N m) with profile errors: some samples' linear mesh pulls. The index column names them,
    the run's summary counts them in one line; each flag agrees with the sample simulated alone with every
    channel (mesh force below zero or not)."""
    doc = base(operating__torque_nm=[0.05, 2.0], effects={"profile_error": {"grade": 6.0}})
    toml = tmp_path / "sweep.toml"
    from test_dataset_generate import _to_toml

    toml.write_text(_to_toml(doc))
    assert main(["generate", str(toml), "--out", str(tmp_path / "ds"), "--quiet"]) == 0
    index = dataset.load_index(tmp_path / "ds")
    flagged = index[index[WARNINGS_COLUMN] != ""]
    assert 0 < len(flagged) < len(index) and set(flagged[WARNINGS_COLUMN]) == {"mesh_tension"}
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"gearpit generate: warning: {len(flagged)} of the 18 samples computed now are physically "
                   f"implausible (mesh_tension {len(flagged)}); the index column {WARNINGS_COLUMN} names them, and "
                   "`gearpit simulate` of such a case says why"]
    sweep = sweep_from_dict(doc)
    yes, no = int(flagged["sample_index"].iloc[0]), int(index[index[WARNINGS_COLUMN] == ""]["sample_index"].iloc[0])
    specs = [draw_sample(sweep, i) for i in (yes, no)]
    sigs = simulate([build_case(sweep, s, build_pit_map(sweep, s)) for s in specs])
    assert sigs[0].channels["mesh_force_n"].min() < 0 < sigs[1].channels["mesh_force_n"].min()
    report = generate(sweep, tmp_path / "ds2", progress=False)
    assert report.flagged == len(flagged) and report.warnings == {"mesh_tension": len(flagged)}


def _toml(d: dict) -> str:
    pits = d.get("pits")
    lines = [f"duration_s = {d['duration_s']}", f"fs_hz = {d['fs_hz']}", f"seed = {d['seed']}", "[pair]",
             'preset = "spur-gds"', "[operating]", f"speed_rpm = {d['operating']['speed_rpm']}",
             f"torque_nm = {d['operating']['torque_nm']}"]
    if pits:
        lines += ["[pits]", 'gear = "pinion"', 'shape = "rectangle"', "teeth = [0]", "severity = 1.0"]
    return "\n".join(lines) + "\n"
