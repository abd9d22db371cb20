"""Moving centres (hook 2c): MeshStiffness.slots_at_centre_offset (datagen.centre_offset), the record on
subdivided grid steps, and the eccentricity effects.

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
    from datagen.compliance import pair_compliance

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


# ---------------------------------------------------------------- the record on subdivided grid steps
def _rect_pit(pair, tooth=3):
    from datagen.flank import PitMap

    grid = pair.flank_grid("pinion", 40, 20)
    d = np.zeros(grid.shape)
    d[10:25, 5:15] = 0.2e-3
    return PitMap(grid=grid, depth_m={tooth: d}, gear="pinion")


@pytest.mark.parametrize("name,pitted", [("spur-gds", False), ("helical-dct", False), ("spur-gds", True)])
def test_no_offset_on_subdivided_steps_is_the_nominal_as_read(name, pitted):
    """Zero offset, 8 points per grid step: at the grid points the nominal pair stiffnesses (bit for bit on a
    healthy spur pair, to rounding otherwise), in between the nominal total stiffness as the dynamics reads it
    (its linear interpolation, MeshStiffness.at; tolerance: rounding, 1e-12 of the maximum). The pair that
    enters at the next cycle's first grid point ramps up in the early-pair column during the last step."""
    pair = preset(name)
    ms = mesh_stiffness(pair, pits=_rect_pit(pair) if pitted else None)
    q, ppc = 8, ms.positions_per_cycle
    n = ms.period_cycles * ppc
    k = ms.slots_at_centre_offset(np.zeros(n * q), np.zeros(n * q), subdivisions=q)
    ref = ms.k_slots_n_per_m
    if name == "spur-gds" and not pitted:
        assert np.array_equal(k[::q, :-1], ref)
    np.testing.assert_allclose(k[::q, :-1], ref, rtol=0, atol=1e-12 * ref.max())
    x = np.arange(n * q) / (ppc * q)
    np.testing.assert_allclose(k.sum(axis=1), ms.at(x), rtol=0, atol=1e-12 * ref.max())
    last_step = np.arange(n * q) % (ppc * q) >= (ppc - 1) * q     # the pair entering at the next cycle
    assert not np.any(k[~last_step, -1])


@pytest.mark.parametrize("name", ["spur-gds", "helical-dct"])
@pytest.mark.parametrize("steps", [0.3, 0.5, 0.8])
def test_subgrid_timing_shift_keeps_the_edge_ramps(name, steps):
    """A displacement across the line of centres (``dy``) only shifts the mesh timing, by ``dg`` (to first
    order; the centre distance changes by dy^2 / 2 a_w): the record as the dynamics reads it (linear
    interpolation) must be the nominal one read ``dg`` further on. Shifts of a fraction of a grid step.
    Tolerances, with dK the largest change of the nominal stiffness over one grid step: a moved ramp keeps its
    one-step width except at its corners, cut by at most dK / (4 q) (q = points per step), plus 0.05 dK for
    the stiffness between the edges (the healthy stiffness at the displaced grid positions, not the shifted
    interpolation; measured up to 0.07 dK together at 15/16 of a step, helical); a shift leaves the amplitude
    spectrum unchanged (shift theorem): mesh orders 8-32 within 2 % (measured 0.8 % at most; with box edges,
    the default, 0.7 % and deviations up to 0.045 dK). On the grid
    itself (q = 1, the record before the subdivision) each moved edge spread over two steps: deviations
    0.16-0.25 dK, 26-57 % less energy in orders 8-32 at these shifts."""
    from datagen.centre_offset import SUBDIVISIONS as q

    pair = preset(name)
    ms = mesh_stiffness(pair)
    ppc = ms.positions_per_cycle
    dg = steps * pair.base_pitch_m / ppc
    dy = pair.centre_distance_m * math.tan(-dg / pair.base_radius_m("pinion"))
    k = ms.slots_at_centre_offset(np.zeros(ppc * q), np.full(ppc * q, dy), subdivisions=q).sum(axis=1)
    x = np.arange(ppc * 32) / (ppc * 32)
    got = np.interp(x * ppc * q, np.arange(ppc * q + 1), np.append(k, k[0]))
    ref = ms.at(x + dg / pair.base_pitch_m)
    k_nom = np.append(ms.k_n_per_m[:ppc], ms.k_n_per_m[0])
    dK = np.abs(np.diff(k_nom)).max()
    assert np.abs(got - ref).max() <= (1 / (4 * q) + 0.05) * dK, np.abs(got - ref).max() / dK
    band = slice(8, 33)
    e_got, e_ref = ((np.abs(np.fft.rfft(a))[band] ** 2).sum() for a in (got, ref))
    assert abs(e_got / e_ref - 1) < 0.02, e_got / e_ref


