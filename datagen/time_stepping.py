"""Time stepping through a start-up transient (the ``transient`` path of :mod:`datagen.dynamics`).

For nonlinear mesh laws (hook 4), speed/torque modulation (hook 5) and extra forces (hook 3).
Starts from the static equilibrium under load (mean stiffness, consistent accelerations), runs
``transient_s`` and discards it (default: ``ln(1000)`` slowest modal decay times of the mean system
rounded up to whole record periods, i.e. the start-up transient decays by 60 dB), then keeps
``duration_s``. The step is ``1 / (R fs)`` with the smallest integer ``R >= 2`` keeping
``w_max dt <= omega_dt``; chunks of :data:`CHUNK` steps are turned into channels and decimated by
``R`` through the anti-alias FIR (:class:`datagen.decimation.FirDecimator`).

The reference rotation is ``theta_ref = integral of Omega_ref(t)`` (hook 5); its angular
acceleration loads every rotating DOF with ``-M r dOmega_ref/dt`` (d'Alembert), the load torque
follows hook 5, the motor feed-forward stays at the nominal torque (the speed controller supplies
the rest). The mesh stiffness is read at the actual pinion angle ``theta_ref + phi_1``, with
``phi_1`` predicted to the new step (``phi + dt phi' + dt^2/2 phi''``). The record is read as its mean over
the window the step spans (``omega_ref dt`` of rotation: :meth:`datagen.mesh_excitation.MeshRecords.window_all_at`),
not at one point: the step rate is not commensurate with the record's positions here (the periodic path's is),
and a point read folded the record's content near multiples of the step rate into the band (stop 49,
``experiments/step_convergence.py``). A nonlinear mesh law is
solved per step by Newton on the scalar mesh deflection (:func:`datagen.newmark.solve_mesh_law`), with a
bracketed fallback where the law's force jumps (a pair's damping switching on as it touches).
The loop over the steps runs compiled (:mod:`datagen.compiled_stepping`) unless a mesh law of the batch has
no compiled form; the numpy loop (:func:`datagen.newmark.run_general`) is kept as its reference.
"""
from __future__ import annotations

import numpy as np

from datagen import newmark
from datagen.decimation import FirDecimator
from datagen.dynamics import CHUNK, Response, mesh_damping, static_state, wanted_channels
from datagen.effects.base import MeshState
from datagen.mesh_excitation import MeshRecords
from datagen.output_channels import channel_coefficients, channel_values, finish, fine_names

#: run the time-stepping loop compiled where the batch's mesh laws allow it (:mod:`datagen.compiled_stepping`);
#: False: the numpy loop of :func:`datagen.newmark.run_general` (the reference the tests compare against)
COMPILED = True


