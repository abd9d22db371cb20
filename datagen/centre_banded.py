"""The banded point rule of the moving-centre stiffness record (:mod:`datagen.centre_offset`, hook 2c) on a
staggered (helical) pair: a point's slices summed by contact bands instead of one by one.

Along one pair the slices' contact edges rise with their stagger across the face, so at one record point the
slices fall into runs: out of contact, inside (summed from running sums over the slices) and two narrow edge
bands (the full point rule, slice by slice). :func:`banded_pays` says when that does less work than the
slice-by-slice rule; :func:`banded_record` runs it compiled (:mod:`datagen.compiled_centre`), block by block,
:func:`points_banded` by the numpy rule kept here as the tests' reference.
"""
from __future__ import annotations

import numpy as np


def _scale(v, scaled, r0: int = 0, r1: int | None = None) -> None:
    """Scale the pitted samples of ``v`` in place: ``scaled`` holds (sorted rows, column, ratio per slice); with
    ``r0``, ``r1``, ``v`` is the block of rows ``r0 .. r1 - 1``."""
    for rows, c, ratio in scaled:
        lo, hi = (0, rows.size) if r1 is None else np.searchsorted(rows, (r0, r1))
        if hi > lo:
            v[rows[lo:hi] - r0, c] *= ratio[lo:hi]


#: slices from which :func:`datagen.centre_offset.slots_at_centre_offset` may sum a point's slices by contact bands
#: (:func:`points_banded`) instead of one by one (:func:`datagen.centre_offset._points`; see :func:`banded_pays`)
BANDED_MIN_SLICES = 8


def banded_pays(start_edges, n_slices: int) -> bool:
    """Whether summing by contact bands (:func:`points_banded`) does less work than slice by slice: the slices'
    contact starts ``start_edges`` (grid steps) must be staggered, so that an edge band (about 3 steps wide)
    holds few slices: the two bands together at most a quarter of them. A spur pair's slices (a pitted flank
    has one per pixel column) share their edges: a point near an edge has every slice in its band, and the
    banded sum measured 5x slower than the slice-by-slice one there (the benchmark sweep's pitted, eccentric
    spur samples); it keeps the latter, bit for bit."""
    if n_slices < BANDED_MIN_SLICES:
        return False
    e0 = np.asarray(start_edges, float)
    span = float(e0.max() - e0.min()) if e0.size > 1 else 0.0
    if span <= 0.0:
        return False
    stagger = span / (n_slices - 1)
    return 2.0 * (3.0 / stagger + 1.0) <= n_slices / 4.0


#: record points per block of :func:`points_banded` (numpy rule)
_BANDED_BLOCK_POINTS = 8192
#: margin (grid steps) of the band bounds: a slice this close to a bound is summed one by one, by the full rule
_BAND_MARGIN = 1e-9


