"""Nuisance calibration: fit the drive-train parameters nobody measures before asking which effect is missing.

Why
---
A user never knows the mesh damping, the bearing stiffness or the bearing
damping of their rig; the model's defaults
(:class:`datagen.lumped_model.DriveTrain`) are educated guesses. Left at the
defaults, their mismatch moves the mesh-harmonic levels and the resonances by
several dB - as much as a tip relief, a housing mode or the load-dependent
Hertz stiffness do - so the attribution would either credit a gear effect for
what is only a nuisance, or miss an effect because the nuisance mismatch buries
it. Calibrating first makes the baseline "the model as well as its free
drive-train parameters allow"; an effect then earns its claim only by what it
explains beyond that, and its error reduction is measured against the
calibrated baseline (:mod:`compare.attribution` refits the nuisances together
with each leading candidate, so an effect that resembles a nuisance - Hertz
stiffness moves the mesh resonance like bearing stiffness does - is judged on
equal terms).

What
----
The parameters of :data:`NUISANCES` (a small, documented set: each costs
simulations, and more would start to imitate effects), each searched in
``log10`` between its bounds (damping ratios and stiffnesses are scale
quantities). The bounds are physically plausible ranges: mesh damping ratio
0.03-0.1 (PHYSICS.md, the range :mod:`datagen.lumped_model` quotes), bearing
stiffness 3e7-2e9 N/m (rolling-element supports, Harris & Kotzalas:
1e8-1e9, widened), bearing damping ratio 0.01-0.2. They matter: with a wider
mesh-damping range a backlash rig pulled the calibrated mesh damping to 0.19,
mimicking part of the contact loss, and left the model with the true backlash
at 0.53 of the calibrated baseline's error instead of 0.28. The sensor gain is
fitted in every evaluation (:func:`compare.error.fit_gain_db`), so it is fitted
jointly with them.

The objective is the error of the *order* view only (``views``): the drive
train shapes the mesh harmonics, their sidebands and the shaft orders (its
frequency response at those lines), while bands, envelope lines and statistics
are where disturbances outside the model show up (a bearing defect's ringing,
mains hum). Calibrated on the total error, the nuisances bend to such a
disturbance (measured: a bearing defect pulled the mesh damping from 0.06 to
0.14, which lowered the band error at the cost of -6 dB at every mesh harmonic)
and the disturbance is no longer flagged. The total error is reported with it.

How
---
Coordinate scans in the search coordinates ``u`` in ``[0, 1]^n``
(:class:`compare.fitspace.FitParameter`, log scale), all points of a round in
one batched :func:`datagen.simulate.simulate` call:

1. round ``r`` scans every parameter alone around the current centre, at
   ``points_per_side[r]`` points on each side up to ``widths_u[r]`` (defaults
   +/-0.3, 0.1, 0.03: coarse enough to find a resonance that moved, fine enough
   to land on it: the error is sharp in the bearing stiffness);
2. each coordinate moves to the vertex of the parabola through its scan's best
   point and neighbours (Numerical Recipes eq. 10.2.1); the combined point is
   the next centre (or the best point so far, if that one is better);
3. the best point evaluated is the result.

The model's added noise is the same draw for every point (common random
numbers), so the error is a smooth function of the parameters.

Uncertainty: the conditional 1-sigma of each parameter (the others held) from
the curvature of ``E^2 ~ a du^2`` along its last scan, ``sigma_u^2 = E_min^2 / (N a)``
with ``N`` Kish's effective number of the residuals of the calibrated views
(as :mod:`compare.attribution` does for effect parameters); ``inf`` when that
curvature is not positive (the views do not pin the parameter down,
typically a bearing damping far from any resonance). Being conditional, it is
a lower bound when parameters trade off (the two dampings do).

Effects that make the model time-stepped (backlash, speed or torque
fluctuation) are held out of the calibration: the nuisances are fitted on the
model's periodic part, and the comparison then runs the whole model with them.
A time-stepped point costs a transient simulation of the whole record, and
calibrating on a short window instead proved unreliable (a backlash rig pulled
the mesh damping to twice its value and raised the total error); this is also
how :mod:`compare.attribution` fits such effects (at the calibrated nuisances
of the periodic baseline).

Switch, and why it is not always on
-----------------------------------
``gearpit compare --calibrate`` (``--no-calibrate``) or ``[calibration]
enabled = true`` (``false``) in the model TOML (:mod:`compare.model`), which
also chooses the parameters; :data:`CALIBRATE_BY_DEFAULT` is "auto": calibrate only when no registered effect
explains the mismatch of the model as written (:mod:`compare.escalation`). Measured on
the hidden-effect rigs of :mod:`compare.synthetic` (2 s, SNR 30 dB, every
registered effect a candidate), calibrating first helps where a nuisance
mismatch hides the effect (transmission_path: the model with the claimed
effect falls to 0.20 of the calibrated baseline, against 0.67 without
calibration) but hurts where the effect's signature *is* a change of the
mesh-harmonic levels, which the nuisances can imitate: the calibration of the
baseline absorbs part of it before any candidate is tried (profile_error:
bearing stiffness pulled to 7.9e7 N/m and mesh damping to its bound; the
profile error is still claimed but fitted at grade 2.2 instead of 9 and the
error falls only to 0.58; tip_relief no longer ranks first), and a rolling
bearing defect's 3.9 kHz ringing let transmission_path pass the claim
threshold (0.30) once the nuisances were refitted with it. Fitting the two
leading periodic candidates jointly with the nuisances from the uncalibrated
start as well (this module's wide scans, the effect's parameters free) was
tried and left out: on the test rig it took the profile error's fit from
grade 2.2 to 7.1 (0.40 of the error kept instead of 0.58), but on the helical
rig of ``experiments/generalisation_check.py`` it let a tip relief, with the
nuisances free, beat the hidden profile error (69.5 % against 56.5 %; the
model with it then kept 0.91 of the error): with the drive train free, a
profile error and a tip relief both reshape the mesh harmonics and become
twins, and the wider search only picks one of them by the noise. A tip relief
still lands in its mirror minimum (5.1 um with mesh damping 0.092 against
the rig's 10 um and 0.06). Once the ranking is made, though, the claimed
effect alone is refitted with the nuisances over their whole box
(:mod:`compare.joint_refit`): no rival is at stake there, and on the helical rig
it takes a hidden pitch error fitted at grade 5 (calibrated without it) to 7.7.
Time-stepped candidates are not refitted with the nuisances at all (a transient
batch per nuisance step). So the default
attributes against the model as written first and calibrates only when that
leaves the mismatch unexplained (:mod:`compare.escalation`): on a rig whose
drive train is far from the defaults the calibrated pass is the better one
(docs/compare_validation.md, "On another rig").

References
----------
Press, W. H. et al. (2007). Numerical Recipes, 3rd ed., sec. 15.6 (confidence limits from the curvature of
    the merit function).
Press, W. H. et al. (2007). Numerical Recipes, 3rd ed., sec. 10.2 (parabolic interpolation) and 10.8
    (direction-set methods: minimisation along coordinates).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from compare.calibration_points import Point, evaluate_points, find_point, scan_sigma, scan_vertex
from compare.fitspace import FitParameter, bound_side
from gearpit.errors import require

#: calibrated drive-train fields (datagen.lumped_model.DriveTrain) and their search bounds (SI, log scale)
NUISANCES = {
    "mesh_damping_ratio": (0.03, 0.10),
    "bearing_n_per_m": (3e7, 2e9),
    "bearing_damping_ratio": (0.01, 0.2),
}
DEFAULT_PARAMETERS = tuple(NUISANCES)
#: whether a comparison calibrates when neither the model file nor the caller says: "auto", only when the model as
#: written leaves the mismatch unexplained (compare.escalation; module docstring: why not always)
CALIBRATE_BY_DEFAULT = "auto"


def nuisance_parameter(name: str, default: float) -> FitParameter:
    """The :class:`FitParameter` (log scale) of nuisance ``name``."""
    require(name in NUISANCES, "calibration.parameters", name, f"one of: {', '.join(NUISANCES)}")
    lo, hi = NUISANCES[name]
    return FitParameter(name, lo, hi, "-" if name.endswith("ratio") else "N/m", float(default), True)


@dataclass(frozen=True)
class CalibrationSettings:
    """Knobs of :func:`calibrate`: which nuisances, and per round the scan half-width in ``u`` and the scan
    points on each side of the centre."""

    parameters: tuple = DEFAULT_PARAMETERS
    views: tuple = ("order",)
    widths_u: tuple = (0.3, 0.1, 0.03)
    points_per_side: tuple = (3, 2, 2)
    seed: int = 0

    def __post_init__(self):
        for p in self.parameters:
            require(p in NUISANCES, "calibration.parameters", p, f"one of: {', '.join(NUISANCES)}")
        from compare.plan import VIEWS

        require(bool(self.views) and all(v in VIEWS for v in self.views), "calibration.views", self.views,
                f"some of: {', '.join(VIEWS)}")
        require(len(self.widths_u) == len(self.points_per_side) and len(self.widths_u) >= 1
                and all(0.0 < w <= 0.5 for w in self.widths_u) and all(k >= 1 for k in self.points_per_side),
                "calibration.widths_u", self.widths_u, "widths in (0, 0.5], one points_per_side (>= 1) each")


@dataclass
class Calibration:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    values : dict
        Calibrated drive-train fields (SI), the model's drive train to use.
    sigma : dict
        1-sigma of each (SI; ``inf``: not identifiable from these views, or on a bound: see ``at_bound``).
    start : dict
        The values before calibration (the model's drive train).
    error_before_db, error_db : float
        Raw total error ``E`` (:mod:`compare.error`, step 6: before the noise correction; the calibration
        adds the same noise to every point, so its noise error is common to all) with the start values and
        with the calibrated ones (dB), of the model calibrated.
    held_out : tuple of str
        Time-stepped effects of the model left out of the calibration (module docstring).
    effect_params : dict
        With ``free_effect``: the refitted numeric parameters of the freed effect.
    effect_sigma : dict
        With ``free_effect``: their conditional 1-sigma, as ``sigma`` for the nuisances.
    objective_before_db, objective_db : float
        The error over the calibration's ``views`` (what is minimised), before and after (dB).
    gain_db : float
        The sensor gain fitted with the calibrated values (dB).
    at_bound : dict
        The calibrated fields on a bound of their search (:data:`NUISANCES`): name -> "lower" or "upper"
        (:func:`compare.fitspace.bound_side`); their scan is one-sided, so a ``sigma`` of ``inf`` there means "on
        its bound", not "not identifiable".
    """

    values: dict
    sigma: dict
    start: dict
    error_before_db: float
    error_db: float
    gain_db: float
    n_simulations: int
    elapsed_s: float
    objective_before_db: float = math.nan
    objective_db: float = math.nan
    views: tuple = ()
    held_out: tuple = ()
    effect_params: dict = field(default_factory=dict)
    effect_sigma: dict = field(default_factory=dict)
    residual_db: np.ndarray | None = field(default=None, repr=False)
    view_error_db: dict = field(default_factory=dict)
    at_bound: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"parameters": {k: float(v) for k, v in self.values.items()},
                "sigma": {k: (float(v) if math.isfinite(v) else None) for k, v in self.sigma.items()},
                "at_bound": dict(self.at_bound),
                "start": {k: float(v) for k, v in self.start.items()},
                "error_before_db": float(self.error_before_db), "error_db": float(self.error_db),
                "views": list(self.views), "held_out": list(self.held_out),
                "objective_before_db": float(self.objective_before_db),
                "objective_db": float(self.objective_db),
                "gain_db": float(self.gain_db), "n_simulations": int(self.n_simulations),
                "elapsed_s": float(self.elapsed_s)}


