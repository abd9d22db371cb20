"""The one orchestrator: a case (pair, pits, operating point, effects) -> signals.

The CLI, datasets, comparison and tests all call :func:`simulate`. Stages:
pit map (:mod:`datagen.pits`) -> mesh stiffness (:mod:`datagen.stiffness`) ->
effect hooks 1-2 (:mod:`datagen.mesh_excitation`) -> lumped model
(:mod:`datagen.lumped_model`) -> dynamics, batched (:mod:`datagen.dynamics`)
-> effect hooks 6-7 -> :class:`Signals`.

Case file (TOML; units in key names, unknown keys are errors)::

    duration_s = 1.0
    fs_hz = 20000.0
    seed = 7
    [pair]                       # datagen.pair_file.pair_from_dict: preset = "spur-gds" or full keys
    preset = "spur-gds"
    [operating]
    speed_rpm = 1500.0           # pinion speed
    torque_nm = 11.3             # pinion (input) torque; the load carries torque * z2/z1
    [pits]                       # optional: datagen.pits.PitSpec keys plus gear and grid
    gear = "pinion"
    grid = [64, 64]              # flank pixels (profile x face)
    shape = "ellipse"
    teeth = [0]
    severity = 0.2
    [stiffness]                  # optional: positions_per_cycle, n_slices, pit_model, edges (point|box)
    [drivetrain]                 # optional: datagen.lumped_model.DriveTrain fields (SI)
    [solver]                     # optional: omega_dt (0.3; 0.05 with backlash), method ("auto"), transient_s,
                                 #   mesh_angle ("dynamic"), step_limit ("position")
    [[effects]]                  # optional, repeatable: name + parameters (SI)
    name = "noise"
    snr_db = 30.0
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from datagen import dynamics
from datagen.effects import EffectContext, build_effects
from datagen.flank import PitMap
from datagen.geometry import GearPair
from datagen.pair_file import pair_from_dict
from datagen.lumped_model import HELICAL_DOFS, SPUR_DOFS, DriveTrain, build_model
from datagen.case_options import PASS_FRACTION as _PASS
from datagen.case_options import (OperatingPoint, SolverOptions, StiffnessOptions,  # noqa: F401  (re-exported)
                                  auto_positions_per_cycle, options_from_table)
from datagen.mesh_excitation import mesh_record
from datagen.plausibility import record_warnings
from datagen.stiffness_limits import check_case_record
from gearpit import __version__
from gearpit.errors import require, require_positive
from gearpit.tomlio import check_keys, read_toml

#: passband edge of the output anti-alias filter as a fraction of fs (datagen.decimation.PASS_EDGE)
_CASE_KEYS = {"duration_s", "fs_hz", "seed", "pair", "operating", "pits", "stiffness", "drivetrain", "solver", "effects"}


@dataclass(frozen=True, eq=False)
class Case:
    """One simulation case (all SI).

    Parameters
    ----------
    pair : GearPair
    operating : OperatingPoint
    duration_s : float
        Output duration (s), at least one pinion revolution.
    fs_hz : float
        Output sampling rate (Hz); the flat pass band (0.4 fs) must contain the mesh frequency.
    pits : PitMap, PitSpec or None
        Pits; a PitSpec is drawn on a ``pit_grid`` flank grid of ``pit_gear``.
    pit_gear : {"pinion", "wheel"}
    pit_grid : (int, int)
        Flank pixels (profile x face) for a PitSpec.
    effects : tuple of Effect (EffectSpec or dicts are converted)
    seed : int
        Seed of everything random in the case (measurement noise); pit shapes use the PitSpec's seed.
    drivetrain : DriveTrain
    stiffness : StiffnessOptions
    solver : SolverOptions
    """

    pair: GearPair
    operating: OperatingPoint
    duration_s: float = 1.0
    fs_hz: float = 20000.0
    pits: object = None
    pit_gear: str = "pinion"
    pit_grid: tuple = (64, 64)
    effects: tuple = ()
    seed: int = 0
    drivetrain: DriveTrain = field(default_factory=DriveTrain)
    stiffness: StiffnessOptions = field(default_factory=StiffnessOptions)
    solver: SolverOptions = field(default_factory=SolverOptions)

    def __post_init__(self):
        require(isinstance(self.pair, GearPair), "pair", type(self.pair).__name__, "a GearPair")
        require(isinstance(self.operating, OperatingPoint), "operating", self.operating, "an OperatingPoint")
        require_positive("duration_s", self.duration_s)
        require_positive("fs_hz", self.fs_hz)
        require(isinstance(self.seed, int) and not isinstance(self.seed, bool) and self.seed >= 0, "seed", self.seed,
                "an integer >= 0")
        rev_s = 60.0 / self.operating.speed_rpm
        require(self.duration_s >= rev_s * (1 - 1e-9), "duration_s", self.duration_s,
                f">= one pinion revolution ({rev_s:.6g} s at {self.operating.speed_rpm:g} rpm)")
        fm = self.pair.mesh_frequency_hz(self.operating.speed_rpm)
        require(_PASS * self.fs_hz > fm, "fs_hz", self.fs_hz,
                f"> {fm / _PASS:.6g} Hz (the mesh frequency {fm:.6g} Hz must lie in the flat pass band 0.4 fs)")
        require(self.pit_gear in ("pinion", "wheel"), "pits.gear", self.pit_gear, "one of: pinion, wheel")
        require(isinstance(self.solver, SolverOptions), "solver", type(self.solver).__name__,
                "a SolverOptions (a dict of its fields: SolverOptions(**d))")
        require(self.pits is None or isinstance(self.pits, PitMap) or hasattr(self.pits, "build"), "pits",
                type(self.pits).__name__, "None, a PitMap or a PitSpec")
        require(isinstance(self.stiffness, StiffnessOptions), "stiffness", type(self.stiffness).__name__,
                "a StiffnessOptions (a dict of its fields: StiffnessOptions(**d))")
        object.__setattr__(self, "effects", build_effects(self.effects))
        check_case_record(self)
        stepped = [e.name for e in self.effects if e.is_nonlinear or e.is_nonstationary]
        require(not (stepped and self.solver.method == "periodic"), "solver.method", self.solver.method,
                f"'auto' or 'transient' with effects {stepped} (nonlinear or non-stationary: no periodic steady state)")

    # ------------------------------------------------------------------ file boundary
    @classmethod
    def from_dict(cls, d: dict) -> "Case":
        """From the TOML form (module docstring); unknown keys raise :class:`gearpit.errors.InputError`."""
        require(isinstance(d, dict), "case", d, "a table")
        check_keys(d, _CASE_KEYS, "", required={"pair", "operating"})
        pair = pair_from_dict(d["pair"])
        op = d["operating"]
        require(isinstance(op, dict), "operating", op, "a table with speed_rpm, torque_nm")
        check_keys(op, {"speed_rpm", "torque_nm"}, "operating", required={"speed_rpm", "torque_nm"})
        for k in ("speed_rpm", "torque_nm"):
            require(_is_num(op[k]), f"operating.{k}", op[k], "a number")
        kwargs = {"pair": pair, "operating": OperatingPoint(float(op["speed_rpm"]), float(op["torque_nm"]))}
        for k in ("duration_s", "fs_hz"):
            if k in d:
                require(_is_num(d[k]), k, d[k], "a number")
                kwargs[k] = float(d[k])
        if "seed" in d:
            kwargs["seed"] = d["seed"]
        if "pits" in d:
            from datagen.pits import PitSpec

            p = dict(d["pits"])
            kwargs["pit_gear"] = p.pop("gear", "pinion")
            grid = p.pop("grid", [64, 64])
            require(isinstance(grid, (list, tuple)) and len(grid) == 2 and all(isinstance(g, int) for g in grid),
                    "pits.grid", grid, "[rows, cols], two integers")
            kwargs["pit_grid"] = tuple(grid)
            kwargs["pits"] = PitSpec.from_dict(p)
        for key, klass in (("stiffness", StiffnessOptions), ("solver", SolverOptions)):
            if key in d:
                kwargs[key] = options_from_table(klass, d[key], key)
        if "drivetrain" in d:
            kwargs["drivetrain"] = DriveTrain.from_dict(d["drivetrain"])
        if "effects" in d:
            require(isinstance(d["effects"], list), "effects", d["effects"], "an array of tables [[effects]]")
            kwargs["effects"] = tuple(d["effects"])
        return cls(**kwargs)

    @classmethod
    def from_toml(cls, path: str | Path) -> "Case":
        return cls.from_dict(read_toml(path))

    def to_dict(self) -> dict:
        """The TOML form (regenerates the case exactly, except a PitMap given as an array)."""
        d = {"duration_s": self.duration_s, "fs_hz": self.fs_hz, "seed": self.seed, "pair": self.pair.to_dict(),
             "operating": {"speed_rpm": self.operating.speed_rpm, "torque_nm": self.operating.torque_nm},
             "stiffness": self.stiffness.to_dict(),
             "drivetrain": self.drivetrain.to_dict(),
             "solver": {k: v for k, v in vars(self.solver).items() if v is not None},
             "effects": [e.to_dict() for e in self.effects]}
        if isinstance(self.pits, PitMap):
            d["pits_map"] = {"gear": self.pits.gear, "grid": list(self.pits.grid.shape),
                             "severity_by_tooth": {str(t): s for t, s in self.pits.severities().items()}}
        elif self.pits is not None:
            d["pits"] = _pitspec_dict(self.pits, self.pit_gear, self.pit_grid)
        return d

    # ------------------------------------------------------------------ stages
    def pit_map(self) -> PitMap | None:
        if self.pits is None or isinstance(self.pits, PitMap):
            return self.pits
        grid = self.pair.flank_grid(self.pit_gear, *self.pit_grid)
        return self.pits.build(grid, self.pit_gear)

    def context(self, dofs: tuple) -> EffectContext:
        return EffectContext(pair=self.pair, speed_rpm=self.operating.speed_rpm, torque_nm=self.operating.torque_nm,
                             dof_names=dofs, fs_hz=self.fs_hz, duration_s=self.duration_s)


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _pitspec_dict(spec, gear, grid) -> dict:
    from datagen.pits import TOML_KEYS

    out = {"gear": gear, "grid": list(grid)}
    for key, (name, factor) in TOML_KEYS.items():
        v = getattr(spec, name)
        if v is None:
            continue
        out[key] = v / factor if factor else (list(v) if isinstance(v, tuple) else v)
    return out


@dataclass(frozen=True, eq=False)
class Signals:
    """Simulated channels at ``fs_hz``.

    Attributes
    ----------
    channels : dict[str, ndarray]
        Name (unit in the name) -> samples. Always: ``acc_pinion_loa_m_s2``,
        ``acc_wheel_loa_m_s2`` (acceleration of the gear centre at its bearing
        along the line of action: the housing reading when the housing is rigid;
        the ``transmission_path`` effect replaces it by a housing-mode response
        to the bearing force), ``force_bearing_*_loa_n`` (force each bearing
        transmits), ``dte_m`` (dynamic transmission error ``rb1 phi1 - rb2 phi2``),
        ``mesh_deflection_m`` (``v . q``, incl. centre motion), ``mesh_force_n``,
        ``speed_pinion_rpm``, ``speed_wheel_rpm``, ``tacho_pinion``,
        ``tacho_wheel`` (1 at the first sample of each revolution, else 0);
        helical pairs add ``acc_*_axial_m_s2`` and ``force_bearing_*_axial_n``.
    fs_hz : float
    metadata : dict
        ``case`` (TOML form), ``seed``, ``software_version``, ``solver`` facts
        (method, time step, discarded transient, natural frequencies, ...).
    """

    channels: dict
    fs_hz: float
    metadata: dict

    @property
    def n_samples(self) -> int:
        return len(next(iter(self.channels.values())))

    @property
    def time_s(self) -> np.ndarray:
        return np.arange(self.n_samples) / self.fs_hz

    def save_npz(self, path: str | Path) -> None:
        from gearpit.atomic import atomic_path

        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, fs_hz=self.fs_hz, metadata_json=json.dumps(self.metadata), **self.channels)

    @classmethod
    def load_npz(cls, path: str | Path) -> "Signals":
        with np.load(path) as z:
            meta = json.loads(str(z["metadata_json"]))
            ch = {k: z[k] for k in z.files if k not in ("fs_hz", "metadata_json")}
            return cls(channels=ch, fs_hz=float(z["fs_hz"]), metadata=meta)

    def save_csv(self, path: str | Path) -> None:
        from gearpit.atomic import atomic_path

        names = ["time_s"] + sorted(self.channels)
        data = np.column_stack([self.time_s] + [self.channels[k] for k in sorted(self.channels)])
        with atomic_path(path) as tmp:
            np.savetxt(tmp, data, delimiter=",", header=",".join(names), comments="", fmt="%.9g")


def prepare(case: Case) -> dynamics.DynamicCase:
    """Stages before the time loop: pits, stiffness, effect hooks 1-2, lumped model."""
    from datagen.stiffness import mesh_stiffness

    so = case.stiffness
    ppc = so.positions_per_cycle or auto_positions_per_cycle(
        case.fs_hz, case.pair.mesh_frequency_hz(case.operating.speed_rpm))
    ms = mesh_stiffness(case.pair, pits=case.pit_map(), positions_per_cycle=ppc,
                        n_slices=so.n_slices, pit_model=so.pit_model, edges=so.edges)
    ctx = case.context(case_dofs(case))
    rec = mesh_record(ms, case.effects, ctx, keep_slots=any(e.is_nonlinear for e in case.effects),
                      cycles_needed=cycles_rolled(case, ctx))
    model = build_model(case.pair, case.drivetrain, k_mean_n_per_m=rec.mean_k_n_per_m,
                        torque_nm=case.operating.torque_nm)
    return dynamics.DynamicCase(model=model, record=rec, effects=case.effects, ctx=ctx,
                                speed_rpm=case.operating.speed_rpm, torque_nm=case.operating.torque_nm,
                                fs_hz=case.fs_hz, duration_s=case.duration_s,
                                omega_dt=case.solver.step_for(case.effects), method=case.solver.method,
                                transient_s=case.solver.transient_s,
                                mesh_angle=case.solver.mesh_angle, step_limit=case.solver.step_limit)


def case_dofs(case: Case) -> tuple:
    """The lumped model's degrees of freedom for ``case``'s pair (a helical pair adds the axial ones)."""
    return HELICAL_DOFS if case.pair.is_helical else SPUR_DOFS


#: :func:`cycles_rolled`: the mesh cycles of a time-stepped run's reference angle (its speed integrated, speed
#: fluctuations included), times this (the pinion's dynamic angle and the integration's sampling), plus
#: ROLL_SPARE_CYCLES
ROLL_FACTOR = 1.1
ROLL_SPARE_CYCLES = 4
#: time points per second (at least 4096 in all) on which cycles_rolled integrates a fluctuating speed
ROLL_POINTS_PER_S = 20000


def cycles_rolled(case: Case, ctx=None) -> int | None:
    """The mesh cycles a time-stepped case rolls through (its start-up and its record, with the margins
    :data:`ROLL_FACTOR`, :data:`ROLL_SPARE_CYCLES`), so that its mesh record need hold no more
    (:func:`datagen.mesh_excitation.mesh_record`); None when it may run on the periodic path, or its start-up is
    not given (:attr:`datagen.dynamics.DynamicCase.discard_s` then rounds it to whole record periods).

    An effect that moves the operating point (a speed fluctuation: up to 20 % for a while at a low frequency)
    changes the cycles: the speed is then integrated as the time loop does (trapezoids, on
    :data:`ROLL_POINTS_PER_S`; ``ctx``: the case's effect context, made if not given)."""
    so = case.solver
    stepped = so.method == "transient" or any(e.is_nonlinear or e.is_nonstationary for e in case.effects)
    if not stepped or so.transient_s is None:
        return None
    seconds = float(so.transient_s) + float(case.duration_s) + 2.0 / float(case.fs_hz)
    cycles = seconds * case.pair.mesh_frequency_hz(case.operating.speed_rpm)
    op_fx = [e for e in case.effects if "operating_point" in e.hooks()]
    if op_fx:
        if ctx is None:
            ctx = case.context(case_dofs(case))
        t = np.linspace(0.0, seconds, max(4096, int(ROLL_POINTS_PER_S * seconds)))
        speed = np.full(t.size, float(case.operating.speed_rpm))
        torque = np.full(t.size, float(case.operating.torque_nm))
        for e in op_fx:
            speed, torque = e.operating_point(t, speed, torque, ctx)
        speed = np.abs(np.broadcast_to(np.asarray(speed, float), t.shape))
        turns = float(np.sum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))) / 60.0
        cycles = max(cycles, turns * case.pair.pinion.teeth)
    return int(math.ceil(ROLL_FACTOR * cycles)) + ROLL_SPARE_CYCLES


