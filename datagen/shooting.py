"""Periodic steady state of linear, stationary cases by shooting (the ``periodic`` path of
:mod:`datagen.dynamics`).

The steady state repeats after one record period ``T = P / f_m`` (``P`` mesh cycles: one for a
healthy pair, one pinion revolution for pinion pits). With ``n_c`` Newmark steps per mesh cycle
(``N = P n_c`` per period, ``w_max dt <= omega_dt``), the one-period map ``x -> Phi x + p`` on
``x = (q, q')`` is the product of the ``P`` one-cycle maps; cycles with identical stiffness and
error-force samples (all healthy cycles of a case) share one map, so only the distinct cycles are
integrated with ``2n + 1`` columns (the particular solution from rest plus the ``2n`` unit initial
states). The periodic start solves ``(I - Phi) x0 = p``; the cycles' start states follow by the maps, and
one storing pass marches all cycles side by side from them (each cycle's end matches the next one's start
to ~1e-12, reported as ``periodicity_error``); :func:`datagen.decimation.resample_periodic` anti-aliases
the record and samples it at the output rate.

The mesh position is the pinion's actual angle, ``x = f_m t + z_1 phi_1 / 2 pi`` (nominal rotation plus the
dynamic angle, static wind-up included), as in the time-stepped path. The response depends on it only
weakly, so it is found by passes: the first at the static wind-up, each further one at the previous pass's
angle, its periodic state by multiple shooting with the first pass's maps (:func:`periodic_response`);
``periodicity_error`` is then ~1e-9. ``solver.mesh_angle = "nominal"`` keeps the first pass (the classic
linear time-varying model).

References
----------
Nayfeh, A. H., Balachandran, B. (1995). Applied Nonlinear Dynamics, sec. 6.1 (shooting; monodromy matrix).
Ascher, U. M., Mattheij, R. M. M., Russell, R. D. (1995). Numerical Solution of Boundary Value Problems for
    Ordinary Differential Equations, ch. 4 (multiple shooting).
"""
from __future__ import annotations

import numpy as np

from datagen import newmark
from datagen.decimation import resample_periodic
from datagen.dynamics import Response, mesh_damping, static_state, wanted_channels
from datagen.output_channels import channel_coefficients, channel_values, fine_names, finish, state_rows


#: the periodic path evaluates the mesh at the pinion's actual angle (nominal rotation plus its dynamic angle
#: ``phi_1``, as the time-stepped path does) by fixed-point iteration; it stops when the angle's change between
#: two passes is below this many mesh cycles: a timing error of 1e-4 mesh cycles, i.e. a phase of 2 pi h 1e-4 rad at
#: mesh harmonic h and spurious sidebands below 3e-4 h of the mesh line (healthy and pitted pairs: 2 passes;
#: 100 um of eccentricity: 3)
ANGLE_TOL_CYCLES = 1e-4
#: cycles that differ in their error force only share their homogeneous map (:func:`_cycle_maps`); False marches
#: every distinct cycle's map in full (the reference the tests compare with)
SHARE_PHI = True
#: at most this many passes (the map from the angle to the response contracts by ~0.02 per pass)
MAX_ANGLE_PASSES = 5


