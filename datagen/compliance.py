"""Tooth compliance by the potential-energy method, per unit face width.

The tooth is a non-uniform cantilever on the root circle (Yang & Lin 1987;
Tian 2004). Where the root circle lies inside the base circle (small pinions,
z < ~42 at 20 deg) the tooth between root and base circle is modelled as a
straight flank of the base-circle thickness (Liang, Zuo & Pandey 2014); where it
lies outside, the cantilever starts on the involute at the root circle.

This module discretises the tooth along its centre line once per gear and keeps
the cumulative section integrals

    W_n(y) = int_{y_root}^{y} (y' - y_root)^n / I(y') dy'   (n = 0, 1, 2)
    A_0(y) = int_{y_root}^{y} 1 / A(y') dy'

per unit face width (I = (2h)^3 / 12, A = 2h, h the half thickness), so that
the bending, shear and axial compliance of ANY load point is a closed form in
them (the moment (Y - y) cos a1 - h sin a1 expands into a polynomial in y).
The same integrals, summed over the pixels a pit removes, give the section
loss of a pitted slice (see :mod:`datagen.pit_stiffness`). An independent slow
reference (``scipy.integrate.quad`` on the angular form of PHYSICS.md) lives
in ``tests/stiffness_reference.py``.

The healthy compliance of a tooth pair (Hertz + both teeth) is tabulated once
along the path of contact by :func:`pair_compliance`; :mod:`datagen.stiffness`
assembles the mesh stiffness from that table.

References
----------
Yang, D. C. H., Lin, J. Y. (1987). Hertzian damping, tooth friction and bending elasticity in gear
    impact dynamics. J. Mech. Trans. Autom. Des. 109, 189-196.
Tian, X. (2004). Dynamic simulation for system response of gearbox including localized gear faults.
    MSc thesis, University of Alberta.
Sainsot, P., Velex, P., Duverger, O. (2004). Contribution of gear body to tooth deflections - a new
    bidimensional analytical formula. J. Mech. Des. 126, 748-752.
Liang, X., Zuo, M. J., Pandey, M. (2014). Analytically evaluating the influence of crack on the mesh
    stiffness of a planetary gear set. Mech. Mach. Theory 76, 20-38.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Sainsot et al. (2004) fillet-foundation coefficients A..F for L*, M*, P*, Q*
SAINSOT_COEFFS = {
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}

#: shear correction factor of a rectangular section (Timoshenko), used in the shear energy
SHEAR_FACTOR = 1.2

#: points of the healthy compliance table along the line of action
_TABLE_POINTS = 4097


def sainsot_coefficient(which: str, h_f: float, theta_f: float) -> float:
    """X*(h_f, theta_f) = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f + E h_f + F (Sainsot 2004)."""
    a, b, c, d, e, f = SAINSOT_COEFFS[which]
    return a / theta_f**2 + b * h_f**2 + c * h_f / theta_f + d / theta_f + e * h_f + f


@dataclass(frozen=True, eq=False)
class ToothBeam:
    """One gear's tooth as a cantilever, discretised along its centre line.

    Built by :func:`tooth_beam`. Lengths in m; integrals per unit face width.
    """

    base_radius_m: float
    root_radius_m: float
    alpha2_rad: float        #: half tooth angle on the base circle
    y_root_m: float          #: centre-line coordinate of the root section
    h_root_m: float          #: half thickness at the root section
    theta_f_rad: float       #: half tooth angle at the root circle (Sainsot)
    h_f: float               #: root radius / bore radius (Sainsot)
    y_nodes_m: np.ndarray    #: node heights (from the gear centre) along the centre line
    h_nodes_m: np.ndarray    #: half thickness at the nodes
    W: np.ndarray            #: (3, n) cumulative W_0, W_1, W_2 at the nodes
    A0: np.ndarray           #: (n,) cumulative A_0 at the nodes

    def load_point(self, roll_rad):
        """Load angle a1, height above the root section Y and half thickness h at a contact point.

        ``roll_rad`` is the involute roll angle theta of the contact point;
        a1 = theta - alpha2 (PHYSICS.md section 2).
        """
        t = np.asarray(roll_rad, dtype=float)
        a1 = t - self.alpha2_rad
        rb = self.base_radius_m
        h = rb * (t * np.cos(a1) - np.sin(a1))
        y = rb * (np.cos(a1) + t * np.sin(a1))
        return a1, y - self.y_root_m, h

    def cumulative(self, height_m):
        """W_0, W_1, W_2, A_0 from the root section up to a height above it (linear in the nodes)."""
        yy = np.asarray(height_m) + self.y_root_m
        w = np.stack([np.interp(yy, self.y_nodes_m, self.W[n]) for n in range(3)])
        return w, np.interp(yy, self.y_nodes_m, self.A0)


def beam_compliance(a1, Y, h, W, A0, E: float, G: float):
    """Bending, shear and axial compliance (per unit width) from the section integrals.

    Bending: int ((Y - y) cos a1 - h sin a1)^2 / (E I) dy; shear: 1.2 cos^2 a1 int 1/(G A) dy;
    axial: sin^2 a1 int 1/(E A) dy (Tian 2004, Cartesian form).
    """
    c, s = np.cos(a1), np.sin(a1)
    p = Y * c - h * s
    bending = (p * p * W[0] - 2.0 * p * c * W[1] + c * c * W[2]) / E
    shear = SHEAR_FACTOR * c * c * A0 / G
    axial = s * s * A0 / E
    return bending, shear, axial


def fillet_compliance(beam: ToothBeam, a1, Y, h, E: float):
    """Fillet-foundation compliance per unit width (Sainsot, Velex & Duverger 2004).

    1/kf = cos^2 a1 / E * (L* (uf/Sf)^2 + M* (uf/Sf) + P* (1 + Q* tan^2 a1)), with
    uf = Y - h tan a1 the distance from the root section to where the load line
    crosses the centre line and Sf = 2 rf theta_f.
    """
    L = sainsot_coefficient("L", beam.h_f, beam.theta_f_rad)
    M = sainsot_coefficient("M", beam.h_f, beam.theta_f_rad)
    P = sainsot_coefficient("P", beam.h_f, beam.theta_f_rad)
    Q = sainsot_coefficient("Q", beam.h_f, beam.theta_f_rad)
    sf = 2.0 * beam.root_radius_m * beam.theta_f_rad
    u = (Y - h * np.tan(a1)) / sf
    return np.cos(a1) ** 2 / E * (L * u * u + M * u + P * (1.0 + Q * np.tan(a1) ** 2))


def hertz_compliance(E: float, nu: float) -> float:
    """Linear Hertzian contact compliance per unit width, 4 (1 - nu^2) / (pi E) (Yang & Lin 1987)."""
    return 4.0 * (1.0 - nu * nu) / (math.pi * E)


def tooth_beam(pair, which: str, n_nodes: int = 3000) -> ToothBeam:
    """Discretise one gear's tooth (see module docstring) for load points up to its tip."""
    rb = pair.base_radius_m(which)
    rf = pair.root_radius_m(which)
    ra = pair.tip_radius_m(which)
    alpha2 = pair.half_tooth_angle_base_rad(which)
    bore = pair._gear(which).bore_radius_m
    t_tip = math.sqrt(ra * ra / (rb * rb) - 1.0)
    ys, hs = [], []
    if rf < rb:
        # straight flank of base-circle thickness between root and base circle (Liang et al. 2014)
        h_b = rb * math.sin(alpha2)
        y_root = math.sqrt(rf * rf - h_b * h_b)
        y_base = rb * math.cos(alpha2)
        n_s = max(50, int(n_nodes * (y_base - y_root) / (ra - rf)))
        ys.append(np.linspace(y_root, y_base, n_s, endpoint=False))
        hs.append(np.full(n_s, h_b))
        t0 = 0.0
        h_root, theta_f = h_b, math.asin(h_b / rf)
    else:
        t0 = math.sqrt(rf * rf / (rb * rb) - 1.0)
        a0 = alpha2 - t0
        y_root = rb * (math.cos(a0) - t0 * math.sin(a0))
        h_root = rb * (t0 * math.cos(a0) + math.sin(a0))
        theta_f = math.asin(h_root / rf)
    # involute nodes, denser near the root where 1/h^3 varies most: uniform in t
    t = np.linspace(t0, t_tip, n_nodes)
    a = alpha2 - t
    ys.append(rb * (np.cos(a) - t * np.sin(a)))
    hs.append(rb * (t * np.cos(a) + np.sin(a)))
    y = np.concatenate(ys)
    h = np.concatenate(hs)
    inv_i = 12.0 / (2.0 * h) ** 3
    inv_a = 1.0 / (2.0 * h)
    z = y - y_root
    W = np.stack([_cumtrapz(inv_i * z**n, y) for n in range(3)])
    A0 = _cumtrapz(inv_a, y)
    return ToothBeam(base_radius_m=rb, root_radius_m=rf, alpha2_rad=alpha2, y_root_m=y_root, h_root_m=h_root,
                     theta_f_rad=theta_f, h_f=rf / bore, y_nodes_m=y, h_nodes_m=h, W=W, A0=A0)