def drivetrain_values(model, names=DEFAULT_PARAMETERS) -> dict:
    """The model's current values of the nuisances ``names`` (its ``[drivetrain]`` table over the defaults)."""
    from datagen.lumped_model import DriveTrain

    dt = DriveTrain.from_dict(dict(model.tables.get("drivetrain", {})))
    return {n: float(getattr(dt, n)) for n in names}


def _setup(model, extra_effects: tuple, settings: CalibrationSettings, start: dict | None, time_stepped: bool):
    """What :func:`calibrate` and :func:`error_at` start from: the model and extra effects without the held-out
    time-stepped ones (module docstring), their names, the start values (the model's drive train, overridden by
    ``start``) and the nuisances' search parameters."""
    held_out = () if time_stepped else tuple(e.name for e in tuple(model.effects) + tuple(extra_effects)
                                             if e.is_nonlinear or e.is_nonstationary)
    if held_out:      # module docstring: time-stepped effects are held out
        model = replace(model, effects=tuple(e for e in model.effects if e.name not in held_out))
        extra_effects = tuple(e for e in extra_effects if e.name not in held_out)
    names = tuple(settings.parameters)
    s0 = drivetrain_values(model, names)
    if start is not None:
        s0.update({k: float(v) for k, v in start.items() if k in s0})
    return model, extra_effects, held_out, s0, [nuisance_parameter(n, s0[n]) for n in names]


