"""Mesh stiffness of the pair at moving centres (effect hook 2c: eccentricity, bearing play).

At every mesh position the record holds the rigid pair with its centres displaced there (quasi-static
geometry; an involute pair stays conjugate, the transmission error of the displacement is hook 2b's). The
displacement moves the start of contact and the mesh timing by fractions of a grid step; this module resolves
those moves below the position grid of :func:`datagen.stiffness.mesh_stiffness`.

Grid model. The nominal record is point-sampled on ``ppc`` positions per mesh cycle and read by the dynamics
through linear interpolation, so each contact edge of a slice is a linear ramp one grid step wide. With a
displacement that edge moves by a fraction of a step. On the record's own grid a moved ramp cannot stay one
step wide: its two corners fall between grid points, and linear interpolation spreads it over two steps
(the stiffness steps are smoothed and the high mesh harmonics lost). :func:`slots_at_centre_offset` therefore
writes the record on ``subdivisions`` points per grid step (:data:`SUBDIVISIONS` in
:func:`datagen.mesh_excitation.mesh_record`): the edge is the nominal one-step ramp, moved continuously, and
between edges the slice stiffness is the linear interpolation of the grid samples of the displaced pair. With
no displacement this is the nominal record as the dynamics reads it (equal at the grid points, its linear
interpolation in between); only the corners of a moved ramp are cut, by at most ``1 / subdivisions`` of a step.
:func:`refine_slots` brings a grid-sampled per-pair record (hook 2a's error force) onto the same points.

References
----------
Litvin, F. L., Fuentes, A. (2004). Gear Geometry and Applied Theory, 2nd ed., Cambridge University Press,
    ch. 10 (path of contact ``a_w sin(alpha_w)`` minus the tip-circle segments; contact ratio against centre
    distance).
"""
from __future__ import annotations

import math

import numpy as np

from datagen.centre_banded import _lattice_interp, _scale, banded_pays, banded_record, points_banded
from gearpit.errors import require

#: record points per grid step of the hook-2c records that :func:`datagen.mesh_excitation.mesh_record` builds
#: (a moved ramp's corners are cut by up to 1/(4 q) of its height: the housing RMS change of a 10 um
#: eccentricity is within 0.3 % of its converged value at 8, 0.9 % at 4; see slots_at_centre_offset)
SUBDIVISIONS = 8
#: sum unstaggered slices before the rule (slots_at_centre_offset; False: slice by slice, the tests' reference)
MERGE_UNSTAGGERED = True
#: the slice stiffnesses by :func:`datagen.compiled_centre.slice_stiffness_into` (the same bits), a staggered pair's
#: banded rule by :func:`datagen.compiled_centre.points_banded` (the same to rounding), a one-slice record's points by
#: :func:`datagen.compiled_records.points_one_slice` (the same bits) and :func:`refine_slots` by
#: :func:`datagen.compiled_records.refine_slots_into`; False: the numpy rules (the tests' reference)
COMPILED = True
#: elements (positions x pairs x slices) per block of the vectorised evaluation (bounds the memory)
_BLOCK_ELEMENTS = 1 << 16


