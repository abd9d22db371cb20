"""Time-varying mesh stiffness over a revolution, by slices of the face width, with pits.

Method (PHYSICS.md sections 2-3):

- The face width in contact is cut into ``n_slices`` slices; each is a thin
  spur pair whose contact point on the transverse line of action is shifted by
  ``w tan(beta_b)`` at face position ``w`` (slice method; Wan et al. 2014).
  Slices act in parallel, tooth pairs in contact act in parallel.
- The healthy compliance of a tooth pair per unit face width is tabulated ONCE
  as a function of the contact position ``g`` on the line of action (measured
  from T1, the pinion base tangent point): Hertz + bending + shear + axial +
  fillet foundation of both teeth (:mod:`datagen.compliance`). A revolution is
  assembled by indexing that table; only the pitted engagements need more work.
- Mesh position ``x`` counts mesh cycles (pinion angle = 2 pi x / z1). Engagement
  ``m`` (pinion tooth ``m % z1``, wheel tooth ``m % z2``) enters contact at
  ``x = m``; its slice at ``w`` is at ``g = A + (x - m) p_bt - w tan(beta_b)``
  and in contact while ``A <= g <= E``.
- Pits: the slices of the pitted engagements take their stiffness from
  :mod:`datagen.pit_stiffness` (``pit_model="no_contact"``, default: a pitted
  pixel on the contact line carries no load, and the removed material lowers
  the section above it; ``"weak_spring"``: the spur paper's weak spring). The
  record keeps them as overrides of the healthy cycle.
- The fillet-foundation term of each tooth is taken independently per pair
  (no Chen & Shao multi-pair correction); no coupling between slices.

References
----------
Wan, Z., Cao, H., Zi, Y., He, W., He, Z. (2014). An improved time-varying mesh stiffness algorithm and
    dynamic modeling of gear-rotor system with tooth root crack. Eng. Fail. Anal. 42, 157-177.
Chen, Z., Shao, Y. (2011). Dynamic simulation of spur gear with tooth root crack propagating along tooth
    width and crack depth. Eng. Fail. Anal. 18, 2149-2164.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from datagen.compliance import pair_compliance
from datagen.pit_stiffness import PIT_MODELS, normalise_pits, pit_overrides
from datagen.stiffness_limits import (MAX_N_SLICES, MAX_SLICE_STEP_PITCHES, RECORD_FIXED_BYTES,  # noqa: F401
                                      STIFFNESS_BUDGET_BYTES, min_n_slices, record_bytes, require_n_slices,
                                      require_record_fits)
from gearpit.errors import require


@dataclass(frozen=True, eq=False)
class MeshStiffness:
    """Mesh stiffness over ``period_cycles`` mesh cycles (see module docstring).

    Attributes
    ----------
    pair : GearPair
    period_cycles : int
        Length of the periodic record in mesh cycles (z1 = one pinion revolution).
    x_cycles : ndarray (n_pos,)
        Uniform mesh-position grid in [0, period_cycles); pinion angle = 2 pi x / z1.
    k_n_per_m : ndarray (n_pos,)
        Total mesh stiffness along the transverse line of action (N/m).
    k_slots_n_per_m : ndarray (n_pos, n_slots)
        Stiffness of each tooth pair in contact; slot ``s`` holds engagement ``floor(x) - s``.
    engagement : ndarray (n_pos, n_slots) of int
        Engagement index ``m`` (pinion tooth ``m % z1``, wheel tooth ``m % z2``), -1 if no contact.
    """

    pair: object
    period_cycles: int
    positions_per_cycle: int
    n_slices: int
    pit_model: str
    pits: tuple
    x_cycles: np.ndarray
    k_n_per_m: np.ndarray
    k_slots_n_per_m: np.ndarray
    engagement: np.ndarray
    _g_cycle: np.ndarray = field(repr=False)        # (ppc, n_slots, n_slices) contact position, NaN if none
    _k_cycle: np.ndarray = field(repr=False)        # (ppc, n_slots, n_slices) healthy slice stiffness
    _overrides: dict = field(repr=False)            # (m, slot) -> (ppc, n_slices) slice stiffness of pitted pairs
    edges: str = "box"                              # contact edges on the grid: EDGE_MODES

    @property
    def n_slots(self) -> int:
        return self.k_slots_n_per_m.shape[1]

    @property
    def angle_rad(self) -> np.ndarray:
        """Pinion angle of each position (rad)."""
        return 2 * np.pi * self.x_cycles / self.pair.pinion.teeth

    @cached_property
    def mean_n_per_m(self) -> float:
        return float(self.k_n_per_m.mean())

    def at(self, x_cycles) -> np.ndarray:
        """Total stiffness at mesh positions (periodic linear interpolation)."""
        x = np.mod(np.asarray(x_cycles, dtype=float), self.period_cycles) * self.positions_per_cycle
        i0 = np.floor(x).astype(np.int64)
        f = x - i0
        n = self.k_n_per_m.size
        i0 %= n
        return self.k_n_per_m[i0] * (1 - f) + self.k_n_per_m[(i0 + 1) % n] * f

    def contact_positions(self, i_pos: int) -> np.ndarray:
        """Contact position g (m from T1) of every slice of every slot at one position; NaN out of contact."""
        return self._g_cycle[i_pos % self.positions_per_cycle]

    def slice_stiffness(self, i_pos: int) -> np.ndarray:
        """(n_slots, n_slices) stiffness of every slice of every pair in contact at one position (N/m)."""
        c, u = divmod(int(i_pos), self.positions_per_cycle)
        k = self._k_cycle[u].copy()
        for s in range(self.n_slots):
            m = (c - s) % self.period_cycles
            if (m, s) in self._overrides:
                k[s] = self._overrides[(m, s)][u]
        return k

    def weighted(self, f, *, n_cycles: int | None = None, position_free: bool = False) -> np.ndarray:
        """(n_cycles * ppc, n_slots): sum over slices of k_slice * f(g_m, pinion_tooth, wheel_tooth).

        ``f`` is vectorised over arrays of equal shape. With ``f`` a tooth-pair
        deviation along the line of action (m) this is the pair's error force
        at zero deflection (N/m * m = N). ``n_cycles`` (default: the record's
        period) may be any length: engagement ``m = cycle - slot`` keeps its own
        pinion and wheel teeth (``m % z1``, ``m % z2``) while its stiffness repeats
        with the record's period, so a per-wheel-tooth deviation over a wheel
        revolution needs no hunting-period record. ``position_free``: ``f`` does not depend on ``g`` (a whole
        tooth displaced), so it is evaluated once per pair and weighted by the pair's stiffness, as on a spur pair
        (the same sum to rounding; on a helical pair of 100 slices 100 times fewer evaluations).
        """
        P, ppc, S = self.period_cycles, self.positions_per_cycle, self.n_slots
        n_cycles = P if n_cycles is None else int(n_cycles)
        z1, z2 = self.pair.pinion.teeth, self.pair.wheel.teeth
        g = np.nan_to_num(self._g_cycle, nan=self.pair.contact_start_m)          # (ppc, S, n_slices)
        k_cycle, overrides = self._k_cycle, self._overrides
        if self.pair.base_helix_angle_rad == 0.0 or position_free:
            # spur: every slice of a pair sits at the same g, so f is evaluated once and weighted by the pair's k
            g, k_cycle = g[:, :, :1], k_cycle.sum(axis=2, keepdims=True)
            overrides = {key: kk.sum(axis=1, keepdims=True) for key, kk in overrides.items()}
        g_t, k_t = g.transpose(1, 0, 2), k_cycle.transpose(1, 0, 2)                 # (S, ppc, n_slices)
        out = np.empty((n_cycles, ppc, S))
        chunk = max(1, 2_000_000 // g.size)                                         # bound the temporaries
        for c0 in range(0, n_cycles, chunk):
            m = np.arange(c0, min(n_cycles, c0 + chunk))[:, None] - np.arange(S)[None, :]  # engagements
            k = np.broadcast_to(k_t[None], (m.shape[0],) + k_t.shape).copy()
            for (mm, s), kk in overrides.items():
                k[np.nonzero(m[:, s] % P == mm)[0], s] = kk
            shape = k.shape
            vals = f(np.broadcast_to(g_t[None], shape), np.broadcast_to((m % z1)[:, :, None, None], shape),
                     np.broadcast_to((m % z2)[:, :, None, None], shape))
            out[c0:c0 + m.shape[0]] = np.sum(k * vals, axis=3).transpose(0, 2, 1)
        return out.reshape(n_cycles * ppc, S)

    def map_cycle_blocks(self, fn) -> "MeshStiffness":
        """A record with every mesh cycle's slice stiffness replaced by ``fn(block)``.

        ``block`` is the ``(ppc, n_slots, n_slices)`` slice stiffness of one mesh
        cycle (every pair in contact); ``fn`` returns an array of that shape. It
        is applied to the healthy cycle and, separately, to every cycle in which a
        pitted pair is in contact, because a change that depends on the load
        sharing (e.g. a load-dependent contact stiffness) couples all pairs of a
        cycle. Contact positions and engagements are unchanged.
        """
        P, ppc, S = self.period_cycles, self.positions_per_cycle, self.n_slots
        k_cycle = np.asarray(fn(self._k_cycle.copy()), dtype=float)
        if k_cycle.shape != self._k_cycle.shape:
            raise ValueError(f"map_cycle_blocks: fn returned shape {k_cycle.shape}, expected {self._k_cycle.shape}")
        k_slots = np.tile(k_cycle.sum(axis=2), (P, 1))
        overrides = {}
        for c in sorted({(m + s) % P for (m, s) in self._overrides}):
            block = self._k_cycle.copy()
            for s in range(S):
                block[:, s] = self._overrides.get(((c - s) % P, s), block[:, s])
            new = np.asarray(fn(block), dtype=float)
            for s in range(S):
                overrides[((c - s) % P, s)] = new[:, s]
            k_slots[c * ppc:(c + 1) * ppc] = new.sum(axis=2)
        return replace(self, k_n_per_m=k_slots.sum(axis=1), k_slots_n_per_m=k_slots, _k_cycle=k_cycle,
                       _overrides=overrides)

    def slots_at_centre_offset(self, dx_m, dy_m, *, subdivisions: int = 1) -> np.ndarray:
        """Pair stiffnesses at every point of a record whose wheel centre is displaced by ``(dx, dy)`` (m)
        relative to the pinion centre (eccentricity, bearing play), on ``subdivisions`` points per position
        step: :func:`datagen.centre_offset.slots_at_centre_offset` (geometry, sub-grid contact edges, the
        measured effect of the grid)."""
        from datagen.centre_offset import slots_at_centre_offset

        return slots_at_centre_offset(self, dx_m, dy_m, subdivisions=subdivisions)

    @cached_property
    def repeat_cycles(self) -> int:
        """Smallest number of mesh cycles after which the stiffness repeats (1 without pits)."""
        if not self._overrides:
            return 1
        return self.period_cycles

    def summary(self) -> dict:
        """The numbers ``gearpit stiffness --json`` prints."""
        k = self.k_n_per_m
        b_mm = self.pair.contact_face_width_m * 1e3
        return {
            "pair": self.pair.name,
            "period_cycles": self.period_cycles,
            "positions": int(k.size),
            "n_slices": self.n_slices,
            "pit_model": self.pit_model,
            "pitted_teeth": {pm.gear: pm.pitted_teeth for pm in self.pits},
            "mean_n_per_m": float(k.mean()),
            "min_n_per_m": float(k.min()),
            "max_n_per_m": float(k.max()),
            "ripple_peak_to_peak_over_mean": float((k.max() - k.min()) / k.mean()),
            "mean_n_per_mm_um": float(k.mean() / b_mm / 1e6),
            "contact_ratio_transverse": self.pair.contact_ratio_transverse,
            "contact_ratio_overlap": self.pair.contact_ratio_overlap,
        }


def face_slices(pair, n_slices: int):
    """Width ``dw`` of a face-width slice, slice centres ``w`` and their shift along the line of action
    ``w tan(beta_b)`` (helical stagger)."""
    dw = pair.contact_face_width_m / n_slices
    w = (np.arange(n_slices) + 0.5) * dw
    return dw, w, w * math.tan(pair.base_helix_angle_rad)


def slot_positions(pair, u, slots, shift):
    """Nominal contact position ``g`` (m from T1), shape ``(len(u), len(slots), len(shift))``, of the pair in
    each slot at cycle fractions ``u``: ``A + (u + slot) p_bt - shift``."""
    return (pair.contact_start_m + (u[:, None, None] + np.asarray(slots)[None, :, None]) * pair.base_pitch_m
            - shift[None, None, :])


#: contact fractions within this of 0 or 1 are 0 or 1 (a grid cell that only touches a contact edge)
FRACTION_SNAP = 1e-9
#: how a contact edge between two grid positions enters the record (:func:`contact_fraction`)
EDGE_MODES = ("point", "box")


def contact_fraction(pair, positions_per_cycle: int, n_slots: int, shift, edges: str = "box") -> np.ndarray:
    """(ppc, n_slots, n_slices) share of each grid position in which each slice of each slot is in contact,
    ``A <= g <= E``.

    ``edges="point"``: the position is in contact or not (point sampling; each edge moves to the grid position
    after it, a timing error of up to one step that is the same in every cycle). ``"box"``: the share of the
    position's cell ``[x - h/2, x + h/2]`` in contact (the edges box-filtered over one step: the area under the
    linearly interpolated record is the exact contact length, each edge keeps its time to first order; the
    slice's stiffness in a part cell is that at the edge, ``g`` clipped into ``[A, E]``).

    Measured (spur-gds, 50 N m, healthy, periodic path, pinion-bearing acceleration at 12.8 kHz, RMS of the
    difference from 2048 box positions at omega_max dt 0.03): 64 positions per cycle, point / box: 63 / 36 %
    at 600 rpm, 24 / 4.2 % at 1800 rpm, 12 / 1.2 % at 3000 rpm; 256 positions: 13 / 1.7 %, 4.3 / 0.9 %,
    4.2 / 1.8 %. Box edges converge as the square of the step, point edges linearly."""
    require(edges in EDGE_MODES, "stiffness.edges", edges, f"one of: {', '.join(EDGE_MODES)}")
    ppc = positions_per_cycle
    h = pair.base_pitch_m / ppc
    j = np.arange(ppc)[:, None, None] + ppc * np.arange(n_slots)[None, :, None]       # cell centres, steps from A
    shift = np.asarray(shift, float)[None, None, :]
    lo, hi = shift / h, (pair.contact_end_m - pair.contact_start_m + shift) / h
    if edges == "point":        # the edges moved to the cell boundaries around the first and last position inside
        lo, hi = np.ceil(lo - 1e-9) - 0.5, np.floor(hi + 1e-9) + 0.5
    return cell_share(j - lo + 0.5, hi - j + 0.5)


def cell_share(x, y) -> np.ndarray:
    """``clip(x, 0, 1) * clip(y, 0, 1)``: the share of a cell in contact, ``x`` and ``y`` the distances (in
    cells) from the cell's start to the contact's start and from the contact's end to the cell's end, plus one;
    exact while the contact is longer than a cell. Shares within :data:`FRACTION_SNAP` of 0 or 1 are 0 or 1."""
    f = np.clip(x, 0.0, 1.0)
    f *= np.clip(y, 0.0, 1.0)
    f[f < FRACTION_SNAP] = 0.0
    f[f > 1.0 - FRACTION_SNAP] = 1.0
    return f


def default_n_slices(pair) -> int:
    """Slices across the face width of a record without pits: 1 for a spur pair, 100 for a helical one (at least
    :func:`min_n_slices`)."""
    return max(100, min_n_slices(pair)) if pair.is_helical else 1


def mesh_stiffness(pair, *, pits=None, positions_per_cycle: int = 64, n_slices: int | None = None,
                   pit_model: str = "no_contact", edges: str = "box") -> MeshStiffness:
    """Mesh stiffness of ``pair`` over one revolution of the pitted gear(s).

    Parameters
    ----------
    pair : GearPair
    pits : PitMap or sequence of PitMap, optional
        Pit depths on the pinion and/or the wheel. The record covers one pinion
        revolution (z1 cycles) for pinion pits or none, one wheel revolution for
        wheel pits, the hunting period lcm(z1, z2) for both.
    positions_per_cycle : int
        Mesh positions per mesh cycle; at most what fits :data:`STIFFNESS_BUDGET_BYTES`
        (:func:`require_record_fits`).
    n_slices : int, optional
        Slices across the contact face width, at least :func:`min_n_slices` (1 for
        spur gears). Default: the pit maps' face columns (at least that minimum),
        else 1 for spur and 100 for helical gears.
    pit_model : {"no_contact", "weak_spring"}
    edges : {"point", "box"}
        Contact edges between grid positions: point-sampled, or box-filtered over a position step
        (:func:`contact_fraction`, measured there; "box" needs ~4x fewer positions for the same accuracy).

    Returns
    -------
    MeshStiffness

    Examples
    --------
    >>> from datagen.geometry import spur_pair_example
    >>> ms = mesh_stiffness(spur_pair_example())
    >>> 12 < ms.summary()["mean_n_per_mm_um"] < 25
    True
    """
    require(pit_model in PIT_MODELS, "pit_model", pit_model, f"one of: {', '.join(PIT_MODELS)}")
    require(isinstance(positions_per_cycle, int) and 4 <= positions_per_cycle <= 100000, "positions_per_cycle",
            positions_per_cycle, "an integer in [4, 100000]")
    maps = normalise_pits(pair, pits)
    n_slices = resolve_n_slices(pair, maps, n_slices)
    require_n_slices(pair, n_slices)
    require_record_fits(pair, positions_per_cycle, n_slices, {pm.gear: len(pm.pitted_teeth) for pm in maps})
    if pits is None:
        key = (pair, positions_per_cycle, n_slices, pit_model, edges)
        hit = _HEALTHY.get(key)
        if hit is None:
            hit = _frozen(_mesh_stiffness(pair, None, positions_per_cycle, n_slices, pit_model, edges))
            _HEALTHY[key] = hit
            while len(_HEALTHY) > HEALTHY_CACHE:
                _HEALTHY.pop(next(iter(_HEALTHY)))
        return hit
    return _mesh_stiffness(pair, pits, positions_per_cycle, n_slices, pit_model, edges)


#: unpitted records kept (a comparison simulates one pair at many nuisances and effect parameters: the Sobol stage
#: of compare.joint_refit 256 times the same record, 7 ms each on a helical pair)
HEALTHY_CACHE = 8
_HEALTHY: dict = {}


def _frozen(ms: MeshStiffness) -> MeshStiffness:
    """``ms`` with its arrays read-only: a cached record is shared, so a caller writing into it fails loudly."""
    for v in vars(ms).values():
        if isinstance(v, np.ndarray):
            v.flags.writeable = False
    return ms


def resolve_n_slices(pair, maps, n_slices: int | None) -> int | None:
    """``n_slices``, or when None the default: the pit maps' face columns (at least :func:`min_n_slices`), else
    :func:`default_n_slices`."""
    if n_slices is not None:
        return n_slices
    cols = [pm.grid.n_face for pm in maps if pm.pitted_teeth]
    return max(max(cols), min_n_slices(pair)) if cols else default_n_slices(pair)


def _mesh_stiffness(pair, pits, positions_per_cycle, n_slices, pit_model, edges) -> MeshStiffness:
    maps = normalise_pits(pair, pits)
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    gears = {pm.gear for pm in maps if pm.pitted_teeth}
    P = {frozenset(): z1, frozenset({"pinion"}): z1, frozenset({"wheel"}): z2}.get(frozenset(gears), math.lcm(z1, z2))
    pc = pair_compliance(pair)
    A, E_end = pair.contact_start_m, pair.contact_end_m
    dw, w, shift = face_slices(pair, n_slices)
    n_slots = int(math.floor(pair.contact_ratio_total)) + 2
    u = np.arange(positions_per_cycle) / positions_per_cycle
    g = slot_positions(pair, u, np.arange(n_slots), shift)
    frac = contact_fraction(pair, positions_per_cycle, n_slots, shift, edges)
    in_contact = frac > 0
    g = np.where(in_contact, np.clip(g, A, E_end), np.nan)
    k_cycle = np.where(in_contact, frac * dw / pc(np.nan_to_num(g, nan=A)), 0.0)
    overrides = {key: frac[:, key[1]] * k for key, k in pit_overrides(pair, pc, maps, P, g, dw, w, pit_model).items()}
    k_slots = np.tile(k_cycle.sum(axis=2), (P, 1))
    n_pos = P * positions_per_cycle
    cyc = np.arange(n_pos) // positions_per_cycle
    engagement = (cyc[:, None] - np.arange(n_slots)[None, :]) % P
    for (m, s), k in overrides.items():
        c = (m + s) % P
        k_slots[c * positions_per_cycle:(c + 1) * positions_per_cycle, s] = k.sum(axis=1)
    engagement = np.where(np.tile(in_contact.any(axis=2), (P, 1)), engagement, -1)
    return MeshStiffness(pair=pair, period_cycles=P, positions_per_cycle=positions_per_cycle, n_slices=n_slices,
                         pit_model=pit_model, pits=maps, x_cycles=np.arange(n_pos) / positions_per_cycle,
                         k_n_per_m=k_slots.sum(axis=1), k_slots_n_per_m=k_slots, engagement=engagement,
                         _g_cycle=g, _k_cycle=k_cycle, _overrides=overrides, edges=edges)
