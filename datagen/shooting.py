"""Periodic steady state of linear, stationary cases by shooting (the ``periodic`` path of
:mod:`datagen.dynamics`).

The steady state repeats after one record period ``T = P / f_m`` (``P`` mesh cycles: one for a
healthy pair, one pinion revolution for pinion pits). With ``n_c`` Newmark steps per mesh cycle
(``N = P n_c`` per period, ``w_max dt <= omega_dt``), the one-period map ``x -> Phi x + p`` on
``x = (q, q')`` is the product of the ``P`` one-cycle maps; cycles with identical stiffness and
error-force samples (all healthy cycles of a case) share one map, so only the distinct cycles are
integrated with ``2n + 1`` columns (the particular solution from rest plus the ``2n`` unit initial
states). The periodic start solves ``(I - Phi) x0 = p``; one storing pass from ``x0`` gives the
record (its end matches ``x0`` to ~1e-12, reported as ``periodicity_error``), which
:func:`datagen.decimation.resample_periodic` anti-aliases and samples at the output rate.
The mesh position is ``x = f_m t + x_s`` with ``x_s`` the pinion's static wind-up.

References
----------
Nayfeh, A. H., Balachandran, B. (1995). Applied Nonlinear Dynamics, sec. 6.1 (shooting; monodromy matrix).
"""
from __future__ import annotations

import numpy as np

from datagen import newmark
from datagen.decimation import resample_periodic
from datagen.dynamics import Response, mesh_damping, static_state
from datagen.output_channels import channel_coefficients, channel_names, channel_values, finish


