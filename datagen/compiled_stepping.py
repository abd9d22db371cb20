"""The time-stepping loop of :func:`datagen.newmark.run_general`, compiled (numba), for the ``transient`` path.

Why
---
A time-stepped record (speed or torque fluctuation, backlash, a candidate whose record repeats only over the
hunting period) takes a Newmark step per ``1 / (R fs)``: 100 000-200 000 steps for a 2 s record. In numpy each
step is ~20 array operations on arrays of a few cases, so the interpreter's overhead, not arithmetic, sets the
cost (60-240 us per step). The comparison's time-stepped candidates are where its 60 s budget goes
(``experiments/bench_compare.py``). Here one compiled function marches a whole chunk of steps: the same
operations case by case (the state update ``s @ B~``, the mesh position predicted to the new step, the
periodic interpolation of the mesh record, the mesh law solved in closed form or by Newton), with the
forcing and the reference rotation of the chunk computed beforehand in numpy, as before.

What it covers
--------------
The linear mesh law ``F = k delta + c delta' - E`` for every batch, and a nonlinear law (hook 4) when every
nonlinear case of the batch carries the same effect class and that class offers a compiled scalar form of its
law, ``scalar_mesh_law`` (:class:`datagen.effects.base.Effect`), made with :func:`scalar_law` (a numba
``cfunc`` of :data:`SCALAR_LAW_SIGNATURE`; :mod:`datagen.effects.backlash` has one). The loop takes the law as a
function pointer, so it is compiled once and kept in numba's on-disk cache (a loop specialised on each law would
be compiled again in every process, ~4 s). An effect without one (a user's plugin) runs through the numpy loop,
unchanged: adding an effect never needs this module. ``datagen.time_stepping.COMPILED = False`` forces the
numpy loop (the reference the tests compare against).

Equal to the numpy loop to rounding: the products are summed in another order, and Newton stops per case
rather than when the whole batch has converged (both below ``tol`` relative), so records agree to ~1e-10 of
their RMS (``tests/test_compiled_stepping.py``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import cfunc, njit, types

#: the signature of an effect's compiled scalar mesh law (``scalar_mesh_law``, hook 4):
#: ``(p, delta_m, delta_dot_m_s, k_n_per_m, c_n_s_per_m, error_force_n, k_slots_n_per_m, e_slots_m) -> (F, dF/d delta,
#: dF/d delta_dot)``, ``p`` the case's parameters in field order, the slots 1-D
SCALAR_LAW_SIGNATURE = types.UniTuple(types.float64, 3)(
    types.float64[::1], types.float64, types.float64, types.float64, types.float64, types.float64,
    types.float64[::1], types.float64[::1])


def scalar_law(fn):
    """Decorator of an effect's ``scalar_mesh_law``: compiled to a C callback of :data:`SCALAR_LAW_SIGNATURE`
    (numba ``cfunc``, cached on disk). The loop takes it as a function pointer, so one compiled loop serves
    every law and stays in numba's cache across processes."""
    return cfunc(SCALAR_LAW_SIGNATURE, cache=True)(fn)


@njit(cache=True)
def evaluate_law(law, p, delta, delta_dot, k, c, e_force, k_slots, e_slots):
    """``law(...)`` called from Python (a ``cfunc`` is not callable there): for tests and checks."""
    return law(p, delta, delta_dot, k, c, e_force, k_slots, e_slots)


@njit(cache=True)
def linear_law(p, delta, delta_dot, k, c, e_force, k_slots, e_slots):
    """The linear mesh law in the scalar form of ``scalar_mesh_law`` (the batches without a nonlinear law)."""
    return k * delta + c * delta_dot - e_force, k, c


@njit(cache=True)
def _predict(S, B, bi, c, Y, dg_c, theta_c, omega_c, x_static, z1, dynamic, i_phi1, n, dt, ppc, nflt, last, nrec,
             offset, coff, k_tab, k_cum, e_tab, e_cum):
    """``Y = s_c @ B~`` (next state, ``d_lin``, ``h``) and the mesh record of case ``c`` at the new step, read as its
    mean over the step's window (``omega_c``: the reference speed, rad/s): returns ``(d_lin, h, ends, width, k,
    e_force)``, the window's :func:`_window_ends` and width (record positions) for the pairs' slots."""
    m1 = S.shape[1]
    # row by row, so the inner loop runs along B's contiguous rows (vectorised); each Y[q] still sums over p in
    # order from 0.0, the same additions as the column-wise dot products before (bit-equal, 1.6x faster march)
    s0 = S[c, 0]
    for q in range(Y.size):
        Y[q] = 0.0 + s0 * B[bi, 0, q]
    for p in range(1, m1):
        sp = S[c, p]
        for q in range(Y.size):
            Y[q] += sp * B[bi, p, q]
    phi = S[c, i_phi1] + dt * S[c, n + i_phi1] + 0.5 * dt * dt * S[c, 2 * n + i_phi1]
    x = z1[c] * (theta_c + dynamic[c] * phi) + (1.0 - dynamic[c]) * x_static[c]
    width = z1[c] * omega_c * dt * ppc[c]
    ends = _window_ends(x * ppc[c], width, nflt, last, nrec, c)
    k = _window_mean(k_tab, k_cum, ends, width, c, nrec, offset, coff)
    e_force = _window_mean(e_tab, e_cum, ends, width, c, nrec, offset, coff)
    return Y[m1] + dg_c, Y[m1 + 1], ends, width, k, e_force


