"""Moving centres (hook 2c): MeshStiffness.slots_at_centre_offset and the eccentricity effects.

References: plane involute geometry, computed here independently of the closed forms in
datagen.stiffness (vector construction of the internal common tangent of the two base circles and its
intersections with the tip circles); the linearised contact-ratio change of a centre-distance change,
d eps = -da / (p_bt sin alpha_w) (e.g. Litvin & Fuentes, Gear Geometry and Applied Theory, 2004,
ch. 10: the path of contact is a_w sin(alpha_w) minus the two tip-circle segments).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from datagen.effects import EffectContext, get
from datagen.geometry import preset
from datagen.stiffness import mesh_stiffness


def _reference(pair, ppc: int, dx: float, dy: float):
    """Contact positions of the pairs at each of ``ppc`` positions of a cycle (from T1 along the displaced line
    of action, pairs -1..3) and the start and end of contact, by vector geometry (spur pair)."""
    rb1, rb2 = pair.base_radius_m("pinion"), pair.base_radius_m("wheel")
    ra1, ra2 = pair.tip_radius_m("pinion"), pair.tip_radius_m("wheel")
    o2 = np.array([pair.centre_distance_m + dx, dy])
    a = np.linalg.norm(o2)
    dhat = o2 / a
    alpha = math.acos((rb1 + rb2) / a)
    c, s = math.cos(-alpha), math.sin(-alpha)
    n = np.array([c * dhat[0] - s * dhat[1], s * dhat[0] + c * dhat[1]])    # unit normal O1 -> T1
    t1 = rb1 * n
    d = np.array([-n[1], n[0]])                                              # line of action, T1 -> T2
    assert abs(np.dot(o2 - t1, n) - rb2) < 1e-12 and np.dot(o2 - t1, d) > 0  # tangent to the wheel circle too
    # wheel tip circle: |t1 + t d - o2| = ra2, the root nearer T1 is the start of contact
    w = t1 - o2
    b, cc = np.dot(w, d), np.dot(w, w) - ra2 ** 2
    t_start = -b - math.sqrt(b * b - cc)
    t_end = math.sqrt(ra1 ** 2 - rb1 ** 2)
    phi_t1 = math.atan2(n[1], n[0])
    # nominal: T1 at polar angle -alpha_w, tooth crossings at A + (u + s) p_b from T1 at this pinion angle
    shift = rb1 * (-pair.working_pressure_angle_rad - phi_t1)
    u = np.arange(ppc) / ppc
    pos = pair.contact_start_m + (u[:, None] + np.arange(-1, 4)[None, :]) * pair.base_pitch_m + shift
    return pos, t_start, t_end


OFFSETS = [(120e-6, 0.0), (-120e-6, 0.0), (0.0, 300e-6), (-80e-6, -250e-6), (7e-6, 0.0)]


@pytest.mark.parametrize("dx,dy", OFFSETS)
def test_contact_pattern_matches_vector_geometry(dx, dy):
    """At every position the pairs in contact (sum of the contact fractions) are the vector construction's,
    except within one grid step of a contact edge, where they differ by less than one pair."""
    pair = preset("spur-gds")
    ms = mesh_stiffness(pair, positions_per_cycle=256)
    ppc = ms.positions_per_cycle
    k = ms.slots_at_centre_offset(np.full(ppc, dx), np.full(ppc, dy))
    pos, t0, t1 = _reference(pair, ppc, dx, dy)
    ref = np.sum((pos >= t0) & (pos <= t1), axis=1)
    got = np.sum(k > 0, axis=1)
    h = pair.base_pitch_m / ppc
    near = np.any((np.abs(pos - t0) < h) | (np.abs(pos - t1) < h), axis=1)
    assert np.array_equal(got[~near], ref[~near]), np.nonzero(got[~near] != ref[~near])
    assert np.all(np.abs(got - ref) <= 1) and near.sum() < 0.05 * ppc


def _mean_pairs(ms, pair, dx: float, dy: float) -> float:
    """Mean number of pairs in contact over a cycle: each pair's stiffness over the healthy stiffness at its
    contact position (from the vector construction) is its contact fraction."""
    from datagen.stiffness import pair_compliance

    ppc = ms.positions_per_cycle
    k = ms.slots_at_centre_offset(np.full(ppc, dx), np.full(ppc, dy))
    pos, _, _ = _reference(pair, ppc, dx, dy)
    cols = np.concatenate([k[:, -1:], k[:, :-1]], axis=1)          # pairs -1, 0, 1, 2
    kh = pair.contact_face_width_m / pair_compliance(pair)(pos[:, :cols.shape[1]])
    return float(np.sum(cols / kh) / ppc)


@pytest.mark.parametrize("dx,dy", OFFSETS)
def test_mean_contact_follows_the_path_of_contact(dx, dy):
    """The mean number of pairs in contact changes by exactly (A - A') / p_bt, with A' from the vector
    construction (tolerance 1e-9): the edges move continuously with the offset, not in steps of the grid."""
    pair = preset("spur-gds")
    ms = mesh_stiffness(pair, positions_per_cycle=256)
    _, t0, _ = _reference(pair, 256, dx, dy)
    change = _mean_pairs(ms, pair, dx, dy) - _mean_pairs(ms, pair, 0.0, 0.0)
    assert abs(change - (pair.contact_start_m - t0) / pair.base_pitch_m) < 1e-9, change


def test_contact_ratio_linearised():
    """d eps = -da / (p_bt sin alpha_w) for a centre-distance change da (linearised; tolerance: the
    second-order term, 2 % of the change at 150 um); below the grid step the mean stiffness falls linearly
    with da (steps of 2 um = 0.1 grid step, each change within 10 % of their mean: no staircase)."""
    pair = preset("spur-gds")
    ms = mesh_stiffness(pair, positions_per_cycle=64)
    for da in (-150e-6, 150e-6):
        expect = -da / (pair.base_pitch_m * math.sin(pair.working_pressure_angle_rad))
        got = _mean_pairs(ms, pair, da, 0.0) - _mean_pairs(ms, pair, 0.0, 0.0)
        assert abs(got - expect) <= 0.02 * abs(expect), (got, expect)
    means = [ms.slots_at_centre_offset(np.full(64, da), np.zeros(64)).sum(axis=1).mean()
             for da in np.arange(0, 11e-6, 2e-6)]
    steps = np.diff(means)
    assert np.all(steps < 0) and np.all(np.abs(steps / steps.mean() - 1) < 0.1), steps


def test_no_offset_gives_the_nominal_record():
    """Zero offset: the nominal pair stiffnesses, bit for bit on a spur pair (to rounding on a helical one),
    and an empty early-entry column."""
    for name, exact in (("spur-gds", True), ("helical-dct", False)):
        ms = mesh_stiffness(preset(name))
        n = 2 * ms.positions_per_cycle
        k = ms.slots_at_centre_offset(np.zeros(n), np.zeros(n))
        ref = ms.k_slots_n_per_m[:n]
        if exact:
            assert np.array_equal(k[:, :-1], ref)
        else:
            np.testing.assert_allclose(k[:, :-1], ref, rtol=1e-12, atol=1e-9 * ref.max())
        assert not np.any(k[:, -1])


def test_early_entry_goes_to_the_extra_column():
    """Closer centres start the contact before the nominal start: at the end of a cycle the next pair is
    already in contact, in the extra column, and the total stiffness there exceeds the nominal one."""
    pair = preset("spur-gds")
    ms = mesh_stiffness(pair, positions_per_cycle=256)
    k = ms.slots_at_centre_offset(np.full(256, -150e-6), np.zeros(256))
    assert np.any(k[:, -1] > 0) and not np.any(k[:128, -1] > 0)
    late = k[:, -1] > 0
    assert np.all(k[late].sum(axis=1) > ms.k_n_per_m[:256][late])


@pytest.mark.parametrize("gear", ["pinion", "wheel"])
def test_eccentricity_hooks_agree(gear):
    """The centre offset's component along the line of action (sin alpha_w, cos alpha_w) is the
    transmission error of hook 2b, and its length is the eccentricity, at every angle."""
    pair = preset("spur-gds")
    ctx = EffectContext(pair=pair, speed_rpm=1000.0, torque_nm=50.0)
    eff = get(f"eccentricity_{gear}")(amplitude_m=80e-6, phase_rad=0.7)
    th1 = np.linspace(0, 4 * np.pi, 97)
    th2 = th1 * pair.pinion.teeth / pair.wheel.teeth
    off = np.asarray(eff.centre_offset_m(th1, th2, ctx))
    al = pair.working_pressure_angle_rad
    np.testing.assert_allclose(off[0] * math.sin(al) + off[1] * math.cos(al), eff.angle_deviation_m(th1, th2, ctx),
                               atol=1e-15)
    np.testing.assert_allclose(np.hypot(off[0], off[1]), 80e-6, rtol=1e-12)
