"""Where a fitted housing mode sits among the mesh harmonics it was fitted to: among them, or off to one side.

Why
---
A transmission path (:mod:`datagen.effects.transmission_path`) is a housing mode between the bearing force and
the sensor, accelerance ``A(f) = -w^2 / (k - w^2 m + i w c)``. Among the mesh harmonics its frequency and damping
shape their levels, and the fit locates them (the far helical rig's 3 kHz mode fitted at 3076 Hz,
``docs/compare_validation.md``). Off to one side it does not: more than a factor ~3 below the mesh frequency every
harmonic sits on the mode's *mass line* (``|A| m`` within 1 dB of 1: the housing acceleration follows the bearing
force), more than ~3 above the highest harmonic compared on its *stiffness line* (``|A| k / w^2`` within 1 dB of
1). There the fit's frequency says only "below (above) about ...", its damping nothing, and what the
measurement asked for is a *slope*: the harmonics falling (rising) with frequency faster than the model's,
whose sensor reads the pinion's own acceleration. Measured (``tests/test_compare_path_regime.py``): a rig whose
housing mode is at 80 Hz, six times below its 483 Hz mesh, is fitted at 687 Hz with 50 % damping, and modes at 60,
80 and 150 Hz give the same error within 0.1 dB. (It was first seen on a real recording, SpectraQuest b30hz50: a
mode at 127.5 Hz with 0.1 % damping claimed at 41 %; that fit turned out to be the ring of the housing filter on a
record shorter than the mode's decay, since fixed, ``docs/compare_validation.md`` stop 55.) :func:`path_regime`
classifies a fit by where it sits; :func:`check_asymptotes` measures whether an asymptote fits as well (a mode
below the mesh can still be located by the shaft-order lines around it); :func:`path_regime_text` says it the way
the CLI and the report print it. The attribution sets ``CandidateResult.path_regime`` for every fitted candidate
with a ``housing_frequency_hz`` and a ``housing_damping_ratio`` (a plugin's too).

The 1 dB edges: ``r^2 / |1 - r^2 + 2 i zeta r| <= 10^(1/20)`` needs ``r >= 3.03`` for light damping
(``r = f / f_h``), and ``1 / |1 - r^2 + 2 i zeta r| <= 10^(1/20)`` needs ``r <= 0.33``.
"""
from __future__ import annotations

import math

import numpy as np

#: a harmonic counts as on an asymptote (mass or stiffness line) within this many dB of it
ASYMPTOTE_DB = 1.0
#: the asymptote trials of :func:`check_asymptotes`: the mode this factor below the mesh frequency (above the
#: highest harmonic compared), damped by this ratio (the harmonics then lie within 0.6 dB of the line)
ASYMPTOTE_FACTOR = 4.0
ASYMPTOTE_DAMPING = 0.5
#: an asymptote fits as well as the fitted mode when it takes this fraction of the fitted mode's fall of the
#: excess error
AS_WELL = 0.9


def _accelerance_ratios(f_hz: np.ndarray, natural_hz: float, damping_ratio: float) -> tuple:
    """``(|A| m, |A| k / w^2)`` of the SDOF housing at ``f_hz``: the effect's own accelerance
    (:func:`datagen.effects.transmission_path.housing_accelerance`) at unit mass."""
    from datagen.effects.transmission_path import housing_accelerance

    f = np.asarray(f_hz, dtype=float)
    mass = np.abs(housing_accelerance(f, 1.0, natural_hz, damping_ratio))
    return mass, mass * (natural_hz / f) ** 2


def corner_ratio(db: float = ASYMPTOTE_DB) -> float:
    """The frequency ratio ``r`` (undamped) above which ``|A| m`` stays within ``db`` of the mass line: the
    stiffness line's edge is its inverse (within ``db`` below ``1 / r``)."""
    g = 10 ** (db / 20.0)
    return math.sqrt(g / (g - 1.0))


def is_housing_mode(params: dict) -> bool:
    """A fitted candidate whose parameters name a housing mode (the registered transmission path, or a plugin
    with the same two parameters)."""
    return "housing_frequency_hz" in params and "housing_damping_ratio" in params