@njit(cache=True)
def _window_ends(p, width, nflt, last, nrec, c):
    """Where the step's window ``p +/- width / 2`` (record positions) of case ``c`` falls, computed once per step
    and case for every record read from it: (lower index, fraction, upper index, fraction, whole periods from the
    lower to the upper end), as :meth:`MeshRecords._window`; for a zero width the point ``p`` as (index,
    fraction, -1, 0, 0)."""
    if width <= 0.0:
        pos = p % nflt[c]
        a = int(pos)
        if a > last[c]:
            a = last[c]
        return a, pos - a, -1, 0.0, 0.0
    p_lo = (p - 0.5 * width) % nflt[c]
    p_hi = p_lo + width
    q_hi = np.floor(p_hi / nflt[c])
    r_hi = p_hi - q_hi * nflt[c]
    lo = int(p_lo)
    if lo > last[c]:
        lo = last[c]
    hi = int(r_hi)
    if hi > last[c]:
        hi = last[c]
    return lo, p_lo - lo, hi, r_hi - hi, q_hi


@njit(cache=True)
def _integral(tab, cum, i, f, q, c, nrec, offset, coff):
    """Integral of case ``c``'s interpolated record ``tab`` from position 0 to index ``i`` + ``f`` plus ``q``
    periods (``cum``: :func:`datagen.mesh_excitation._cumulative`)."""
    a = i + offset[c]
    b = (0 if i + 1 == nrec[c] else i + 1) + offset[c]
    return q * cum[nrec[c] + coff[c]] + cum[i + coff[c]] + tab[a] * f + (tab[b] - tab[a]) * (0.5 * f * f)


@njit(cache=True)
def _window_mean(tab, cum, ends, width, c, nrec, offset, coff):
    """Mean of the interpolated record ``tab`` over the step's window whose :func:`_window_ends` are ``ends`` (or
    its value at the point for a zero width): :meth:`datagen.mesh_excitation.MeshRecords.window_all_at`."""
    lo, flo, hi, fhi, q = ends
    if width <= 0.0:
        b = (0 if lo + 1 == nrec[c] else lo + 1) + offset[c]
        return tab[lo + offset[c]] * (1.0 - flo) + tab[b] * flo
    return (_integral(tab, cum, hi, fhi, q, c, nrec, offset, coff)
            - _integral(tab, cum, lo, flo, 0.0, c, nrec, offset, coff)) / width


@njit(cache=True)
def _advance(Y, G_jc, us_c, F, Sn_c, traj_jc):
    """The next state of one case: ``Y + G - F u`` (and its first 3n components into the trajectory)."""
    for q in range(Sn_c.size):
        Sn_c[q] = Y[q] + G_jc[q] - F * us_c[q]
    for q in range(traj_jc.size):
        traj_jc[q] = Sn_c[q]


@njit(cache=True)
def _march_linear(S, B, shared, G, dg, us, theta, x_static, z1, dynamic, i_phi1, n, dt,
                  ppc, nflt, last, nrec, offset, k_tab, e_tab, omega, coff, k_cum, e_cum, c_m, sigma, traj, force):
    """A chunk of steps with the linear law, solved in closed form; the record is read as its mean over the
    step's window (``omega``: the reference speed, rad/s)."""
    C, m1 = S.shape
    Y = np.empty(m1 + 2)
    Sn = np.empty((C, m1))
    two_dt = 2.0 / dt
    for j in range(G.shape[0]):
        for c in range(C):
            d_lin, h, ends, width, k, e_force = _predict(
                S, B, 0 if shared else c, c, Y, dg[j, c], theta[j, c], omega[j, c], x_static, z1, dynamic, i_phi1,
                n, dt, ppc, nflt, last, nrec, offset, coff, k_tab, k_cum, e_tab, e_cum)
            kappa = k + two_dt * c_m[c]
            t1 = c_m[c] * h + e_force
            delta = (d_lin + sigma[c] * t1) / (1.0 + sigma[c] * kappa)
            F = kappa * delta - t1
            _advance(Y, G[j, c], us[c], F, Sn[c], traj[j, c])
            force[j, c] = F
        S[:, :] = Sn
    return 0


