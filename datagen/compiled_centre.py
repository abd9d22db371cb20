"""Compiled (numba) kernels of the moving-centre stiffness record (:mod:`datagen.centre_offset`, hook 2c) on a
staggered (helical) pair: the slice stiffness at every grid sample and the banded point rule.

Why: on the far helical rig of :data:`compare.synthetic.OTHER_RIGS` (``helical-dct``, 512 positions per cycle, 100
slices, a wheel eccentricity over a 1020-cycle hunting period) :func:`datagen.centre_offset.slots_at_centre_offset`
was 10.8 s of a case's 11.3 s: 5.0 s in ``np.interp`` of the compliance table (a binary search per element of a
(positions, pairs, slices) array of 2e8 values), 4.1 s in the banded rule's array temporaries, the rest in making
and filling the position and compliance arrays. Here the table, which is uniform, is read by index, nothing of the
record's size is made but the slice stiffnesses themselves, and the rule runs point by point.

:func:`slice_stiffness_into` does the numpy code's IEEE operations in its order (positions as
:func:`datagen.stiffness.slot_positions` plus the displacement, ``np.interp``'s rule, ``dw / compliance``), so the
same bits; :func:`points_banded` sums a band's slices in another order than numpy's reduction, so it equals
:func:`datagen.centre_banded.points_banded` to rounding (tested to 1e-12 of the largest value). The numpy code stays
the reference of the tests (``datagen.centre_offset.COMPILED = False``).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from datagen.compiled_records import point_place, point_rule


@njit(cache=True)
def _interp_uniform(x, g, c, inv_step):
    """``np.interp(x, g, c)`` on an increasing table ``g`` of about uniform step (a ``np.linspace``; ``inv_step``
    the reciprocal of its step), the same bits: the interval guessed from the step, then corrected against the
    table's own values (so the linspace's rounding cannot move it), and numpy's rule in it (a point on a node
    gives that node's value; outside the table, the end values)."""
    n = g.shape[0]
    if x < g[0]:
        return c[0]
    if x >= g[n - 1]:
        return c[n - 1]
    j = int((x - g[0]) * inv_step)
    if j > n - 2:
        j = n - 2
    if j < 0:
        j = 0
    while j > 0 and x < g[j]:
        j -= 1
    while j < n - 2 and x >= g[j + 1]:
        j += 1
    if g[j] == x:
        return c[j]
    slope = (c[j + 1] - c[j]) / (g[j + 1] - g[j])
    return slope * (x - g[j]) + c[j]


@njit(cache=True)
def slice_stiffness_into(ppc, start_m, pitch_m, slots, shift, rows, dg, g_table, c_table, dw, v):
    """Slice stiffness ``dw / compliance(g + dg)`` (N/m) of every slot and slice at the grid samples ``rows``
    (their displacements ``dg``), into ``v`` (len(rows), len(slots) + 1, len(shift)); the last column is a copy
    of the one before (the slot after the last, out of contact). ``g = A + (u + slot) p_bt - shift`` at cycle
    fraction ``u = (r % ppc) / ppc`` of grid sample ``r``, as :func:`datagen.stiffness.slot_positions` computes
    it, plus the sample's displacement."""
    n_slot = slots.shape[0]
    n_sh = shift.shape[0]
    inv_step = (g_table.shape[0] - 1) / (g_table[g_table.shape[0] - 1] - g_table[0])
    for b in range(v.shape[0]):
        u = (rows[b] % ppc) / ppc
        d = dg[b]
        for s in range(n_slot):
            base = start_m + (u + slots[s]) * pitch_m
            for k in range(n_sh):
                x = (base - shift[k]) + d
                v[b, s, k] = dw / _interp_uniform(x, g_table, c_table, inv_step)
        for k in range(n_sh):
            v[b, n_slot, k] = v[b, n_slot - 1, k]


@njit(cache=True)
def cumsum_slices(v):
    """``np.cumsum(v, axis=2, out=v)``: running sums over the last axis, in place, the same order of additions."""
    for r in range(v.shape[0]):
        for c in range(v.shape[1]):
            acc = v[r, c, 0]
            for k in range(1, v.shape[2]):
                acc = acc + v[r, c, k]
                v[r, c, k] = acc


@njit(cache=True)
def _search(a, x, right):
    """``np.searchsorted(a, x, side="right" if right else "left")`` on an increasing ``a``."""
    lo, hi = 0, a.shape[0]
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < x or (right and a[mid] == x):
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _upto(cum, r, c, k):
    """Sum of slices ``0 .. k - 1`` of row ``r``, column ``c`` from the running sums (0 for k = 0)."""
    return cum[r, c, k - 1] if k > 0 else 0.0


@njit(cache=True)
def _band(cum, ia, ib, col, col_b, start, stop, e0, e1, j, t, d_s, d_e, snap):
    """The point rule (:func:`datagen.centre_offset._points`) on slices ``start .. stop - 1``, summed."""
    total = 0.0
    for sl in range(start, stop):
        v_a = _upto(cum, ia, col, sl + 1) - _upto(cum, ia, col, sl)
        v_b = _upto(cum, ib, col_b, sl + 1) - _upto(cum, ib, col_b, sl)
        total += point_rule(v_a, v_b, j - e0[sl] + 0.5, e1[sl] - j + 0.5, t, d_s, d_e, snap)
    return total


@njit(cache=True)
def points_banded(cum, r0, e0, e1, d_start, d_end, ppc, q, snap, margin, out, i0, i1):
    """:func:`datagen.centre_banded.points_banded` point by point, on record points ``i0 .. i1 - 1`` (rows of
    ``out``; ``d_start``, ``d_end`` indexed alike): ``cum`` holds the running sums over the slices (sorted by
    their contact start ``e0``) of grid samples ``r0, r0 + 1, ..``, one more than the points' own (the sample
    after a point's last is the next one, periodically). Per point and column the slices fall into runs (out of
    contact, the lower edge band, inside, the upper edge band) found by binary search with the margin
    ``margin``; the inside run is a difference of running sums, linearly interpolated between the two grid
    samples; the bands take the full rule."""
    n_cols = cum.shape[1] - 1
    for i in range(i0, i1):
        ia, c0, t = point_place(i, q, ppc)
        d_s = d_start[i]
        d_e = d_end[i]
        fs = np.floor(t - d_s)
        fe = np.floor(d_e - t)
        la = ia - r0
        lb = la + 1
        nxt = 1 if c0 == ppc - 1 else 0
        for col in range(n_cols):
            j = float(c0 + (col - 1) * ppc)
            hi = _search(e0, j - 0.5 + min(fs, -d_s) - margin, True)
            lo = _search(e1, j + 0.5 + max(-fe, 1.0 - d_e) + margin, False)
            end = _search(e0, j + 1.5 + fs + margin, False)
            beg = _search(e1, j - 1.5 - fe - margin, True)
            end = max(end, beg)
            lo = min(max(lo, beg), end)
            hi = min(max(hi, lo), end)
            col_b = col + nxt
            inside_a = _upto(cum, la, col, hi) - _upto(cum, la, col, lo)
            inside_b = _upto(cum, lb, col_b, hi) - _upto(cum, lb, col_b, lo)
            total = (1.0 - t) * inside_a + t * inside_b
            if lo > beg:
                total += _band(cum, la, lb, col, col_b, beg, lo, e0, e1, j, t, d_s, d_e, snap)
            if end > hi:
                total += _band(cum, la, lb, col, col_b, hi, end, e0, e1, j, t, d_s, d_e, snap)
            out[i, col] = total