def periodic_response(cases, P: int, n_c: int) -> list[Response]:
    """Periodic steady state by shooting, the monodromy composed from distinct mesh cycles.

    With ``n_c`` steps per mesh cycle, the one-period map is the product of the
    ``P`` one-cycle maps ``x -> Phi_j x + p_j`` on ``x = (q, q')``. Cycles with
    the same samples (all healthy cycles of a case) share their map, so the
    ``2n + 1``-column runs cover only the distinct cycles; the record follows from
    the cycles' start states, all cycles marched side by side (:func:`_march`).

    The mesh position is the pinion's actual angle in mesh cycles, ``x = f_m t + z_1 phi_1 / 2 pi``, as in the
    time-stepped path (:mod:`datagen.time_stepping`): each further pass reads the mesh at the angle of the
    previous one (the first at the static wind-up only), until the angle changes by less than
    :data:`ANGLE_TOL_CYCLES`. Its periodic state is found by multiple shooting over the cycles with the first
    pass's one-cycle maps as the (approximate) Jacobian (:func:`_reshoot`): a few one-column marches, not a new
    monodromy. A healthy or pitted pair's dynamic angle swings by ~1e-3 of a cycle; a gear that follows a
    transmission error of tens of micrometres (eccentricity, pitch error) turns by ~1e-2 of a cycle once per
    revolution, which phase-modulates the mesh: its sidebands change by up to 40 % (the two paths disagreed by
    that much before the iteration). A case with ``solver.mesh_angle = "nominal"`` keeps the first pass's
    positions (the classic linear time-varying model).
    """
    N = P * n_c
    C = len(cases)
    n = cases[0].model.n
    ops = [newmark.newmark_operators(c.model.M, c.model.K_s, c.model.C_s, c.model.v, c.period_s / N) for c in cases]
    f = np.stack([c.model.f_static for c in cases])
    c_m = mesh_damping(cases)
    statics = [static_state(c) for c in cases]
    i_phi1 = cases[0].model.index("phi_1")
    z1_per_rad = np.array([c.model.pair.pinion.teeth for c in cases], dtype=float) / (2 * np.pi)
    u = np.arange(1, n_c + 1) / n_c
    nominal = np.arange(P)[:, None] + u[None, :]                         # (P, n_c): f_m t at steps 1..N
    x = np.stack([nominal + s[1] for s in statics])                      # (C, P, n_c)
    dynamic = np.array([c.mesh_angle == "dynamic" for c in cases])
    mesh = _mesh_samples(cases, x)
    maps, inverse, distinct = _cycle_maps(ops, f, c_m, mesh, n)
    starts = _fixed_point_starts(maps, inverse)
    # only the state components the output channels and the mesh angle read are stored (bit-equal: copies)
    wanted = wanted_channels(cases)
    names = fine_names(n, wanted)
    keep = (np.arange(3 * n) if wanted is None else
            np.array(sorted(set(state_rows(n, {d: i for i, d in enumerate(cases[0].model.dofs)}, names)) | {i_phi1})))
    store = None if wanted is None else keep
    traj, force, ends = _march(ops, f, c_m, mesh, starts, store)
    periodicity = _defect(starts, ends)
    passes = 1
    change = np.zeros(C)
    first = (traj, force, periodicity)
    while dynamic.any():
        # step i (1..N) of the period is row i % N of traj
        angle = z1_per_rad[:, None] * np.roll(traj[:, int(np.searchsorted(keep, i_phi1)), :], -1, axis=-1)
        x_new = np.where(dynamic[:, None, None], nominal[None] + angle.reshape(C, P, n_c), x)
        change = np.abs(x_new - x).max(axis=(1, 2))
        if np.all(change <= ANGLE_TOL_CYCLES) or passes == MAX_ANGLE_PASSES:
            break
        x, passes = x_new, passes + 1
        mesh = _mesh_samples(cases, x)
        traj, force, starts, periodicity = _reshoot(ops, f, c_m, mesh, starts, maps, inverse, store)
    swing = (x - nominal[None]).max(axis=(1, 2)) - (x - nominal[None]).min(axis=(1, 2))
    # a case whose angle did not settle within the passes (seen with grade-8 pitch errors, swings of ~0.1 cycle:
    # the iteration does not contract there) keeps the first pass, a consistent solution at the nominal rotation,
    # and says so (``angle_converged``); the time-stepped path (solver.method = "transient") follows the angle there
    converged = change <= ANGLE_TOL_CYCLES
    traj = np.where(converged[:, None, None], traj, first[0])
    force = np.where(converged[:, None], force, first[1])
    periodicity = np.where(converged, periodicity, first[2])
    co = channel_coefficients(cases)
    omega = np.array([2 * np.pi * c.speed_rpm / 60.0 for c in cases])
    full = np.zeros((C, 3 * n, traj.shape[2]))          # the rows not stored stay unread (and untouched)
    full[:, keep] = traj
    fine = channel_values(full, force, omega[:, None], co, names)      # (C, n_ch, N), sample j at time j dt
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
                "period_cycles": c.record.period_cycles, "distinct_cycles": int(distinct[j]),
                "angle_passes": passes, "angle_change_cycles": float(change[j]),
                "angle_swing_cycles": float(swing[j]), "angle_converged": bool(converged[j]),
                "periodicity_error": float(periodicity[j]), "transient_discarded_s": 0.0, "start_time_s": 0.0,
                "natural_frequencies_hz": c.model.natural_frequencies_hz.tolist(),
                "mesh_damping_n_s_per_m": c.model.c_mesh_n_s_per_m})
    return out