@pytest.mark.parametrize("gear", ["pinion", "wheel"])
def test_small_eccentricity_keeps_the_high_mesh_harmonics(gear):
    """The mesh record of a 10 um (30 um) eccentricity keeps the energy of mesh orders 8-32 of the nominal
    record as the dynamics reads it: an eccentricity this small moves the start of contact by up to 0.32
    (0.95) grid steps (64 positions per cycle), the mesh timing by up to 0.07 (0.2) steps and the contact
    ratio by 0.005 (0.015), a change of the edge ramps' spectrum of order 1 %. Measured -0.3 % (+1.3 %) with
    point-sampled edges, -0.19 % (+1.42 %) with box edges (datagen.stiffness.contact_fraction, the default);
    with the record on the grid itself (edges spread over two steps; commit 904a59f) -13.9 % (-23.1 %).
    Tolerance 3 %."""
    from datagen.effects import EffectContext, get
    from datagen.mesh_excitation import mesh_record

    pair = preset("spur-gds")
    ms = mesh_stiffness(pair)
    ctx = EffectContext(pair=pair, speed_rpm=1000.0, torque_nm=50.0)
    nominal = mesh_record(ms, (), ctx)

    def band_energy(rec, P):
        k, _ = rec.at(np.arange(P * 64 * 16) / (64 * 16))
        spec = np.abs(np.fft.rfft(k)) ** 2
        order = np.arange(spec.size) / P
        return spec[(order > 7.5) & (order < 32.5)].sum()

    for a in (10e-6, 30e-6):
        rec = mesh_record(ms, (get(f"eccentricity_{gear}")(amplitude_m=a),), ctx)
        P = rec.period_cycles
        assert abs(band_energy(rec, P) / band_energy(nominal, P) - 1) < 0.03, (a, band_energy(rec, P))


def test_small_eccentricity_barely_changes_the_housing_rms():
    """Housing acceleration (pinion bearing) of spur-gds at 1000 rpm, 50 N m (periodic steady state, two pinion
    revolutions): a 10 um pinion eccentricity changes the RMS by -1.22 % (box edges, 512 positions per cycle
    chosen by the band, 8 points per step; RMS 511 m/s^2). On 64 point-sampled positions it was -0.2 % (with
    16 points per grid step +0.1 %; with 256 positions per cycle on the grid itself -1.0 %: the finer grids
    agree); the record on the 64-position grid itself lowered it by 7.2 % (edges spread over two steps; commit
    8a372fd). Tolerance 1.5 %."""
    from datagen.simulate import Case, OperatingPoint, simulate

    def rms(effects):
        (s,) = simulate([Case(preset("spur-gds"), OperatingPoint(1000.0, 50.0), duration_s=0.12, fs_hz=20000.0,
                              effects=effects)])
        x = s.channels["acc_pinion_loa_m_s2"]
        return float(np.std(x))

    change = rms(({"name": "eccentricity_pinion", "amplitude_m": 10e-6},)) / rms(()) - 1
    assert abs(change) < 0.015, change


def test_zero_eccentricity_record_is_the_nominal_as_read():
    """mesh_record with a zero eccentricity (hook 2c on subdivided steps) and a pitch error (hook 2a, refined
    per pair): stiffness and error force equal the record without the eccentricity as the dynamics reads it
    (linear interpolation; tolerance: rounding, 1e-12 of the maximum), per pair too (each pair interpolated
    between its own grid samples)."""
    from datagen.centre_offset import refine_slots
    from datagen.effects import EffectContext, get
    from datagen.mesh_excitation import mesh_record

    pair = preset("spur-gds")
    ms = mesh_stiffness(pair)
    ctx = EffectContext(pair=pair, speed_rpm=1000.0, torque_nm=50.0)
    pitch = get("pitch_error")(grade=7.0, single_tooth_factor=2.0)
    ref = mesh_record(ms, (pitch,), ctx)
    rec = mesh_record(ms, (pitch, get("eccentricity_pinion")(amplitude_m=0.0)), ctx)
    assert rec.period_cycles == ref.period_cycles
    q = rec.positions_per_cycle // ref.positions_per_cycle
    x = np.arange(rec.n_pos) / rec.positions_per_cycle
    k, e = ref.at(x)
    np.testing.assert_allclose(rec.k, k, rtol=0, atol=1e-12 * np.abs(k).max())
    np.testing.assert_allclose(rec.error_force, e, rtol=0, atol=1e-12 * np.abs(e).max())
    ppc = ref.positions_per_cycle
    np.testing.assert_allclose(rec.k_slots, refine_slots(ref.k_slots, ppc, q), rtol=0, atol=1e-12 * k.max())
