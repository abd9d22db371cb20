"""The effect contract: how a physical effect plugs into a simulation.

An *effect* is one physical phenomenon (backlash, sensor noise, a housing
resonance, a profile error, ...) written as a small module: a frozen dataclass
of parameters plus one or more *contribution hooks* at fixed points of the
simulation. The integrator (:mod:`datagen.newmark`, driven by
:mod:`datagen.simulate`) knows the seven contribution points, never the
effects. Adding an effect never means editing the integrator.

How to write an effect
----------------------
1. Subclass :class:`Effect` as a frozen dataclass and decorate it with
   :func:`register`::

       from dataclasses import dataclass, field
       from datagen.effects.base import Effect, register

       @register
       @dataclass(frozen=True)
       class Runout(Effect):
           name = "runout"                       # short, stable, unique
           signature = "wheel shaft order 1 and +/-fr2 sidebands around mesh harmonics"
           amplitude_m: float = field(default=5e-6, metadata={"unit": "m", "bounds": (0.0, 50e-6)})
           phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-3.1416, 3.1416)})

           def deviation_period_cycles(self, ctx):
               return ctx.pair.wheel.teeth          # repeats once per wheel revolution

           def angle_deviation_m(self, theta_pinion_rad, theta_wheel_rad, ctx):
               return self.amplitude_m * np.sin(theta_wheel_rad + self.phase_rad)

2. Every parameter field needs a default and ``metadata`` with ``"unit"`` (SI,
   ``"-"`` for dimensionless) and ``"bounds"`` ``(lo, hi)``: values outside
   (and, for a field annotated ``int``, values that are not integers) raise :class:`~gearpit.errors.InputError`, and the model-vs-measurement
   comparison fits the parameter within these bounds. A string option uses
   ``metadata={"unit": "-", "choices": ("a", "b")}`` instead of bounds.
3. ``name`` is the key used in case files (``[[effects]] name = "runout"``)
   and on the command line (``--effect runout:amplitude_m=5e-6``);
   ``signature`` is one line saying which shaft orders, sidebands, bands or
   envelope lines the effect leaves: the comparison's attribution reads it.
4. Override only the hooks you need (a hook you do not override contributes
   nothing). All angles are shaft rotation angles (rad) measured from the
   start of the simulation, all quantities SI. The hooks:

   ===  ==========================  ==============================================================
   no.  hook                        what it returns
   ===  ==========================  ==============================================================
   1    ``mesh_stiffness``          a modified :class:`MeshStiffness` (pits, tip relief, Hertz)
   2a   ``tooth_deviation_m``       deviation e(g, pinion tooth, wheel tooth) (m) of each contact
                                    point from the ideal flank (profile/pitch error, tip relief);
                                    positive = material missing = less deflection carried
   2b   ``angle_deviation_m``       deviation e(theta1, theta2) (m) along the line of action
                                    (run-out, eccentricity)
   2c   ``centre_offset_m``         displacement (dx, dy)(theta1, theta2) (m) of the wheel centre
                                    relative to the pinion centre (eccentricity): moves the start
                                    of contact and the mesh timing
                                    (:func:`datagen.centre_offset.slots_at_centre_offset`)
   3    ``generalized_force``       extra generalized forces (n_t, n_dof) on the nominal
                                    trajectory (unbalance, torque ripple); N or N m per DOF
   4    ``mesh_force_batch``        nonlinear mesh law F(delta, delta_dot) and its derivatives,
                                    vectorised over the cases that carry the effect (classmethod);
                                    the only hook that makes the integrator iterate (Newton)
   5    ``operating_point``         speed (rpm) and load torque (N m) as functions of time
   6    ``output_path``             channels -> channels: bearing forces to housing acceleration
   7    ``measurement``             channels -> channels: gain, noise, clipping (gets an rng)
   ===  ==========================  ==============================================================

   Hook 2c is part of point 2: the record's pair stiffnesses are those of the
   pair with its centres displaced so at every mesh position.
   Hooks 2a/2b define the *error force* E = sum over contact slices of
   k_slice * e, so the linear mesh force is F = k(x) delta - E (+ damping).
   Hook 3 sees the nominal trajectory (time and reference shaft angles) and
   returns forces per DOF (``ctx.dof_index("phi_b")`` etc., DOFs of
   :mod:`datagen.lumped_model`); state feedback belongs in hook 4.
   Hook 5 sets the *reference* of the motor speed controller and the load
   torque: the actual shaft speed follows through the drive train (fully well
   below the controller bandwidth, ~5 Hz, partly above it).
   Their deviations repeat after ``deviation_period_cycles`` mesh cycles
   (default 1; z_pinion for a per-pinion-tooth error, z_wheel for the wheel):
   the simulation's periodic record is the least common multiple.
   Hooks 1, 2, 3, 5 run once per case before the time loop; hook 4 runs every
   time step (and Newton iteration) on arrays over the cases; hooks 6, 7 run
   once per case on the decimated output (1-D arrays at ``fs_hz``).
   Hooks 3 and 5 make a case non-stationary, hook 4 nonlinear: such cases are
   time-stepped through a start-up transient instead of solved for their
   periodic steady state. Optionally, hook 4's law for one case compiled
   with numba (class attribute ``scalar_mesh_law``) lets that time loop run
   compiled (:mod:`datagen.compiled_stepping`); without it the loop runs in
   numpy, with the same result.
5. Randomness only in hook 7 through the ``rng`` handed in (derived from the
   case seed and the effect's position): same seed, same bytes.
6. The parameters the model-vs-measurement comparison fits (its attribution
   of a missing effect, :mod:`compare.attribution`) are declared in the class
   attribute ``fit_parameters``: a tuple of field names or :class:`Fit`
   entries (search bounds inside the field's bounds, and the scale ``"log"``,
   ``"linear"`` or ``"auto"``); a string option named there is tried at every
   value. Few parameters (one or two numeric ones): each one costs the
   comparison a grid of simulations. ``fit_parameters = ()`` fits nothing (an
   effect without free parameters is still tried as it is)::

       fit_parameters = (Fit("amplitude_m", scale="log"),)      # phase: amplitude spectra do not see it

   Without a declaration (``None``) the first :data:`datagen.effects.fit.MAX_FIT` numeric fields
   whose unit is not ``rad`` and the first string option are fitted (phases
   leave amplitude spectra, envelope and TSA levels unchanged).
   :meth:`Effect.fit_declaration` resolves either form; ``"auto"`` scale is
   log when the bounds are positive and span more than a factor
   :data:`datagen.effects.fit.LOG_SPAN`, or run from 0 to at most 1 (SI magnitudes, fractions:
   0 means "off"), else linear (a grade, a count).
   Where the physics of the operating point singles out a scale of a fitted
   parameter (a tip relief is sized against the tooth deflection under the
   load), :meth:`Effect.fit_seeds` returns values the search starts from in
   addition to its grid: a coarse grid over decades can step over a narrow
   minimum near that scale.
7. A user's own effect in their own file: ``load_plugin("my_effects.py")``
   (or ``gearpit simulate case.toml --plugin my_effects.py``) imports the file,
   whose ``@register`` decorators add the effects to the registry; they are
   then available to simulation, datasets and comparison by name.

References
----------
../shared/DESIGN.md, section "Effects" (the seven contribution points).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np

from datagen.effects.fit import Fit, resolve_fit
from gearpit.errors import InputError

#: the units of a dimensionless parameter, not written after its range in an error ("[0, 12]", not "[0, 12] -")
DIMENSIONLESS_UNITS = ("", "-", "1")
#: the contribution points, in simulation order (method names on :class:`Effect`)
HOOKS = ("mesh_stiffness", "tooth_deviation_m", "angle_deviation_m", "centre_offset_m", "generalized_force",
         "mesh_force_batch", "operating_point", "output_path", "measurement")

@dataclass(frozen=True)
class EffectContext:
    """What a hook may know about the case it acts on.

    Parameters
    ----------
    pair : GearPair
        The gear pair.
    speed_rpm : float
        Nominal pinion speed (rpm).
    torque_nm : float
        Nominal load torque on the pinion shaft (N m).
    dof_names : tuple of str
        Names of the generalized coordinates, in order (see :mod:`datagen.lumped_model`).
    fs_hz : float
        Output sampling rate (Hz).
    duration_s : float
        Output duration (s).
    """

    pair: Any
    speed_rpm: float
    torque_nm: float
    dof_names: tuple = ()
    fs_hz: float = 0.0
    duration_s: float = 0.0

    def dof_index(self, name: str) -> int:
        """Column of DOF ``name`` in ``generalized_force`` output."""
        if name not in self.dof_names:
            raise InputError("dof", name, f"one of: {', '.join(self.dof_names)}")
        return self.dof_names.index(name)

    @property
    def mesh_frequency_hz(self) -> float:
        return self.pair.mesh_frequency_hz(self.speed_rpm)


@dataclass(frozen=True)
class MeshState:
    """The mesh at one time step, arrays over the cases handed to ``mesh_force_batch``.

    Parameters
    ----------
    k_n_per_m : ndarray (B,)
        Total mesh stiffness at the current mesh position (N/m).
    c_n_s_per_m : ndarray (B,)
        Mesh damping coefficient (N s/m).
    error_force_n : ndarray (B,)
        E = sum over slices of k_slice * e (N); the linear law is k delta - E.
    k_slots_n_per_m : ndarray (B, S)
        Stiffness of each tooth pair in contact (N/m), 0 for an empty slot.
    e_slots_m : ndarray (B, S)
        Stiffness-weighted mean deviation of each tooth pair (m), 0 for an empty slot; between record points
        the pair's error force over its stiffness, so ``sum(k_slots * e_slots) == error_force`` and a law that
        keeps every pair touching reduces to the linear one (:meth:`datagen.mesh_excitation.MeshRecords.slots_at`).
    """

    k_n_per_m: np.ndarray
    c_n_s_per_m: np.ndarray
    error_force_n: np.ndarray
    k_slots_n_per_m: np.ndarray
    e_slots_m: np.ndarray

    def subset(self, idx: np.ndarray) -> "MeshState":
        return MeshState(*(getattr(self, f.name)[idx] for f in fields(self)))


@dataclass(frozen=True)
class Effect:
    """Base class of all effects (see the module docstring for how to write one).

    Subclasses are frozen dataclasses whose fields are the parameters, each
    with a default and ``metadata={"unit": ..., "bounds": (lo, hi)}``.
    """

    name: ClassVar[str] = ""
    signature: ClassVar[str] = ""
    #: what the comparison fits: field names or :class:`Fit` entries; None: the default rule (module docstring)
    fit_parameters: ClassVar[tuple | None] = None
    #: True for an effect that acts alike on every tooth and so changes only the mesh harmonics' levels (no
    #: sidebands, no other orders): a comparison that claims it warns that two models of one healthy pair differ
    #: there too (:mod:`compare.workflow`)
    mesh_harmonics_only: ClassVar[bool] = False
    #: True when the fitted string option moves the signature to other lines (which gear carries a local tooth
    #: fault: its shaft's orders), so that the comparison's first search round sweeps the first parameter at
    #: every value of the option (:func:`compare.search.round_a`) instead of trying the others only at the
    #: default's best point
    fit_choice_grid: ClassVar[bool] = False
    #: the coarsest ``omega_max dt`` at which this effect's records are converged, for an effect whose records need
    #: a finer step than the default 0.3 (a law whose pairs lose contact); a case that leaves ``[solver] omega_dt``
    #: unset is stepped at the finest its effects ask for (:meth:`datagen.case_options.SolverOptions.step_for`)
    max_omega_dt: ClassVar[float | None] = None

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            where = f"effects.{self.name}.{f.name}"
            if "choices" in f.metadata:
                if v not in f.metadata["choices"]:
                    raise InputError(where, v, f"one of: {', '.join(map(str, f.metadata['choices']))}")
                continue
            lo, hi = f.metadata["bounds"]
            if f.type in ("int", int):      # an integer field (a seed, a count) takes integers only
                ok = isinstance(v, (int, np.integer)) and not isinstance(v, bool) and lo <= v <= hi
                if not ok:
                    raise InputError(where, v, f"an integer in [{lo}, {hi}]")
                continue
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and lo <= v <= hi
            if not ok:
                unit = f.metadata.get("unit", "")
                shown = "" if unit in DIMENSIONLESS_UNITS else f" {unit}"
                raise InputError(where, v, f"a number in [{lo}, {hi}]{shown}")

    # ------------------------------------------------------------------ description
    @classmethod
    def hooks(cls) -> frozenset[str]:
        """The contribution points this effect overrides."""
        def owner(hook):
            return next(k for k in cls.__mro__ if hook in vars(k))
        return frozenset(h for h in HOOKS if owner(h) is not Effect)

    @classmethod
    def parameter_table(cls) -> list[dict]:
        """One row per parameter: name, unit, default, bounds (or choices)."""
        rows = []
        for f in fields(cls):
            row = {"name": f.name, "unit": f.metadata.get("unit", "-"), "default": f.default}
            row.update({"choices": f.metadata["choices"]} if "choices" in f.metadata
                       else {"bounds": tuple(f.metadata["bounds"])})
            rows.append(row)
        return rows

    @classmethod
    def fit_declaration(cls) -> tuple[tuple[Fit, ...], tuple[str, tuple] | None]:
        """The fitted numeric parameters (resolved :class:`Fit`: bounds set, scale "log" or "linear") and the
        string option tried at every value (``(field, choices)`` or None); see the module docstring.

        Raises :class:`InputError` for an entry that names no field, a numeric entry with bounds outside the
        field's, or more than one string option.
        """
        return resolve_fit(cls)

    @classmethod
    def fit_seeds(cls, ctx: "EffectContext", stiffness) -> dict:
        """Values of fitted parameters that the operating point singles out (module docstring, item 6):
        ``{field: sequence of values}``, tried by the comparison's first search round beside its grid (values
        outside the search bounds are dropped). ``ctx`` is the measurement's :class:`EffectContext`,
        ``stiffness`` the healthy :class:`datagen.stiffness.MeshStiffness` of its pair. Default: none."""
        return {}

    def params(self) -> dict:
        """The parameters as a plain dict (SI, as in the field names)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def to_dict(self) -> dict:
        """The case-file form: ``{"name": ..., **params}``."""
        return {"name": self.name, **self.params()}

    @property
    def is_nonlinear(self) -> bool:
        return "mesh_force_batch" in self.hooks()

    @property
    def is_nonstationary(self) -> bool:
        return bool({"generalized_force", "operating_point"} & self.hooks())

    # ------------------------------------------------------------------ 1. stiffness
    def mesh_stiffness(self, stiffness, ctx: EffectContext):
        """Return a modified :class:`datagen.stiffness.MeshStiffness` (default: unchanged)."""
        return stiffness

    # ------------------------------------------------------------------ 2. displacement excitation
    def deviation_period_cycles(self, ctx: EffectContext) -> int:
        """Mesh cycles after which this effect's deviation repeats (default 1)."""
        return 1

    #: True when :meth:`tooth_deviation_m` does not depend on the contact position ``g_m`` (a whole tooth
    #: displaced, as a pitch error): the record then weights each pair's deviation by the pair's stiffness
    #: instead of slice by slice (:meth:`datagen.stiffness.MeshStiffness.weighted`, ``position_free``)
    tooth_deviation_position_free = False

    def tooth_deviation_m(self, g_m: np.ndarray, pinion_tooth: np.ndarray, wheel_tooth: np.ndarray,
                          ctx: EffectContext) -> np.ndarray:
        """Deviation (m) at line-of-action position ``g_m`` (from T1) on the given teeth."""
        return np.zeros(np.broadcast(g_m, pinion_tooth, wheel_tooth).shape)

    def angle_deviation_m(self, theta_pinion_rad: np.ndarray, theta_wheel_rad: np.ndarray,
                          ctx: EffectContext) -> np.ndarray:
        """Deviation (m) along the line of action as a function of the shaft angles."""
        return np.zeros(np.broadcast(theta_pinion_rad, theta_wheel_rad).shape)

    def centre_offset_m(self, theta_pinion_rad: np.ndarray, theta_wheel_rad: np.ndarray,
                        ctx: EffectContext) -> np.ndarray:
        """Displacement ``(dx, dy)`` (m, shape ``(2, ...)``) of the wheel centre relative to the pinion centre as
        a function of the shaft angles; frame of :func:`datagen.centre_offset.slots_at_centre_offset`
        (``x`` along the line of centres, pinion to wheel)."""
        shape = np.broadcast(theta_pinion_rad, theta_wheel_rad).shape
        return np.zeros((2,) + shape)

    # ------------------------------------------------------------------ 3. extra forces
    def generalized_force(self, t_s: np.ndarray, theta_pinion_rad: np.ndarray, theta_wheel_rad: np.ndarray,
                          ctx: EffectContext) -> np.ndarray:
        """Extra generalized forces, shape ``(len(t_s), len(ctx.dof_names))`` (N or N m)."""
        return np.zeros((len(t_s), len(ctx.dof_names)))

    # ------------------------------------------------------------------ 4. nonlinear mesh law
    #: optional: the law of :meth:`mesh_force_batch` for one case, compiled by the decorator
    #: :func:`datagen.compiled_stepping.scalar_law`, signature ``(p, delta_m, delta_dot_m_s, k_n_per_m,
    #: c_n_s_per_m, error_force_n, k_slots_n_per_m, e_slots_m) -> (F, dF/d delta, dF/d delta_dot)`` with ``p`` the
    #: case's parameters in field order (floats) and the slots 1-D; the time-stepping loop then runs compiled
    #: (:mod:`datagen.compiled_stepping`). Without it the law runs through the numpy loop: nothing else changes.
    scalar_mesh_law = None

    @classmethod
    def mesh_force_batch(cls, params: dict[str, np.ndarray], delta_m: np.ndarray, delta_dot_m_s: np.ndarray,
                         mesh: MeshState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mesh force and derivatives for the B cases carrying this effect.

        ``params`` maps each parameter name to an array (B,) of its values.
        Returns ``(F, dF/d delta, dF/d delta_dot)``, each (B,). Default: the linear law.
        """
        f = mesh.k_n_per_m * delta_m + mesh.c_n_s_per_m * delta_dot_m_s - mesh.error_force_n
        return f, mesh.k_n_per_m, mesh.c_n_s_per_m

    # ------------------------------------------------------------------ 5. operating point
    def operating_point(self, t_s: np.ndarray, speed_rpm: np.ndarray, torque_nm: np.ndarray,
                        ctx: EffectContext) -> tuple[np.ndarray, np.ndarray]:
        """Return the (possibly modulated) pinion speed (rpm) and load torque (N m) at ``t_s``."""
        return speed_rpm, torque_nm

    # ------------------------------------------------------------------ 6., 7. output
    def output_path(self, channels: dict[str, np.ndarray], fs_hz: float, ctx: EffectContext) -> dict[str, np.ndarray]:
        """Transform the channels from bearing forces to housing acceleration (default: unchanged)."""
        return channels

    def measurement(self, channels: dict[str, np.ndarray], fs_hz: float, rng: np.random.Generator,
                    ctx: EffectContext) -> dict[str, np.ndarray]:
        """Apply the measurement chain (default: unchanged)."""
        return channels

    def channels_read(self, wanted: frozenset) -> frozenset | None:
        """The channels hooks 6-7 of this effect read to give the channels ``wanted``; None: every channel.

        A simulation asked for a few channels (:func:`datagen.simulate.simulate` ``channels``) makes and decimates
        only what its effects' hooks read, walking them from the last to the first. Default: ``wanted`` when the
        effect overrides neither hook, None (every channel, as if nothing were asked) when it overrides one and
        does not say what it reads: a plugin's output hook always sees the channels it saw before.
        """
        hooks = self.hooks()
        return None if ("output_path" in hooks or "measurement" in hooks) else frozenset(wanted)


# the registry and effect specs live in datagen.effects.registry; re-exported here, where effect modules and users'
# plugins import them from (module docstring)
from datagen.effects.registry import (EffectSpec, build_effects, get, load_plugin, names, register,  # noqa: E402
                                      unregister)

__all__ = ["Effect", "EffectContext", "EffectSpec", "Fit", "MeshState", "HOOKS", "register", "unregister", "get",
           "names", "load_plugin", "build_effects"]
