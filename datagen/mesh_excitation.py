"""The periodic mesh record a simulation reads: stiffness, error force and per-pair data.

From a :class:`datagen.stiffness.MeshStiffness` and the case's effects
(hook 1 modifies the stiffness, hooks 2a/2b give deviations, hook 2c moving
centres: :func:`datagen.centre_offset.slots_at_centre_offset`), build one record
over ``period_cycles`` mesh cycles (the least common multiple of the stiffness
period and of every effect's ``deviation_period_cycles``, then reduced to the
smallest period the samples actually have: 1 cycle for a healthy pair), on the
stiffness's position grid, or with hook 2c on :data:`datagen.centre_offset.SUBDIVISIONS`
points per grid step (the nominal record's linear interpolation when nothing moves):

- ``k`` (N/m): total mesh stiffness;
- ``error_force`` E (N) = sum over slices of ``k_slice * e``, so the linear mesh
  force is ``k delta - E``;
- ``k_slots`` (N/m) and ``e_slots`` (m): each tooth pair's stiffness and its
  stiffness-weighted mean deviation, for per-pair nonlinear laws (contact loss).

:class:`MeshRecords` concatenates the records of a batch of cases and looks
them up at arbitrary mesh positions, vectorised over the cases.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from datagen.centre_offset import SUBDIVISIONS, refine_slots, slots_at_centre_offset


@dataclass(frozen=True, eq=False)
class MeshRecord:
    """One case's periodic mesh record on a uniform mesh-position grid (module docstring)."""

    period_cycles: int
    positions_per_cycle: int
    k: np.ndarray
    error_force: np.ndarray
    k_slots: np.ndarray
    e_slots: np.ndarray
    edges: str = "point"            # the stiffness record's contact edges (datagen.stiffness.contact_fraction)
    subdivisions: int = 1           # record points per stiffness-record position (hook 2c refines by SUBDIVISIONS)
    #: a truncated record (:func:`mesh_record`, ``cycles_needed``): the mesh positions (cycles, lo, hi) it holds
    #: exactly, read as a periodic one; None: the whole period
    valid_cycles: tuple | None = None
    #: a truncated record's mean stiffness (N/m) and error force (N) (:func:`mesh_record`); None: the arrays' means
    mean_k: float | None = None
    mean_error_force: float | None = None

    @property
    def mean_k_n_per_m(self) -> float:
        """Mean mesh stiffness over the period (N/m): the lumped model's mean stiffness."""
        return float(np.mean(self.k)) if self.mean_k is None else self.mean_k

    @property
    def mean_error_force_n(self) -> float:
        """Mean error force (N): the static state's."""
        return float(np.mean(self.error_force)) if self.mean_error_force is None else self.mean_error_force

    @property
    def n_pos(self) -> int:
        return self.k.size

    @property
    def has_error(self) -> bool:
        return bool(np.any(self.error_force != 0))

    @property
    def stored_cycles(self) -> int:
        """Mesh cycles the arrays hold: ``period_cycles``, or fewer for a truncated record."""
        return self.n_pos // self.positions_per_cycle

    def distinct_cycles(self) -> int:
        """Number of different mesh cycles in the record (1 for a healthy pair; P when every cycle differs)."""
        if getattr(self, "valid_cycles", None) is not None:
            raise ValueError("distinct_cycles: a truncated record does not hold its whole period")
        P, ppc = self.period_cycles, self.positions_per_cycle
        k = self.k.reshape(P, ppc) / np.abs(self.k).max()
        e = self.error_force.reshape(P, ppc) / max(np.abs(self.error_force).max(), 1e-300)
        rows = np.round(np.hstack([k, e]), 10) + 0.0        # + 0.0: -0.0 becomes 0.0, as np.unique compares them
        # a set of the rows' bytes: np.unique(axis=0) sorts them as structured records, 40 ms a record of 29 cycles
        return len({r.tobytes() for r in rows})

    def at(self, x_cycles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and error force at mesh positions (periodic linear interpolation)."""
        i0, f = _grid_index(np.asarray(x_cycles, float), self.positions_per_cycle, self.n_pos)
        i1 = (i0 + 1) % self.n_pos
        return (self.k[i0] * (1 - f) + self.k[i1] * f, self.error_force[i0] * (1 - f) + self.error_force[i1] * f)


def _cumulative(values: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Per record (consecutive blocks of ``n`` rows of ``values``): the integral of its linear interpolant (periodic)
    from position 0 to each position 0 .. n, in positions; blocks of n + 1 rows, concatenated."""
    out, start = [], 0
    for nj in n:
        v = values[start:start + nj]
        c = np.zeros((nj + 1,) + v.shape[1:])
        c[1:] = np.cumsum(0.5 * (v + np.roll(v, -1, axis=0)), axis=0)
        out.append(c)
        start += nj
    return np.concatenate(out)


def _window_mean(values, cum, recs, lo, q_lo, f_lo, hi, q_hi, f_hi, width, *, slots: bool = False):
    """Mean of the interpolated record ``values`` (rows of :class:`MeshRecords`) between two positions given as
    (index, whole periods, fraction) each, over ``width`` positions (:meth:`MeshRecords.window_all_at`)."""
    def integral(i, q, f):
        a = i + recs.offset
        b = np.where(i + 1 == recs.n, 0, i + 1) + recs.offset
        c0 = i + recs.cum_offset
        tot = recs.n + recs.cum_offset
        if slots:
            q, f = q[:, None], f[:, None]
        return q * cum[tot] + cum[c0] + values[a] * f + (values[b] - values[a]) * (0.5 * f * f)
    w = np.where(width > 0, width, 1.0)
    if slots:
        w = w[:, None]
    return (integral(hi, q_hi, f_hi) - integral(lo, q_lo, f_lo)) / w


def _grid_index(x, ppc, n):
    p = np.mod(x * ppc, n)
    i0 = np.floor(p).astype(np.int64)
    f = p - i0
    return i0 % n, f


def mesh_record(stiffness, effects, ctx, *, keep_slots: bool = True, cycles_needed: int | None = None) -> MeshRecord:
    """Apply hooks 1 and 2 of ``effects`` to ``stiffness`` and build the periodic record.

    ``keep_slots=False``: the per-pair ``k_slots`` and ``e_slots`` are not kept (zero columns), for a case whose
    mesh law is linear and reads only ``k`` and ``error_force`` (:func:`datagen.simulate.prepare`); ``k`` and
    ``error_force`` are the same to the bit. Why: they are four fifths of a record's memory, and with errors on
    both gears a record spans the hunting period (spur-gds, 2900 mesh cycles: 0.48 GB with them, 0.1 GB without,
    at 2048 points per cycle).

    ``cycles_needed``: a time-stepped case reads the record only from its start position over the cycles it
    rolls through (:func:`datagen.simulate.prepare` passes them). When the record has moving centres (hook 2c,
    the costly part) and its period exceeds them by more than :data:`TRUNCATE_MARGIN_CYCLES`, the record holds
    only those cycles (and one more) and the :data:`TRUNCATE_BEHIND_CYCLES` before cycle 0 (at its end, where a
    periodic lookup of a slightly negative position reads them), each the same as in the whole record;
    ``valid_cycles`` says which positions it holds exactly
    (:func:`datagen.time_stepping.transient_response` checks that the run stayed in them). The period is not
    reduced (:func:`minimal_period`): a truncated record is not periodic. Its mean stiffness (the lumped model's)
    is the whole record's: the stiffness repeats after the stiffness's and the centres' periods (a wheel
    revolution), and the mean is taken over whole ones of them; the mean error force (the static start) over
    the same cycles, an estimate (the deviations' hunting period is not held), whose error decays with the
    start-up. Why: with errors on both gears a record
    spans the hunting period, and one with a moving centre (hook 2c) costs a case most of its time: measured on
    the helical rig of ``experiments/generalisation_check.py`` (17/60 teeth, 1500 rpm, a grade-7 pitch error in
    the model, a wheel eccentricity fitted on a 0.5 s window: 1020 cycles), 12 s of a case's 12.4 s.
    """
    # an effect that rebuilds the stiffness from the pair and its pits (a tooth pit) first, then those that
    # correct it (the Hertz term), so that no correction is lost; otherwise in the case's order
    hook1 = [e for e in effects if "mesh_stiffness" in e.hooks()]
    for e in sorted(hook1, key=lambda e: not getattr(e, "rebuilds_stiffness", False)):
        stiffness = e.mesh_stiffness(stiffness, ctx)
    pair = stiffness.pair
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    ppc = stiffness.positions_per_cycle
    P0 = stiffness.repeat_cycles  # 1 for a healthy pair: a wheel-tooth error then needs z2 cycles, not lcm(z1, z2)
    tooth_fx = [e for e in effects if "tooth_deviation_m" in e.hooks()]
    angle_fx = [e for e in effects if "angle_deviation_m" in e.hooks()]
    centre_fx = [e for e in effects if "centre_offset_m" in e.hooks()]
    P = P0
    for e in tooth_fx + angle_fx + centre_fx:
        P = math.lcm(P, int(e.deviation_period_cycles(ctx)))
    # the cycles the record holds: all P, or (truncated) 0 .. ahead - 1 and the last TRUNCATE_BEHIND_CYCLES ones
    cycles, valid = np.arange(P), None
    if (centre_fx and cycles_needed is not None
            and int(cycles_needed) + 1 + TRUNCATE_BEHIND_CYCLES + TRUNCATE_MARGIN_CYCLES < P):
        # one cycle more than needed: a record point interpolates towards the next grid sample, and the last
        # cycle's next one (a cycle behind 0) is not its own
        ahead = int(cycles_needed)
        cycles = np.concatenate([np.arange(ahead + 1), np.arange(P - TRUNCATE_BEHIND_CYCLES, P)])
        valid = (-float(TRUNCATE_BEHIND_CYCLES), float(ahead))
    n_cyc = cycles.size
    # hook 2c: the record on SUBDIVISIONS points per grid step, so that sub-step moves of the contact edges keep
    # the nominal edge ramps (datagen.centre_offset)
    q = SUBDIVISIONS if centre_fx else 1
    x = (cycles[:, None] + np.arange(ppc * q)[None, :] / (ppc * q)).ravel()
    th1, th2 = 2 * np.pi * x / z1, 2 * np.pi * x / z2
    if centre_fx:   # the pair at the moving centres (one more slot: an early entry)
        offs = [np.broadcast_to(np.asarray(e.centre_offset_m(th1, th2, ctx), float), (2,) + x.shape) for e in centre_fx]
        k_slots = _slots_at_centre_offset_reused(stiffness, sum(o[0] for o in offs), sum(o[1] for o in offs), q,
                                                 None if valid is None else cycles)
    else:
        k_slots = np.tile(stiffness.k_slots_n_per_m[:P0 * ppc], (P // P0, 1))   # whole: truncated only with centres
    if tooth_fx:
        def f(g, pt, wt):
            return sum(e.tooth_deviation_m(g, pt, wt, ctx) for e in tooth_fx)

        e_force_slots = stiffness.weighted(f, n_cycles=P, position_free=all(e.tooth_deviation_position_free
                                                                             for e in tooth_fx))
        if valid is not None:
            e_force_slots = e_force_slots.reshape(P, ppc, -1)[cycles].reshape(n_cyc * ppc, -1)
        if centre_fx:   # the deviations of the nominal contact positions; the early pair has none before its start
            e_force_slots = refine_slots(e_force_slots, ppc, q)
    else:
        e_force_slots = np.zeros_like(k_slots)
    if angle_fx:
        e_ang = sum(np.asarray(e.angle_deviation_m(th1, th2, ctx), float) for e in angle_fx)
        e_force_slots = e_force_slots + k_slots * e_ang[:, None]
    k, E = k_slots.sum(axis=1), e_force_slots.sum(axis=1)
    P_min = minimal_period(P, ppc * q, k, E) if valid is None else P
    n = (P_min if valid is None else n_cyc) * ppc * q
    means = {}
    if valid is not None:
        # the stiffness repeats after the stiffness's and the moving centres' periods (the deviations move E only):
        # its mean over whole such periods is the record's; E's over the whole periods held, an estimate
        P_k = P0
        for e in centre_fx:
            P_k = math.lcm(P_k, int(e.deviation_period_cycles(ctx)))
        n_mean = (int(valid[1]) // P_k) * P_k or int(valid[1])
        means = {"mean_k": float(np.mean(k[:n_mean * ppc * q])), "mean_error_force": float(np.mean(E[:n_mean * ppc * q]))}
    if keep_slots:
        with np.errstate(invalid="ignore", divide="ignore"):
            e_slots = np.where(k_slots[:n] > 0, e_force_slots[:n] / k_slots[:n], 0.0)
    else:
        k_slots = e_slots = np.zeros((k.size, 0))
    return MeshRecord(period_cycles=P_min, positions_per_cycle=ppc * q, k=k[:n], error_force=E[:n], k_slots=k_slots[:n],
                      e_slots=e_slots[:n], edges=stiffness.edges, subdivisions=q, valid_cycles=valid, **means)


#: a truncated record (:func:`mesh_record`) holds this many cycles before cycle 0 (a time-stepped case starts at
#: its static wind-up, a fraction of a cycle either side of 0, and its dynamic angle moves by far less than a cycle)
TRUNCATE_BEHIND_CYCLES = 2
#: ... and is made only when the period exceeds the cycles it holds by at least this many (else the whole one)
TRUNCATE_MARGIN_CYCLES = 8


#: the last record of :func:`slots_at_centre_offset` made by :func:`mesh_record`: (stiffness, q, dx, dy, k_slots, cycles)
_LAST_SLOTS: list = []


def _slots_at_centre_offset_reused(stiffness, dx, dy, q: int, cycles=None) -> np.ndarray:
    """:func:`slots_at_centre_offset`, reusing the previous call's result when the stiffness record is the same
    object and the displacements the same values.

    Why: a comparison's fit of an effect that does not move the centres (a pitch error, say) on a model with an
    eccentricity simulates a batch of cases whose pair (the cached healthy record) and centre displacements are
    the same; with errors on both gears each of them spans the hunting period (spur-gds: 2900 mesh cycles), and
    this call was 1.7 s of a case's 4.8 s. The kept record is read-only and holds its stiffness record, so an
    ``id`` is never reused while it is kept; one record is kept (0.14 GB at the hunting period, its displacements
    0.09 GB: comparing them costs less than hashing them).
    """
    dx = np.asarray(dx, dtype=float)
    dy = np.broadcast_to(np.asarray(dy, dtype=float), dx.shape)
    cyc = None if cycles is None else np.asarray(cycles, dtype=np.int64)
    if (_LAST_SLOTS and _LAST_SLOTS[0] is stiffness and _LAST_SLOTS[1] == q and np.array_equal(_LAST_SLOTS[2], dx)
            and np.array_equal(_LAST_SLOTS[3], dy)
            and (cyc is None) == (_LAST_SLOTS[5] is None) and (cyc is None or np.array_equal(cyc, _LAST_SLOTS[5]))):
        return _LAST_SLOTS[4]
    _LAST_SLOTS.clear()
    k_slots = slots_at_centre_offset(stiffness, dx, dy, subdivisions=q, cycles=cyc)
    k_slots.flags.writeable = False
    _LAST_SLOTS.extend((stiffness, q, dx, dy, k_slots, cyc))
    return k_slots


def minimal_period(P: int, ppc: int, *arrays: np.ndarray, rtol: float = 1e-12) -> int:
    """Smallest divisor ``d`` of ``P`` such that every array (P * ppc samples) repeats after ``d`` cycles.

    A healthy pair's record repeats every mesh cycle: its steady state then needs
    one mesh period, not one revolution. A divisor is first tried on the second period against the first
    (most divisors of a hunting period fail there), then on the whole array: the same answer as the whole test
    alone, which was a fifth of a hunting-period record's build. ``P`` itself needs no test.
    """
    tols = [rtol * max(float(np.abs(a).max()), 1e-300) for a in arrays]
    for d in range(1, P + 1):
        if P % d:
            continue
        if d == P:
            return P
        n = d * ppc
        if not all(np.allclose(a[n:2 * n], a[:n], rtol=rtol, atol=t) for a, t in zip(arrays, tols)):
            continue
        if all(np.allclose(a.reshape(P // d, n), a[None, :n], rtol=rtol, atol=t) for a, t in zip(arrays, tols)):
            return d
    return P


class MeshRecords:
    """The records of a batch of cases, concatenated for vectorised lookup."""

    def __init__(self, records: list[MeshRecord]):
        self.records = records
        self.n = np.array([r.n_pos for r in records], dtype=np.int64)
        self.ppc = np.array([r.positions_per_cycle for r in records], dtype=float)
        self.offset = np.concatenate([[0], np.cumsum(self.n)[:-1]]).astype(np.int64)
        self.k = np.concatenate([r.k for r in records])
        self.error_force = np.concatenate([r.error_force for r in records])
        n_slots = max(r.k_slots.shape[1] for r in records)
        pad = [np.pad(r.k_slots, ((0, 0), (0, n_slots - r.k_slots.shape[1]))) for r in records]
        self.k_slots = np.concatenate(pad)
        # each pair's error force k_s e_s (N), not its deviation e_s: between two record points a pair's deviation
        # is read as its interpolated error force over its interpolated stiffness (:meth:`all_at`). Interpolating
        # e_s itself breaks at a contact edge, where the record holds k_s = 0 and e_s = 0 at one point: a pair
        # entering contact was read at a fraction of its deviation (of a 47 um eccentricity's, say, separating it
        # by tens of um), and a nonlinear law did not reduce to the linear one while every pair touched
        pad = [np.pad(r.k_slots * r.e_slots, ((0, 0), (0, n_slots - r.e_slots.shape[1]))) for r in records]
        self.ef_slots = np.concatenate(pad)
        self.has_error = any(r.has_error for r in records)
        # the integrals of the interpolated record from position 0 (:meth:`window_all_at`): record j's block starts
        # at row offset[j] + j and holds n_j + 1 values, the last the integral over its whole period
        self.cum_offset = self.offset + np.arange(len(records), dtype=np.int64)
        self.k_cum = _cumulative(self.k, self.n)
        self.error_force_cum = _cumulative(self.error_force, self.n)
        self.k_slots_cum = _cumulative(self.k_slots, self.n)
        self.ef_slots_cum = _cumulative(self.ef_slots, self.n)
        # for the per-step lookup (:meth:`_index`): the period as a float, the last index, the wrap-around step
        self._n_float = self.n.astype(float)
        self._last = self.n - 1
        self._zeros = np.zeros(len(records))
        self._zeros.flags.writeable = False

    def _index(self, x_cycles):
        p = np.mod(x_cycles * self.ppc, self._n_float)     # in [0, n): truncation is the floor
        i0 = p.astype(np.int64)
        f = p - i0
        i0 = np.minimum(i0, self._last)
        i1 = i0 + 1
        i1[i1 == self.n] = 0
        i0 += self.offset
        i1 += self.offset
        return i0, i1, f

    def at(self, x_cycles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and error force per case at positions ``x_cycles`` (shape (..., C)); the error force of a
        batch without errors is a shared read-only zero array."""
        a, b, f = self._index(x_cycles)
        g = 1 - f
        k = self.k[a] * g + self.k[b] * f
        if not self.has_error:
            return k, (self._zeros if k.shape == self._zeros.shape else np.zeros_like(k))
        return k, self.error_force[a] * g + self.error_force[b] * f

    def all_at(self, x_cycles: np.ndarray) -> tuple:
        """:meth:`at` and :meth:`slots_at` at positions ``x_cycles`` (C,), sharing one interpolation index."""
        a, b, f = self._index(x_cycles)
        g = 1 - f
        k = self.k[a] * g + self.k[b] * f
        e = self.error_force[a] * g + self.error_force[b] * f if self.has_error else np.zeros_like(k)
        return (k, e) + self._slots(a, b, f)

    def window_all_at(self, x_cycles: np.ndarray, w_cycles: np.ndarray) -> tuple:
        """:meth:`all_at` averaged over the window ``x_cycles +/- w_cycles / 2`` (C,) of the interpolated record:
        what a time step of ``w_cycles`` sees of it (:func:`datagen.time_stepping.transient_response`).

        A step that reads the record at one point samples the record's content at the position rate and its
        multiples at the step rate; where the two rates are not commensurate (the time-stepped path: the step is
        ``1 / (R fs)``, the positions follow the speed), harmonics of the position rate close to a multiple of the
        step rate fold into the band as lines no physical order explains (on helical-dct at 2 N m, ``omega_max dt``
        0.15: lines at mesh harmonics + 5 x fr, 84 dB above the fine step's). The average over the step is the
        step's own box filter: zero at every multiple of the step rate, so what folds close to 0 Hz is cut
        (experiments/step_convergence.py)."""
        k, e = self.window_at(x_cycles, w_cycles)
        a, b, f = self._index(x_cycles)
        lo, q, flo, hi, qh, fhi, width = self._window(x_cycles, w_cycles)
        point = width <= 0
        args = (lo, q, flo, hi, qh, fhi, width)
        ks = _window_mean(self.k_slots, self.k_slots_cum, self, *args, slots=True)
        efs = _window_mean(self.ef_slots, self.ef_slots_cum, self, *args, slots=True)
        if point.any():
            ks_p, es_p = self._slots(a, b, f)
            ks[point] = ks_p[point]
            efs[point] = (ks_p * es_p)[point]
        es = np.divide(efs, ks, out=np.zeros_like(efs), where=ks > 0)
        return k, e, ks, es

    def window_at(self, x_cycles: np.ndarray, w_cycles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and error force of :meth:`window_all_at` (the linear law)."""
        a, b, f = self._index(x_cycles)
        lo, q, flo, hi, qh, fhi, width = self._window(x_cycles, w_cycles)
        point = width <= 0
        args = (lo, q, flo, hi, qh, fhi, width)
        k = np.where(point, self.k[a] * (1 - f) + self.k[b] * f, _window_mean(self.k, self.k_cum, self, *args))
        if not self.has_error:
            return k, np.zeros_like(k)
        e = np.where(point, self.error_force[a] * (1 - f) + self.error_force[b] * f,
                     _window_mean(self.error_force, self.error_force_cum, self, *args))
        return k, e

    def _window(self, x_cycles, w_cycles):
        """The window's ends in record positions: the lower end in [0, n) (index, fraction), the upper end as the
        lower plus the width (index, fraction, whole periods past the lower end's), and the width."""
        width = np.maximum(np.asarray(w_cycles, float) * self.ppc, 0.0)
        p_lo = np.mod(x_cycles * self.ppc - 0.5 * width, self._n_float)
        p_hi = p_lo + width
        q_hi = np.floor(p_hi / self._n_float)
        r_hi = p_hi - q_hi * self._n_float
        lo = np.minimum(p_lo.astype(np.int64), self._last)
        hi = np.minimum(r_hi.astype(np.int64), self._last)
        return lo, np.zeros_like(q_hi), p_lo - lo, hi, q_hi, r_hi - hi, width

    def slots_at(self, x_cycles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-pair stiffness and deviation (C, S) at positions ``x_cycles`` (C,): the stiffness interpolated, the
        deviation as the interpolated error force over it (0 where the pair is out of contact). So
        ``sum(k_s * (delta - e_s))`` is the linear law's ``k delta - E`` at every position."""
        return self._slots(*self._index(x_cycles))

    def _slots(self, a, b, f):
        f = f[:, None]
        g = 1 - f
        ks = self.k_slots[a] * g + self.k_slots[b] * f
        efs = self.ef_slots[a] * g + self.ef_slots[b] * f
        es = np.divide(efs, ks, out=np.zeros_like(efs), where=ks > 0)
        return ks, es
