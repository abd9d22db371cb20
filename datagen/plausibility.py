"""Physical plausibility of a simulated record: the warnings :func:`datagen.simulate.simulate` attaches.

A record can be a correct solution of the model and still describe nothing a
gear pair does. Three checks, each a ``{"code", "message"}`` entry of
``Signals.metadata["warnings"]`` (the message says what to change):

``mesh_tension``
    the mesh force goes below zero while no effect of the case has a
    nonlinear mesh law (hook 4, e.g. ``backlash``): the teeth would separate,
    and the linear law lets the mesh pull them together instead.
``solver_unconverged``
    the periodic solution's mesh angle did not settle (``angle_converged``),
    or time steps of the time-stepped path left their Newton iteration
    unconverged (``newton_unconverged_steps``).
``deflection_beyond_strength``
    the mean mesh deflection (the static deflection ``F/k``: mean mesh force
    over mean mesh stiffness) exceeds the deflection at which the mean tooth
    load reaches the static bending strength of case-hardened steel at the
    tooth root (:func:`deflection_limit_m`): the teeth would have broken.

References
----------
ISO 6336-3:2019, Calculation of load capacity of spur and helical gears - Part 3: tooth bending strength
(nominal root stress ``sigma_F0 = F_t / (b m_n) Y_F Y_S Y_beta Y_B Y_DT``).
ISO 6336-5:2016, Part 5: strength and quality of materials (case-carburised steel ``sigma_Flim`` up to
~500 MPa, ``Y_ST = 2``, static life factor ``Y_NT = 2.5``).
Kahraman, A., Singh, R. (1990). Non-linear dynamics of a spur gear pair. J. Sound Vib. 142(1), 49-75 (contact
loss needs a dead-zone mesh law).
"""
from __future__ import annotations

import math

import numpy as np

#: a least mesh force within this fraction of the mean of zero is contact lost, not tension (the same tolerance as
#: compare.response.CONTACT_LOSS_TOL: the backlash law's zero force read through the solver's rounding)
CONTACT_LOSS_TOL = 1e-3
#: static tooth-root bending strength (Pa): ISO 6336-5 sigma_Flim 500 MPa (case-carburised, grade MQ) x Y_ST 2 x
#: static life factor Y_NT 2.5; the strongest steel class, so that only loads no steel gear carries are flagged
ROOT_STRENGTH_PA = 2.5e9
#: combined tooth form and stress correction factor Y_F Y_S of ISO 6336-3 for 20 deg teeth without profile shift:
#: ~4.6 at 17 teeth falling to ~4.2 for a rack; the smallest value (the largest load) is taken; Y_beta = Y_B = Y_DT = 1
FORM_STRESS_FACTOR = 4.2


def deflection_limit_m(pair, mean_stiffness_n_per_m: float) -> float:
    """Mean mesh deflection (m) at which the mean tooth load reaches the static root strength.

    The tangential load at that stress is ``F_t = sigma b m_n / (Y_F Y_S)``
    (ISO 6336-3 nominal root stress with :data:`ROOT_STRENGTH_PA` and
    :data:`FORM_STRESS_FACTOR`); along the line of action it is
    ``F_t / cos(alpha_wt)``, and the mesh takes it at a deflection ``F / k``
    (``k``: the mean mesh stiffness).

    Examples
    --------
    >>> from datagen.geometry import spur_pair_example
    >>> round(deflection_limit_m(spur_pair_example(), 3.77e8) * 1e6, 1)     # spur-gds: um
    67.2
    """
    f_t = ROOT_STRENGTH_PA * pair.contact_face_width_m * pair.module_n_m / FORM_STRESS_FACTOR
    return f_t / math.cos(pair.working_pressure_angle_rad) / mean_stiffness_n_per_m


def has_mesh_law(effects) -> bool:
    """Whether an effect replaces the linear mesh law (hook 4: contact loss possible, a negative force is then
    back-flank contact)."""
    return any(getattr(e, "is_nonlinear", False) for e in effects)


def record_warnings(case, solver_channels: dict, solver_info: dict, mean_stiffness_n_per_m: float) -> list[dict]:
    """The warnings of one simulated record (empty: nothing implausible found).

    Parameters
    ----------
    case : datagen.simulate.Case
    solver_channels : dict
        The solver's channels before the output hooks; reads ``mesh_force_n`` (without it the force checks are
        skipped).
    solver_info : dict
        ``Response.info`` (``angle_converged``, ``angle_change_cycles`` or ``newton_unconverged_steps``).
    mean_stiffness_n_per_m : float
        Mean mesh stiffness (N/m).
    """
    out = []
    force = solver_channels.get("mesh_force_n")
    force = None if force is None else np.asarray(force, dtype=float)
    if force is not None and force.size and not has_mesh_law(case.effects):
        # compare.response's criterion, min / |mean| < -tol, without the division (a zero mean force)
        if force.min() < -CONTACT_LOSS_TOL * abs(force.mean()):
            out.append({"code": "mesh_tension", "message": (
                f"the mesh force goes negative ({force.min():.4g} N at least, mean {force.mean():.4g} N): the teeth "
                "would separate, and the linear mesh law pulls them together instead; add the backlash effect (a "
                "dead-zone mesh law with contact loss and back-flank impact, datagen/effects/backlash.py), e.g. "
                "[[effects]] name = \"backlash\" or --effect backlash:backlash_m=1e-4")})
    if solver_info.get("angle_converged") is False:
        out.append({"code": "solver_unconverged", "message": (
            f"the periodic solution's mesh angle did not settle (last change "
            f"{solver_info.get('angle_change_cycles', float('nan')):.3g} mesh cycles after "
            f"{solver_info.get('angle_passes', '?')} passes): the record is the solution at the nominal rotation; set "
            "[solver] method = \"transient\" (the time-stepped path follows the angle), or lower the load or the "
            "errors")})
    bad_steps = solver_info.get("newton_unconverged_steps") or 0
    if bad_steps > 0:
        out.append({"code": "solver_unconverged", "message": (
            f"{bad_steps} time steps ended with an unconverged Newton iteration of the mesh law; lower "
            "[solver] omega_dt")})
    if force is not None and force.size:
        mean_force = float(np.mean(force))
        deflection = mean_force / mean_stiffness_n_per_m
        limit = deflection_limit_m(case.pair, mean_stiffness_n_per_m)
        if deflection > limit:
            out.append({"code": "deflection_beyond_strength", "message": (
                f"the mean mesh deflection (mean force / mean stiffness) {deflection * 1e6:.4g} um exceeds "
                f"{limit * 1e6:.4g} um, where the mean tooth load ({mean_force:.4g} N now, "
                f"{limit * mean_stiffness_n_per_m:.4g} N there) reaches the static tooth-root strength of hardened "
                f"steel ({ROOT_STRENGTH_PA / 1e9:g} GPa, ISO 6336-3/-5): the teeth would break; lower "
                "operating.torque_nm")})
    return out