def points_banded(out, v, edges, d_start, d_end, ppc: int, q: int) -> None:
    """:func:`datagen.centre_offset._points` on every record point, into ``out``, with the slices summed by bands
    (same result to rounding; tested against it). The numpy rule: the tests' reference of the compiled
    :func:`banded_record`.

    Why: on a helical pair the slices (100 across the face) make :func:`datagen.centre_offset._points` the cost of a hook-2c record:
    measured on ``helical-dct`` at 512 positions per cycle, a wheel eccentricity's record over one wheel
    revolution (245760 points x 5 columns x 100 slices) took 3.2 s of the 3.4 s of its periodic simulation, and
    the attribution of a 2 s record spent 32-37 s of its pool's time on that candidate.

    How: along a column the slices' nominal contact edges ``edges`` (grid steps from ``A``) rise with the slice's
    stagger, so at one point the slices of one engagement fall into consecutive runs: out of contact (share 0:
    either edge factor is 0), inside (both edge factors and both cell shares are 1, so the value is the linear
    interpolation ``(1 - t) v_a + t v_b``), and the two edge bands between them. The inside run is summed from
    running sums of ``v`` over the slices (made in place: ``v`` is overwritten); only the edge bands (a few
    slices each) take :func:`datagen.centre_offset._points`' full rule, on values taken back from the running sums.
    The run bounds come from the conditions of that rule solved for the slice's edge (``searchsorted``), with a
    margin of :data:`_BAND_MARGIN` steps: a slice near a bound goes to a band, where the full rule decides."""
    n_grid, n_cols = v.shape[0], v.shape[1] - 1
    e0 = np.asarray(edges[0], float)
    e1 = np.broadcast_to(np.asarray(edges[1], float), e0.shape)
    order = np.argsort(e0, kind="stable")
    if not np.array_equal(order, np.arange(e0.size)):
        e0, e1, v = e0[order], e1[order], v[:, :, order]
    if np.any(np.diff(e1) < 0):      # the contact length is the same on every slice, so e1 follows e0
        raise ValueError("slots_at_centre_offset: contact ends not in the order of the contact starts")
    # the running sums over the slices, in place (``v`` is this call's own array; no second copy of its size):
    # v[..., s] becomes the sum of slices 0..s, and a slice's own value is the difference of two of them
    np.cumsum(v, axis=2, out=v)
    cum = v

    def upto(rows: tuple, k):
        """Sum of slices ``0 .. k - 1`` at ``rows`` (0 for k = 0)."""
        return np.where(k > 0, cum[rows + (np.maximum(k - 1, 0),)], 0.0)
    cols = np.arange(n_cols)
    for r0 in range(0, out.shape[0], _BANDED_BLOCK_POINTS):
        i = np.arange(r0, min(r0 + _BANDED_BLOCK_POINTS, out.shape[0]))
        ia, sub = np.divmod(i, q)
        c0 = ia % ppc
        t = (sub / q)[:, None]
        d_s, d_e = d_start[i][:, None], d_end[i][:, None]
        j = (c0[:, None] + (cols[None, :] - 1) * ppc).astype(float)                  # (points, cols)
        fs, fe = np.floor(t - d_s), np.floor(d_e - t)
        # inside: e0 <= j + 0.5 + min(floor(t - d_s), -d_s) - 1 and e1 >= j + 0.5 + max(-floor(d_e - t), 1 - d_e)
        hi = np.searchsorted(e0, (j - 0.5 + np.minimum(fs, -d_s) - _BAND_MARGIN).ravel(), side="right")
        lo = np.searchsorted(e1, (j + 0.5 + np.maximum(-fe, 1.0 - d_e) + _BAND_MARGIN).ravel(), side="left")
        # out of contact: e0 >= j + 1.5 + floor(t - d_s) (start factor 0) or e1 <= j - 1.5 - floor(d_e - t)
        end = np.searchsorted(e0, (j + 1.5 + fs + _BAND_MARGIN).ravel(), side="left")
        beg = np.searchsorted(e1, (j - 1.5 - fe - _BAND_MARGIN).ravel(), side="right")
        shape = j.shape
        beg, end = beg.reshape(shape), np.maximum(end.reshape(shape), beg.reshape(shape))
        lo = np.clip(lo.reshape(shape), beg, end)
        hi = np.clip(hi.reshape(shape), lo, end)
        ib = (ia + 1) % n_grid
        col_b = cols[None, :] + (c0 == ppc - 1)[:, None]
        ra, rb = (ia[:, None], cols[None, :]), (ib[:, None], col_b)
        inside_a = upto(ra, hi) - upto(ra, lo)
        inside_b = upto(rb, hi) - upto(rb, lo)
        total = (1.0 - t) * inside_a + t * inside_b
        for start, stop in ((beg, lo), (hi, end)):        # the two edge bands, by the full rule
            width = int((stop - start).max(initial=0))
            if width == 0:
                continue
            sl = start[:, :, None] + np.arange(width)[None, None, :]
            valid = sl < stop[:, :, None]
            sl = np.minimum(sl, e0.size - 1)
            v_a = upto((ia[:, None, None], cols[None, :, None]), sl + 1) - upto((ia[:, None, None], cols[None, :, None]), sl)
            v_b = upto((ib[:, None, None], col_b[:, :, None]), sl + 1) - upto((ib[:, None, None], col_b[:, :, None]), sl)
            total += _band_sum(v_a, v_b, e0[sl], e1[sl], valid, j, t, d_s, d_e)
        out[i] = total


#: grid samples per block of :func:`banded_record`
BANDED_BLOCK_ROWS = 2048