def path_regime(params: dict, *, mesh_hz: float, n_harmonics: int, fs_hz: float) -> dict:
    """Where the fitted mode ``params`` (``housing_frequency_hz``, ``housing_damping_ratio``) sits among the mesh
    harmonics ``k mesh_hz``, ``k = 1 .. n_harmonics`` below ``fs_hz / 2``: ``regime`` "mass_line" (every one within
    :data:`ASYMPTOTE_DB` of ``1 / m``), "stiffness_line" (of ``w^2 / k``) or "resonant"; ``deviation_db``: the
    largest departure from that asymptote over the harmonics (for "resonant": from the mass line), and
    ``edge_hz``: the frequency the mode is only known to lie below (mass line) or above (stiffness line), else
    None. Empty for parameters that are no housing mode."""
    if not is_housing_mode(params):
        return {}
    f_h, zeta = float(params["housing_frequency_hz"]), float(params["housing_damping_ratio"])
    k = np.arange(1, max(int(n_harmonics), 1) + 1)
    f = k * mesh_hz
    f = f[f < fs_hz / 2] if np.any(f < fs_hz / 2) else f[:1]
    mass, stiff = _accelerance_ratios(f, f_h, zeta)
    mass_db, stiff_db = 20 * np.log10(mass), 20 * np.log10(stiff)
    out = {"housing_frequency_hz": f_h, "housing_damping_ratio": zeta, "mesh_hz": float(mesh_hz),
           "top_harmonic_hz": float(f[-1])}
    if np.max(np.abs(mass_db)) <= ASYMPTOTE_DB:
        return {**out, "regime": "mass_line", "deviation_db": float(np.max(np.abs(mass_db))),
                "edge_hz": float(f[0] / corner_ratio())}
    if np.max(np.abs(stiff_db)) <= ASYMPTOTE_DB:
        return {**out, "regime": "stiffness_line", "deviation_db": float(np.max(np.abs(stiff_db))),
                "edge_hz": float(f[-1] * corner_ratio())}
    return {**out, "regime": "resonant", "deviation_db": float(np.max(np.abs(mass_db))), "edge_hz": None}


def path_regime_text(regime: dict) -> str:
    """One sentence on a fitted housing mode that the mesh harmonics do not locate (CLI, report): it lies on an
    asymptote beside them, or (:func:`check_asymptotes`) an asymptote fits as well; "" when the fit located it."""
    if not regime:
        return ""
    kind = regime.get("regime")
    f_h, fm, top = regime["housing_frequency_hz"], regime["mesh_hz"], regime["top_harmonic_hz"]
    as_well = regime.get("as_well")
    sides = set(as_well) if as_well is not None else ({kind} - {"resonant"})
    err = regime.get("asymptotes", {})
    fits = (lambda k: f" (excess error {err[k]:.2f} dB against the fit's {regime['fitted_excess_db']:.2f})"
            if k in err else "")
    below, above = fm / corner_ratio(), top * corner_ratio()
    if sides == {"mass_line"}:
        return (f"the mesh harmonics do not locate this mode: " +
                (f"at {f_h:.4g} Hz it lies below them all (fm {fm:.4g} Hz) and they sit on its mass line"
                 if kind == "mass_line" else f"a mode below them all{fits('mass_line')} fits as well") +
                ": over them the housing acceleration follows the bearing force, the measured harmonics falling "
                "with frequency faster than the model's pinion acceleration; any mode below about "
                f"{below:.4g} Hz does the same, so neither {f_h:.4g} Hz nor the damping is measured - read a "
                "housing (or mounting) mode below the mesh")
    if sides == {"stiffness_line"}:
        return (f"the mesh harmonics do not locate this mode: " +
                (f"at {f_h:.4g} Hz it lies above them all (up to {top:.4g} Hz) and they sit on its stiffness line"
                 if kind == "stiffness_line" else f"a mode above them all{fits('stiffness_line')} fits as well") +
                ": the measured harmonics rise with frequency faster than the model's; any mode above about "
                f"{above:.4g} Hz does the same, so neither {f_h:.4g} Hz nor the damping is measured - read a stiff "
                "path with its mode above the harmonics")
    if sides == {"mass_line", "stiffness_line"}:
        return ("the mesh harmonics do not locate this mode: a mode below them all and one above them all fit "
                "as well, so the fit changes the path's gain, not its shape; its frequency and damping are unknown")
    return ""