@njit(cache=True)
def _residual(law, p, x, d_lin, h, sig, two_dt, k, cm, e_force, ks, es):
    F, dF, dFd = law(p, x, two_dt * x - h, k, cm, e_force, ks, es)
    return x + sig * F - d_lin


@njit(cache=True)
def _bracketed_root(law, p, delta, d_lin, h, sig, two_dt, k, cm, e_force, ks, es, tol):
    """:func:`datagen.newmark.bracketed_root` for one case: ``(delta, F)`` by doubling a search width to a sign
    change of the residual and bisecting it; at a jump of the law over zero the force that closes the step.
    Unchanged (and counted unconverged by the caller) if no bracket is found."""
    if sig <= 0.0:
        F, dF, dFd = law(p, delta, two_dt * delta - h, k, cm, e_force, ks, es)
        return delta, F
    r0 = _residual(law, p, delta, d_lin, h, sig, two_dt, k, cm, e_force, ks, es)
    lo, hi, r_lo, r_hi = delta, delta, r0, r0
    w = max(abs(delta), 1e-9) * 1e-6
    for _ in range(60):
        if r_lo > 0.0:
            lo = delta - w
            r_lo = _residual(law, p, lo, d_lin, h, sig, two_dt, k, cm, e_force, ks, es)
        if r_hi < 0.0:
            hi = delta + w
            r_hi = _residual(law, p, hi, d_lin, h, sig, two_dt, k, cm, e_force, ks, es)
        if r_lo <= 0.0 and r_hi >= 0.0:
            break
        w *= 2.0
    if not (r_lo <= 0.0 and r_hi >= 0.0):
        F, dF, dFd = law(p, delta, two_dt * delta - h, k, cm, e_force, ks, es)
        return delta, F
    for _ in range(80):
        if hi - lo <= tol * (abs(lo) + 1e-9):
            break
        mid = 0.5 * (lo + hi)
        if _residual(law, p, mid, d_lin, h, sig, two_dt, k, cm, e_force, ks, es) > 0.0:
            hi = mid
        else:
            lo = mid
    x = 0.5 * (lo + hi)
    return x, (d_lin - x) / sig


@njit(cache=True)
def _march_law(law, S, B, shared, G, dg, us, theta, x_static, z1, dynamic, i_phi1, n, dt,
               ppc, nflt, last, nrec, offset, k_tab, e_tab, omega, coff, k_cum, e_cum, k_slots, ef_slots,
               ks_cum, efs_cum, c_m, sigma, law_row, P, tol, max_iter, traj, force):
    """A chunk of steps with a nonlinear law ``law`` for the cases whose ``law_row >= 0`` (parameters
    ``P[law_row]``), solved by Newton per case as :func:`datagen.newmark.solve_mesh_law` does; the other cases in
    closed form. ``law`` is a :func:`scalar_law` (a function pointer), so this loop is compiled once and cached."""
    C, m1 = S.shape
    n_slots = k_slots.shape[1]
    Y = np.empty(m1 + 2)
    Sn = np.empty((C, m1))
    ks = np.empty(n_slots)
    es = np.empty(n_slots)
    two_dt = 2.0 / dt
    bad = 0
    for j in range(G.shape[0]):
        for c in range(C):
            d_lin, h, ends, width, k, e_force = _predict(
                S, B, 0 if shared else c, c, Y, dg[j, c], theta[j, c], omega[j, c], x_static, z1, dynamic, i_phi1,
                n, dt, ppc, nflt, last, nrec, offset, coff, k_tab, k_cum, e_tab, e_cum)
            sig, cm, r = sigma[c], c_m[c], law_row[c]
            if r < 0:
                kappa = k + two_dt * cm
                t1 = cm * h + e_force
                delta = (d_lin + sig * t1) / (1.0 + sig * kappa)
                F = kappa * delta - t1
            else:
                for s in range(n_slots):
                    ks[s] = _window_mean(k_slots[:, s], ks_cum[:, s], ends, width, c, nrec, offset, coff)
                    ef = _window_mean(ef_slots[:, s], efs_cum[:, s], ends, width, c, nrec, offset, coff)
                    es[s] = ef / ks[s] if ks[s] > 0.0 else 0.0        # MeshRecords.window_all_at
                delta = d_lin
                done = False
                F = 0.0
                for _ in range(max_iter):
                    F, dF, dFd = law(P[r], delta, two_dt * delta - h, k, cm, e_force, ks, es)
                    slope = dF + two_dt * dFd
                    step = (delta + sig * F - d_lin) / (1.0 + sig * slope)
                    delta -= step
                    if abs(step) <= tol * (abs(delta) + 1e-9):
                        F = F - slope * step
                        done = True
                        break
                if not done:
                    F, dF, dFd = law(P[r], delta, two_dt * delta - h, k, cm, e_force, ks, es)
                    if abs(delta + sig * F - d_lin) > 1e3 * tol * (abs(delta) + 1e-9):
                        delta, F = _bracketed_root(law, P[r], delta, d_lin, h, sig, two_dt, k, cm, e_force, ks, es,
                                                   tol)
                        if abs(delta + sig * F - d_lin) > 1e3 * tol * (abs(delta) + 1e-9):
                            bad += 1
            _advance(Y, G[j, c], us[c], F, Sn[c], traj[j, c])
            force[j, c] = F
        S[:, :] = Sn
    return bad


