"""Batched implicit Newmark integration with a rank-one (scalar) mesh force.

Solves, for many cases at once (arrays cases x DOF; the time loop is the only
Python loop),

    M q'' + C_s q' + K_s q + v F = f(t),    delta = v . q,

where everything except the scalar mesh force ``F`` is linear and constant.
Newmark's constant average acceleration (gamma = 1/2, beta = 1/4) gives, per step,

    A0 q_{n+1} = f_{n+1} + P' s_n - v F_{n+1},   A0 = K_s + (2/dt) C_s + (4/dt^2) M,

with the state ``s = (q, q', q'')``. ``A0`` is factorised once; the mesh term is
a rank-one change that enters only through the scalar ``delta_{n+1}``:
``delta = d_lin - sigma F(delta)`` with ``u = A0^-1 v``, ``sigma = v . u``
(Sherman-Morrison). For the linear law ``F = k delta + c delta' - E`` this is
solved in closed form; a nonlinear law (hook 4) is solved by a scalar Newton
iteration per case, vectorised over the batch. The whole update of ``s`` is one
matrix product ``s_n @ B`` plus a correction along ``u``.

References
----------
Newmark, N. M. (1959). A method of computation for structural dynamics. J. Eng. Mech. Div. 85(3), 67-94.
Hughes, T. J. R. (1987). The Finite Element Method, sec. 9.1 (average acceleration: unconditionally
    stable, period error (w dt)^2/12).
Sherman, J., Morrison, W. J. (1950). Adjustment of an inverse matrix corresponding to a change in one
    element of a given matrix. Ann. Math. Stat. 21(1), 124-127.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class NewmarkOperators:
    """Precomputed step operators of one case (module docstring).

    Attributes
    ----------
    B : ndarray (3n, 3n + 2)
        ``s_n @ B`` = (next state without forcing and mesh force, v . q_lin, h) with
        ``h = (2/dt) delta_n + delta'_n``.
    u_state : ndarray (3n,)
        Change of the next state per newton of mesh force (enters with a minus sign).
    force_state : ndarray (n, 3n)
        ``f @ force_state`` = change of the next state due to the forcing ``f_{n+1}``.
    u : ndarray (n,)
        ``A0^-1 v``; ``f . u`` is the forcing's share of ``d_lin``.
    sigma : float
        ``v . A0^-1 v`` (m/N).
    """

    dt: float
    M: np.ndarray
    K_s: np.ndarray
    C_s: np.ndarray
    v: np.ndarray
    B: np.ndarray
    u_state: np.ndarray
    force_state: np.ndarray
    u: np.ndarray
    sigma: float

    @property
    def n(self) -> int:
        return self.v.size


def newmark_operators(M, K_s, C_s, v, dt: float) -> NewmarkOperators:
    """Step operators for time step ``dt`` (average acceleration)."""
    n = v.size
    eye = np.eye(n)
    A0 = K_s + (2 / dt) * C_s + (4 / dt**2) * M
    A0inv = np.linalg.inv(A0)
    A0inv = 0.5 * (A0inv + A0inv.T)
    P = np.vstack([(4 / dt**2) * M + (2 / dt) * C_s, (4 / dt) * M + C_s, M])
    W = P @ A0inv
    R1 = np.hstack([eye, (2 / dt) * eye, (4 / dt**2) * eye])
    Z = np.zeros((n, n))
    R2 = np.block([[Z, -(2 / dt) * eye, -(4 / dt**2) * eye], [Z, -eye, -(4 / dt) * eye], [Z, Z, -eye]])
    ell = np.concatenate([(2 / dt) * v, v, np.zeros(n)])
    B = np.hstack([W @ R1 + R2, (W @ v)[:, None], ell[:, None]])
    u = A0inv @ v
    return NewmarkOperators(dt=dt, M=M, K_s=K_s, C_s=C_s, v=v, B=B, u_state=u @ R1, force_state=A0inv @ R1,
                            u=u, sigma=float(v @ u))


def consistent_states(ops: list[NewmarkOperators], x: np.ndarray, f: np.ndarray, k0: np.ndarray, E0: np.ndarray,
                      c_m: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """States ``(q, q', q'')`` (C, J, 3n) whose accelerations satisfy the equations of motion at t = 0.

    ``x`` (C, J, 2n) holds ``(q, q')``; ``f`` (C, n) the forcing, ``k0``, ``E0``, ``c_m`` (C,) the mesh
    stiffness, error force and damping at t = 0, ``scale`` (J,) multiplies forcing and error force per
    column (0 for homogeneous columns). Set-up only: loops over the C cases.
    """
    C, J, m2 = x.shape
    n = m2 // 2
    S = np.empty((C, J, 3 * n))
    rhs = np.empty((C, n, J))
    for j, o in enumerate(ops):
        q, qd = x[j, :, :n], x[j, :, n:]
        F = k0[j] * (q @ o.v) + c_m[j] * (qd @ o.v) - E0[j] * scale
        rhs[j] = (f[j][None] * scale[:, None] - qd @ o.C_s - q @ o.K_s - F[:, None] * o.v[None]).T
    S[..., :2 * n] = x
    # one stacked call: LAPACK's gesv on each case's (M, rhs) as the single calls, without their overhead
    S[..., 2 * n:] = np.linalg.solve(np.stack([o.M for o in ops]), rhs).transpose(0, 2, 1)
    return S


#: :func:`run_linear`'s per-step update compiled (:func:`datagen.compiled_stepping.linear_update`, the same
#: bits); False: the numpy lines, the reference of the tests
COMPILED_UPDATE = True


class Batch:
    """The operators of C cases stacked for the time loop, with a constant forcing per case.

    The state is augmented with one constant component ``s[3n]`` that carries the
    constant forcing ``f`` (0 in homogeneous columns), so a step is a single
    product ``s @ B~`` with ``B~`` of shape (3n+1, 3n+3): columns = next state
    (3n + constant), ``d_lin``, ``h``. When every case has the same operators and
    forcings proportional to one vector (e.g. only the torque differs) ``B~`` is
    shared and the constant component is the proportionality factor.
    """

    def __init__(self, ops: list[NewmarkOperators], f: np.ndarray):
        self.ops = ops
        self.n = n = ops[0].n
        m = 3 * n
        C = len(ops)
        f = np.asarray(f, dtype=float).reshape(C, n)
        # each distinct operator object compared once (a periodic march repeats a case's object per mesh cycle)
        same_ops = all(np.array_equal(o.B, ops[0].B) and np.array_equal(o.force_state, ops[0].force_state)
                       for o in {id(o): o for o in ops[1:] if o is not ops[0]}.values())
        ref = f[int(np.argmax(np.abs(f).max(axis=1)))]
        norm = float(ref @ ref)
        factor = f @ ref / norm if norm > 0 else np.zeros(C)
        self.shared = same_ops and np.allclose(f, factor[:, None] * ref[None], rtol=1e-12, atol=0.0)

        def augmented(o: NewmarkOperators, fv: np.ndarray) -> np.ndarray:
            Bt = np.zeros((m + 1, m + 3))
            Bt[:m, :m] = o.B[:, :m]
            Bt[:m, m + 1:] = o.B[:, m:]
            Bt[m, :m] = fv @ o.force_state
            Bt[m, m] = 1.0
            Bt[m, m + 1] = fv @ o.u
            return Bt

        if self.shared:
            self.B = augmented(ops[0], ref)
            self.const = factor                                    # (C,)
        else:
            self.B = np.stack([augmented(o, fv) for o, fv in zip(ops, f)])
            self.const = np.ones(C)
        self.u_state = np.stack([np.append(o.u_state, 0.0) for o in ops])   # (C, 3n+1)
        self.force_state = np.stack([o.force_state for o in ops])          # (C, n, 3n)
        self.u = np.stack([o.u for o in ops])                              # (C, n)
        self.sigma = np.array([o.sigma for o in ops])                      # (C,)
        self.dt = np.array([o.dt for o in ops])                            # (C,)

    def augment(self, S: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Append the constant component: S (C, J, 3n) -> (C, J, 3n+1) with ``const * scale[j]``."""
        c = self.const[:, None] * scale[None, :]
        return np.concatenate([S, c[..., None]], axis=-1)

    def product(self, S: np.ndarray) -> np.ndarray:
        """``S @ B~`` for S of shape (C, J, 3n+1)."""
        if self.shared:
            C, J, m = S.shape
            return (S.reshape(C * J, m) @ self.B).reshape(C, J, -1)
        return np.matmul(S, self.B)

    def forcing(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """State change (..., C, 3n+1) and ``d_lin`` share (..., C) of a time-varying forcing ``f`` (..., C, n)."""
        if f.ndim == 3:     # (L, C, n): C batched products (L x n)(n x m), 5x faster than the einsum (measured)
            Gc = np.matmul(f.transpose(1, 0, 2), self.force_state)              # (C, L, m)
            # written once into the (L, C, m + 1) layout the march reads, the constant component 0 (one copy, not
            # a transpose, a concatenation and the march's own contiguous copy)
            G = np.empty((f.shape[0], f.shape[1], Gc.shape[2] + 1))
            G[..., :-1] = Gc.transpose(1, 0, 2)
            G[..., -1] = 0.0
        else:
            G = np.einsum("...cn,cnm->...cm", f, self.force_state)
            G = np.concatenate([G, np.zeros(G.shape[:-1] + (1,))], axis=-1)
        return G, np.einsum("...cn,cn->...c", f, self.u)

    def forcing_basis(self, basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The state changes and ``d_lin`` shares of the forcing vectors ``basis`` (C, r, n): (C, r, 3n), (C, r),
        for :meth:`forcing_combined`."""
        return np.matmul(basis, self.force_state), np.einsum("crn,cn->cr", basis, self.u)

    def forcing_combined(self, coef: np.ndarray, basis_terms: tuple) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`forcing` of ``f[l, c] = sum_r coef[l, c, r] basis[c, r]`` (coef (L, C, r)), from
        ``basis_terms = forcing_basis(basis)``: r products per step instead of n.

        Why: the time-stepped path's forcing is the motor torque, the load torque and the reference
        acceleration's inertia forces, three vectors per case with time-varying weights; the product with all n
        components was a fifth of a time-stepped batch's own work (profile of a hidden pitch error on a helical
        rig, experiments/bench_compare.py). Equal to :meth:`forcing` of the assembled ``f`` to rounding."""
        P, pu = basis_terms
        L, C, r = coef.shape
        G = np.empty((L, C, P.shape[2] + 1))
        G[..., :-1] = np.matmul(coef.transpose(1, 0, 2), P).transpose(1, 0, 2)
        G[..., -1] = 0.0
        return G, np.einsum("lcr,cr->lc", coef, pu)


def run_linear(batch: Batch, S0: np.ndarray, k: np.ndarray, c: np.ndarray, E: np.ndarray | None,
               force_scale: np.ndarray, *, store: bool, store_shift: int = 0, groups: int | None = None,
               store_rows: np.ndarray | None = None) -> tuple:
    """March the linear mesh law ``F = k delta + c delta' - E`` over ``len(k)`` steps.

    Parameters
    ----------
    batch : Batch
        Operators and the constant forcing.
    S0 : ndarray (C, J, 3n)
        Initial states; the J columns of a case share its mesh stiffness.
    k : ndarray (N, C)
        Mesh stiffness at steps 1..N (N/m).
    c : ndarray (C,)
        Mesh damping (N s/m).
    E : ndarray (N, C) or None
        Error force at steps 1..N (N).
    force_scale : ndarray (J,)
        Multiplies the forcing and E per column (0 for homogeneous columns).
    store : bool
        Return the trajectory of column 0.
    store_shift : int
        Step ``i`` (1..N) is stored in row ``(i - 1 + store_shift) % N`` (1: row j = time j dt of a period).
    groups : int or None
        With ``groups = G`` the C cases are ``C / G`` records of ``G`` consecutive pieces each (the mesh
        cycles of :func:`datagen.shooting._march`): ``traj`` is stored as (C / G, 3n, G, N) and
        ``force`` as (C / G, G, N), each record's pieces side by side in time.

    store_rows : ndarray of int, optional
        Store only these state components (in this order; default all 3n).

    Returns
    -------
    S : ndarray (C, J, 3n)
        Final states.
    traj : ndarray (C, 3n, N) or None
        States of column 0 (time last: every state component of a case is a contiguous row); with
        ``store_rows`` only those components, (C, len(store_rows), N).
    force : ndarray (C, N) or None
        Mesh force of column 0.
    """
    N = k.shape[0]
    C, J, m = S0.shape
    kappa = k + (2.0 / batch.dt) * c                           # (N, C)
    inv = 1.0 / (1.0 + batch.sigma * kappa)
    # F = alpha d_lin + beta h + gamma E   (closed form of the linear law, module docstring)
    alpha = kappa * inv                                         # (N, C)
    gamma = kappa * batch.sigma * inv - 1.0
    beta = gamma * c
    gE = (gamma * E)[..., None] * force_scale[None, None, :] if E is not None else None   # (N, C, J)
    S = batch.augment(S0, force_scale)
    R = C // (groups or 1)
    # stored time-major (each step one contiguous block) and turned time-last once at the end: writing every step
    # across the time axis touched a cache line per value (the periodic path's Sobol batches: 25 % of the march)
    sel = np.arange(m) if store_rows is None else np.asarray(store_rows, dtype=np.int64)
    k_st = sel.size
    rows = np.empty((N, C, k_st)) if store else None
    forces = np.empty((N, C)) if store else None
    if COMPILED_UPDATE:
        from datagen.compiled_stepping import linear_update

        us = np.ascontiguousarray(batch.u_state)
        F = np.empty((C, J))
        no_error = np.zeros((1, 1))
        rows_c = rows if store else np.empty((1, 1, 1))
        forces_c = forces if store else np.empty((1, 1))
        for i in range(N):
            Y = batch.product(S)
            linear_update(Y, m, alpha[i], beta[i], no_error if gE is None else gE[i], gE is not None, us, F, store,
                          rows_c, forces_c, (i + store_shift) % N, sel)
            S = Y[..., :m + 1]
    else:   # the numpy reference of the same operations (tests)
        us = batch.u_state[:, None, :]
        for i in range(N):
            Y = batch.product(S)
            F = alpha[i][:, None] * Y[..., m + 1] + beta[i][:, None] * Y[..., m + 2]
            if gE is not None:
                F += gE[i]
            S = Y[..., :m + 1]
            S -= F[..., None] * us
            if store:
                r = (i + store_shift) % N
                rows[r] = S[:, 0, :m] if store_rows is None else S[:, 0, sel]
                forces[r] = F[:, 0]
    if not store:
        return S[..., :m], None, None
    if groups is None:
        return S[..., :m], np.ascontiguousarray(rows.transpose(1, 2, 0)), np.ascontiguousarray(forces.T)
    traj = np.ascontiguousarray(rows.reshape(N, R, groups, k_st).transpose(1, 3, 2, 0))
    force = np.ascontiguousarray(forces.reshape(N, R, groups).transpose(1, 2, 0))
    return S[..., :m], traj, force


def solve_mesh_law(delta_lin, h, sigma, dt, law, *, tol=1e-12, max_iter=30):
    """Solve ``delta + sigma F(delta, (2/dt) delta - h) = delta_lin`` per case by Newton.

    ``law(delta, delta_dot) -> (F, dF/d delta, dF/d delta_dot)``. Returns
    ``(delta, F, n_unconverged)``. Once every case's last step is below ``tol`` (relative), ``F`` at the final
    ``delta`` is the last evaluation moved along its tangent by that step (the law is not evaluated again: its
    change over a step of 1e-12 relative is below rounding for any law with a bounded slope). A case Newton does
    not settle (a law whose force jumps with ``delta``: the mesh damping of a dead zone acts only while a pair
    touches, so the residual can jump over zero and Newton cycles between the two sides) is solved by
    :func:`bracketed_root`; the cases whose residual still exceeds ``1e3 tol`` are counted as unconverged.
    """
    delta = delta_lin.copy()
    for _ in range(max_iter):
        F, dFd, dFdd = law(delta, (2.0 / dt) * delta - h)
        r = delta + sigma * F - delta_lin
        slope = dFd + (2.0 / dt) * dFdd
        step = r / (1.0 + sigma * slope)
        delta = delta - step
        if (np.abs(step) <= tol * (np.abs(delta) + 1e-9)).all():
            return delta, F - slope * step, 0
    F, _, _ = law(delta, (2.0 / dt) * delta - h)
    open_ = np.abs(delta + sigma * F - delta_lin) > 1e3 * tol * (np.abs(delta) + 1e-9)
    if open_.any():
        delta, F = bracketed_root(delta, F, open_, delta_lin, h, sigma, dt, law, tol=tol)
    bad = int((np.abs(delta + sigma * F - delta_lin) > 1e3 * tol * (np.abs(delta) + 1e-9)).sum())
    return delta, F, bad


#: bracketed_root: doublings of the search width, and bisections (a bracket of width |delta| shrinks below 1e-12
#: relative in 40)
BRACKET_DOUBLINGS = 60
BISECTIONS = 80


def bracketed_root(delta, F, which, delta_lin, h, sigma, dt, law, *, tol=1e-12):
    """The cases ``which`` of :func:`solve_mesh_law` that Newton did not settle, by bracketing and bisection.

    The residual ``r(delta) = delta + sigma F - delta_lin`` grows with ``delta`` but for jumps of the law (a pair's
    damping switching on as it touches), so a sign change is found by doubling a search width from ``delta``, then
    bisected to ``tol``. Where the residual jumps over zero there is no root, and the step is taken at the jump
    with the force ``(delta_lin - delta) / sigma``, which lies between the law's one-sided limits there (the
    set-valued reading of a discontinuous law); where it is continuous that is its root. Returns ``(delta, F)``
    with the other cases unchanged."""
    delta, F = delta.copy(), F.copy()

    def res(x):
        return x + sigma * law(x, (2.0 / dt) * x - h)[0] - delta_lin

    r0 = res(delta)
    lo, hi = delta.copy(), delta.copy()
    r_lo, r_hi = r0.copy(), r0.copy()
    w = np.maximum(np.abs(delta), 1e-9) * 1e-6
    for _ in range(BRACKET_DOUBLINGS):
        need_lo, need_hi = which & (r_lo > 0), which & (r_hi < 0)
        if not (need_lo.any() or need_hi.any()):
            break
        x = np.where(need_lo, delta - w, lo)
        rx = res(x)
        lo, r_lo = np.where(need_lo, x, lo), np.where(need_lo, rx, r_lo)
        x = np.where(need_hi, delta + w, hi)
        rx = res(x)
        hi, r_hi = np.where(need_hi, x, hi), np.where(need_hi, rx, r_hi)
        w = 2.0 * w
    ok = which & (r_lo <= 0) & (r_hi >= 0) & (sigma > 0)
    for _ in range(BISECTIONS):
        if not ok.any() or (hi - lo <= tol * (np.abs(lo) + 1e-9))[ok].all():
            break
        mid = 0.5 * (lo + hi)
        rm = res(mid)
        up = ok & (rm > 0)
        down = ok & ~up
        hi, lo = np.where(up, mid, hi), np.where(down, mid, lo)
    x = 0.5 * (lo + hi)
    delta = np.where(ok, x, delta)
    F = np.where(ok, (delta_lin - x) / np.where(sigma > 0, sigma, 1.0), F)
    return delta, F


def run_general(batch: Batch, S0: np.ndarray, n_steps: int, chunk: int, inputs, mesh_force):
    """March any mesh law with time-varying inputs, yielding trajectory chunks.

    Parameters
    ----------
    batch : Batch
    S0 : ndarray (C, 3n)
    n_steps, chunk : int
    inputs : callable ``(i0, L, S) -> (G (L, C, 3n), dg (L, C))``
        Forcing of steps i0+1 .. i0+L.
    mesh_force : callable ``(i, S, delta_lin, h) -> (delta, F, n_unconverged)``
        The mesh law solved at step i+1 given the current state (for the
        mesh-position predictor).

    Yields
    ------
    i0, traj (L, C, 3n), force (L, C), n_unconverged
        Time first (the order they are written in).
    """
    m = 3 * batch.n
    S = batch.augment(S0[:, None, :], np.zeros(1))       # constant forcing comes through ``inputs``
    us = batch.u_state
    for i0 in range(0, n_steps, chunk):
        L = min(chunk, n_steps - i0)
        G, dg = inputs(i0, L, S[:, 0])
        traj = np.empty((L, S.shape[0], m))           # time first while stepping: contiguous row writes
        force = np.empty((L, S.shape[0]))
        bad = 0
        for j in range(L):
            Y = batch.product(S)[:, 0]
            _, F, nb = mesh_force(i0 + j, S[:, 0], Y[:, m + 1] + dg[j], Y[:, m + 2])
            bad += nb
            Sn = Y[:, :m + 1]
            Sn += G[j]
            Sn -= F[:, None] * us
            traj[j] = Sn[:, :m]
            force[j] = F
            S = Sn[:, None, :]
        yield i0, traj, force, bad
