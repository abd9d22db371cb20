"""Slow reference for the healthy tooth-pair stiffness: the test oracle.

Independent of :mod:`datagen.compliance`: it integrates the ANGULAR form of the
potential-energy terms exactly as written in ../shared/PHYSICS.md section 2
(Tian 2004; Chaari et al. 2009) with ``scipy.integrate.quad`` per contact
position, adds the straight root segment (root below base circle, Liang et al.
2014) in closed form, and the Sainsot fillet term. Only geometry (radii, half
tooth angle) comes from :mod:`datagen.geometry`.
"""
from __future__ import annotations

import math

from scipy.integrate import quad

from datagen.compliance import sainsot_coefficient


def _tooth_terms(pair, which, roll):
    E = pair.material.youngs_modulus_pa
    nu = pair.material.poisson
    rb = pair.base_radius_m(which)
    rf = pair.root_radius_m(which)
    a2 = pair.half_tooth_angle_base_rad(which)
    a1 = roll - a2
    L = 1.0  # per unit width
    # involute part: a from -a1 to a_root (a_root = a2 at the base circle, or the root on the involute)
    if rf < rb:
        a_top = a2
    else:
        a_top = a2 - math.sqrt(rf * rf / (rb * rb) - 1.0)

    def D(a):
        return math.sin(a) + (a2 - a) * math.cos(a)

    kb = quad(lambda a: 3 * (1 + math.cos(a1) * ((a2 - a) * math.sin(a) - math.cos(a))) ** 2 * (a2 - a) * math.cos(a)
              / (2 * E * L * D(a) ** 3), -a1, a_top, epsabs=0, epsrel=1e-10, limit=200)[0]
    ks = quad(lambda a: 1.2 * (1 + nu) * (a2 - a) * math.cos(a) * math.cos(a1) ** 2 / (E * L * D(a)),
              -a1, a_top, epsabs=0, epsrel=1e-10, limit=200)[0]
    ka = quad(lambda a: (a2 - a) * math.cos(a) * math.sin(a1) ** 2 / (2 * E * L * D(a)),
              -a1, a_top, epsabs=0, epsrel=1e-10, limit=200)[0]
    # the angular form is in units of rb: the integrals above are per rb^0 for bending? (dimensionless by design)
    # load point (Tian 2004): d above the base-circle section, h half thickness
    d = rb * (math.cos(a1) + roll * math.sin(a1) - math.cos(a2))
    h = rb * (roll * math.cos(a1) - math.sin(a1))
    if rf < rb:
        hb = rb * math.sin(a2)
        d1 = rb * math.cos(a2) - math.sqrt(rf * rf - hb * hb)
        inertia = (2 * hb) ** 3 / 12
        area = 2 * hb
        c, s = math.cos(a1), math.sin(a1)
        u0 = d * c - h * s
        kb += ((u0 + d1 * c) ** 3 - u0**3) / (3 * c) / (E * inertia)
        ks += 1.2 * c * c * d1 * 2 * (1 + nu) / (E * area)
        ka += s * s * d1 / (E * area)
        y_above_root = d + d1
        theta_f = math.asin(hb / rf)
    else:
        t0 = math.sqrt(rf * rf / (rb * rb) - 1.0)
        a0 = a2 - t0
        y_root = rb * (math.cos(a0) - t0 * math.sin(a0))
        y_above_root = d + rb * math.cos(a2) - y_root
        theta_f = math.asin(rb * (t0 * math.cos(a0) + math.sin(a0)) / rf)
    h_f = rf / pair._gear(which).bore_radius_m
    Ls, Ms, Ps, Qs = (sainsot_coefficient(k, h_f, theta_f) for k in "LMPQ")
    uf = y_above_root - h * math.tan(a1)
    sf = 2 * rf * theta_f
    kf = math.cos(a1) ** 2 / E * (Ls * (uf / sf) ** 2 + Ms * uf / sf + Ps * (1 + Qs * math.tan(a1) ** 2))
    return kb + ks + ka + kf


def pair_stiffness_per_width(pair, g_m: float) -> float:
    """Healthy single tooth-pair stiffness per unit width (N/m per m) at line-of-action position g (from T1)."""
    E, nu = pair.material.youngs_modulus_pa, pair.material.poisson
    c = 4 * (1 - nu * nu) / (math.pi * E)
    c += _tooth_terms(pair, "pinion", pair.roll_angle_rad("pinion", g_m))
    c += _tooth_terms(pair, "wheel", pair.roll_angle_rad("wheel", g_m))
    return 1.0 / c