def asymptote_modes(params: dict, *, mesh_hz: float, top_hz: float, bounds: dict) -> dict:
    """The housing modes that put every mesh harmonic on an asymptote, within the parameters' ``bounds``
    (name -> (lo, hi)): "mass_line" at :data:`ASYMPTOTE_FACTOR` below ``mesh_hz``, "stiffness_line" as far above
    ``top_hz``, each with the damping :data:`ASYMPTOTE_DAMPING` (no resonant peak on a shaft order below the mesh);
    one that its bound keeps within :func:`corner_ratio` of the harmonics is left out."""
    lo, hi = bounds["housing_frequency_hz"]
    z_lo, z_hi = bounds["housing_damping_ratio"]
    zeta = min(max(ASYMPTOTE_DAMPING, z_lo), z_hi)
    out = {}
    f_mass = max(mesh_hz / ASYMPTOTE_FACTOR, lo)
    if mesh_hz / f_mass >= corner_ratio():
        out["mass_line"] = {**params, "housing_frequency_hz": f_mass, "housing_damping_ratio": zeta}
    f_stiff = min(top_hz * ASYMPTOTE_FACTOR, hi)
    if f_stiff / top_hz >= corner_ratio():
        out["stiffness_line"] = {**params, "housing_frequency_hz": f_stiff, "housing_damping_ratio": zeta}
    return out


def check_asymptotes(c, ref, model, seed: int = 0) -> dict:
    """Whether the fitted housing mode of candidate ``c`` is *located* by the measurement: the comparison
    (:func:`compare.comparison.compare`, the model with ``c``'s nuisances) with the mode as fitted and with each
    asymptote of :func:`asymptote_modes` in its place. An asymptote whose excess error takes at least
    :data:`AS_WELL` of the fitted mode's fall from the baseline ``c.baseline_error_db`` fits as well, and the
    mode's frequency is then bounded only on that side (:func:`path_regime_text`). Sets and returns
    ``c.path_regime`` (with ``asymptotes``: name -> excess error dB, ``fitted_excess_db`` and ``as_well``: the
    asymptotes that fit as well); a candidate that is no housing mode is left alone (``{}``)."""
    from compare.comparison import compare
    from compare.fitspace import fit_space
    from datagen.effects import EffectSpec, get

    if not (c.params and is_housing_mode(c.params)):
        return {}
    plan = ref.plan
    mesh_hz = plan.z_pinion * plan.fr_pinion_hz
    regime = path_regime(c.params, mesh_hz=mesh_hz, n_harmonics=plan.n_harmonics, fs_hz=plan.fs_hz)
    bounds = {p.name: (p.lo, p.hi) for p in fit_space(get(c.effect)).params}
    if not {"housing_frequency_hz", "housing_damping_ratio"} <= set(bounds):
        c.path_regime = regime
        return regime
    base = model.with_drivetrain(c.nuisance) if c.nuisance else model
    trials = {"fitted": dict(c.params),
              **asymptote_modes(c.params, mesh_hz=mesh_hz, top_hz=regime["top_harmonic_hz"], bounds=bounds)}
    errors = {}
    for name, ps in trials.items():
        e = EffectSpec.from_dict({"name": c.effect, **ps}).build()
        errors[name] = float(compare(ref.measurement, base.with_effect(e), seed=seed,
                                     reference=ref).evaluation.residuals.excess_total_db)
    fall = c.baseline_error_db - errors["fitted"]
    as_well = [k for k in errors if k != "fitted" and fall > 0
               and c.baseline_error_db - errors[k] >= AS_WELL * fall]
    regime.update(asymptotes={k: v for k, v in errors.items() if k != "fitted"}, fitted_excess_db=errors["fitted"],
                  as_well=as_well)
    c.path_regime = regime
    return regime


__all__ = ["ASYMPTOTE_DB", "corner_ratio", "is_housing_mode", "asymptote_modes", "check_asymptotes", "path_regime", "path_regime_text"]