def calibrate(ref, model, *, extra_effects: tuple = (), settings: CalibrationSettings | None = None,
              start: dict | None = None, solver: dict | None = None, free_effect: bool = False,
              time_stepped: bool = False) -> Calibration:
    """Fit the nuisance drive-train parameters of ``model`` (plus ``extra_effects``) to the reference
    (module docstring).

    Parameters
    ----------
    ref : compare.comparison.Reference
        The measurement side.
    model : compare.model.ComparisonModel
        The model; its ``[drivetrain]`` table (or the defaults) is the start unless ``start`` is given.
    extra_effects : tuple of Effect
        Effects added to the model for this calibration (a candidate held at its fitted parameters).
    settings : CalibrationSettings
        Parameters and scan widths (``widths_u``: one round per entry).
    start : dict, optional
        Start values of the nuisances (SI).
    solver : dict, optional
        Solver options for every simulation (as :func:`compare.comparison.simulate_model`).
    free_effect : bool
        Fit the numeric parameters of the last of ``extra_effects`` (its declared fit parameters,
        :func:`compare.fitspace.fit_space`) together with the nuisances, from its given values: the joint refit
        of a candidate effect (:mod:`compare.attribution`); the result's ``effect_params`` holds them.
    time_stepped : bool
        Keep the time-stepped effects in (a transient ``solver``): the drive train fitted with a nonlinear
        candidate in, as :func:`compare.attribution._drivetrain_draws` does for a chaotic fit (module docstring:
        held out otherwise).
    """
    settings = settings or CalibrationSettings()
    t0 = time.perf_counter()
    model, extra_effects, held_out, s0, params = _setup(model, extra_effects, settings, start, time_stepped)
    names = tuple(settings.parameters)
    free = None
    if free_effect and extra_effects:
        from compare.fitspace import fit_space

        free = extra_effects[-1]
        for fp in fit_space(type(free)).params:
            v = float(free.params()[fp.name])
            params.append(fp)
            s0[fp.name] = v
    n = len(params)
    centre = np.array([float(p.to_u(min(max(s0[p.name], p.lo), p.hi))) for p in params])
    counter = [0]
    first = Point(centre.copy())      # the start values, exactly (evaluated with the first scan)
    points: list[Point] = []
    scans: list[list[Point]] = []
    for w, k in zip(settings.widths_u, settings.points_per_side):
        offsets = [w * i / k for i in range(-k, k + 1) if i]
        scans = [[] for _ in range(n)]
        batch = []
        centre_pt = find_point(points, centre)
        if centre_pt is None:
            centre_pt = first if not points else Point(centre.copy())
            batch.append(centre_pt)
        for j in range(n):
            for d in offsets:
                u = centre.copy()
                u[j] = np.clip(u[j] + d, 0.0, 1.0)
                q = find_point(points + batch, u)
                if q is None:
                    q = Point(u)
                    batch.append(q)
                scans[j].append(q)
        evaluate_points(ref, model, params, batch, extra_effects, settings.seed, solver, counter, settings.views,
                  exact=first if any(q is first for q in batch) else None, start=s0, free=free)
        points += batch
        for j in range(n):
            scans[j].append(centre_pt)
        # each coordinate to the vertex of the parabola through its scan's best point and neighbours
        new = centre.copy()
        for j in range(n):
            new[j] = scan_vertex([q for q in scans[j] if math.isfinite(q.error_db)], j, centre[j])
        best = min(points, key=lambda q: q.error_db)
        centre = new if find_point(points, new) is None or find_point(points, new).error_db <= best.error_db else best.u.copy()
    last = find_point(points, centre)
    if last is None:
        last = Point(centre.copy())
        evaluate_points(ref, model, params, [last], extra_effects, settings.seed, solver, counter, settings.views,
                  free=free)
        points.append(last)
    best = min((q for q in points if math.isfinite(q.error_db)), key=lambda q: q.error_db, default=None)
    require(best is not None, "calibration", model.describe(), "a model that simulates at this operating point")
    values = {p.name: s0[p.name] if best is first else float(p.from_u(best.u[j])) for j, p in enumerate(params)}
    sigma = scan_sigma(ref, params, values, scans, best, settings.views)
    effect_params = {k: values.pop(k) for k in list(values) if k not in names}
    effect_sigma = {k: v for k, v in sigma.items() if k not in names}
    sigma = {k: v for k, v in sigma.items() if k in names}
    s0 = {k: v for k, v in s0.items() if k in names}
    at_bound = {p.name: side for p in params if p.name in values
                and (side := bound_side(float(p.to_u(values[p.name])))) is not None}
    return Calibration(values=values, sigma=sigma, start=s0, at_bound=at_bound, error_before_db=first.total_db, error_db=best.total_db,
                       objective_before_db=first.error_db, objective_db=best.error_db, views=tuple(settings.views),
                       held_out=held_out, effect_params=effect_params, effect_sigma=effect_sigma,
                       gain_db=best.gain_db, n_simulations=counter[0], elapsed_s=time.perf_counter() - t0,
                       residual_db=best.residual_db, view_error_db=best.view_error_db)