def banded_record(out, values, scaled, edges, d_start, d_end, ppc: int, q: int, n_grid: int,
                  block_rows: int = BANDED_BLOCK_ROWS) -> None:
    """:func:`points_banded` compiled (:mod:`datagen.compiled_centre`), block by block of grid samples: the slice
    values of a block (``values(rows)``: (rows, columns + 1, slices), as
    :func:`datagen.centre_offset.slots_at_centre_offset` makes them), its pitted samples scaled (``scaled``, as
    :func:`_scale`), their running sums over the slices and the points of its grid steps, into ``out``. Each
    block takes one grid sample more than its own (the next one, periodically), which its last points read.

    Why blocks: on the far helical rig's whole hunting period (1020 mesh cycles, 512 positions, 100 slices) the
    slice values of the whole record are 2.5 GB, whose fresh pages cost about as much system time as the
    arithmetic; a block of 2048 samples is 10 MB. Equal to :func:`points_banded` to rounding (tested)."""
    from datagen.compiled_centre import cumsum_slices, points_banded as kernel
    from datagen.stiffness import FRACTION_SNAP

    e0 = np.ascontiguousarray(edges[0], dtype=float)
    e1 = np.ascontiguousarray(np.broadcast_to(np.asarray(edges[1], float), e0.shape))
    # the slices' stagger w tan(beta_b) rises across the face (helix angles are >= 0, datagen.geometry), and the
    # contact length is the same on every slice, so both edges are in the slices' order
    if np.any(np.diff(e0) < 0) or np.any(np.diff(e1) < 0):
        raise ValueError("slots_at_centre_offset: slice contact edges not in the order of the slices")
    d_start = np.ascontiguousarray(d_start, dtype=float)
    d_end = np.ascontiguousarray(d_end, dtype=float)
    for r0 in range(0, n_grid, block_rows):
        r1 = min(r0 + block_rows, n_grid)
        rows = np.arange(r0, r1 + 1) % n_grid
        v = values(rows)
        _scale(v[:-1], scaled, r0, r1)
        _scale(v[-1:], scaled, int(rows[-1]), int(rows[-1]) + 1)
        cumsum_slices(v)
        kernel(v, r0, e0, e1, d_start, d_end, ppc, q, FRACTION_SNAP, _BAND_MARGIN, out, r0 * q, r1 * q)


def _band_sum(v_a, v_b, e0, e1, valid, j, t, d_s, d_e):
    """:func:`datagen.centre_offset._points`' rule on gathered slices (points, cols, k) of each point and column: their grid samples
    ``v_a``, ``v_b`` and edges ``e0``, ``e1``; slices not ``valid`` add nothing."""
    from datagen.stiffness import FRACTION_SNAP, cell_share

    x0 = j[:, :, None] - e0 + 0.5
    y0 = e1 - j[:, :, None] + 0.5
    t3, d_s3, d_e3 = t[:, :, None], d_s[:, :, None], d_e[:, :, None]
    share = _lattice_interp(x0, t3 - d_s3) * _lattice_interp(y0, d_e3 - t3)
    share[share < FRACTION_SNAP] = 0.0
    share[share > 1.0 - FRACTION_SNAP] = 1.0
    w_a = (1.0 - t3) * cell_share(x0 - d_s3, y0 + d_e3)
    w_b = t3 * cell_share(x0 + 1.0 - d_s3, y0 - 1.0 + d_e3)
    w = w_a + w_b
    value = np.where(w > 0, (w_a * v_a + w_b * v_b) / np.where(w > 0, w, 1.0), (1.0 - t3) * v_a + t3 * v_b)
    value = np.where(t3 == 0.0, v_a, value)
    return np.where(valid, share * value, 0.0).sum(axis=2)



def _lattice_interp(z0, dz):
    """Linear interpolation of ``clip(z, 0, 1)`` between the lattice points ``z0 + n`` (n integer) around
    ``z0 + dz``."""
    n = np.floor(dz)
    tau = dz - n
    lo = z0 + n
    return (1.0 - tau) * np.clip(lo, 0.0, 1.0) + tau * np.clip(lo + 1.0, 0.0, 1.0)


__all__ = ["BANDED_MIN_SLICES", "banded_pays", "banded_record", "points_banded"]
