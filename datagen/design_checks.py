"""Design checks of a gear pair: can it be cut, and does it mesh without interference.

:func:`check_design` runs when a :class:`datagen.geometry.GearPair` is built and
raises :class:`gearpit.errors.DesignError` naming the cause and what is allowed:
undercut of the generating rack, a bore that leaves no rim, a pointed tip,
involute interference of either tip, a start of active profile below the root
circle, a contact ratio below 1.

References
----------
ISO 21771:2007, Gears - Cylindrical involute gears and gear pairs - Concepts and geometry.
Niemann, G., Winter, H. (1983). Maschinenelemente II, ch. 21 (contact ratio, undercut, tip thickness).
"""
from __future__ import annotations

import math

from gearpit.errors import DesignError, DesignLimitError


def check_design(pair) -> None:
    """Raise :class:`DesignError` if ``pair`` (a :class:`datagen.geometry.GearPair`) cannot be made or meshed."""
    mn = pair.module_n_m
    for which in ("pinion", "wheel"):
        g = pair._gear(which)
        # undercut: rack addendum line above the interference point (ISO 21771, Niemann 21.4)
        limit = pair.pitch_radius_m(which) * math.sin(pair.pressure_angle_t_rad) ** 2 / mn
        needed = pair.addendum_coef - g.profile_shift
        if needed > limit + 1e-9:
            z_min = math.ceil(2 * needed * math.cos(pair.helix_angle_rad) / math.sin(pair.pressure_angle_t_rad) ** 2)
            raise DesignError(
                f"{which}.teeth: {g.teeth} teeth with profile shift {g.profile_shift} are undercut "
                f"(needs h_a* - x <= {limit:.3f}); allowed: >= {z_min} teeth or a larger profile shift")
        if g.bore_radius_m >= pair.root_radius_m(which) - mn:
            raise DesignLimitError(f"{which}.bore_radius_m", g.bore_radius_m, pair.root_radius_m(which) - mn, "m",
                                   "leaves no rim", "root radius minus one module")
        sa = pair.tooth_thickness_at_m(which, pair.tip_radius_m(which))
        if sa < 0.2 * pair.module_t_m:
            raise DesignError(
                f"{which}.profile_shift: tip thickness {sa * 1e3:.3f} mm (pointed tip); allowed: >= 0.2 m_t = "
                f"{0.2 * pair.module_t_m * 1e3:.3f} mm (reduce the profile shift or the addendum)")
    # interference: each tip must engage the mate's involute, not below its base circle
    if pair.contact_start_m <= 0:
        raise DesignError(
            f"wheel.tip: the wheel tip reaches below the pinion base circle (contact start {pair.contact_start_m * 1e3:.3f} mm "
            "from T1): involute interference; allowed: contact start > 0 (more pinion teeth, positive pinion shift)")
    if pair.contact_end_m >= pair.line_of_action_length_m:
        raise DesignError(
            "pinion.tip: the pinion tip reaches below the wheel base circle: involute interference; "
            "allowed: a shorter pinion addendum or more wheel teeth")
    for which in ("pinion", "wheel"):
        t0, _ = pair.active_roll_range_rad(which)
        r_sap = pair.base_radius_m(which) * math.sqrt(1 + t0 * t0)
        r_f = pair.root_radius_m(which)
        if r_sap <= r_f:
            raise DesignError(f"{which}: start of active profile {r_sap * 1e3:.3f} mm lies below the root circle "
                              f"{r_f * 1e3:.3f} mm (interference with the fillet); allowed: above the root circle")
    if pair.contact_ratio_transverse < 1.0 and pair.contact_ratio_total < 1.0:
        raise DesignError(f"contact ratio: eps_alpha + eps_beta = {pair.contact_ratio_total:.3f}; allowed: >= 1 "
                          "(the pair would lose contact between teeth)")
    if pair.contact_ratio_transverse < 1.0 and not pair.is_helical:
        raise DesignError(f"contact_ratio_transverse: {pair.contact_ratio_transverse:.3f}; allowed: >= 1 for spur gears")
