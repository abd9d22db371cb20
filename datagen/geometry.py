"""Involute gear-pair geometry: a frozen description, derived quantities, presets, validation.

Transverse-plane involute geometry; helical gears through the normal module and
the helix angle. All lengths in metres, angles in radians inside; the TOML file
boundary uses millimetres and degrees with the unit in the key name. A pair
checks its fields when built, then its design (undercut, rim, pointed tip,
interference, contact ratio) by :func:`datagen.design_checks.check_design`.

References
----------
ISO 21771:2007, Gears - Cylindrical involute gears and gear pairs - Concepts and geometry.
Niemann, G., Winter, H. (1983). Maschinenelemente II, ch. 21 (contact ratio, undercut, tip thickness).
../shared/PHYSICS.md section 1 (formulas used here, same notation).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

from datagen.design_checks import check_design
from gearpit.errors import InputError, require, require_positive, require_range


def inv(a: float) -> float:
    """Involute function ``tan(a) - a``."""
    return math.tan(a) - a


def inv_inverse(y: float) -> float:
    """Angle ``a`` with ``inv(a) = y`` (Newton, from Cheng's start value)."""
    a = (3.0 * y) ** (1.0 / 3.0) if y > 0 else 0.0
    for _ in range(50):
        f = math.tan(a) - a - y
        df = math.tan(a) ** 2
        if df == 0:
            break
        step = f / df
        a -= step
        if abs(step) < 1e-15:
            break
    return a


@dataclass(frozen=True)
class Material:
    """Linear elastic gear material.

    Parameters
    ----------
    youngs_modulus_pa : float
        Young's modulus E (Pa).
    poisson : float
        Poisson's ratio nu (-).
    density_kg_m3 : float
        Density (kg/m^3).
    """

    youngs_modulus_pa: float = 210e9
    poisson: float = 0.3
    density_kg_m3: float = 7850.0

    def __post_init__(self):
        require_positive("material.youngs_modulus_pa", self.youngs_modulus_pa)
        require_range("material.poisson", self.poisson, 0.0, 0.5, hi_open=True)
        require_positive("material.density_kg_m3", self.density_kg_m3)

    @property
    def shear_modulus_pa(self) -> float:
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson))


@dataclass(frozen=True)
class Gear:
    """One gear of a pair.

    Parameters
    ----------
    teeth : int
        Number of teeth z.
    face_width_m : float
        Face width b (m).
    profile_shift : float
        Profile shift coefficient x (-).
    bore_radius_m : float
        Bore (shaft hole) radius (m); sets the fillet-foundation rim and the inertia.
    """

    teeth: int
    face_width_m: float
    profile_shift: float = 0.0
    bore_radius_m: float = 0.01


#: allowed range (SI, ends included) of the bounded scalar fields of a :class:`Gear` and a :class:`GearPair`; the
#: file boundary (:mod:`datagen.pair_file`) states them in the file's units
FIELD_RANGES = {"profile_shift": (-1.0, 1.5), "pressure_angle_n_rad": (math.radians(10), math.radians(35)),
                "helix_angle_rad": (0.0, math.radians(45)), "addendum_coef": (0.5, 1.5)}