def effect_rng(seed: int, position: int) -> np.random.Generator:
    """Generator of the effect at ``position`` in a case with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1000 + position,)))


def solver_channels(effects, wanted) -> frozenset | None:
    """The solver channels that make the output channels ``wanted`` through the output hooks of ``effects``
    (applied in order: every ``output_path``, then every ``measurement``; walked back from the last), by each
    effect's :meth:`Effect.channels_read`; None (every channel) when ``wanted`` is None or an effect reads all."""
    if wanted is None:
        return None
    need = frozenset(wanted)
    chain = ([e for e in effects if "output_path" in e.hooks()] + [e for e in effects if "measurement" in e.hooks()])
    for e in reversed(chain):
        need = e.channels_read(need)
        if need is None:
            return None
    return frozenset(need)


#: solver channel the plausibility checks read (:func:`datagen.plausibility.record_warnings`); made even when the
#: caller asks for others (each channel is the same to the bit whatever else is made; ~3 % more time on a shard of
#: 0.5 s records at 4096 Hz, two more channels cost 14 %)
CHECKED_CHANNELS = frozenset({"mesh_force_n"})

#: mesh records (bytes) a batch of time-stepped cases may hold at once (:func:`_prepare_and_solve`)
RECORD_BUDGET_BYTES = 1.5e9