#: multiple shooting with the first pass's maps stops at this defect (relative to the state; the output is
#: read to ~1e-6), or after :data:`MAX_RESHOOT` marches (each contracts the defect by ~1e-4 for the angles of a
#: pitted pair: three marches per pass)
RESHOOT_TOL = 1e-8
MAX_RESHOOT = 12


def _mesh_samples(cases, x):
    """Stiffness and error force at the positions ``x`` (C, P, n_c), and at each cycle's previous sample."""
    C, P, n_c = x.shape
    kc = np.empty((C, P, n_c))
    Ec = np.empty((C, P, n_c))
    for j, c in enumerate(cases):
        kc[j], Ec[j] = c.record.at(x[j])
    # a cycle's start acceleration is consistent with the last sample of the cycle before
    k_prev = np.roll(kc[:, :, -1], 1, axis=1)                           # (C, P)
    E_prev = np.roll(Ec[:, :, -1], 1, axis=1)
    return {"k": kc, "E": Ec if np.any(Ec != 0) else None, "k_prev": k_prev,
            "E_prev": E_prev if np.any(Ec != 0) else np.zeros_like(k_prev)}


def _cycle_maps(ops, f, c_m, mesh, n):
    """The one-cycle maps ``x -> Phi x + p`` of the distinct cycles: ``(Phi_q, p_q)``, the map of cycle ``cy``
    of case ``j`` (``inverse[j, cy]``) and the number of distinct cycles per case.

    ``Phi`` depends on the cycle's stiffness samples only, ``p`` on its error force too: cycles whose
    stiffness agrees but whose error force does not (every cycle of a healthy pair with a pitch error: the
    deviation changes from tooth to tooth, the stiffness does not) share one ``Phi``, marched with ``2n + 1``
    columns once, and each further error force adds one column (its particular solution from rest) instead
    of ``2n + 1``. Measured on a spur pair with a wheel pitch error (100 distinct cycles, 2n = 12): the maps'
    columns 1300 -> 112. Without such cycles (healthy, pitted or eccentric records) the maps are the ones of
    the distinct cycles, as before."""
    kc, Ec, k_prev, E_prev = mesh["k"], mesh["E"], mesh["k_prev"], mesh["E_prev"]
    C, P, n_c = kc.shape
    E_all = Ec if Ec is not None else np.zeros_like(kc)
    rows, inverse = [], np.empty((C, P), dtype=np.int64)
    hom, hom_of = [], []                     # rows with their own Phi; the row whose Phi each row uses
    for j in range(C):                       # set-up loop over cases (not over time)
        kk = np.hstack([k_prev[j][:, None], kc[j]])
        ee = np.hstack([E_prev[j][:, None], E_all[j]])
        key_k = np.round(kk / np.abs(kk).max(), 10)
        key = np.hstack([key_k, np.round(ee / max(np.abs(ee).max(), 1e-300), 10)])
        seen: dict[bytes, int] = {}
        seen_k: dict[bytes, int] = {}
        for cy in range(P):
            b = key[cy].tobytes()
            if b not in seen:
                seen[b] = len(rows)
                bk = key_k[cy].tobytes() if SHARE_PHI else b
                if bk not in seen_k:
                    seen_k[bk] = len(rows)
                    hom.append(len(rows))
                hom_of.append(seen_k[bk])
                rows.append((j, cy))
            inverse[j, cy] = seen[b]
    case_of = np.array([r[0] for r in rows])
    cyc_of = np.array([r[1] for r in rows])
    Q = len(rows)
    hom, hom_of = np.array(hom), np.array(hom_of)
    # columns: 0 = particular from rest, 1..2n = unit (q, q'); accelerations consistent at the start
    Phi_h, p_h = _march_columns(ops, f, c_m, kc, Ec, k_prev, E_prev, case_of[hom], cyc_of[hom], n, units=True)
    Phi_q = Phi_h[np.searchsorted(hom, hom_of)]
    p_q = np.empty((Q, 2 * n))
    p_q[hom] = p_h
    rest = np.setdiff1d(np.arange(Q), hom)
    if rest.size:                            # a further error force on a shared Phi: its particular column only
        _, p_q[rest] = _march_columns(ops, f, c_m, kc, Ec, k_prev, E_prev, case_of[rest], cyc_of[rest], n,
                                      units=False)
    return (Phi_q, p_q), inverse, np.bincount(case_of, minlength=C)


