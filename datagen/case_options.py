"""The options of a simulation case: operating point, numerical solver, mesh stiffness record
(:class:`datagen.simulate.Case` holds them; re-exported by :mod:`datagen.simulate`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

from datagen import dynamics
from datagen.decimation import PASS_EDGE as PASS_FRACTION   # the output's flat band / fs
from gearpit.errors import require, require_positive, require_range
from gearpit.tomlio import check_keys


#: allowed pinion torque (N m) of a case and a sweep: an unloaded pair (0 N m) has no static mesh deflection, and
#: the periodic solution divides by it (all-zero channels, a NaN periodicity error)
TORQUE_RANGE_NM = (1e-3, 1e6)


@dataclass(frozen=True)
class OperatingPoint:
    """Nominal operating point.

    Parameters
    ----------
    speed_rpm : float
        Pinion (input shaft) speed (rpm), > 0.
    torque_nm : float
        Pinion (input shaft) torque (N m), in :data:`TORQUE_RANGE_NM`; the load torque is ``torque_nm * z2 / z1``.
    """

    speed_rpm: float
    torque_nm: float

    def __post_init__(self):
        require_positive("operating.speed_rpm", self.speed_rpm)
        lo, hi = TORQUE_RANGE_NM
        ok = isinstance(self.torque_nm, (int, float)) and not isinstance(self.torque_nm, bool) \
            and lo <= self.torque_nm <= hi
        require(ok, "operating.torque_nm", self.torque_nm, f"a number in [{lo:g}, {hi:g}] N m (> 0: a loaded pair)")


#: ``omega_max dt`` of a case whose ``[solver] omega_dt`` is unset and whose effects ask for no finer step
DEFAULT_OMEGA_DT = 0.3


@dataclass(frozen=True)
class SolverOptions:
    """Numerical options: ``omega_dt`` (w_max dt; unset: :meth:`step_for` the case's effects), ``method``
    (auto|periodic|transient), ``transient_s`` (s),
    ``mesh_angle``: where the mesh stiffness and error are read, at the pinion's actual angle ("dynamic": the
    nominal rotation plus its vibration ``phi_1``, so a gear that follows a transmission error shifts its mesh
    timing) or at the nominal rotation plus the static wind-up ("nominal": the classic linear time-varying
    model, ``k(t)`` fixed in advance). Both solution paths honour it (:mod:`datagen.shooting`).
    ``step_limit``: "position" (the step spans at most one position of a box-edged mesh record as well,
    :attr:`datagen.dynamics.DynamicCase.dt_max`) or "omega_dt" (``omega_dt`` alone: on the periodic path up to 6x
    faster at 20 kHz and above for records that repeat once per wheel revolution, but less accurate - the fits of
    the attribution moved, compare.candidates.AttributionSettings.search_solver; on the time-stepped path a
    step that straddles box edges modulates the mesh)."""

    omega_dt: float | None = None
    method: str = "auto"
    transient_s: float | None = None
    mesh_angle: str = "dynamic"
    step_limit: str = "position"

    def __post_init__(self):
        if self.omega_dt is not None:
            require_range("solver.omega_dt", self.omega_dt, 0.01, 1.0)
        require(self.method in dynamics.METHODS, "solver.method", self.method, f"one of: {', '.join(dynamics.METHODS)}")
        if self.transient_s is not None:
            require_range("solver.transient_s", self.transient_s, 0.0, 100.0)
        require(self.mesh_angle in dynamics.MESH_ANGLES, "solver.mesh_angle", self.mesh_angle,
                f"one of: {', '.join(dynamics.MESH_ANGLES)}")
        require(self.step_limit in dynamics.STEP_LIMITS, "solver.step_limit", self.step_limit,
                f"one of: {', '.join(dynamics.STEP_LIMITS)}")

    def step_for(self, effects=()) -> float:
        """The ``omega_max dt`` a case with ``effects`` is stepped at: ``omega_dt`` when it is set, else
        :data:`DEFAULT_OMEGA_DT` or the finest step an effect asks for (``Effect.max_omega_dt``: backlash, whose
        pairs part at their contact edges, is converged only at 0.05; experiments/step_convergence.py)."""
        if self.omega_dt is not None:
            return float(self.omega_dt)
        asked = [e.max_omega_dt for e in effects if e.max_omega_dt is not None]
        return float(min([DEFAULT_OMEGA_DT, *asked]))


#: mesh positions per cycle chosen by :func:`auto_positions_per_cycle`: per mesh harmonic in the flat pass band,
#: and the range of the power of two it is rounded up to
POSITIONS_PER_HARMONIC = 16
AUTO_POSITIONS_RANGE = (64, 4096)


def auto_positions_per_cycle(fs_hz: float, mesh_hz: float) -> int:
    """Mesh positions per cycle for a record at ``fs_hz``: :data:`POSITIONS_PER_HARMONIC` per mesh harmonic in
    the flat pass band (``0.4 fs / f_m`` harmonics), rounded up to a power of two in :data:`AUTO_POSITIONS_RANGE`.

    The stiffness record is linearly interpolated between positions, so a harmonic ``h`` of the mesh is
    smoothed by about ``(pi h / ppc)^2 / 3``; a fixed grid is too coarse at low speed and high ``fs`` (the
    band holds many harmonics) and wasted at high speed. Measured with box edges (spur-gds, 50 N m, healthy,
    periodic path, pinion-bearing acceleration at 12.8 kHz, RMS of the difference from 2048 positions):
    600 rpm (17.7 harmonics in the band; 512 positions) 0.6 %, 1800 rpm (5.9; 128) 0.5 %, 3000 rpm (3.5; 64)
    1.2 %; the former fixed 64 point-sampled positions 63 / 24 / 12 %.

    >>> auto_positions_per_cycle(12800.0, 290.0), auto_positions_per_cycle(12800.0, 870.0)
    (512, 128)
    """
    lo, hi = AUTO_POSITIONS_RANGE
    need = POSITIONS_PER_HARMONIC * PASS_FRACTION * fs_hz / mesh_hz
    return int(min(hi, max(lo, 2 ** math.ceil(math.log2(max(need, 1.0))))))


@dataclass(frozen=True)
class StiffnessOptions:
    """Options passed to :func:`datagen.stiffness.mesh_stiffness`: ``positions_per_cycle`` (None: chosen by the
    output band, :func:`auto_positions_per_cycle`), ``n_slices``, ``pit_model``, ``edges`` (how a contact edge
    between positions enters the record, :func:`datagen.stiffness.contact_fraction`).

    The defaults are the accurate record: positions chosen by the band, box edges (README, "Dynamics": within
    0-7 % of a converged record). ``StiffnessOptions(positions_per_cycle=64, edges="point")`` is the former
    coarse record (6-512 % off), kept to reproduce datasets made before commit d1b9c53."""

    positions_per_cycle: int | None = None
    n_slices: int | None = None
    pit_model: str = "no_contact"
    edges: str = "box"

    def __post_init__(self):
        from datagen.stiffness import EDGE_MODES

        if self.positions_per_cycle == "auto":     # the file form of None
            object.__setattr__(self, "positions_per_cycle", None)
        if self.positions_per_cycle is not None:
            require(isinstance(self.positions_per_cycle, int) and not isinstance(self.positions_per_cycle, bool)
                    and 4 <= self.positions_per_cycle <= 100000, "stiffness.positions_per_cycle",
                    self.positions_per_cycle, "an integer in [4, 100000], or \"auto\" (chosen by the output band)")
        require(self.edges in EDGE_MODES, "stiffness.edges", self.edges, f"one of: {', '.join(EDGE_MODES)}")

    def to_dict(self) -> dict:
        """The file form (``[stiffness]`` of a case or sweep): positions chosen by the band as ``"auto"``, unset
        options left out."""
        return {k: ("auto" if k == "positions_per_cycle" and v is None else v)
                for k, v in vars(self).items() if v is not None or k == "positions_per_cycle"}


def options_from_table(klass, table, name: str):
    """``klass`` (:class:`StiffnessOptions` or :class:`SolverOptions`) from its file table ``[name]`` of a case
    or sweep; an unknown key names the table and the allowed keys."""
    require(isinstance(table, dict), name, table, "a table")
    check_keys(table, {f.name for f in fields(klass)}, name)
    return klass(**table)