def _record_bytes(rec) -> int:
    return rec.k.nbytes + rec.error_force.nbytes + rec.k_slots.nbytes + rec.e_slots.nbytes


def _prepare_and_solve(cases: list, channels) -> tuple[list, list]:
    """Prepare every case and solve it. Time-stepped cases are solved as soon as their mesh records reach
    :data:`RECORD_BUDGET_BYTES` together, and their records dropped; the rest (and the periodic cases, whose
    batch shares its steps per cycle) in one call at the end. A time-stepped case's response does not depend on
    the other cases of its batch (each has its own state, record and Newton iterations), so the split changes
    nothing but the memory: the accelerations to the bit, the wheel speed by a rounding
    (``tests/test_dynamics_simulate.py``; a mix of mesh laws that the compiled loop cannot take together runs
    the numpy loop, the same to 1e-9 of the RMS). Below the budget nothing changes: every case in one call. Why: with errors on both gears a record spans
    the hunting period (spur-gds, 2900 mesh cycles; 0.5 GB at 2048 points per cycle), and the time-stepped fits
    of one comparison with a wheel eccentricity in the model prepared a batch of such cases together: 15.6 GB,
    killed by the kernel on a 24 GB machine (``experiments/foreign_rig_check.py``, stop 43)."""
    n = len(cases)
    prepared, responses = [None] * n, [None] * n
    held, held_bytes = [], 0

    def flush():
        for j, r in zip(held, dynamics.solve([prepared[j] for j in held])):
            responses[j] = r
            prepared[j] = replace(prepared[j], record=None)      # its memory is free; the output needs no record
        held.clear()

    for i, c in enumerate(cases):
        dc = prepare(c)
        if channels is not None:
            need = solver_channels(c.effects, channels)
            dc = replace(dc, channels=None if need is None else need | CHECKED_CHANNELS)
        prepared[i] = dc
        if dc.chosen_method() == "transient":
            held.append(i)
            held_bytes += _record_bytes(dc.record)
            if held_bytes > RECORD_BUDGET_BYTES:
                flush()
                held_bytes = 0
    rest = [i for i in range(n) if responses[i] is None]
    for j, r in zip(rest, dynamics.solve([prepared[j] for j in rest]) if rest else ()):
        responses[j] = r
    return prepared, responses