def slots_at_centre_offset(stiffness, dx_m, dy_m, *, subdivisions: int = 1, cycles=None) -> np.ndarray:
    """Pair stiffnesses (N/m) of a record whose wheel centre is displaced by ``(dx, dy)`` (m) relative to the
    pinion centre, on ``subdivisions`` points per position step of ``stiffness``.

    Parameters
    ----------
    stiffness : MeshStiffness
        The nominal pair (its grid, slices, pits).
    dx_m, dy_m : array_like
        Displacement at every point of the returned record: ``n * ppc * subdivisions`` values for a record of
        ``n`` mesh cycles (point ``i`` at mesh position ``i / (ppc * subdivisions)``; engagement
        ``m = cycle - slot`` as in :meth:`MeshStiffness.weighted`). Frame: ``x`` from the pinion centre towards
        the wheel centre, ``y`` such that the line of action runs along ``(sin alpha_w, cos alpha_w)`` (from T1
        to T2; T1 at polar angle ``-alpha_w`` on the pinion base circle).
    subdivisions : int
        Record points per position step (module docstring). 1: the grid of ``stiffness`` itself.
    cycles : array_like of int, optional
        The mesh cycle each of the record's ``n`` cycles stands for (default ``0 .. n - 1``): a record of some
        cycles of a longer period (:func:`datagen.mesh_excitation.mesh_record`'s truncated records). Only a pitted
        pair's samples depend on it (which engagement of which tooth is pitted); ``dx``, ``dy`` are given per
        point anyway, and a record's last point is interpolated towards its first as in a periodic one.

    Returns
    -------
    ndarray (n * ppc * subdivisions, n_slots + 1)
        Columns ``0 .. n_slots - 1`` as ``stiffness.k_slots_n_per_m``; the last column holds the pair that
        enters one cycle early (engagement ``cycle + 1``) when the contact starts before its nominal start.

    Notes
    -----
    Geometry at each point (quasi-static, rigid pair at the displaced centres):

    - centre distance ``a' = |(a_w + dx, dy)|``, line of centres turned by ``beta = atan2(dy, a_w + dx)``,
      working pressure angle ``alpha' = arccos((r_b1 + r_b2) / a')``;
    - start of contact from T1 ``A' = a' sin(alpha') - sqrt(r_a2^2 - r_b2^2)`` (``dA ~ da / sin alpha_w``);
      the end ``E = sqrt(r_a1^2 - r_b1^2)`` does not move;
    - T1 moves on the pinion base circle to polar angle ``beta - alpha'``, so at a given pinion angle every
      pinion tooth's contact position moves by ``dg = r_b1 (alpha' - alpha_w - beta)``: the mesh timing
      shifts.

    Along one slice the nominal positions are ``A - shift + j h`` (``j`` an integer, ``h = p_bt / ppc``) and
    the nominal contact runs from ``j_s`` to ``j_e`` (real: ``shift / h`` and ``(E - A + shift) / h``; with
    point edges moved to the cell boundaries around the first and last position inside, as
    :func:`datagen.stiffness.contact_fraction`). Grid position ``j`` holds the share of its cell
    ``[j - 1/2, j + 1/2]`` in contact, ``clip(j + 1/2 - j_s, 0, 1) * clip(j_e - j + 1/2, 0, 1)``. The displaced
    pair's contact runs from ``j_s + d_s`` to ``j_e + d_e``, ``d_s = (A' - A - dg) / h``, ``d_e = -dg / h``;
    at a record point between two grid positions each edge's share factor is the nominal one, linearly
    interpolated between the lattice points around the point moved back by the displacement: each edge is the
    nominal record's edge moved continuously by the displacement (the mean number of pairs in contact changes
    by exactly ``(A - A') / p_bt``). Its slice stiffness in contact is that of the two grid samples around the
    point, weighted by their shares against the displaced edges; a sample's value is the healthy slice
    stiffness at its displaced position ``A - shift + j h + dg`` (``dg`` of that grid sample; the compliance
    table, held at its end values outside the nominal path: the wheel's roll offset and the flank below the
    nominal start are not re-tabulated). A pitted pair's slice stiffness is its healthy one scaled by the
    nominal ratio pitted / healthy at the same grid sample (the pit is taken where it was). With no
    displacement the record is the nominal one at the grid points (bit for bit on a spur pair) and its linear
    interpolation in between.

    Measured with point edges (before box edges were the default) on ``spur-gds`` at 1000 rpm, 50 N m, 64
    positions per cycle, pinion-bearing acceleration over
    three wheel revolutions (time stepping; RMS 477 m/s^2 without eccentricity). A pinion eccentricity of
    10 um / 30 um changes the RMS by -7.2 % / -14.0 % on the grid itself (``subdivisions=1``: each moved ramp
    spread over two steps; energy above 8 f_m -14.5 % / -27 %), by -0.9 % / -1.4 % with 4 points per step,
    -0.3 % / -0.5 % with 8 (:data:`SUBDIVISIONS`), -0.1 % / -0.3 % with 16; on a 256-position grid itself by
    -0.9 % / -1.2 %. Wheel eccentricity alike (8 points: -0.3 % / -0.4 %; grid itself -7.2 % / -13.9 %). The
    nominal RMS depends on the grid (518 m/s^2 at 256 positions: the ramps are one grid step wide), so
    records are compared on one grid; with subdivided steps they are.

    Examples
    --------
    >>> import numpy as np
    >>> from datagen.geometry import spur_pair_example
    >>> from datagen.stiffness import mesh_stiffness
    >>> ms = mesh_stiffness(spur_pair_example())
    >>> k = slots_at_centre_offset(ms, np.zeros(4 * 64), np.zeros(4 * 64), subdivisions=4)
    >>> bool(np.array_equal(k[::4, :-1], ms.k_slots_n_per_m[:64]))
    True
    """
    from datagen.compliance import pair_compliance
    from datagen.stiffness import face_slices, slot_positions

    require(isinstance(subdivisions, int) and not isinstance(subdivisions, bool) and 1 <= subdivisions <= 64,
            "subdivisions", subdivisions, "an integer in [1, 64]")
    pair, ppc, S = stiffness.pair, stiffness.positions_per_cycle, stiffness.n_slots
    q = subdivisions
    dx = np.asarray(dx_m, dtype=float).ravel()
    dy = np.broadcast_to(np.asarray(dy_m, dtype=float).ravel(), dx.shape)
    n_cycles, rem = divmod(dx.size, ppc * q)
    if rem or n_cycles < 1:
        raise ValueError(f"slots_at_centre_offset: {dx.size} values, need a whole number of cycles of {ppc * q}")
    rb1, rb2 = pair.base_radius_m("pinion"), pair.base_radius_m("wheel")
    a_w, alpha_w = pair.centre_distance_m, pair.working_pressure_angle_rad
    a = np.hypot(a_w + dx, dy)
    if np.any(a <= rb1 + rb2):
        raise ValueError("slots_at_centre_offset: centre distance below the sum of the base radii")
    # as differences from the nominal pair, so that no offset gives the nominal record bit for bit
    alpha = alpha_w + (np.arccos((rb1 + rb2) / a) - math.acos((rb1 + rb2) / a_w))
    beta = np.arctan2(dy, a_w + dx)
    start = pair.contact_start_m + (a * np.sin(alpha) - a_w * math.sin(alpha_w))   # A' from T1
    dg = rb1 * (alpha - alpha_w - beta)
    h = pair.base_pitch_m / ppc
    dw, _, shift = face_slices(pair, stiffness.n_slices)
    slots = np.arange(-1, S)                                                        # -1: the early pair
    # slice stiffness in contact at the grid samples (each at its own displacement): (n_grid, S + 1, slices)
    dg_grid = dg[::q]
    # slices at one shift (a spur pair's pixel columns) have the same positions: their compliance is read once
    # (the same values, so the same quotients to the bit); 200 columns of a pitted flank made this a fifth of
    # the record's time
    one = shift.size > 1 and bool(np.all(shift == shift[0]))
    sh = np.ascontiguousarray(shift[:1] if one else shift, dtype=float)
    table = pair_compliance(pair)

    def values(rows):
        """``dw / compliance(positions + dg)`` at grid samples ``rows``: (rows, S + 2, slices), the slot after
        the last appended (out of contact, any finite value: a copy of the last slot)."""
        if COMPILED:        # the same bits, without the position and compliance arrays
            from datagen.compiled_centre import slice_stiffness_into

            v = np.empty((rows.size, slots.size + 1, sh.size))
            slice_stiffness_into(ppc, float(pair.contact_start_m), float(pair.base_pitch_m), slots, sh, rows,
                                 np.ascontiguousarray(dg_grid[rows]), table.g_table_m, table.c_table, float(dw), v)
            return v
        # on 3 record-size arrays instead of 5 (their fresh pages cost about what the arithmetic does)
        pos = slot_positions(pair, (rows % ppc) / ppc, slots, sh)
        pos += dg_grid[rows][:, None, None]
        comp = table(pos)
        del pos
        v = np.empty((comp.shape[0], comp.shape[1] + 1, comp.shape[2]))
        np.divide(dw, comp, out=v[:, :-1])
        del comp
        v[:, -1] = v[:, -2]
        return v
    # pitted pairs: scaled by the nominal pitted / healthy ratio at that sample: (rows, column, ratio per slice)
    scaled = []
    if stiffness._overrides:
        cyc = np.arange(dg_grid.size) // ppc
        if cycles is not None:
            cycles = np.asarray(cycles, dtype=np.int64)
            require(cycles.shape == (n_cycles,), "cycles", cycles.shape, f"one mesh cycle per record cycle ({n_cycles})")
            cyc = cycles[cyc]
        for (m, s), kk in stiffness._overrides.items():
            rows = np.nonzero((cyc - s) % stiffness.period_cycles == m)[0]
            kn = stiffness._k_cycle[rows % ppc, s]          # the nominal record repeats every cycle
            ratio = np.divide(kk[rows % ppc], kn, out=np.ones_like(kn), where=kn > 0)
            scaled += [(rows, c, ratio) for c in ((s + 1, S + 1) if s + 1 == S else (s + 1,))]
    edges = (shift / h, (pair.contact_end_m - pair.contact_start_m + shift) / h)   # in grid steps from A
    if stiffness.edges == "point":      # as datagen.stiffness.contact_fraction: at the cell boundaries
        edges = (np.ceil(edges[0] - 1e-9) - 0.5, np.floor(edges[1] + 1e-9) + 0.5)
    d_start = ((start - pair.contact_start_m) - dg) / h
    d_end = -dg / h
    e0, e1 = (np.broadcast_to(np.asarray(e, float), shift.shape) for e in edges)
    out = np.empty((dx.size, S + 1))
    if q > 1 and COMPILED and banded_pays(edges[0], shift.size):
        # a staggered pair: block by block of grid samples, no array of the record's size but ``out``
        banded_record(out, values, scaled, edges, d_start, d_end, ppc, q, dg_grid.size)
        return np.concatenate([out[:, 1:], out[:, :1]], axis=1)
    v = values(np.arange(dg_grid.size))
    if MERGE_UNSTAGGERED and shift.size > 1 and np.all(e0 == e0[0]) and np.all(e1 == e1[0]):
        # unstaggered slices (a spur pair's pixel columns): every weight of the rule is the same on each slice
        # and the rule is linear in the slice values, so their sum goes through it once (to rounding)
        v = _slice_sums(v, shift.size if one else None, scaled)
        edges, shift = (e0[:1], e1[:1]), shift[:1]
    else:
        if one and v.shape[2] == 1:
            v = np.repeat(v, shift.size, axis=2)
        _scale(v, scaled)
    if q > 1 and banded_pays(edges[0], shift.size):
        points_banded(out, v, edges, d_start, d_end, ppc, q)
    elif q > 1 and v.shape[2] == 1 and COMPILED:
        from datagen.compiled_records import points_one_slice
        from datagen.stiffness import FRACTION_SNAP

        points_one_slice(v, float(np.ravel(edges[0])[0]), float(np.ravel(edges[1])[0]),
                          np.ascontiguousarray(d_start, dtype=float), np.ascontiguousarray(d_end, dtype=float), 0,
                          dx.size, ppc, q, FRACTION_SNAP, out)
    else:
        block = max(1, _BLOCK_ELEMENTS // ((S + 1) * shift.size))
        for r0 in range(0, dx.size, block):
            i = np.arange(r0, min(r0 + block, dx.size))
            out[i] = _points(v, edges, d_start[i], d_end[i], i, ppc, q)
    return np.concatenate([out[:, 1:], out[:, :1]], axis=1)


#: elements (rows x columns x slices) per block of :func:`_slice_sums` (a block stays in the cache)
_SUM_BLOCK_ELEMENTS = 1 << 17


def _slice_sums(v, n_slices, scaled):
    """Sum over the slices of ``v`` (rows, columns, slices) after the pitted rows are scaled (``scaled``: rows,
    column, ratio per slice); ``n_slices``: ``v`` holds one slice that stands for that many equal ones
    (a spur pair's pixel columns), else None.

    The same sums as scaling ``np.repeat(v, n_slices, axis=2)`` and summing it along the slices, bit for bit,
    block by block of rows instead of on one array of them all (a pitted spur flank's 200 columns made that
    copies more than half of a hook-2c record's time)."""
    if n_slices is None:
        _scale(v, scaled)
        return v.sum(axis=2, keepdims=True)
    n_rows, n_cols = v.shape[:2]
    out = np.empty((n_rows, n_cols, 1))
    block = max(1, _SUM_BLOCK_ELEMENTS // (n_cols * n_slices))
    for r0 in range(0, n_rows, block):
        r1 = min(r0 + block, n_rows)
        b = np.repeat(v[r0:r1], n_slices, axis=2)
        _scale(b, scaled, r0, r1)
        out[r0:r1] = b.sum(axis=2, keepdims=True)
    return out


def _points(v, edges, d_start, d_end, i, ppc: int, q: int) -> np.ndarray:
    """Columns (early pair, slots 0 ..) at record points ``i`` from the grid samples ``v`` (see
    :func:`slots_at_centre_offset`): the contact share is the nominal record's share at the point (its grid
    cells' box-filtered shares, linearly interpolated), each edge moved by its own displacement; the value in
    contact is the two grid samples' values, weighted by their shares against the displaced edges. No
    displacement gives the nominal record as the dynamics reads it: its grid samples and their linear
    interpolation; a displacement ``d`` of both edges and a constant value give it read ``d`` steps on."""
    from datagen.stiffness import FRACTION_SNAP, cell_share

    n_grid, n_cols = v.shape[0], v.shape[1] - 1
    ia, sub = np.divmod(i, q)                                   # grid sample below the point, points past it
    c0 = ia % ppc
    cols = np.arange(n_cols)
    j = (c0[:, None] + (cols[None, :] - 1) * ppc)[:, :, None].astype(float)     # grid coordinate of sample a
    # nominal distances (in steps, plus 1/2) from the contact's start to sample a's cell end, and from sample
    # a's cell start to the contact's end: cell_share(x0, y0) is sample a's nominal share
    x0 = j - edges[0] + 0.5
    y0 = edges[1] - j + 0.5
    d_s, d_e = d_start[:, None, None], d_end[:, None, None]
    v_a = v[ia, :n_cols]
    if q == 1:
        return (cell_share(x0 - d_s, y0 + d_e) * v_a).sum(axis=2)
    t = (sub / q)[:, None, None]
    # each edge's share factor, interpolated between the nominal lattice samples around the displaced point
    share = _lattice_interp(x0, t - d_s) * _lattice_interp(y0, d_e - t)
    share[share < FRACTION_SNAP] = 0.0
    share[share > 1.0 - FRACTION_SNAP] = 1.0
    # sample b: the next grid sample of the same engagement (in the next slot across a cycle boundary)
    ib = (ia + 1) % n_grid
    v_b = v[ib[:, None], cols[None, :] + (c0 == ppc - 1)[:, None]]
    w_a = (1.0 - t) * cell_share(x0 - d_s, y0 + d_e)
    w_b = t * cell_share(x0 + 1.0 - d_s, y0 - 1.0 + d_e)
    w = w_a + w_b
    value = np.where(w > 0, (w_a * v_a + w_b * v_b) / np.where(w > 0, w, 1.0), (1.0 - t) * v_a + t * v_b)
    value = np.where(t == 0.0, v_a, value)
    return (share * value).sum(axis=2)


def refine_slots(x: np.ndarray, positions_per_cycle: int, subdivisions: int) -> np.ndarray:
    """A per-pair record on the grid on ``subdivisions`` points per grid step, each pair linearly
    interpolated between its own grid samples.

    Parameters
    ----------
    x : ndarray (n * ppc, S)
        Periodic record of ``n`` cycles, slot ``s`` holding engagement ``cycle - s``.
    positions_per_cycle : int
    subdivisions : int

    Returns
    -------
    ndarray (n * ppc * subdivisions, S + 1)
        In the layout of :func:`slots_at_centre_offset`: across a cycle boundary pair ``s`` moves to slot
        ``s + 1``, and the pair that enters at the boundary is in the last column (its engagement is
        ``cycle + 1``) during the last grid step. The slot sum is the linear interpolation of the record's
        slot sum, as the dynamics reads it.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([[1.0, 0.0], [2.0, 5.0]])      # two cycles of one position, two slots
    >>> refine_slots(x, 1, 2)
    array([[1. , 0. , 0. ],
           [3. , 0. , 1. ],
           [2. , 5. , 0. ],
           [1. , 2.5, 0.5]])
    """
    q, ppc = subdivisions, positions_per_cycle
    n, S = x.shape
    if COMPILED and S >= 1:
        from datagen.compiled_records import refine_slots_into

        out = np.empty((n * q, S + 1))
        refine_slots_into(np.ascontiguousarray(x, dtype=float), ppc, q, out)
        return out
    x = np.pad(x, ((0, 0), (0, 1)))                        # the entering pair: not in contact yet
    nxt = np.roll(x, -1, axis=0)
    last = (np.arange(n) % ppc) == ppc - 1                 # the next sample of slot s is in slot s + 1
    nxt[last] = np.concatenate([nxt[last][:, 1:S], np.zeros((int(last.sum()), 1)), nxt[last][:, :1]], axis=1)
    t = (np.arange(q) / q)[None, :, None]
    return (x[:, None, :] * (1.0 - t) + nxt[:, None, :] * t).reshape(n * q, S + 1)


__all__ = ["SUBDIVISIONS", "refine_slots", "slots_at_centre_offset"]