def transient_response(cases, R: int, n_discard: int) -> list[Response]:
    C = len(cases)
    n = cases[0].model.n
    fs = cases[0].fs_hz
    dt = 1.0 / (R * fs)
    ops = [newmark.newmark_operators(c.model.M, c.model.K_s, c.model.C_s, c.model.v, dt) for c in cases]
    batch = newmark.Batch(ops, np.zeros((len(cases), cases[0].model.n)))
    dec = FirDecimator(R)
    D = dec.delay
    n_discard = max(n_discard, D + 1)
    n_out = cases[0].n_out
    n_total = n_discard + (n_out - 1) * R + D + 1
    records = MeshRecords([c.record for c in cases])
    c_m = mesh_damping(cases)
    z1_per_rad = np.array([c.model.pair.pinion.teeth for c in cases], dtype=float) / (2 * np.pi)  # mesh cycles/rad
    ratio2 = np.array([c.model.ratio[c.model.index("phi_2")] for c in cases])
    i_phi1 = cases[0].model.index("phi_1")
    # the mesh is read at the pinion's actual angle, or ("nominal") at its rotation plus the static wind-up
    dynamic = np.array([c.mesh_angle == "dynamic" for c in cases], dtype=float)
    statics = [static_state(c) for c in cases]
    x_static = np.array([s[1] for s in statics])
    i_phim, i_phib = cases[0].model.index("phi_m"), cases[0].model.index("phi_b")
    M_ratio = np.stack([c.model.M @ c.model.ratio for c in cases])            # (C, n)
    motor_torque = np.array([c.model.f_static[i_phim] for c in cases])
    load_per_torque = np.array([c.model.f_static[i_phib] / c.torque_nm if c.torque_nm else
                                -c.model.pair.wheel.teeth / c.model.pair.pinion.teeth for c in cases])
    nonlinear = _nonlinear_groups(cases)
    forcing_fx = [[e for e in c.effects if "generalized_force" in e.hooks()] for c in cases]
    op_fx = [[e for e in c.effects if "operating_point" in e.hooks()] for c in cases]
    base_speed = np.array([2 * np.pi * c.speed_rpm / 60.0 for c in cases])
    base_torque = np.array([c.torque_nm for c in cases])

    def operating(t: np.ndarray):
        """Pinion reference speed (rad/s) and load torque (N m) at times t (L,), per case -> (L, C)."""
        w = np.broadcast_to(base_speed, (t.size, C)).copy()
        T = np.broadcast_to(base_torque, (t.size, C)).copy()
        for j, fx in enumerate(op_fx):
            if fx:
                s, tq = np.full(t.size, cases[j].speed_rpm), np.full(t.size, cases[j].torque_nm)
                for e in fx:
                    s, tq = e.operating_point(t, s, tq, cases[j].ctx)
                w[:, j], T[:, j] = 2 * np.pi * np.asarray(s) / 60.0, tq
        return w, T

    basis = np.zeros((C, 3, n))
    basis[:, 0, i_phim] = motor_torque
    basis[:, 1, i_phib] = load_per_torque
    basis[:, 2] = -M_ratio
    basis_terms = batch.forcing_basis(basis)
    # reference angle bookkeeping (theta_ref at the last completed step)
    state = {"theta": np.zeros(C), "omega_prev": operating(np.zeros(1))[0][0]}
    theta_steps = {}

    def inputs(i0: int, L: int, S: np.ndarray):
        t = (i0 + 1 + np.arange(L)) * dt
        # the step times and the half steps either side, in one call (the hooks act pointwise in time)
        w3, T3 = operating(np.concatenate([t, t + 0.5 * dt, t - 0.5 * dt]))
        w, wp, wm, T = w3[:L], w3[L:2 * L], w3[2 * L:], T3[:L]
        wdot = (wp - wm) / dt
        prev = np.vstack([state["omega_prev"][None], w[:-1]])
        theta = state["theta"] + np.cumsum(0.5 * dt * (prev + w), axis=0)
        state["theta"], state["omega_prev"] = theta[-1], w[-1]
        theta_steps["theta"], theta_steps["omega"] = theta, w
        # f = motor torque e_m + load e_b T - wdot M_ratio (+ the effects' generalised forces)
        coef = np.empty((L, C, 3))
        coef[..., 0] = 1.0
        coef[..., 1] = T
        coef[..., 2] = wdot
        G, dg = batch.forcing_combined(coef, basis_terms)
        if any(forcing_fx):
            f = np.zeros((L, C, n))
            for j, fx in enumerate(forcing_fx):
                for e in fx:
                    f[:, j, :] += e.generalized_force(t, theta[:, j], theta[:, j] * ratio2[j], cases[j].ctx)
            G_e, dg_e = batch.forcing(f)
            G, dg = G + G_e, dg + dg_e
        return G, dg

    sig = batch.sigma

    def mesh_force(i: int, S: np.ndarray, delta_lin: np.ndarray, h: np.ndarray):
        j = i % CHUNK
        phi_pred = S[:, i_phi1] + dt * S[:, n + i_phi1] + 0.5 * dt * dt * S[:, 2 * n + i_phi1]
        x = z1_per_rad * (theta_steps["theta"][j] + dynamic * phi_pred) + (1.0 - dynamic) * x_static
        w = z1_per_rad * theta_steps["omega"][j] * dt        # mesh cycles the step spans (its window on the record)
        if not nonlinear:
            k, E = records.window_at(x, w)
            kappa = k + (2.0 / dt) * c_m
            t1 = c_m * h + E
            delta = (delta_lin + sig * t1) / (1.0 + sig * kappa)
            return delta, kappa * delta - t1, 0
        k, E, ks, es = records.window_all_at(x, w)
        # each law's cases, cut once per step (not per Newton iteration)
        parts = [(cls.mesh_force_batch, idx, params, MeshState(k[idx], c_m[idx], E[idx], ks[idx], es[idx]))
                 for cls, idx, params in nonlinear]

        def law(delta, delta_dot):
            F = k * delta + c_m * delta_dot - E
            dF, dFd = k.copy(), c_m.copy()
            for force_batch, idx, params, mesh in parts:
                F[idx], dF[idx], dFd[idx] = force_batch(params, delta[idx], delta_dot[idx], mesh)
            return F, dF, dFd

        return newmark.solve_mesh_law(delta_lin, h, sig, dt, law)

    # start: static equilibrium under mean stiffness, consistent acceleration at t = 0
    x0 = x_static
    k0, E0 = records.at(x0)
    f0 = np.zeros((C, n))
    f0[:, i_phim] = motor_torque
    w0, T0 = operating(np.zeros(1))
    f0[:, i_phib] = load_per_torque * T0[0]
    x_init = np.zeros((C, 1, 2 * n))
    x_init[:, 0, :n] = np.stack([s[0] for s in statics])
    S0 = newmark.consistent_states(ops, x_init, f0, k0, E0, c_m, np.ones(1))[:, 0]

    co = channel_coefficients(cases)
    names = fine_names(n, wanted_channels(cases))
    kept, theta_out = [], []
    bad_total = 0
    first = n_discard - D
    law = _compiled_law(nonlinear, C) if COMPILED else None
    if law is not None:               # the same loop compiled (datagen.compiled_stepping)
        from datagen import compiled_stepping

        mesh = compiled_stepping.CompiledMesh(records, z1_per_rad, dynamic, np.asarray(x_static, float), i_phi1,
                                              np.asarray(c_m, float), *law)
        chunks = compiled_stepping.run_general(batch, S0, n_total, CHUNK, inputs, lambda: theta_steps["theta"], mesh,
                                              lambda: theta_steps["omega"])
    else:
        chunks = newmark.run_general(batch, S0, n_total, CHUNK, inputs, mesh_force)
    for i0, traj, force, bad in chunks:
        bad_total += bad
        L = traj.shape[0]
        steps = i0 + 1 + np.arange(L)                     # step index of each sample
        sel = steps >= first
        if not np.any(sel):
            continue
        fine = channel_values(traj[sel].transpose(1, 2, 0), force[sel].T, theta_steps["omega"][sel].T, co, names)  # (C, Q, l)
        kept.append(dec.push(fine.reshape(-1, fine.shape[2]).T))
        out_rows = (steps - n_discard) % R == 0
        out_rows &= steps >= n_discard
        theta_out.append(theta_steps["theta"][out_rows])
    _check_rolled(cases, x_static, z1_per_rad * state["theta"] + x_static)
    vals = np.ascontiguousarray(np.concatenate(kept)[:n_out].reshape(n_out, C, len(names)).transpose(1, 2, 0))
    theta1 = np.concatenate(theta_out)[:n_out]
    out = []
    for j, c in enumerate(cases):
        ch = finish(vals[j], names, theta1[:, j], co["gear_ratio"][j])
        out.append(Response(ch, {
            "method": "transient", "dt_s": dt, "decimation": R, "transient_discarded_s": n_discard * dt,
            "period_cycles": c.record.period_cycles, "record_cycles": c.record.stored_cycles,
            "start_time_s": n_discard * dt, "newton_unconverged_steps": bad_total,
            "natural_frequencies_hz": c.model.natural_frequencies_hz.tolist(),
            "mesh_damping_n_s_per_m": c.model.c_mesh_n_s_per_m}))
    return out