def _cumtrapz(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    out = np.zeros_like(f)
    out[1:] = np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(x))
    return out


def tooth_compliance(beam: ToothBeam, roll_rad, E: float, G: float) -> dict[str, np.ndarray]:
    """Healthy bending, shear, axial and fillet compliance (per unit width) at contact roll angles."""
    a1, Y, h = beam.load_point(roll_rad)
    W, A0 = beam.cumulative(Y)
    b, s, a = beam_compliance(a1, Y, h, W, A0, E, G)
    return {"bending": b, "shear": s, "axial": a, "fillet": fillet_compliance(beam, a1, Y, h, E)}


@dataclass(frozen=True, eq=False)
class PairCompliance:
    """Healthy tooth-pair compliance per unit face width as a function of ``g`` (m/N * m)."""

    pair: object
    beams: dict
    g_table_m: np.ndarray
    c_table: np.ndarray
    c_hertz: float

    def __call__(self, g_m):
        return np.interp(g_m, self.g_table_m, self.c_table)


def pair_compliance(pair) -> PairCompliance:
    """Tabulate the healthy pair compliance per unit width over the path of contact."""
    E, nu = pair.material.youngs_modulus_pa, pair.material.poisson
    G = pair.material.shear_modulus_pa
    beams = {w: tooth_beam(pair, w) for w in ("pinion", "wheel")}
    g = np.linspace(pair.contact_start_m, pair.contact_end_m, _TABLE_POINTS)
    c_h = hertz_compliance(E, nu)
    c = np.full_like(g, c_h)
    for w, beam in beams.items():
        c += sum(tooth_compliance(beam, pair.roll_angle_rad(w, g), E, G).values())
    return PairCompliance(pair=pair, beams=beams, g_table_m=g, c_table=c, c_hertz=c_h)