def _march_columns(ops, f, c_m, kc, Ec, k_prev, E_prev, case_of, cyc_of, n: int, *, units: bool):
    """One cycle of each row ``(case_of, cyc_of)`` from rest with the forcing (the particular column) and, with
    ``units``, from each unit state without it: ``(Phi (rows, 2n, 2n) or None, p (rows, 2n))``."""
    k_q = kc[case_of, cyc_of].T                                         # (n_c, rows)
    E_q = Ec[case_of, cyc_of].T if Ec is not None else None
    ops_q = [ops[j] for j in case_of]
    batch_q = newmark.Batch(ops_q, f[case_of])
    J = 2 * n + 1 if units else 1
    x_init = np.zeros((len(case_of), J, 2 * n))
    scale = np.zeros(J)
    scale[0] = 1.0
    if units:
        x_init[:, 1:, :] = np.eye(2 * n)[None]
    S0 = newmark.consistent_states(ops_q, x_init, f[case_of], k_prev[case_of, cyc_of], E_prev[case_of, cyc_of],
                                   c_m[case_of], scale)
    S_end, _, _ = newmark.run_linear(batch_q, S0, k_q, c_m[case_of], E_q, scale, store=False)
    Phi = np.transpose(S_end[:, 1:, :2 * n], (0, 2, 1)) if units else None   # column i = image of unit state i
    return Phi, S_end[:, 0, :2 * n]


def _cyclic_states(Phi_q, inverse, add):
    """States ``s`` (C, P + 1, 2n) around the period with ``s_{cy+1} = Phi_cy s_cy + add_cy`` and ``s_P = s_0``:
    the fixed point of the composed maps, then each cycle's map applied in turn. ``add`` is (C, P, 2n)."""
    C, P = inverse.shape
    n2 = add.shape[2]
    Phi = np.broadcast_to(np.eye(n2), (C, n2, n2)).copy()
    r = np.zeros((C, n2))
    for cy in range(P):
        sel = inverse[:, cy]
        Phi = np.matmul(Phi_q[sel], Phi)
        r = np.einsum("cij,cj->ci", Phi_q[sel], r) + add[:, cy]
    s = np.empty((C, P + 1, n2))
    s[:, 0] = np.linalg.solve(np.eye(n2)[None] - Phi, r[..., None])[..., 0]
    for cy in range(P):
        s[:, cy + 1] = np.einsum("cij,cj->ci", Phi_q[inverse[:, cy]], s[:, cy]) + add[:, cy]
    return s