#: mesh cycles a truncated record must hold beyond a run's start and end (the pinion's dynamic angle: a fraction of
#: a cycle)
ROLL_SLACK_CYCLES = 0.5


def _check_rolled(cases, x_start, x_end) -> None:
    """Raise when a case with a truncated mesh record (:func:`datagen.mesh_excitation.mesh_record`) rolled out of
    the cycles it holds (its reference angle from ``x_start`` to ``x_end``, mesh cycles, less
    :data:`ROLL_SLACK_CYCLES`): its record would have been read where it does not hold the period's values."""
    for j, c in enumerate(cases):
        valid = c.record.valid_cycles
        if valid is None:
            continue
        lo, hi = float(min(x_start[j], x_end[j])), float(max(x_start[j], x_end[j]))
        if lo - ROLL_SLACK_CYCLES < valid[0] or hi + ROLL_SLACK_CYCLES > valid[1]:
            raise RuntimeError(f"time stepping: case {j} rolled through mesh cycles {lo:.2f} .. {hi:.2f}, but its "
                               f"truncated mesh record holds {valid[0]:g} .. {valid[1]:g} "
                               f"(datagen.simulate.cycles_rolled underestimated the run)")


def _compiled_law(nonlinear, C: int):
    """``(law, law_row, law_params)`` of :class:`datagen.compiled_stepping.CompiledMesh` for a batch whose
    nonlinear cases (``nonlinear``: :func:`_nonlinear_groups`) all carry one effect class with a compiled
    ``scalar_mesh_law``; None otherwise (the numpy loop runs)."""
    from datagen.compiled_stepping import linear_law

    row = np.full(C, -1, dtype=np.int64)
    if not nonlinear:
        return linear_law, row, np.zeros((1, 1))
    if len(nonlinear) > 1 or getattr(nonlinear[0][0], "scalar_mesh_law", None) is None:
        return None
    cls, idx, params = nonlinear[0]
    row[idx] = np.arange(idx.size)
    return cls.scalar_mesh_law, row, np.column_stack([np.asarray(v, dtype=float) for v in params.values()])


def _nonlinear_groups(cases):
    """(effect class, case indices, stacked parameters) for each nonlinear mesh law in the batch."""
    by_cls: dict[type, list[tuple[int, object]]] = {}
    for j, c in enumerate(cases):
        for e in c.effects:
            if e.is_nonlinear:
                by_cls.setdefault(type(e), []).append((j, e))
    groups = []
    for cls, items in by_cls.items():
        idx = np.array([j for j, _ in items])
        params = {k: np.array([e.params()[k] for _, e in items]) for k in items[0][1].params()}
        groups.append((cls, idx, params))
    return groups