@dataclass(frozen=True)
class GearPair:
    """A meshing involute gear pair (pinion drives wheel).

    Parameters
    ----------
    pinion, wheel : Gear
    module_n_m : float
        Normal module m_n (m).
    pressure_angle_n_rad : float
        Normal pressure angle alpha_n (rad).
    helix_angle_rad : float
        Helix angle beta (rad); 0 for spur gears.
    addendum_coef : float
        Addendum coefficient h_a* (-), standard 1.0.
    dedendum_coef : float
        Dedendum coefficient h_f* = h_a* + c* (-), standard 1.25.
    material : Material
    name : str
        Free label, carried into results.
    """

    pinion: Gear
    wheel: Gear
    module_n_m: float
    pressure_angle_n_rad: float = math.radians(20.0)
    helix_angle_rad: float = 0.0
    addendum_coef: float = 1.0
    dedendum_coef: float = 1.25
    material: Material = field(default_factory=Material)
    name: str = "custom"

    def __post_init__(self):
        for g, gear in (("pinion", self.pinion), ("wheel", self.wheel)):
            require(isinstance(gear.teeth, int) and not isinstance(gear.teeth, bool) and gear.teeth >= 5,
                    f"{g}.teeth", gear.teeth, "an integer >= 5")
            require_positive(f"{g}.face_width_m", gear.face_width_m)
            require_positive(f"{g}.bore_radius_m", gear.bore_radius_m)
            require_range(f"{g}.profile_shift", gear.profile_shift, *FIELD_RANGES["profile_shift"])
        require_positive("module_n_m", self.module_n_m)
        for name in ("pressure_angle_n_rad", "helix_angle_rad", "addendum_coef"):
            require_range(name, getattr(self, name), *FIELD_RANGES[name])
        require_range("dedendum_coef", self.dedendum_coef, self.addendum_coef, 2.0, lo_open=True)
        check_design(self)

    # ------------------------------------------------------------------ transverse basics
    @property
    def is_helical(self) -> bool:
        return self.helix_angle_rad > 0

    @cached_property
    def module_t_m(self) -> float:
        """Transverse module m_t = m_n / cos(beta) (m)."""
        return self.module_n_m / math.cos(self.helix_angle_rad)

    @cached_property
    def pressure_angle_t_rad(self) -> float:
        """Transverse pressure angle alpha_t = atan(tan(alpha_n)/cos(beta)) (rad)."""
        return math.atan(math.tan(self.pressure_angle_n_rad) / math.cos(self.helix_angle_rad))

    @cached_property
    def base_helix_angle_rad(self) -> float:
        """Base helix angle beta_b, tan(beta_b) = tan(beta) cos(alpha_t) (rad)."""
        return math.atan(math.tan(self.helix_angle_rad) * math.cos(self.pressure_angle_t_rad))

    def _gear(self, which: str) -> Gear:
        require(which in ("pinion", "wheel"), "gear", which, "one of: pinion, wheel")
        return self.pinion if which == "pinion" else self.wheel

    def pitch_radius_m(self, which: str) -> float:
        return self._gear(which).teeth * self.module_t_m / 2.0

    def base_radius_m(self, which: str) -> float:
        return self.pitch_radius_m(which) * math.cos(self.pressure_angle_t_rad)

    def tip_radius_m(self, which: str) -> float:
        g = self._gear(which)
        return self.pitch_radius_m(which) + self.module_n_m * (self.addendum_coef + g.profile_shift)

    def root_radius_m(self, which: str) -> float:
        g = self._gear(which)
        return self.pitch_radius_m(which) - self.module_n_m * (self.dedendum_coef - g.profile_shift)

    def half_tooth_angle_base_rad(self, which: str) -> float:
        """Half tooth angle on the base circle, alpha2 = pi/(2z) + inv(alpha_t) + 2 x tan(alpha_n)/z (rad)."""
        g = self._gear(which)
        return (math.pi / (2 * g.teeth) + inv(self.pressure_angle_t_rad)
                + 2 * g.profile_shift * math.tan(self.pressure_angle_n_rad) / g.teeth)

    def tooth_thickness_at_m(self, which: str, radius_m: float) -> float:
        """Transverse arc tooth thickness at a radius on the involute (m)."""
        rb = self.base_radius_m(which)
        a_y = math.acos(min(1.0, rb / radius_m))
        return 2 * radius_m * (self.half_tooth_angle_base_rad(which) - inv(a_y))

    # ------------------------------------------------------------------ pair
    @cached_property
    def working_pressure_angle_rad(self) -> float:
        """Working transverse pressure angle alpha_wt from the profile-shift sum (rad)."""
        x_sum = self.pinion.profile_shift + self.wheel.profile_shift
        z_sum = self.pinion.teeth + self.wheel.teeth
        return inv_inverse(inv(self.pressure_angle_t_rad) + 2 * math.tan(self.pressure_angle_n_rad) * x_sum / z_sum)

    @cached_property
    def centre_distance_m(self) -> float:
        """Working centre distance a_w (m)."""
        r_sum = self.pitch_radius_m("pinion") + self.pitch_radius_m("wheel")
        return r_sum * math.cos(self.pressure_angle_t_rad) / math.cos(self.working_pressure_angle_rad)

    @cached_property
    def base_pitch_m(self) -> float:
        """Transverse base pitch p_bt = pi m_t cos(alpha_t) (m)."""
        return math.pi * self.module_t_m * math.cos(self.pressure_angle_t_rad)

    @cached_property
    def line_of_action_length_m(self) -> float:
        """Distance T1 T2 between the base-circle tangent points (m)."""
        return self.centre_distance_m * math.sin(self.working_pressure_angle_rad)

    @cached_property
    def contact_start_m(self) -> float:
        """Start of contact A on the line of action, measured from T1 (m)."""
        rb2, ra2 = self.base_radius_m("wheel"), self.tip_radius_m("wheel")
        return self.line_of_action_length_m - math.sqrt(ra2**2 - rb2**2)

    @cached_property
    def contact_end_m(self) -> float:
        """End of contact E on the line of action, measured from T1 (m)."""
        rb1, ra1 = self.base_radius_m("pinion"), self.tip_radius_m("pinion")
        return math.sqrt(ra1**2 - rb1**2)

    @cached_property
    def pitch_point_m(self) -> float:
        """Pitch point C on the line of action, from T1 (m)."""
        return self.base_radius_m("pinion") * math.tan(self.working_pressure_angle_rad)

    @cached_property
    def contact_ratio_transverse(self) -> float:
        """Transverse contact ratio eps_alpha = AE / p_bt."""
        return (self.contact_end_m - self.contact_start_m) / self.base_pitch_m

    @cached_property
    def contact_face_width_m(self) -> float:
        """Face width in contact: the narrower gear, assumed centred on the wider (m)."""
        return min(self.pinion.face_width_m, self.wheel.face_width_m)

    @cached_property
    def contact_ratio_overlap(self) -> float:
        """Overlap ratio eps_beta = b sin(beta) / (pi m_n)."""
        return self.contact_face_width_m * math.sin(self.helix_angle_rad) / (math.pi * self.module_n_m)

    @property
    def contact_ratio_total(self) -> float:
        return self.contact_ratio_transverse + self.contact_ratio_overlap

    @property
    def ratio(self) -> float:
        """Gear ratio z_wheel / z_pinion."""
        return self.wheel.teeth / self.pinion.teeth

    def roll_angle_rad(self, which: str, g_m):
        """Involute roll angle of the contact point at line-of-action position ``g_m`` (from T1)."""
        if which == "pinion":
            return g_m / self.base_radius_m("pinion")
        return (self.line_of_action_length_m - g_m) / self.base_radius_m("wheel")

    def active_roll_range_rad(self, which: str) -> tuple[float, float]:
        """Roll angles at the start of active profile and at the tip (rad)."""
        a, e = self.contact_start_m, self.contact_end_m
        if which == "pinion":
            return self.roll_angle_rad("pinion", a), self.roll_angle_rad("pinion", e)
        return self.roll_angle_rad("wheel", e), self.roll_angle_rad("wheel", a)

    def profile_length_m(self, which: str) -> float:
        """Involute arc length from the start of active profile to the tip (m): rb (t_tip^2 - t_sap^2)/2."""
        t0, t1 = self.active_roll_range_rad(which)
        return self.base_radius_m(which) * (t1**2 - t0**2) / 2.0

    def pitch_arc_m(self, which: str) -> float:
        """Involute arc length from the start of active profile to the pitch point (m)."""
        t0, _ = self.active_roll_range_rad(which)
        tp = self.roll_angle_rad(which, self.pitch_point_m)
        return self.base_radius_m(which) * (tp**2 - t0**2) / 2.0

    def flank_grid(self, which: str, n_profile: int, n_face: int):
        """The pixel grid of one gear's active flank (see :mod:`datagen.flank`)."""
        from datagen.flank import FlankGrid

        return FlankGrid(n_profile=n_profile, n_face=n_face, profile_length_m=self.profile_length_m(which),
                         face_width_m=self._gear(which).face_width_m, pitch_s_m=self.pitch_arc_m(which),
                         contact_face_width_m=self.contact_face_width_m)

    # ------------------------------------------------------------------ frequencies and masses
    def shaft_frequency_hz(self, which: str, speed_rpm: float) -> float:
        """Shaft frequency of ``which`` for a pinion speed (Hz)."""
        f1 = speed_rpm / 60.0
        return f1 if which == "pinion" else f1 * self.pinion.teeth / self.wheel.teeth

    def mesh_frequency_hz(self, speed_rpm: float) -> float:
        """Mesh frequency f_m = z1 n1 / 60 (Hz) for a pinion speed (rpm)."""
        return self.pinion.teeth * speed_rpm / 60.0

    def hunting_period_s(self, speed_rpm: float) -> float:
        """Hunting-tooth period 1/f_r1 * z2 / gcd(z1, z2) (s)."""
        return 60.0 / speed_rpm * self.wheel.teeth / math.gcd(self.pinion.teeth, self.wheel.teeth)

    def mass_kg(self, which: str) -> float:
        """Mass of the gear body, a ring from bore to pitch radius over the face width (kg)."""
        g = self._gear(which)
        r = self.pitch_radius_m(which)
        return self.material.density_kg_m3 * math.pi * (r**2 - g.bore_radius_m**2) * g.face_width_m

    def inertia_kg_m2(self, which: str) -> float:
        """Polar moment of inertia of that ring, m (r^2 + r_bore^2) / 2 (kg m^2)."""
        g = self._gear(which)
        r = self.pitch_radius_m(which)
        return self.mass_kg(which) * (r**2 + g.bore_radius_m**2) / 2.0

    # ------------------------------------------------------------------ summary and IO
    def summary(self) -> dict:
        """Derived quantities as a flat dict (SI units, names carry the unit)."""
        out = {"name": self.name}
        for w in ("pinion", "wheel"):
            out.update({
                f"{w}_teeth": self._gear(w).teeth,
                f"{w}_pitch_radius_m": self.pitch_radius_m(w),
                f"{w}_base_radius_m": self.base_radius_m(w),
                f"{w}_tip_radius_m": self.tip_radius_m(w),
                f"{w}_root_radius_m": self.root_radius_m(w),
                f"{w}_profile_length_m": self.profile_length_m(w),
            })
        out.update({
            "module_t_m": self.module_t_m,
            "pressure_angle_t_deg": math.degrees(self.pressure_angle_t_rad),
            "working_pressure_angle_deg": math.degrees(self.working_pressure_angle_rad),
            "base_helix_angle_deg": math.degrees(self.base_helix_angle_rad),
            "centre_distance_m": self.centre_distance_m,
            "base_pitch_m": self.base_pitch_m,
            "line_of_action_active_m": self.contact_end_m - self.contact_start_m,
            "contact_ratio_transverse": self.contact_ratio_transverse,
            "contact_ratio_overlap": self.contact_ratio_overlap,
        })
        return out

    def to_dict(self) -> dict:
        """The TOML/JSON form (mm, deg, GPa at the boundary) that :func:`datagen.pair_file.pair_from_dict` reads."""
        def gear(g: Gear) -> dict:
            return {"teeth": g.teeth, "face_width_mm": g.face_width_m * 1e3, "profile_shift": g.profile_shift,
                    "bore_radius_mm": g.bore_radius_m * 1e3}
        return {
            "name": self.name,
            "module_n_mm": self.module_n_m * 1e3,
            "pressure_angle_n_deg": math.degrees(self.pressure_angle_n_rad),
            "helix_angle_deg": math.degrees(self.helix_angle_rad),
            "addendum_coef": self.addendum_coef,
            "dedendum_coef": self.dedendum_coef,
            "pinion": gear(self.pinion),
            "wheel": gear(self.wheel),
            "material": {"youngs_modulus_gpa": self.material.youngs_modulus_pa / 1e9,
                         "poisson": self.material.poisson, "density_kg_m3": self.material.density_kg_m3},
        }