def _fixed_point_starts(maps, inverse):
    """Start states (C, P + 1, 2n) of every cycle of the periodic solution (the last = the first again)."""
    Phi_q, p_q = maps
    return _cyclic_states(Phi_q, inverse, p_q[inverse])


def _march(ops, f, c_m, mesh, starts, keep=None):
    """Every cycle of every case from its start state, side by side (one batch row per cycle: a Python loop of
    ``n_c`` steps instead of ``P n_c``). Returns ``traj`` (C, 3n, N) and ``force`` (C, N), sample ``j`` at time
    ``j dt`` of the period, and each cycle's end state (C, P, 2n); ``keep``: the state components stored in
    ``traj`` (default all)."""
    kc, Ec = mesh["k"], mesh["E"]
    C, P, n_c = kc.shape
    n2 = starts.shape[2]
    case_of = np.repeat(np.arange(C), P)
    ops_r = [ops[j] for j in case_of]
    batch = newmark.Batch(ops_r, f[case_of])
    s0 = newmark.consistent_states(ops_r, starts[:, :P].reshape(C * P, 1, n2), f[case_of],
                                   mesh["k_prev"].reshape(-1), mesh["E_prev"].reshape(-1), c_m[case_of], np.ones(1))
    k_r = np.ascontiguousarray(kc.reshape(C * P, n_c).T)
    E_r = np.ascontiguousarray(Ec.reshape(C * P, n_c).T) if Ec is not None else None
    S_end, traj, force = newmark.run_linear(batch, s0, k_r, c_m[case_of], E_r, np.ones(1), store=True,
                                            store_shift=1, groups=P, store_rows=keep)
    # step i < n_c of cycle cy is time cy n_c + i of the period, stored in place; its last step (time (cy + 1) n_c)
    # landed in the cycle's own first sample and belongs to the next cycle's
    traj[..., 0] = np.roll(traj[..., 0], 1, axis=-1)
    force[..., 0] = np.roll(force[..., 0], 1, axis=-1)
    m = traj.shape[1]
    return traj.reshape(C, m, P * n_c), force.reshape(C, P * n_c), S_end[:, 0, :n2].reshape(C, P, n2)


def _defect(starts, ends):
    """Largest mismatch between a cycle's end and the next cycle's start (the last against the first, which
    the composed maps also return to), relative to the state's size, per case."""
    scale = np.abs(starts[:, 0]).max(axis=1)
    d = np.abs(ends - starts[:, 1:]).max(axis=(1, 2))
    return np.maximum(d, np.abs(starts[:, -1] - starts[:, 0]).max(axis=1)) / scale


def _reshoot(ops, f, c_m, mesh, starts, maps, inverse, keep=None):
    """Periodic solution for new mesh samples by multiple shooting over the cycles, from the previous start states,
    with the maps of another solution (close to this one's) as the Jacobian.

    March all cycles from the starts ``s_cy``; their ends ``e_cy`` miss the next starts by ``d_cy = e_cy -
    s_{cy+1}``. The corrections solve ``Delta s_{cy+1} = Phi_cy Delta s_cy + d_cy`` around the cycle (a fixed
    point of the composed maps, as in :func:`_fixed_point_starts`). Exact maps would close the defect in one
    step; the old maps close it by the factor their change makes (~1e-2 here).
    """
    Phi_q, _ = maps
    P = inverse.shape[1]
    s = starts.copy()
    for _ in range(MAX_RESHOOT):
        traj, force, ends = _march(ops, f, c_m, mesh, s, keep)
        s[:, P] = s[:, 0]
        periodicity = _defect(s, ends)
        if np.all(periodicity <= RESHOOT_TOL):
            break
        s += _cyclic_states(Phi_q, inverse, ends - s[:, 1:])
    return traj, force, s, periodicity