def simulate(cases: Sequence[Case], channels: Sequence[str] | None = None, *,
             channels_field: str = "channels") -> list[Signals]:
    """Simulate cases; those sharing DOF count and time grid advance together as one batch.

    ``channels``: the output channels needed (default: all). The solver then makes and decimates only what they
    are made of (:func:`solver_channels`), and the result may hold no others; each asked channel is the same to
    the bit as in a simulation of every channel (tests/test_simulate.py). A name that is no channel of a case
    is an error (naming ``channels_field``), after the simulation.

    Each result's ``metadata["warnings"]`` lists what makes the record physically implausible (a pulling mesh
    without a contact-loss law, an unconverged solution, a deflection beyond the teeth's strength;
    :mod:`datagen.plausibility`), each a ``{"code", "message"}``; empty when nothing was found.
    """
    cases = list(cases)
    for i, c in enumerate(cases):
        require(isinstance(c, Case), f"cases[{i}]", type(c).__name__, "a Case")
    prepared, responses = _prepare_and_solve(cases, channels)
    out = []
    for c, dc, r in zip(cases, prepared, responses):
        ch = r.channels
        warnings = record_warnings(c, ch, r.info, dc.model.k_mean_n_per_m)
        need = solver_channels(c.effects, channels)
        if need is not None:        # what only the checks asked for goes (the hooks would not expect it)
            ch = {k: v for k, v in ch.items() if k in need or k not in CHECKED_CHANNELS}
        for e in c.effects:
            if "output_path" in e.hooks():
                ch = e.output_path(ch, c.fs_hz, dc.ctx)
        for pos, e in enumerate(c.effects):
            if "measurement" in e.hooks():
                ch = e.measurement(ch, c.fs_hz, effect_rng(c.seed, pos), dc.ctx)
        meta = {"case": c.to_dict(), "seed": c.seed, "software_version": __version__,
                "solver": r.info, "dofs": list(dc.model.dofs),
                "mesh_frequency_hz": dc.mesh_hz,
                "shaft_frequency_pinion_hz": c.pair.shaft_frequency_hz("pinion", c.operating.speed_rpm),
                "shaft_frequency_wheel_hz": c.pair.shaft_frequency_hz("wheel", c.operating.speed_rpm),
                "mean_mesh_stiffness_n_per_m": dc.model.k_mean_n_per_m, "warnings": warnings}
        out.append(Signals(channels={k: np.asarray(v, dtype=np.float64) for k, v in ch.items()}, fs_hz=c.fs_hz,
                           metadata=meta))
    if channels is not None:
        for i, s in enumerate(out):
            for name in channels:
                if name not in s.channels:
                    full = simulate([cases[i]])[0].channels      # the error's list: every channel
                    require(False, channels_field, name, "a simulated channel: " + ", ".join(sorted(full)))
    return out


__all__ = ["OperatingPoint", "SolverOptions", "StiffnessOptions", "Case", "Signals", "simulate", "prepare"]
