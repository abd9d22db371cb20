"""The orchestrator (datagen.simulate), case files, the nonlinear path and ``gearpit simulate``.

References per test: torque balance (static loads), helical force components (F tan(beta_b),
Kahraman 1994), dead-zone mesh law (Kahraman & Singh 1990), the case-file contract in
datagen.simulate's docstring and the CLI rules of docs/HELPERS.md.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from datagen.geometry import helical_pair_example, spur_pair_example
from datagen.simulate import Case, OperatingPoint, Signals, SolverOptions, simulate
from gearpit.cli import main
from gearpit.errors import InputError

SPUR = spur_pair_example()
CASE_TOML = """
duration_s = 0.08
fs_hz = 20000.0
seed = 3
[pair]
preset = "spur-gds"
[operating]
speed_rpm = 1500.0
torque_nm = 11.3
[pits]
gear = "pinion"
grid = [32, 32]
shape = "ellipse"
teeth = [0]
severity = 0.2
[solver]
omega_dt = 0.3
[[effects]]
name = "noise"
snr_db = 30.0
"""


def test_case_file_round_trip_regenerates_identical_signals(tmp_path):
    """Case.from_toml -> simulate -> metadata['case'] -> Case.from_dict -> simulate gives identical bytes
    (the regeneration contract of DESIGN.md: results carry the inputs that made them)."""
    p = tmp_path / "case.toml"
    p.write_text(CASE_TOML)
    case = Case.from_toml(p)
    s = simulate([case])[0]
    again = simulate([Case.from_dict(s.metadata["case"])])[0]
    for k in s.channels:
        assert s.channels[k].tobytes() == again.channels[k].tobytes(), k
    assert s.metadata["software_version"] and s.metadata["seed"] == 3
    assert s.n_samples == round(0.08 * 20000)


@pytest.mark.parametrize("edit, field", [
    (lambda t: t.replace("duration_s = 0.08", "duration_s = 0.01"), "duration_s"),        # < one revolution
    (lambda t: t.replace("fs_hz = 20000.0", "fs_hz = 1500.0"), "fs_hz"),                   # f_m outside 0.4 fs
    (lambda t: t.replace('name = "noise"', 'name = "noize"'), "effects.name"),
    (lambda t: t + "[drivetrain]\nmesh_damping_ratio = -0.05\n", "drivetrain.mesh_damping_ratio"),
    (lambda t: t.replace("seed = 3", "seed = 3\nspeed = 4"), "speed"),                      # unknown key
    (lambda t: t.replace("omega_dt = 0.3", "omega_dt = 3.0"), "solver.omega_dt"),
    (lambda t: t + "[stiffness]\nedges = \"boxy\"\n", "stiffness.edges"),
    (lambda t: t + "[stiffness]\npositions = 64\n", "stiffness.positions"),               # unknown key
])
def test_bad_case_files_raise_input_error_naming_the_field(tmp_path, edit, field):
    """Bad input is refused before any work, the message names the field."""
    p = tmp_path / "bad.toml"
    p.write_text(edit(CASE_TOML))
    with pytest.raises(InputError, match=field.replace(".", r"\.")):
        Case.from_toml(p)


def test_cli_writes_csv_npz_json_png_and_refuses_bad_input(tmp_path, capsys):
    """`gearpit simulate CASE --out DIR --png` writes four files; a bad case exits 2 with one line and
    writes nothing (HELPERS.md CLI rules)."""
    p = tmp_path / "case.toml"
    p.write_text(CASE_TOML)
    out = tmp_path / "out"
    assert main(["simulate", str(p), "--out", str(out), "--png"]) == 0
    assert sorted(f.name for f in out.iterdir()) == ["case.csv", "case.json", "case.npz", "case.png"]
    sig = Signals.load_npz(out / "case.npz")
    assert sig.fs_hz == 20000.0 and sig.metadata["case"]["seed"] == 3
    header = (out / "case.csv").read_text().splitlines()[0].split(",")
    assert header[0] == "time_s" and "acc_pinion_loa_m_s2" in header
    bad = tmp_path / "bad.toml"
    bad.write_text(CASE_TOML.replace('name = "noise"', 'name = "noize"'))
    out2 = tmp_path / "out2"
    capsys.readouterr()
    assert main(["simulate", str(bad), "--out", str(out2)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "noize" in err[0]
    assert not out2.exists()


def test_cli_channels_writes_only_those_and_equal_to_the_full_run(tmp_path, capsys):
    """`--channels`: only the named channels are written, each equal to the bit to the full simulation's
    (datagen.simulate.simulate ``channels``); an unknown name exits 2 naming it, before anything is written."""
    p = tmp_path / "case.toml"
    p.write_text(CASE_TOML)
    assert main(["simulate", str(p), "--out", str(tmp_path / "all")]) == 0
    assert main(["simulate", str(p), "--out", str(tmp_path / "two"), "--channels", "acc_pinion_loa_m_s2,tacho_pinion",
                 "--png"]) == 0
    full, two = Signals.load_npz(tmp_path / "all" / "case.npz"), Signals.load_npz(tmp_path / "two" / "case.npz")
    assert sorted(two.channels) == ["acc_pinion_loa_m_s2", "tacho_pinion"]
    for name in two.channels:
        assert np.array_equal(two.channels[name], full.channels[name]), name
    capsys.readouterr()
    assert main(["simulate", str(p), "--out", str(tmp_path / "bad"), "--channels", "acc_pinion_loa_m_s2,acc_nowhere"]) == 2
    err = capsys.readouterr().err
    assert "--channels" in err and "acc_nowhere" in err
    assert not (tmp_path / "bad").exists()


def test_helical_axial_force_is_mesh_force_times_tan_base_helix():
    """Helical pair: mean axial bearing force = mean mesh force * tan(beta_b) (Kahraman 1994), 1e-6."""
    pair = helical_pair_example()
    s = simulate([Case(pair=pair, operating=OperatingPoint(1500.0, 50.0), duration_s=0.04, fs_hz=20000.0)])[0]
    F = np.mean(s.channels["mesh_force_n"])
    Fa = -np.mean(s.channels["force_bearing_pinion_axial_n"])
    assert F == pytest.approx(50.0 / pair.base_radius_m("pinion"), rel=1e-6)
    assert Fa == pytest.approx(F * math.tan(pair.base_helix_angle_rad), rel=1e-6)
    assert "acc_wheel_axial_m_s2" in s.channels


def test_tacho_pulses_once_per_revolution_and_speeds_average_nominal():
    """Tacho channels: one pulse per shaft revolution; shaft speeds average the nominal speeds (1e-6)."""
    rpm = 1500.0
    s = simulate([Case(pair=SPUR, operating=OperatingPoint(rpm, 11.3), duration_s=0.4, fs_hz=20000.0)])[0]
    assert s.channels["tacho_pinion"].sum() == pytest.approx(0.4 * rpm / 60, abs=1)
    assert s.channels["tacho_wheel"].sum() == pytest.approx(0.4 * rpm / 60 * 29 / 100, abs=1)
    assert np.mean(s.channels["speed_pinion_rpm"]) == pytest.approx(rpm, rel=1e-6)
    assert np.mean(s.channels["speed_wheel_rpm"]) == pytest.approx(rpm * 29 / 100, rel=1e-6)


def test_backlash_is_inert_under_load_and_separates_teeth_near_resonance():
    """Dead-zone law (Kahraman & Singh 1990). (a) Under load with no tooth separation the Newton path
    equals the linear path (1e-9). (b) At light load with f_m near the mesh resonance the linear law pulls
    (F < 0) while the dead zone lets the teeth separate: the responses differ by > 10 % rms and Newton
    converges on every step. (The output is band-limited, so separation shows as near-zero force with
    filter ripple, not as exact zeros; the law itself is checked in the next test.)"""
    # one step for both laws (unset, the backlash case would take its own finer step, Effect.max_omega_dt)
    base = Case(pair=SPUR, operating=OperatingPoint(1500.0, 11.3), duration_s=0.04, fs_hz=20000.0,
                solver=SolverOptions(omega_dt=0.3, method="transient", transient_s=0.04))
    lin, bl = simulate([base, replace(base, effects=({"name": "backlash", "backlash_m": 50e-6},))])
    assert np.min(lin.channels["mesh_force_n"]) > 0
    for k in lin.channels:
        np.testing.assert_allclose(bl.channels[k], lin.channels[k], rtol=1e-9,
                                   atol=1e-9 * np.abs(lin.channels[k]).max(), err_msg=k)
    # light load, f_m near the mesh mode: separation
    from datagen.simulate import prepare

    dc = prepare(base)
    fn = dc.model.natural_frequencies_hz[dc.model.mesh_mode_index]
    rpm = 0.9 * fn * 60 / SPUR.pinion.teeth
    light = Case(pair=SPUR, operating=OperatingPoint(rpm, 0.5), duration_s=60 / rpm, fs_hz=50000.0,
                 solver=SolverOptions(omega_dt=0.3, method="transient", transient_s=0.02))
    lin2, bl2 = simulate([light, replace(light, effects=({"name": "backlash", "backlash_m": 50e-6},))])
    assert np.min(lin2.channels["mesh_force_n"]) < 0
    F, F_lin = bl2.channels["mesh_force_n"], lin2.channels["mesh_force_n"]
    assert np.std(F - F_lin) > 0.1 * np.std(F_lin)
    assert np.min(F) > 0.5 * np.min(F_lin)               # far less pull than the linear law
    assert bl2.metadata["solver"]["newton_unconverged_steps"] == 0


def test_backlash_that_never_opens_reproduces_the_linear_law_beside_an_eccentric_wheel():
    """Analytic limit: while every pair in contact stays compressed, the dead-zone law is the linear law, so a
    1 um clearance under load must give the linear record (1e-9 of each channel's peak, as the test above). An
    eccentricity's transmission error is the same for every pair (a rigid-body turn), so it cannot open one pair
    while the others carry the load: the linear record's mesh force stays above 60 % of its mean here.
    The per-pair deviation a nonlinear law reads is interpolated between record points as the pair's error force
    over its stiffness (``MeshRecords.all_at``): interpolating the deviation itself took a pair entering contact
    (stiffness 0 at one point, deviation written 0 there) at a fraction of the 47 um eccentricity instead of all
    of it, separated it by up to 40 um in the model, and changed the record by 14 % of its RMS (the 'backlash' the
    comparison then claimed at its 1 um lower bound on the independent simulator's wheel eccentricity)."""
    base = Case(pair=SPUR, operating=OperatingPoint(1000.0, 50.0), duration_s=0.25, fs_hz=20000.0,
                effects=({"name": "eccentricity_wheel", "amplitude_m": 47e-6},),
                solver=SolverOptions(omega_dt=0.3, method="transient", transient_s=0.05))   # one step for both laws
    lin, bl = simulate([base, replace(base, effects=base.effects + ({"name": "backlash", "backlash_m": 1e-6},))])
    force = lin.channels["mesh_force_n"]
    assert np.min(force) > 0.6 * np.mean(force)
    assert np.std(force) > 0.02 * np.mean(force)        # the eccentricity modulates the mesh (not a trivial case)
    for k in ("acc_pinion_loa_m_s2", "mesh_force_n", "dte_m", "force_bearing_pinion_loa_n"):
        np.testing.assert_allclose(bl.channels[k], lin.channels[k], rtol=0,
                                   atol=1e-9 * np.abs(lin.channels[k]).max(), err_msg=k)


def test_backlash_law_values_and_derivatives():
    """Backlash.mesh_force_batch: per-pair dead zone k_s * (d > 0 ? d : d < -b ? d + b : 0), damping only
    while touching; derivatives match central differences (1e-6)."""
    from datagen.effects.backlash import Backlash
    from datagen.effects.base import MeshState

    b = 10e-6
    ks = np.array([[2e8, 1e8], [2e8, 1e8], [2e8, 1e8], [2e8, 0.0]])
    es = np.array([[0.0, 3e-6], [0.0, 3e-6], [0.0, 3e-6], [0.0, 0.0]])
    mesh = MeshState(ks.sum(1), np.full(4, 500.0), (ks * es).sum(1), ks, es)
    delta = np.array([5e-6, 2e-6, -12e-6, -5e-6])
    ddot = np.full(4, 0.01)
    F, dF, dFd = Backlash.mesh_force_batch({"backlash_m": np.full(4, b)}, delta, ddot, mesh)
    expected = [2e8 * 5e-6 + 1e8 * 2e-6 + 500 * 0.01,          # both pairs touch
                2e8 * 2e-6 + 500 * 0.01 * 2 / 3,                 # second pair inside its clearance
                2e8 * (-2e-6) + 1e8 * (-15e-6 + b) + 500 * 0.01,  # back flank on both
                0.0]                                              # inside the dead zone
    np.testing.assert_allclose(F, expected, rtol=1e-12, atol=1e-9)
    h = 1e-12
    Fp, _, _ = Backlash.mesh_force_batch({"backlash_m": np.full(4, b)}, delta + h, ddot, mesh)
    Fm, _, _ = Backlash.mesh_force_batch({"backlash_m": np.full(4, b)}, delta - h, ddot, mesh)
    np.testing.assert_allclose(dF, (Fp - Fm) / (2 * h), rtol=1e-6, atol=1e-3)


def test_speed_fluctuation_follows_the_drive_train_response():
    """Operating-point hook: the reference speed fluctuates 2 % at 10 Hz; the pinion speed channel shows
    the fluctuation that the mean-stiffness drive train (speed controller + inertias, d'Alembert load
    -M r dOmega/dt) predicts at 10 Hz, within 3 %, and the case is time-stepped.

    Reference: harmonic response (-w^2 M + i w C + K_mean) Phi = -M r Omega0 a w of the lumped model.
    """
    from datagen.simulate import prepare

    a, f = 0.02, 10.0
    case = Case(pair=SPUR, operating=OperatingPoint(1500.0, 11.3), duration_s=0.2, fs_hz=20000.0,
                effects=({"name": "speed_fluctuation", "amplitude_fraction": a, "frequency_hz": f},),
                solver=SolverOptions(transient_s=0.4))
    s = simulate([case])[0]
    assert s.metadata["solver"]["method"] == "transient"
    m = prepare(case).model
    w, omega0 = 2 * np.pi * f, 1500.0 * 2 * np.pi / 60
    Phi = np.linalg.solve(-w**2 * m.M + 1j * w * m.C_mean + m.K_mean, -m.M @ m.ratio * omega0 * a * w)
    expected_rpm = abs(-1j * omega0 * a + 1j * w * Phi[m.index("phi_1")]) * 60 / (2 * np.pi)
    sp = s.channels["speed_pinion_rpm"]
    t = np.arange(sp.size) / s.fs_hz
    amp = 2 * abs(np.mean((sp - sp.mean()) * np.exp(-2j * np.pi * f * t)))
    assert amp == pytest.approx(expected_rpm, rel=0.03)
    assert expected_rpm < 0.9 * a * 1500.0          # the controller does not follow 10 Hz fully




def _line(x: np.ndarray, fs_hz: float, f_hz: float) -> complex:
    """Complex amplitude of the line at ``f_hz`` in ``x`` (Hann-weighted projection)."""
    t = np.arange(x.size) / fs_hz
    w = np.hanning(x.size)
    return complex(2 * np.sum(w * (x - x.mean()) * np.exp(-2j * np.pi * f_hz * t)) / np.sum(w))


def test_motor_side_and_load_side_fluctuations_differ_only_in_the_mesh_torque():
    """The speed/torque-fluctuation 'twins' of the comparison (README, model versus measurement).

    A fluctuation of the speed reference (acting at the motor through the speed controller) and a load-torque
    ripple (acting at the brake), both at 23 Hz, far below the drive train's torsion modes. In each, the ratio
    of the dynamic mesh torque ``F rb1`` to the pinion's angular acceleration at 23 Hz is what the harmonic
    response of the lumped model predicts, within 1 %:
    ``(-w^2 M + i w C + K) Phi = f`` with ``f = -M r Omega0 a w`` (reference fluctuation, as in
    test_speed_fluctuation_follows_the_drive_train_response) or the ripple on the brake, and
    ``F = (k_mean + i w c_mesh) v . Phi``.

    Rigid-train limit (Newton on the reflected inertias J_m' = J_motor + J_1, J_L' = (J_2 + J_brake)(z1/z2)^2):
    a motor-side excitation needs F rb1 = J_L' alpha to accelerate the load side; a load-side one leaves
    F rb1 = -J_m' alpha plus the controller's reaction (checked within 12 %: the shafts are not rigid). So at the same pinion motion (the phase modulation an
    accelerometer sees at the mesh) the two differ only in the mesh torque: in size, and with in-phase parts
    of opposite sign. Checked here: the simulated ratios are 3-6 dB apart and their in-phase parts have
    opposite signs. That mesh-torque modulation is 20-35 dB under the phase modulation in the mesh sidebands,
    which is why an accelerometer cannot tell the two apart (README).
    """
    from datagen.simulate import prepare

    f, n0, t0, fs = 23.0, 1000.0, 50.0, 20000.0
    cases = [Case(pair=SPUR, operating=OperatingPoint(n0, t0), duration_s=1.0, fs_hz=fs, seed=0,
                  effects=(eff,), solver=SolverOptions(transient_s=0.6))
             for eff in ({"name": "speed_fluctuation", "amplitude_fraction": 0.01, "frequency_hz": f},
                         {"name": "torque_fluctuation", "amplitude_fraction": 0.014, "frequency_hz": f})]
    sims = simulate(cases)
    m = prepare(cases[0]).model
    w, omega0 = 2 * np.pi * f, n0 * 2 * np.pi / 60
    rb1 = SPUR.base_radius_m("pinion")
    A = -w**2 * m.M + 1j * w * m.C_mean + m.K_mean
    i1 = m.index("phi_1")
    ripple = np.zeros(m.n, complex)
    ripple[m.index("phi_b")] = -t0 * 0.014 * (SPUR.wheel.teeth / SPUR.pinion.teeth)
    predicted, simulated = [], []
    for sim, (forcing, ref_speed) in zip(sims, ((-m.M @ m.ratio * omega0 * 0.01 * w, -1j * omega0 * 0.01),
                                                (ripple, 0.0))):
        Phi = np.linalg.solve(A, forcing)
        speed = ref_speed + 1j * w * Phi[i1]                          # pinion speed fluctuation (rad/s)
        mesh_torque = (m.k_mean_n_per_m + 1j * w * m.c_mesh_n_s_per_m) * (m.v @ Phi) * rb1
        predicted.append(mesh_torque / (1j * w * speed))             # N m per rad/s^2
        sp = _line(sim.channels["speed_pinion_rpm"] * 2 * np.pi / 60, fs, f)
        tq = _line(sim.channels["mesh_force_n"] * rb1, fs, f)
        simulated.append(tq / (1j * w * sp))
    for p, s in zip(predicted, simulated):          # measured: 3e-5
        assert abs(s - p) <= 0.01 * abs(p)
    speed_ratio, torque_ratio = simulated
    # the rigid-train limit itself (no shaft compliance): its error grows as (f / f_torsion)^2, 9 % for the
    # 77 Hz torsion mode of the brake on its shaft (23 / 77 squared); measured 8 % and 3 %
    i_m = m.drive.motor_inertia_kg_m2 + SPUR.inertia_kg_m2("pinion")
    i_l = (SPUR.inertia_kg_m2("wheel") + m.drive.load_inertia_kg_m2) * (SPUR.pinion.teeth / SPUR.wheel.teeth) ** 2
    wc, zeta = 2 * np.pi * m.drive.speed_control_hz, m.drive.speed_control_damping_ratio
    controller = (i_m + i_l) * (wc**2 + 2j * zeta * wc * w) / w**2    # the controller's reaction per alpha
    assert abs(speed_ratio - i_l) <= 0.12 * i_l
    assert abs(torque_ratio - (-i_m + controller)) <= 0.12 * abs(-i_m + controller)
    assert 3.0 <= 20 * np.log10(abs(torque_ratio) / abs(speed_ratio)) <= 6.0
    assert speed_ratio.real * torque_ratio.real < 0


def test_time_stepped_cases_solved_in_parts_under_a_record_budget_give_the_same_bits(monkeypatch):
    """datagen.batch_solve.prepare_and_solve: with RECORD_BUDGET_BYTES = 0 every time-stepped case is solved as soon
    as it is prepared (its own batch) and its record dropped; the accelerations, mesh force and transmission error
    are the same to the bit as when the cases advance as one batch, every channel within 1e-12 of its RMS (the
    wheel speed moved by one rounding, 5e-16: a batch-wide array op), and a periodic case in the list is still
    solved (at the end). The budget exists
    because a batch of hunting-period records took 15.6 GB (datagen.simulate, stop 43)."""
    import datagen.dynamics as dyn
    import datagen.batch_solve as batch
    from datagen.effects import EffectSpec

    def case(amp, freq, grade):
        fx = (EffectSpec.from_dict({"name": "pitch_error", "grade": grade}).build(),
              EffectSpec.from_dict({"name": "speed_fluctuation", "amplitude_fraction": amp,
                                    "frequency_hz": freq}).build())
        return Case(pair=spur_pair_example(), operating=OperatingPoint(1200.0, 40.0), duration_s=0.08,
                    fs_hz=10000.0, effects=fx, solver=SolverOptions(method="transient", transient_s=0.03))

    cases = [case(0.02, 9.0, 6.0), case(0.05, 13.0, 8.0),
             Case(pair=spur_pair_example(), operating=OperatingPoint(1200.0, 40.0), duration_s=0.08, fs_hz=10000.0),
             case(0.01, 21.0, 9.0)]
    together = simulate(cases)
    batches = []
    real_solve = dyn.solve
    monkeypatch.setattr(dyn, "solve", lambda dcs: batches.append(len(dcs)) or real_solve(dcs))
    monkeypatch.setattr(batch, "RECORD_BUDGET_BYTES", 0)
    apart = simulate(cases)
    assert batches == [1, 1, 1, 1]          # three time-stepped cases one by one, then the periodic one
    assert together[2].metadata["solver"]["method"] == "periodic"
    for a, b in zip(together, apart):
        assert set(a.channels) == set(b.channels)
        for name in a.channels:
            scale = max(float(np.sqrt(np.mean(a.channels[name] ** 2))), 1e-300)
            assert np.max(np.abs(a.channels[name] - b.channels[name])) <= 1e-12 * scale, name
        for name in ("acc_pinion_loa_m_s2", "mesh_force_n", "dte_m"):
            assert np.array_equal(a.channels[name], b.channels[name]), name


def test_a_linear_case_keeps_no_per_pair_slots_and_gives_the_same_bits(monkeypatch):
    """datagen.batch_solve.prepare -> mesh_record(keep_slots=...): a case without a nonlinear mesh law keeps no per-pair
    stiffness and deviation (zero columns: four fifths of a record's memory), one with backlash keeps them; every
    channel of a periodic and of a time-stepped linear case (pitch error + wheel eccentricity, speed fluctuation)
    is the same to the bit as when the slots are kept."""
    import datagen.batch_solve as batch
    from datagen.effects import EffectSpec
    from datagen.mesh_excitation import mesh_record

    def fx(*ds):
        return tuple(EffectSpec.from_dict(d).build() for d in ds)

    pitch_ecc = fx({"name": "pitch_error", "grade": 8.0}, {"name": "eccentricity_wheel", "amplitude_m": 30e-6})
    periodic = Case(pair=spur_pair_example(), operating=OperatingPoint(1500.0, 40.0), duration_s=0.1, fs_hz=10000.0,
                    effects=fx({"name": "pitch_error", "grade": 8.0}))
    stepped = Case(pair=spur_pair_example(), operating=OperatingPoint(1500.0, 40.0), duration_s=0.08, fs_hz=10000.0,
                   effects=pitch_ecc + fx({"name": "speed_fluctuation", "amplitude_fraction": 0.02,
                                           "frequency_hz": 11.0}),
                   solver=SolverOptions(method="transient", transient_s=0.03))
    backlash = Case(pair=spur_pair_example(), operating=OperatingPoint(1500.0, 40.0), duration_s=0.05, fs_hz=10000.0,
                    effects=fx({"name": "backlash", "backlash_m": 20e-6}), solver=SolverOptions(transient_s=0.02))
    lean = batch.prepare(stepped).record
    assert lean.k_slots.shape == (lean.k.size, 0) and lean.e_slots.shape == (lean.k.size, 0)
    assert batch.prepare(backlash).record.k_slots.shape[1] >= 2
    got = simulate([periodic, stepped])
    assert got[0].metadata["solver"]["method"] == "periodic"
    monkeypatch.setattr(batch, "mesh_record", lambda ms, effects, ctx, keep_slots=True, **kw: mesh_record(ms, effects, ctx, **kw))
    full = batch.prepare(stepped).record
    assert full.k_slots.shape[1] >= 2
    assert np.array_equal(full.k, lean.k) and np.array_equal(full.error_force, lean.error_force)
    ref = simulate([periodic, stepped])
    for a, b in zip(ref, got):
        for name in a.channels:
            assert np.array_equal(a.channels[name], b.channels[name]), name


def test_a_case_with_backlash_is_stepped_at_the_step_its_effect_asks_for():
    """``[solver] omega_dt`` unset: the default 0.3, or the finest step an effect declares (Effect.max_omega_dt;
    backlash 0.05, measured in experiments/step_convergence.py); set, it is kept. Checked on the time step the
    record reports (metadata ``solver.dt_s``), against LumpedModel.time_step_s of the same model; and the
    value is checked like any other field."""
    from datagen.case_options import DEFAULT_OMEGA_DT
    from datagen.simulate import prepare

    base = Case(pair=SPUR, operating=OperatingPoint(1000.0, 20.0), duration_s=0.07, fs_hz=20000.0,
                solver=SolverOptions(method="transient", transient_s=0.01))
    bl = replace(base, effects=({"name": "backlash", "backlash_m": 50e-6},))
    pinned = replace(bl, solver=replace(bl.solver, omega_dt=0.3))
    lin_s, bl_s, pin_s = simulate([base, bl, pinned])
    assert DEFAULT_OMEGA_DT == 0.3
    assert [prepare(c).omega_dt for c in (base, bl, pinned)] == [0.3, 0.05, 0.3]
    model = prepare(base).model
    dt_lin, dt_bl = lin_s.metadata["solver"]["dt_s"], bl_s.metadata["solver"]["dt_s"]
    assert 0.5 * model.time_step_s(0.3) < dt_lin <= model.time_step_s(0.3) * (1 + 1e-12)
    assert 0.5 * model.time_step_s(0.05) < dt_bl <= model.time_step_s(0.05) * (1 + 1e-12)
    assert pin_s.metadata["solver"]["dt_s"] == pytest.approx(lin_s.metadata["solver"]["dt_s"], rel=1e-12)
    assert "omega_dt" not in bl.to_dict()["solver"]          # unset stays unset in the case file
    with pytest.raises(InputError, match="solver.omega_dt"):
        SolverOptions(omega_dt=0.0)
