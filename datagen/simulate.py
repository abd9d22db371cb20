"""The one orchestrator: a case (pair, pits, operating point, effects) -> signals.

The CLI, datasets, comparison and tests all call :func:`simulate`. Stages:
pit map (:mod:`datagen.pits`) -> mesh stiffness (:mod:`datagen.stiffness`) ->
effect hooks 1-2 (:mod:`datagen.mesh_excitation`) -> lumped model
(:mod:`datagen.lumped_model`) -> dynamics, batched (:mod:`datagen.dynamics`)
-> effect hooks 6-7 -> :class:`Signals`. The stages up to the dynamics and the
batched solve are :mod:`datagen.batch_solve` (:func:`prepare` re-exported here).

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from datagen.batch_solve import (CHECKED_CHANNELS, case_dofs, cycles_rolled,  # noqa: F401  (re-exported)
                                 prepare, prepare_and_solve, solver_channels)
from datagen.effects import EffectContext, build_effects
from datagen.flank import PitMap
from datagen.geometry import GearPair
from datagen.pair_file import pair_from_dict
from datagen.lumped_model import DriveTrain
from datagen.case_options import PASS_FRACTION as _PASS
from datagen.case_options import (OperatingPoint, SolverOptions, StiffnessOptions,  # noqa: F401  (re-exported)
                                  options_from_table)
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
        if v is None or (key == "subpixel" and not v):      # the default left out: older cases' form unchanged
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


def effect_rng(seed: int, position: int) -> np.random.Generator:
    """Generator of the effect at ``position`` in a case with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1000 + position,)))


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
    prepared, responses = prepare_and_solve(cases, channels)
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
