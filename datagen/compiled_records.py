"""Compiled (numba) kernels of the mesh records, each with the IEEE operations of the numpy code it replaces in
the same order, so the same bits; the numpy code stays as the reference of the tests (``COMPILED`` of the module
that calls them)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _clip01(x):
    """``np.clip(x, 0.0, 1.0)`` for a finite ``x``, signed zeros included (numpy keeps ``x`` where it equals a
    bound)."""
    y = x if x >= 0.0 else 0.0
    return y if y <= 1.0 else 1.0


@njit(cache=True)
def _snap(f, snap):
    if f < snap:
        return 0.0
    if f > 1.0 - snap:
        return 1.0
    return f


@njit(cache=True)
def _lattice_interp_1(z0, dz):
    n = np.floor(dz)
    tau = dz - n
    lo = z0 + n
    return (1.0 - tau) * _clip01(lo) + tau * _clip01(lo + 1.0)


@njit(cache=True)
def point_place(i, q, ppc):
    """Record point ``i`` on ``q`` points per grid step: the grid sample below it, that sample's position in its
    mesh cycle (``ppc`` positions) and the point's fraction of the step past it."""
    ia = i // q
    return ia, ia % ppc, (i - ia * q) / q


@njit(cache=True)
def point_rule(v_a, v_b, x0, y0, t, d_s, d_e, snap):
    """:func:`datagen.centre_offset._points`' rule for one slice of one pair at one record point: its share in
    contact times its value, from the grid samples ``v_a``, ``v_b`` around the point, the nominal distances
    ``x0``, ``y0`` (steps, plus 1/2) from the contact's start to sample a's cell end and from sample a's cell
    start to the contact's end, the point's place ``t`` between the samples and the edges' displacements."""
    share = _snap(_lattice_interp_1(x0, t - d_s) * _lattice_interp_1(y0, d_e - t), snap)
    w_a = (1.0 - t) * _snap(_clip01(x0 - d_s) * _clip01(y0 + d_e), snap)
    w_b = t * _snap(_clip01(x0 + 1.0 - d_s) * _clip01(y0 - 1.0 + d_e), snap)
    w = w_a + w_b
    if t == 0.0:
        value = v_a
    elif w > 0:
        value = (w_a * v_a + w_b * v_b) / w
    else:
        value = (1.0 - t) * v_a + t * v_b
    return share * value


@njit(cache=True)
def points_one_slice(v, e0, e1, d_start, d_end, i0, i1, ppc, q, snap, out):
    """:func:`datagen.centre_offset._points` for ``q > 1`` on a record of one slice (the unstaggered slices summed): rows ``i0 .. i1 - 1``
    of ``out``, the same IEEE operations in the same order, point by point (no temporaries: the numpy rule's
    ~40 array operations on (points, columns, 1) arrays were a sixth of a hook-2c record's generation)."""
    n_grid, n_cols = v.shape[0], v.shape[1] - 1
    for i in range(i0, i1):
        ia, c0, t = point_place(i, q, ppc)
        d_s = d_start[i]
        d_e = d_end[i]
        ib = (ia + 1) % n_grid
        nxt = 1 if c0 == ppc - 1 else 0
        for col in range(n_cols):
            j = float(c0 + (col - 1) * ppc)
            out[i, col] = point_rule(v[ia, col, 0], v[ib, col + nxt, 0], j - e0 + 0.5, e1 - j + 0.5, t, d_s, d_e,
                                     snap)


@njit(cache=True)
def refine_slots_into(x, ppc, q, out):
    """:func:`datagen.centre_offset.refine_slots` of ``x`` (n, S) into ``out`` (n * q, S + 1): each pair linearly
    interpolated between its own grid samples, the same IEEE operations in the same order (``t = j / q``,
    ``a * (1 - t) + b * t``), element by element (the numpy rule's padded, rolled and broadcast temporaries were
    a quarter of a hunting-period record's build)."""
    n, S = x.shape
    for i in range(n):
        i1 = i + 1 if i + 1 < n else 0
        last = (i % ppc) == ppc - 1
        for j in range(q):
            t = j / q
            u = 1.0 - t
            r = i * q + j
            for c in range(S + 1):
                a = x[i, c] if c < S else 0.0
                if last:            # across the cycle boundary pair s moves to slot s + 1
                    if c < S - 1:
                        b = x[i1, c + 1]
                    elif c == S - 1:
                        b = 0.0
                    else:
                        b = x[i1, 0]
                else:
                    b = x[i1, c] if c < S else 0.0
                out[r, c] = a * u + b * t