def periodic_response(cases, P: int, n_c: int) -> list[Response]:
    """Periodic steady state by shooting, the monodromy composed from distinct mesh cycles.

    With ``n_c`` steps per mesh cycle, the one-period map is the product of the
    ``P`` one-cycle maps ``x -> Phi_j x + p_j`` on ``x = (q, q')``. Cycles with
    the same samples (all healthy cycles of a case) share their map, so the
    ``2n + 1``-column runs cover only the distinct cycles; one storing pass
    from the periodic initial state follows.
    """
    N = P * n_c
    C = len(cases)
    n = cases[0].model.n
    m = 3 * n
    ops = [newmark.newmark_operators(c.model.M, c.model.K_s, c.model.C_s, c.model.v, c.period_s / N) for c in cases]
    f = np.stack([c.model.f_static for c in cases])
    batch = newmark.Batch(ops, f)
    c_m = mesh_damping(cases)
    statics = [static_state(c) for c in cases]
    u = np.arange(1, n_c + 1) / n_c
    kc = np.empty((C, P, n_c))
    Ec = np.empty((C, P, n_c))
    for j, c in enumerate(cases):
        x = np.arange(P)[:, None] + (u[None, :] + statics[j][1])
        kc[j], Ec[j] = c.record.at(x)
    has_E = bool(np.any(Ec != 0))
    k = kc.transpose(1, 2, 0)                                           # (P, n_c, C) views
    E = Ec.transpose(1, 2, 0)
    # The map of cycle j acts on (q, q'); its start acceleration is consistent with the last sample of
    # cycle j-1, so a cycle is identified by that sample plus its own n_c samples.
    k_prev = np.roll(k[:, -1, :], 1, axis=0)                           # (P, C)
    E_prev = np.roll(E[:, -1, :], 1, axis=0)
    rows, inverse = [], np.empty((C, P), dtype=np.int64)
    for j in range(C):                       # set-up loop over cases (not over time)
        kk = np.hstack([k_prev[:, j:j + 1], kc[j]])
        ee = np.hstack([E_prev[:, j:j + 1], Ec[j]])
        key = np.round(np.hstack([kk / np.abs(kk).max(), ee / max(np.abs(ee).max(), 1e-300)]), 10)
        seen: dict[bytes, int] = {}
        for cy in range(P):
            b = key[cy].tobytes()
            if b not in seen:
                seen[b] = len(rows)
                rows.append((j, cy))
            inverse[j, cy] = seen[b]
    case_of = np.array([r[0] for r in rows])
    cyc_of = np.array([r[1] for r in rows])
    Q = len(rows)
    k_q = kc[case_of, cyc_of].T                                         # (n_c, Q)
    E_q = Ec[case_of, cyc_of].T if has_E else None
    ops_q = [ops[j] for j in case_of]
    batch_q = newmark.Batch(ops_q, f[case_of])
    # columns: 0 = particular from rest, 1..2n = unit (q, q'); accelerations consistent at the start
    x_init = np.zeros((Q, 2 * n + 1, 2 * n))
    x_init[:, 1:, :] = np.eye(2 * n)[None]
    scale = np.zeros(2 * n + 1)
    scale[0] = 1.0
    S0 = newmark.consistent_states(ops_q, x_init, f[case_of], k_prev[cyc_of, case_of], E_prev[cyc_of, case_of],
                                   c_m[case_of], scale)
    S_end, _, _ = newmark.run_linear(batch_q, S0, k_q, c_m[case_of], E_q, scale, store=False)
    Phi_q = np.transpose(S_end[:, 1:, :2 * n], (0, 2, 1))              # column i = image of unit state i
    p_q = S_end[:, 0, :2 * n]
    Phi = np.broadcast_to(np.eye(2 * n), (C, 2 * n, 2 * n)).copy()
    p = np.zeros((C, 2 * n))
    for cy in range(P):
        sel = inverse[:, cy]
        Phi = np.matmul(Phi_q[sel], Phi)
        p = np.einsum("cij,cj->ci", Phi_q[sel], p) + p_q[sel]
    x0 = np.linalg.solve(np.eye(2 * n)[None] - Phi, p[..., None])[..., 0]
    s0 = newmark.consistent_states(ops, x0[:, None, :], f, kc[:, -1, -1], Ec[:, -1, -1], c_m, np.ones(1))
    k_t = np.ascontiguousarray(kc.reshape(C, N).T)
    E_t = np.ascontiguousarray(Ec.reshape(C, N).T) if has_E else None
    S2, traj, force = newmark.run_linear(batch, s0, k_t, c_m, E_t, np.ones(1), store=True, store_shift=1)
    s0 = s0[:, 0]
    periodicity = np.abs(S2[:, 0, :2 * n] - s0[:, :2 * n]).max(axis=1) / np.abs(s0[:, :2 * n]).max(axis=1)
    co = channel_coefficients(cases)
    omega = np.array([2 * np.pi * c.speed_rpm / 60.0 for c in cases])
    fine = channel_values(traj, force, omega[:, None], co)      # (C, n_ch, N), sample j at time j dt
    names = channel_names(n)
    out: list[Response | None] = [None] * C
    groups: dict[tuple, list[int]] = {}
    for j, c in enumerate(cases):
        groups.setdefault((c.period_s, c.fs_hz, c.n_out), []).append(j)
    for (period, fs, n_out), idx in groups.items():
        vals = resample_periodic(fine[idx], period, fs, n_out)           # (len(idx), n_ch, n_out)
        t = np.arange(n_out) / fs
        for jj, j in enumerate(idx):
            c = cases[j]
            ch = finish(vals[jj], names, omega[j] * t, co["gear_ratio"][j])
            out[j] = Response(ch, {
                "method": "periodic", "dt_s": c.period_s / N, "steps_per_period": N, "period_s": c.period_s,
                "period_cycles": c.record.period_cycles, "distinct_cycles": int(np.sum(case_of == j)),
                "periodicity_error": float(periodicity[j]), "transient_discarded_s": 0.0, "start_time_s": 0.0,
                "natural_frequencies_hz": c.model.natural_frequencies_hz.tolist(),
                "mesh_damping_n_s_per_m": c.model.c_mesh_n_s_per_m})
    return out
