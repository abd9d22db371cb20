"""Dynamic response of a batch of cases: periodic steady state by shooting, or time stepping.

This module chooses the path per case and batches cases; the paths live in
:mod:`datagen.shooting` and :mod:`datagen.time_stepping`, the channels in
:mod:`datagen.output_channels`.

Two solution paths, both on the batched Newmark integrator of
:mod:`datagen.newmark` and ending in the same anti-alias filter
(:mod:`datagen.decimation`):

- **periodic** (:mod:`datagen.shooting`; constant speed and load, linear mesh
  law): the steady state repeats after the record period ``T = P / f_m``
  (``P`` = 1 mesh cycle for a healthy pair, one pinion revolution for pinion
  pits, ...); found by shooting, no start-up transient at all;
- **transient** (:mod:`datagen.time_stepping`; any nonlinear mesh law,
  speed/torque modulation or extra forces): starts from the static equilibrium
  under load and discards ``transient_s`` (default ``ln(1000)`` slowest modal
  decay times of the mean system, rounded up to whole record periods: the
  start-up transient decays by 60 dB; 0.48 s for ``spur-gds`` with the default
  drive train), then keeps ``duration_s``.

``auto`` picks the periodic path whenever it is allowed and its estimated cost
(one pass over ``T`` plus ``2n + 1``-column runs over the distinct mesh cycles)
is lower than the transient path's (``transient_s + duration_s``). Cases are
batched when they share the DOF count and the step grid (periodic: record
period and steps per mesh cycle, merged within 15 %; transient: decimation
factor, output length and discard length); different pairs, speeds and loads
can share a batch.

References
----------
../shared/DESIGN.md, "Speed" (rank-one mesh term, shooting instead of long transients).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from datagen.mesh_excitation import MeshRecord

METHODS = ("auto", "periodic", "transient")
#: where the mesh is read: the pinion's actual angle or its nominal rotation (datagen.simulate.SolverOptions)
MESH_ANGLES = ("dynamic", "nominal")
#: what bounds the time step: omega_max dt and the mesh record's positions, or omega_max dt alone (DynamicCase.dt_max)
STEP_LIMITS = ("position", "omega_dt")
#: decay of the start-up transient before the kept record starts
TRANSIENT_DECAY = math.log(1000.0)
#: time steps per chunk in the transient path
CHUNK = 4096
#: mesh-record positions one time step may span at most (DynamicCase.dt_max). 2 would keep the step of the
#: comparisons' 20 kHz records at 1000 rpm (512 positions, 385 steps per cycle) where omega_max dt puts it, but
#: leaves the 4th mesh harmonic of tests/test_dynamics.py's Radau case 8 % off (1 % with 1)
POSITIONS_PER_STEP = 1
#: memory for stored periodic trajectories per batch (bytes); larger groups are split
MEMORY_BUDGET_BYTES = 256e6


@dataclass(frozen=True, eq=False)
class DynamicCase:
    """What the solver needs of one case (built by :func:`datagen.simulate.simulate`)."""

    model: object                 # LumpedModel
    record: MeshRecord
    effects: tuple
    ctx: object                   # EffectContext
    speed_rpm: float
    torque_nm: float
    fs_hz: float
    duration_s: float
    omega_dt: float = 0.3
    method: str = "auto"
    transient_s: float | None = None
    mesh_angle: str = "dynamic"
    step_limit: str = "position"
    #: the solver's channels this case's output needs (:func:`datagen.simulate.solver_channels`); None: all
    channels: frozenset | None = None

    @property
    def n_out(self) -> int:
        return int(round(self.duration_s * self.fs_hz))

    @property
    def mesh_hz(self) -> float:
        return self.model.pair.mesh_frequency_hz(self.speed_rpm)

    @property
    def period_s(self) -> float:
        return self.record.period_cycles / self.mesh_hz

    @property
    def needs_transient(self) -> bool:
        return any(e.is_nonlinear or e.is_nonstationary for e in self.effects)

    @property
    def dt_max(self) -> float:
        """Largest time step: ``omega_max dt <= omega_dt`` on the mean system, and at most
        :data:`POSITIONS_PER_STEP` positions of the mesh record (a longer step samples the record's contact
        edges, which the record resolves to a position, at the step instead: an edge timing error of up to a
        step). Measured against omega_max dt 0.05 and 2048 positions (housing acceleration; spur-gds pitted /
        helical-dct, 600 / 1800 / 3000 rpm, 51.2 kHz, positions chosen by the band): with one position per step
        0.1 / 0.3 / 0.3 % and 5.9 / 0.3 / 0.4 %, without the limit 1.9 / 2.8 / 0.9 % and 9.6 / 2.9 / 1.1 %
        (1.0-1.6x the time); at 12.8 kHz the limit does not bind. Only for box edges: a point-sampled record's
        edges are a position late anyway, and its cases keep their former step. ``step_limit="omega_dt"``:
        ``omega_dt`` alone."""
        dt = self.model.time_step_s(self.omega_dt)
        if self.record.edges != "box" or self.step_limit == "omega_dt":
            return dt
        # a record refined for a moving centre (hook 2c) keeps its edge ramps one stiffness position wide: the bound
        # is that position, not the refined point (measured: a wheel eccentricity at 20 kHz, 512 positions refined
        # 8x, took 0.5 us steps and 5x the time of the unbounded step)
        edge_positions = self.record.positions_per_cycle / self.record.subdivisions
        return min(dt, POSITIONS_PER_STEP / (self.mesh_hz * edge_positions))

    @property
    def discard_s(self) -> float:
        """Start-up transient to discard (s): given, or ln(1000) slowest decay times rounded up to whole
        record periods (so that, at constant speed, the kept record starts at the same mesh phase as the
        periodic path's)."""
        if self.transient_s is not None:
            return self.transient_s
        t = TRANSIENT_DECAY * self.model.slowest_decay_s
        return math.ceil(t / self.period_s) * self.period_s

    def chosen_method(self) -> str:
        if self.needs_transient or self.method == "transient":
            return "transient"
        if self.method == "periodic":
            return "periodic"
        # one storing pass over the period, plus the (2n + 1)-column runs over the distinct cycles
        # (a column costs about half a single-column step: the per-step overhead is shared)
        share = self.record.distinct_cycles() / self.record.period_cycles
        cost_periodic = self.period_s * (1.0 + share * (2 * self.model.n + 1) / 2)
        cost_transient = self.discard_s + self.duration_s
        return "periodic" if cost_periodic <= cost_transient else "transient"


@dataclass
class Response:
    """Channels at the output rate (1-D arrays) plus solver facts."""

    channels: dict
    info: dict = field(default_factory=dict)


def solve(cases: list[DynamicCase]) -> list[Response]:
    """Responses of all cases; cases are batched when their DOF count and step grid agree.

    The small matrix products of the time loop run single-threaded: a
    multi-threaded BLAS costs far more in synchronisation than it gains on
    (cases x 20) @ (20 x 22) products (30x slower on a busy 2-core machine).
    """
    with _single_thread_blas():
        return _solve(cases)


def _single_thread_blas():
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl comes with scikit-learn
        import contextlib

        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def _solve(cases: list[DynamicCase]) -> list[Response]:
    from datagen.shooting import periodic_response
    from datagen.time_stepping import transient_response

    out: list[Response | None] = [None] * len(cases)
    groups: dict[tuple, list[int]] = {}
    steps = {}
    for i, c in enumerate(cases):
        if c.chosen_method() == "periodic":
            steps[i] = math.ceil(c.period_s / c.record.period_cycles / c.dt_max)
    merged = _merge_step_counts({i: (cases[i].model.n, cases[i].record.period_cycles, s) for i, s in steps.items()})
    for i, c in enumerate(cases):
        if i in merged:
            key = ("periodic", c.model.n, c.record.period_cycles, merged[i])
        else:
            R = max(2, math.ceil(1.0 / (c.fs_hz * c.dt_max)))
            key = ("transient", c.model.n, R, c.fs_hz, c.n_out, round(c.discard_s * R * c.fs_hz))
        groups.setdefault(key, []).append(i)
    for key, idx in groups.items():
        if key[0] == "periodic":     # bound the stored trajectories: N x cases x (3n + channels) floats
            per_case = key[2] * key[3] * (3 * key[1] + 24) * 8
            size = max(1, int(MEMORY_BUDGET_BYTES // per_case))
        else:
            size = len(idx)
        for start in range(0, len(idx), size):
            sub = idx[start:start + size]
            batch = [cases[i] for i in sub]
            if key[0] == "periodic":
                res = periodic_response(batch, key[2], key[3])
            else:
                res = transient_response(batch, key[2], key[5])
            for i, r in zip(sub, res):
                out[i] = r
    return out


def wanted_channels(cases) -> set | None:
    """The union of the channels the cases of a batch need (None: every channel)."""
    if any(c.channels is None for c in cases):
        return None
    return set().union(*(c.channels for c in cases))


def _merge_step_counts(items: dict[int, tuple[int, int, int]], slack: float = 1.15) -> dict[int, int]:
    """Steps per mesh cycle for each case, raised so that cases within ``slack`` of each other share a batch.

    ``items``: case index -> (DOF count, period in cycles, minimum steps per cycle).
    """
    out = {}
    by_key: dict[tuple, list[tuple[int, int]]] = {}
    for i, (n, P, s) in items.items():
        by_key.setdefault((n, P), []).append((max(s, 4), i))
    for lst in by_key.values():
        lst.sort()
        start = 0
        while start < len(lst):
            end = start
            while end + 1 < len(lst) and lst[end + 1][0] <= slack * lst[start][0]:
                end += 1
            for _, i in lst[start:end + 1]:
                out[i] = lst[end][0]
            start = end + 1
    return out


# ---------------------------------------------------------------------- shared set-up
def static_state(c: DynamicCase):
    """Static equilibrium under the mean mesh stiffness and mean error force; pinion wind-up in mesh cycles."""
    e_mean = c.record.mean_error_force_n
    q_s = c.model.static_deflection(error_force_n=e_mean)
    x_s = c.model.pair.pinion.teeth * q_s[c.model.index("phi_1")] / (2 * np.pi)
    return q_s, x_s


def mesh_damping(cases) -> np.ndarray:
    """Mesh damping coefficient of each case (N s/m)."""
    return np.array([c.model.c_mesh_n_s_per_m for c in cases])