@dataclass
class CompiledMesh:
    """What the compiled loop needs of the mesh (arrays over the C cases of a batch).

    ``records``: :class:`datagen.mesh_excitation.MeshRecords`; ``law``: a compiled scalar law (or
    :func:`linear_law`), ``law_row[c]`` the row of ``P`` holding case ``c``'s law parameters, -1 for the linear
    law; the rest as in :func:`datagen.time_stepping.transient_response`."""

    records: object
    z1_per_rad: np.ndarray
    dynamic: np.ndarray
    x_static: np.ndarray
    i_phi1: int
    c_m: np.ndarray
    law: object
    law_row: np.ndarray
    law_params: np.ndarray
    tol: float = 1e-12
    max_iter: int = 30


def run_general(batch, S0: np.ndarray, n_steps: int, chunk: int, inputs, theta_of_chunk, mesh: CompiledMesh,
                omega_of_chunk=None):
    """:func:`datagen.newmark.run_general` with the per-step work compiled; ``theta_of_chunk()`` gives the
    reference rotation (L, C) of the chunk ``inputs`` has just prepared. Yields the same
    ``(i0, traj, force, n_unconverged)``."""
    n = batch.n
    m = 3 * n
    S = np.ascontiguousarray(batch.augment(S0[:, None, :], np.zeros(1))[:, 0])
    B = np.ascontiguousarray(batch.B[None] if batch.shared else batch.B)
    us = np.ascontiguousarray(batch.u_state)
    rec = mesh.records
    C = S.shape[0]
    linear = mesh.law is linear_law
    for i0 in range(0, n_steps, chunk):
        L = min(chunk, n_steps - i0)
        G, dg = inputs(i0, L, S)
        theta = np.ascontiguousarray(theta_of_chunk())
        omega = np.ascontiguousarray(omega_of_chunk() if omega_of_chunk is not None else np.zeros_like(theta))
        traj = np.empty((L, C, m))
        force = np.empty((L, C))
        args = (S, B, batch.shared, np.ascontiguousarray(G), np.ascontiguousarray(dg), us, theta,
                mesh.x_static, mesh.z1_per_rad, mesh.dynamic, mesh.i_phi1, n, float(batch.dt[0]),
                rec.ppc, rec._n_float, rec._last, rec.n, rec.offset, rec.k, rec.error_force, omega, rec.cum_offset,
                rec.k_cum, rec.error_force_cum)
        if linear:
            bad = _march_linear(*args, mesh.c_m, batch.sigma, traj, force)
        else:
            bad = _march_law(mesh.law, *args, rec.k_slots, rec.ef_slots, rec.k_slots_cum, rec.ef_slots_cum,
                             mesh.c_m, batch.sigma, mesh.law_row,
                             mesh.law_params, mesh.tol, mesh.max_iter, traj, force)
        yield i0, traj, force, int(bad)


@njit(cache=True)
def linear_update(Y, m, alpha, beta, gE, has_error, us, F, store, rows, forces, r, sel):
    """One step of :func:`datagen.newmark.run_linear` after its product ``Y = s @ B~`` (C, J, m + 3), in place:
    the mesh force ``F = alpha Y[.., m + 1] + beta Y[.., m + 2] (+ gE)`` (C, J) and the state ``Y[.., :m + 1] -=
    F us``; with ``store``, column 0's components ``sel`` into ``rows[r]`` and its force into ``forces[r]``.

    The same IEEE operations in the same order as the numpy lines it replaces (a product and a difference, never
    fused), so the same bits (``tests/test_dynamics.py``); one call instead of the ~6 array operations whose
    short inner loops (m + 1 values per case and column) made the periodic march's cost."""
    C, J = Y.shape[0], Y.shape[1]
    for c in range(C):
        a = alpha[c]
        b = beta[c]
        for j in range(J):
            f = a * Y[c, j, m + 1] + b * Y[c, j, m + 2]
            if has_error:
                f += gE[c, j]
            F[c, j] = f
            for k in range(m + 1):
                Y[c, j, k] -= f * us[c, k]
        if store:
            for kk in range(sel.size):
                rows[r, c, kk] = Y[c, 0, sel[kk]]
            forces[r, c] = F[c, 0]
