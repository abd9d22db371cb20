"""Gear accuracy grade -> allowed deviations (ISO 1328-1:1995 tolerance formulas).

Not an effect: the profile- and pitch-error effects read their amplitudes here.
ISO 1328-1:1995 gives the grade-5 values in micrometres from the module ``m``
and the reference diameter ``d`` (both in mm) and a step ratio of ``sqrt(2)``
between grades, i.e. ``value(Q) = value(5) * 2**((Q - 5) / 2)``:

=====================  ===============================  ==============================
symbol                 deviation                        grade-5 value (um)
=====================  ===============================  ==============================
``f_pt``               single pitch                     0.3 (m + 0.4 sqrt(d)) + 4
``F_p``                total cumulative pitch           0.3 m + 1.25 sqrt(d) + 7
``F_alpha``            total profile                    3.2 sqrt(m) + 0.22 sqrt(d) + 0.7
``f_f_alpha``          profile form (Annex B)           2.5 sqrt(m) + 0.17 sqrt(d) + 0.5
``f_H_alpha``          profile slope (Annex B)          2 sqrt(m) + 0.14 sqrt(d) + 0.5
``F_r``                radial run-out (ISO 1328-2)      0.8 F_p = 0.24 m + sqrt(d) + 5.6
=====================  ===============================  ==============================

The standard evaluates the formulas at the geometric means of tabulated
module / diameter ranges and rounds the result; here they are evaluated at the
gear's own ``m`` and ``d`` without rounding, and the grade may be fractional
(a continuous parameter for fitting).

References
----------
ISO 1328-1:1995, Cylindrical gears - ISO system of accuracy - Part 1 (tolerance formulas; Annex B: profile
    form and slope).
ISO 1328-2:1997, Part 2: radial composite deviations and runout, Annex B (F_r = 0.8 F_p).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from gearpit.errors import require_positive, require_range

#: ISO 1328-1:1995 defines grades 0 (finest) to 12 (coarsest)
GRADE_RANGE = (0.0, 12.0)

#: the vocabulary of the ``gears`` option of the deviation effects: which gear(s) carry the deviation
GEAR_CHOICES = ("both", "pinion", "wheel")


def selected_gears(choice: str) -> tuple[str, ...]:
    """``("pinion", "wheel")`` for ``"both"``, else the one gear named."""
    return ("pinion", "wheel") if choice == "both" else (choice,)


@dataclass(frozen=True)
class GearTolerances:
    """Allowed deviations of one gear at one accuracy grade (m; module docstring)."""

    grade: float
    single_pitch_m: float
    cumulative_pitch_m: float
    total_profile_m: float
    profile_form_m: float
    profile_slope_m: float
    runout_m: float


def iso1328_tolerances(grade: float, module_m: float, diameter_m: float) -> GearTolerances:
    """ISO 1328-1:1995 deviations of a gear of ``module_m`` and reference ``diameter_m`` at ``grade``.

    Parameters
    ----------
    grade : float
        Accuracy grade Q (0 finest .. 12 coarsest); fractional values interpolate geometrically.
    module_m : float
        Normal module (m).
    diameter_m : float
        Reference diameter (m).

    Returns
    -------
    GearTolerances

    Examples
    --------
    >>> t = iso1328_tolerances(5, 2e-3, 58e-3)
    >>> round(t.profile_form_m * 1e6, 2)   # 2.5 sqrt(2) + 0.17 sqrt(58) + 0.5
    5.33
    """
    require_range("grade", grade, *GRADE_RANGE)
    require_positive("module_m", module_m)
    require_positive("diameter_m", diameter_m)
    m, d = module_m * 1e3, diameter_m * 1e3
    step = 2.0 ** ((grade - 5.0) / 2.0) * 1e-6
    f_p = 0.3 * m + 1.25 * math.sqrt(d) + 7.0
    return GearTolerances(
        grade=float(grade),
        single_pitch_m=(0.3 * (m + 0.4 * math.sqrt(d)) + 4.0) * step,
        cumulative_pitch_m=f_p * step,
        total_profile_m=(3.2 * math.sqrt(m) + 0.22 * math.sqrt(d) + 0.7) * step,
        profile_form_m=(2.5 * math.sqrt(m) + 0.17 * math.sqrt(d) + 0.5) * step,
        profile_slope_m=(2.0 * math.sqrt(m) + 0.14 * math.sqrt(d) + 0.5) * step,
        runout_m=0.8 * f_p * step,
    )


def gear_tolerances(pair, which: str, grade: float) -> GearTolerances:
    """:func:`iso1328_tolerances` of the pinion or wheel of ``pair`` (normal module, reference diameter)."""
    return iso1328_tolerances(grade, pair.module_n_m, 2.0 * pair.pitch_radius_m(which))


__all__ = ["GearTolerances", "iso1328_tolerances", "gear_tolerances", "GRADE_RANGE", "GEAR_CHOICES", "selected_gears"]