# ---------------------------------------------------------------------- presets
def helical_pair_example() -> GearPair:
    """``helical-dct``: the helical paper's pair (7-speed DCT first gear).

    17/60 teeth, m_n 2.1 mm, alpha_n 17.5 deg, beta 29 deg, b 19.8/16.9 mm, 20MnCrS5
    (E 210 GPa, nu 0.278, 7840 kg/m3), from its Tables 1-2. Not given there and
    assumed here: no profile shift, h_a* = 1, h_f* = 1.25, bore radii 12 / 25 mm.
    """
    return GearPair(
        pinion=Gear(teeth=17, face_width_m=19.8e-3, profile_shift=0.0, bore_radius_m=12e-3),
        wheel=Gear(teeth=60, face_width_m=16.9e-3, profile_shift=0.0, bore_radius_m=25e-3),
        module_n_m=2.1e-3, pressure_angle_n_rad=math.radians(17.5), helix_angle_rad=math.radians(29.0),
        material=Material(youngs_modulus_pa=210e9, poisson=0.278, density_kg_m3=7840.0), name="helical-dct")


def spur_pair_example() -> GearPair:
    """``spur-gds``: a spur pair like the spur paper's Gearbox Dynamics Simulator rig.

    Given by the paper: a 29-tooth pinion, f_m = 241.6 Hz at 500 rpm (so the
    pinion is on the input shaft). Everything else is an assumption of ours,
    typical of that class of rig: wheel 100 teeth (ratio 3.45), module 2 mm,
    alpha 20 deg, face width 20 mm both, no profile shift, steel (E 206 GPa,
    nu 0.3, 7850 kg/m3), bore radii 12 / 40 mm (rim ratios r_f / r_bore 2.2 and
    2.4, inside the range Sainsot et al. fitted their fillet formula on).
    """
    return GearPair(
        pinion=Gear(teeth=29, face_width_m=20e-3, bore_radius_m=12e-3),
        wheel=Gear(teeth=100, face_width_m=20e-3, bore_radius_m=40e-3),
        module_n_m=2e-3, pressure_angle_n_rad=math.radians(20.0), helix_angle_rad=0.0,
        material=Material(youngs_modulus_pa=206e9, poisson=0.3, density_kg_m3=7850.0), name="spur-gds")


PRESETS = {"helical-dct": helical_pair_example, "spur-gds": spur_pair_example}


def preset(name: str) -> GearPair:
    """A preset pair by name (``helical-dct``, ``spur-gds``)."""
    if name not in PRESETS:
        raise InputError("preset", name, f"one of: {', '.join(sorted(PRESETS))}")
    return PRESETS[name]()


def with_helix(pair: GearPair, helix_angle_rad: float) -> GearPair:
    """The same pair with another helix angle (for spur-vs-helical comparisons)."""
    return replace(pair, helix_angle_rad=helix_angle_rad, name=f"{pair.name}-beta{math.degrees(helix_angle_rad):g}")


__all__ = [
    "Material", "Gear", "GearPair", "preset", "PRESETS",
    "spur_pair_example", "helical_pair_example", "with_helix", "inv", "inv_inverse", "FIELD_RANGES"]
