"""Lumped model and batched Newmark integrator (datagen.lumped_model, datagen.newmark, datagen.dynamics).

References named per test: the model's own eigen-analysis, the quasi-static limit F/k,
scipy's Radau integrator as an independent reference, Newmark's energy conservation
(Hughes 1987, sec. 9.1) and the mesh resonance (Kahraman & Singh 1990).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from datagen import newmark
from datagen.decimation import resample_periodic
from datagen.lumped_model import DriveTrain
from datagen.simulate import Case, OperatingPoint, SolverOptions, prepare, simulate
from dynamics_support import SPUR, TORQUE, _lsq_amplitudes, _model


def test_static_mesh_force_equals_torque_over_base_radius():
    """Static equilibrium: k_mean * delta_0 = T1 / rb1 (torque balance), and the motor angle stays 0.

    Reference: statics of the model (module docstring). Tolerance 1e-9 relative.
    """
    for helical in (False, True):
        m, _ = _model(helical)
        q0 = m.static_deflection()
        assert m.k_mean_n_per_m * (m.v @ q0) == pytest.approx(TORQUE / m.pair.base_radius_m("pinion"), rel=1e-9)
        assert abs(q0[m.index("phi_m")]) < 1e-12


def test_mesh_damping_gives_requested_modal_damping_on_the_mesh_mode():
    """The mesh mode's modal damping ratio equals DriveTrain.mesh_damping_ratio (Parker et al. 2000 practice).

    Tolerance 1e-9 (it is set so by construction; this guards the mode selection and normalisation).
    """
    m, _ = _model()
    assert m.modal_damping_ratios[m.mesh_mode_index] == pytest.approx(0.07, rel=1e-9)
    assert m.mesh_mode_index == len(m.dofs) - 1          # the highest mode: pinion torsion against the mesh


@pytest.mark.parametrize("helical", [False, True])
def test_impulse_response_peaks_match_eigenfrequencies(helical):
    """Eigenfrequencies of the mean-stiffness system = peaks of the simulated impulse response (1 %).

    Reference: scipy.linalg.eigh(K_mean, M). Light damping (ratios 0.005) for sharp peaks, omega*dt = 0.15
    on the highest mode (Newmark period error (w dt)^2/12 <= 0.2 %), 0.5 s record, every mode excited by a
    unit modal velocity, each peak read (Gaussian interpolation) in the DOF where that mode is largest.
    The speed-controller mode (5 Hz, damping 0.7 by design) has no sharp peak and is skipped.
    """
    drive = DriveTrain(shaft_damping_ratio=0.005, bearing_damping_ratio=0.005, mesh_damping_ratio=0.005)
    m, _ = _model(helical, drive)
    w, phi = m.modes
    dt = 0.15 / w[-1]
    ops = newmark.newmark_operators(m.M, m.K_s, m.C_s, m.v, dt)
    batch = newmark.Batch([ops], np.zeros((1, m.n)))
    n_steps = int(0.5 / dt)
    x0 = np.concatenate([np.zeros(m.n), phi.sum(axis=1)])[None, None, :]
    c = np.array([m.c_mesh_n_s_per_m])
    S0 = newmark.consistent_states([ops], x0, np.zeros((1, m.n)), np.array([m.k_mean_n_per_m]), np.zeros(1), c,
                                   np.zeros(1))
    k = np.full((n_steps, 1), m.k_mean_n_per_m)
    _, traj, _ = newmark.run_linear(batch, S0, k, c, None, np.zeros(1), store=True)
    q = traj[0, :m.n].T
    spec = np.abs(np.fft.rfft(q * np.hanning(n_steps)[:, None], axis=0))
    freqs = np.fft.rfftfreq(n_steps, dt)
    df = freqs[1]
    checked = 0
    for j in range(1, m.n):
        fj = w[j] / (2 * np.pi)
        i_dof = int(np.argmax(np.abs(phi[:, j]) * np.sqrt(np.diag(m.M))))
        band = np.flatnonzero(np.abs(freqs - fj) < 0.05 * fj)
        b = band[np.argmax(spec[band, i_dof])]
        la, lb, lc = np.log(spec[b - 1:b + 2, i_dof])
        f_peak = freqs[b] + 0.5 * (la - lc) / (la - 2 * lb + lc) * df
        assert f_peak == pytest.approx(fj, rel=0.01), (j, f_peak, fj)
        checked += 1
    assert checked == m.n - 1


def test_undamped_free_vibration_conserves_energy():
    """Average-acceleration Newmark conserves the energy of an undamped linear system (Hughes 1987, 9.1.3).

    Constant mesh stiffness, all damping 0, 20000 steps at omega*dt = 0.3: relative energy drift < 1e-9.
    """
    drive = DriveTrain(shaft_damping_ratio=0.0, bearing_damping_ratio=0.0, mesh_damping_ratio=0.0,
                       speed_control_damping_ratio=0.0)
    m, _ = _model(False, drive)
    assert m.c_mesh_n_s_per_m == 0.0
    dt = m.time_step_s(0.3)
    ops = newmark.newmark_operators(m.M, m.K_s, m.C_s, m.v, dt)
    batch = newmark.Batch([ops], np.zeros((1, m.n)))
    rng = np.random.default_rng(1)
    q0 = rng.standard_normal(m.n) * 1e-5
    x0 = np.concatenate([q0, np.zeros(m.n)])[None, None, :]
    S0 = newmark.consistent_states([ops], x0, np.zeros((1, m.n)), np.array([m.k_mean_n_per_m]), np.zeros(1),
                                   np.zeros(1), np.zeros(1))
    k = np.full((20000, 1), m.k_mean_n_per_m)
    _, traj, _ = newmark.run_linear(batch, S0, k, np.zeros(1), None, np.zeros(1), store=True)
    q, qd = traj[0, :m.n].T, traj[0, m.n:2 * m.n].T
    energy = 0.5 * np.einsum("ti,ij,tj->t", qd, m.M, qd) + 0.5 * np.einsum("ti,ij,tj->t", q, m.K_mean, q)
    e0 = 0.5 * q0 @ m.K_mean @ q0
    assert np.max(np.abs(energy - e0)) / e0 < 1e-9


def test_quasi_static_mesh_deflection_is_load_over_stiffness():
    """At 10 rpm (f_m = 4.8 Hz, far below every elastic mode) delta(t) = (T1/rb1) / k(x(t)) within 1 %.

    Reference: quasi-static limit of the mesh equation; the reference curve gets the same anti-alias
    filter as the simulated channel. omega_dt = 1.0 (high modes are not excited at this speed).
    """
    rpm, fs = 10.0, 500.0
    case = Case(pair=SPUR, operating=OperatingPoint(rpm, TORQUE), duration_s=6.0, fs_hz=fs,
                solver=SolverOptions(omega_dt=1.0))
    sig = simulate([case])[0]
    dc = prepare(case)
    rec = dc.record
    f_static = TORQUE / SPUR.base_radius_m("pinion")
    assert sig.metadata["solver"]["method"] == "periodic"
    assert np.max(np.abs(sig.channels["mesh_force_n"] / f_static - 1)) < 0.01
    x_s = SPUR.pinion.teeth * dc.model.static_deflection()[dc.model.index("phi_1")] / (2 * np.pi)
    T = dc.period_s
    n_fine = 4096
    k_fine, _ = rec.at(np.arange(n_fine) / n_fine * rec.period_cycles + x_s)
    ref = resample_periodic((f_static / k_fine)[None, None, :], T, fs, sig.n_samples)[0, 0]
    delta = sig.channels["mesh_deflection_m"]
    assert np.max(np.abs(delta - ref)) / ref.mean() < 0.01


def _radau_periodic(m, rec, x_s, f_m):
    """Independent reference: Radau shooting for the periodic state, then the mesh force over one period.

    Returns the mesh force at 8 instants per record position over the period, the state after one period and
    the start state.
    """
    n = m.n
    T = rec.period_cycles / f_m
    Minv = np.linalg.inv(m.M)
    vv = np.outer(m.v, m.v)
    c = m.c_mesh_n_s_per_m

    def system(t):
        k, E = rec.at(np.array([f_m * t + x_s]))
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -Minv @ (m.K_s + k[0] * vv)
        A[n:, n:] = -Minv @ (m.C_s + c * vv)
        b = np.concatenate([np.zeros(n), Minv @ (m.f_static + m.v * E[0])])
        return A, b

    def rhs(t, y):
        A, b = system(t)
        return A @ y + b

    def rhs_free(t, y):
        return system(t)[0] @ y

    opts = dict(method="Radau", rtol=1e-8, atol=1e-14, max_step=T / 100)
    jac = lambda t, y: system(t)[0]                # noqa: E731
    Phi = np.column_stack([solve_ivp(rhs_free, (0, T), e, jac=jac, **opts).y[:, -1] for e in np.eye(2 * n)])
    p = solve_ivp(rhs, (0, T), np.zeros(2 * n), jac=jac, **opts).y[:, -1]
    y0 = np.linalg.solve(np.eye(2 * n) - Phi, p)
    # the force holds the record's contact edges (a position wide): sampled finely enough that its harmonics 1-5
    # do not alias (256 points per period were enough for 64 point-sampled positions, not for 512 box-filtered)
    n_eval = 8 * rec.positions_per_cycle * rec.period_cycles
    t_eval = np.arange(n_eval + 1) * T / n_eval
    sol = solve_ivp(rhs, (0, T), y0, jac=jac, t_eval=t_eval, **opts)
    q, qd = sol.y[:n, :-1], sol.y[n:, :-1]
    k = rec.at(f_m * t_eval[:-1] + x_s)[0]
    return k * (m.v @ q) + c * (m.v @ qd), sol.y[:, -1], y0


def test_newmark_matches_radau_on_mesh_harmonics():
    """Newmark (shooting, omega_dt 0.3, anti-aliased output) vs scipy Radau (rtol 1e-9) on the same
    linear time-varying spur case at 1500 rpm (the mesh read at the nominal rotation, ``mesh_angle="nominal"``):
    mesh-force harmonics 1-5 of f_m within 1 %.

    The Radau reference (rtol 1e-8) finds its own periodic state (own monodromy over one mesh period,
    the record's period for a healthy pair). The case uses the default record (box edges, positions chosen by
    the band: 512; the step then spans at most one position). On the former record (64 point-sampled
    positions) harmonic 4, the weakest (0.4 % of the strongest), is 3.3 % off and the others within 0.3 %:
    the step samples the point edges' ramps.
    """
    rpm = 1500.0
    fm = SPUR.mesh_frequency_hz(rpm)
    fs = 64 * fm
    # the reference reads the mesh at the nominal rotation (a linear time-varying system): so does the case
    case = Case(pair=SPUR, operating=OperatingPoint(rpm, TORQUE), duration_s=60 / rpm, fs_hz=fs,
                solver=SolverOptions(mesh_angle="nominal"))
    sig = simulate([case])[0]
    dc = prepare(case)
    x_s = SPUR.pinion.teeth * dc.model.static_deflection()[dc.model.index("phi_1")] / (2 * np.pi)
    F_ref, y_end, y0 = _radau_periodic(dc.model, dc.record, x_s, fm)
    assert np.max(np.abs(y_end - y0)) <= 1e-5 * np.max(np.abs(y0))        # the reference is periodic
    a_ref = 2 * np.abs(np.fft.rfft(F_ref))[1:6] / F_ref.size
    F = sig.channels["mesh_force_n"]
    a_nm = 2 * np.abs(np.fft.rfft(F))[SPUR.pinion.teeth * np.arange(1, 6)] / F.size
    np.testing.assert_allclose(a_nm, a_ref, rtol=0.01)


def test_speed_sweep_resonance_at_mesh_natural_frequency():
    """The f_m component of the mesh deflection peaks where f_m crosses the mesh mode (Kahraman & Singh 1990).

    Healthy spur pair, f_m from 0.7 to 1.3 times the mesh-mode frequency in 2 % steps, all speeds in
    one call (batched where the step grids agree). Tolerance: peak within 4 % (two steps) of f_n.
    """
    m, _ = _model()
    fn = m.natural_frequencies_hz[m.mesh_mode_index]
    ratios = np.arange(0.70, 1.301, 0.02)
    rpms = ratios * fn * 60 / SPUR.pinion.teeth
    fs = 3.0 * 1.3 * fn
    cases = [Case(pair=SPUR, operating=OperatingPoint(float(r), TORQUE), duration_s=60 / float(r), fs_hz=fs)
             for r in rpms]
    sigs = simulate(cases)
    amp = [_lsq_amplitudes(s.channels["mesh_deflection_m"], fs, [SPUR.mesh_frequency_hz(c.operating.speed_rpm)])[0]
           for s, c in zip(sigs, cases)]
    r_peak = ratios[int(np.argmax(amp))]
    assert abs(r_peak - 1.0) <= 0.04 + 1e-9
    assert max(amp) > 3 * amp[0]                   # a real resonance, not a slope


def test_forcing_from_weighted_vectors_equals_the_assembled_forcing():
    """newmark.Batch.forcing_combined (the time-stepped path's forcing as three weighted vectors per case) against
    Batch.forcing of the assembled f = sum_r coef[..., r] basis[c, r]: the same state changes and d_lin shares to
    1e-12 of their largest value (only the summation order differs). Two cases with different operators (two
    drive trains of the helical model), 64 steps, random weights."""
    rng = np.random.default_rng(3)
    models = [_model(True, DriveTrain(mesh_damping_ratio=z))[0] for z in (0.02, 0.08)]
    n = models[0].n
    ops = [newmark.newmark_operators(m.M, m.K_s, m.C_s, m.v, m.time_step_s(0.3)) for m in models]
    batch = newmark.Batch(ops, np.zeros((2, n)))
    basis = rng.standard_normal((2, 3, n))
    coef = rng.standard_normal((64, 2, 3))
    G, dg = batch.forcing_combined(coef, batch.forcing_basis(basis))
    G_ref, dg_ref = batch.forcing(np.einsum("lcr,crn->lcn", coef, basis))
    assert G.shape == G_ref.shape and dg.shape == dg_ref.shape
    np.testing.assert_allclose(G, G_ref, rtol=0, atol=1e-12 * np.abs(G_ref).max())
    np.testing.assert_allclose(dg, dg_ref, rtol=0, atol=1e-12 * np.abs(dg_ref).max())
    assert np.all(G[..., -1] == 0.0)