def value_text(name: str, value: float, sigma: float | None, at_bound: dict) -> str:
    """A calibrated value as the CLI and the report write it: ``0.0891 +/- 0.04``, or ``0.1 (on its upper bound)``
    (:func:`compare.candidates.bound_note`; its scan is one-sided there, so it has no 1-sigma), or
    ``0.05 (not identifiable)`` when the error does not change along it."""
    from compare.candidates import bound_note

    text = f"{value:.4g}"
    if sigma is not None and math.isfinite(sigma):
        text += f" +/- {sigma:.2g}"
    return text + (bound_note(name, at_bound, ()) or ("" if sigma is not None and math.isfinite(sigma)
                                                      else " (not identifiable)"))


def calibration_message(cal: "Calibration") -> str:
    """The CLI's line for a calibration: each value with its 1-sigma or its bound note, and the error change."""
    return ("nuisances calibrated: " + ", ".join(f"{k} {value_text(k, v, cal.sigma.get(k), cal.at_bound)}"
                                                 for k, v in cal.values.items())
            + f" (error {cal.error_before_db:.2f} -> {cal.error_db:.2f} dB)")


def error_at(ref, model, values: dict, *, settings: CalibrationSettings | None = None, solver: dict | None = None):
    """The errors of ``model`` at the nuisance ``values`` as a :func:`calibrate` point measures them (same
    views, noise seed, held-out time-stepped effects): a :class:`compare.calibration_points.Point` with
    ``total_db`` (raw), ``error_db`` (over the views) and ``view_error_db``."""
    settings = settings or CalibrationSettings()
    model, _, _, s0, params = _setup(model, (), settings, values, False)
    pt = Point(np.array([float(p.to_u(min(max(s0[p.name], p.lo), p.hi))) for p in params]))
    evaluate_points(ref, model, params, [pt], (), settings.seed, solver, [0], settings.views, exact=pt, start=s0)
    return pt


def calibrated_compare(measurement, model, *, reference=None, seed: int = 0, calibrate_nuisances: bool | None = None,
                       settings: CalibrationSettings | None = None):
    """Calibrate the model's nuisances (when ``calibrate_nuisances``; None: the model's ``[calibration]
    enabled``, default off), then compare the calibrated model with the measurement
    (:func:`compare.comparison.compare`).

    Returns the :class:`compare.comparison.Comparison`; its ``model`` carries the calibrated drive train and
    its ``calibration`` the :class:`Calibration` (None when not calibrated).
    """
    from compare.comparison import compare, prepare_reference

    ref = reference if reference is not None else prepare_reference(measurement)
    on = model.calibrates if calibrate_nuisances is None else calibrate_nuisances
    if not on:
        return compare(measurement, model, seed=seed, reference=ref)
    cal = calibrate(ref, model, settings=settings or model.calibration_settings(seed=seed))
    return compare(measurement, model.with_drivetrain(cal.values), seed=seed, reference=ref, calibration=cal)

