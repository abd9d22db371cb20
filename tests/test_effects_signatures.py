"""Signatures of the physical effects (profile/pitch error, tip relief, eccentricity, speed and torque
fluctuation, load-dependent Hertz stiffness): each effect's deviation function against its formula,
then a short simulation WITH and WITHOUT the effect checked against the signature table in the
effect's module docstring.

Test case: the ``spur-gds`` preset with a 25-tooth pinion (ratio exactly 4), so that a wheel
revolution is 100 mesh cycles and a wheel-borne error gives a periodic record of 0.16 s (with the
29/100 preset it would be the 4 s hunting period); 1500 rpm (f_m = 625 Hz, fr_pinion = 25 Hz,
fr_wheel = 6.25 Hz), 20 N m, 0.48 s at 10 kHz = 12 pinion / 3 wheel revolutions, so that every named
line sits on an FFT bin: stationary cases are solved for their periodic steady state and read with a
rectangular window (exact line amplitudes, no leakage); the speed/torque cases are time-stepped
(0.5 s start-up discarded) and read with a Hann window. ``omega_dt = 0.6``: the modes in the output
band (<= 2.6 kHz) stay at w dt <= 0.15. Channel: the pinion bearing-housing acceleration along the
line of action unless stated. Every simulation is computed once per module (cached).
"""
from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np
import pytest
from scipy.special import jv

import datagen.effects as fx
from datagen.effects.accuracy_grade import gear_tolerances, iso1328_tolerances
from datagen.effects.eccentricity import EccentricityPinion, EccentricityWheel
from datagen.effects.hertz_nonlinear import hertz_nonlinear_stiffness, ma_zeng_hertz_stiffness_n_per_m
from datagen.effects.pitch_error import PitchError
from datagen.effects.profile_error import ProfileError, profile_deviation_m, profile_fraction
from datagen.effects.tip_relief import TipRelief, design_relief_m, relief_length_m
from datagen.geometry import spur_pair_example
from datagen.simulate import Case, OperatingPoint, SolverOptions, StiffnessOptions, simulate
from datagen.stiffness import mesh_stiffness
from features.spectra import line_amplitudes
from gearpit.errors import InputError

_SPUR = spur_pair_example()
PAIR = replace(_SPUR, pinion=replace(_SPUR.pinion, teeth=25), name="spur-gds-z25")
RPM, TORQUE, FS, DURATION = 1500.0, 20.0, 10000.0, 0.48
FR1 = RPM / 60.0
FM = PAIR.pinion.teeth * FR1
FR2 = FR1 * PAIR.pinion.teeth / PAIR.wheel.teeth
ACC = "acc_pinion_loa_m_s2"
PPC = 32
F_FLUCT = 12.5          # speed / torque fluctuation frequency (Hz): 6 bins, between fr2 multiples

STATIONARY = {
    "healthy": (),
    "profile_error": ({"name": "profile_error", "grade": 6.0, "cycles": 2.0},),
    "pitch_error_wheel": ({"name": "pitch_error", "grade": 6.0, "gears": "wheel"},),
    "pitch_error_pinion_tooth": ({"name": "pitch_error", "grade": 6.0, "gears": "pinion", "single_tooth_factor": 2.0},),
    "eccentricity_pinion": ({"name": "eccentricity_pinion", "amplitude_m": 10e-6},),
    "eccentricity_wheel": ({"name": "eccentricity_wheel", "amplitude_m": 10e-6},),
    "hertz_nonlinear": ({"name": "hertz_nonlinear"},),
}
TRANSIENT = {
    "healthy": (),
    "speed_fluctuation": ({"name": "speed_fluctuation", "amplitude_fraction": 0.01, "frequency_hz": F_FLUCT},),
    "torque_fluctuation": ({"name": "torque_fluctuation", "amplitude_fraction": 0.2, "frequency_hz": F_FLUCT},),
}


def _case(effects, torque_nm=TORQUE, method="periodic"):
    solver = SolverOptions(omega_dt=0.6, method=method, transient_s=0.5 if method == "transient" else None)
    return Case(pair=PAIR, operating=OperatingPoint(RPM, torque_nm), duration_s=DURATION, fs_hz=FS, effects=effects,
                stiffness=StiffnessOptions(positions_per_cycle=PPC), solver=solver)


@lru_cache(maxsize=None)
def stationary() -> dict:
    """Periodic steady states of the stationary cases (one batch per record period)."""
    return dict(zip(STATIONARY, simulate([_case(e) for e in STATIONARY.values()])))


@lru_cache(maxsize=None)
def transient() -> dict:
    """Time-stepped cases sharing one grid (one batch)."""
    return dict(zip(TRANSIENT, simulate([_case(e, method="transient") for e in TRANSIENT.values()])))


@lru_cache(maxsize=None)
def relief_runs() -> dict:
    """Tip relief at the design load and at a quarter of it, with the healthy references."""
    c_a = design_relief_m(mesh_stiffness(PAIR, positions_per_cycle=PPC), TORQUE)
    relief = ({"name": "tip_relief", "amount_m": c_a, "length_fraction": 1.0, "shape": "linear"},)
    keys = [("healthy", TORQUE), ("relief", TORQUE), ("healthy", TORQUE / 4), ("relief", TORQUE / 4)]
    runs = simulate([_case(relief if k == "relief" else (), torque_nm=t) for k, t in keys])
    return dict(zip(keys, runs))


def lines(sig, freqs, channel=ACC, window="boxcar"):
    """Line amplitudes (unit of the channel) of the mean-removed channel at ``freqs`` (Hz)."""
    x = sig.channels[channel]
    return line_amplitudes(x - x.mean(), FS, freqs, window=window)


def db(a, b):
    return 20.0 * np.log10(np.asarray(a) / np.asarray(b))


# ---------------------------------------------------------------------- ISO 1328 tolerances
def test_iso1328_formulas_and_grade_step():
    """ISO 1328-1:1995 (and Annex B) grade-5 formulas by hand for m = 2 mm, d = 58 mm, and the
    sqrt(2) step between grades (grade 7 = 2 x grade 5); rel 1e-12."""
    t5 = iso1328_tolerances(5, 2e-3, 58e-3)
    m, d = 2.0, 58.0
    assert t5.profile_form_m == pytest.approx((2.5 * m**0.5 + 0.17 * d**0.5 + 0.5) * 1e-6, rel=1e-12)
    assert t5.profile_slope_m == pytest.approx((2.0 * m**0.5 + 0.14 * d**0.5 + 0.5) * 1e-6, rel=1e-12)
    assert t5.single_pitch_m == pytest.approx((0.3 * (m + 0.4 * d**0.5) + 4.0) * 1e-6, rel=1e-12)
    assert t5.cumulative_pitch_m == pytest.approx((0.3 * m + 1.25 * d**0.5 + 7.0) * 1e-6, rel=1e-12)
    assert t5.runout_m == pytest.approx((0.24 * m + d**0.5 + 5.6) * 1e-6, rel=1e-12)   # ISO 1328-2: 0.8 F_p
    t7 = iso1328_tolerances(7, 2e-3, 58e-3)
    assert t7.profile_form_m == pytest.approx(2 * t5.profile_form_m, rel=1e-12)
    with pytest.raises(InputError):
        iso1328_tolerances(13, 2e-3, 58e-3)


# ---------------------------------------------------------------------- deviation functions
def test_profile_deviation_formula():
    """Spur paper / Mucchi: e = f_H s/l + (f_f/2) sin(2 pi n s/l + phi): the slope term spans f_H over
    the profile, the form term's range is f_f (ISO 1328-1 defines f_f as a range); abs 1e-15 m.
    s/l runs 0 -> 1 from the start of active profile to the tip on both gears (wheel tip at A)."""
    u = np.linspace(0, 1, 20001)
    f_h, f_f = 4e-6, 6e-6
    slope = profile_deviation_m(u, f_h, 0.0, 2.0, 0.3)
    assert slope[-1] - slope[0] == pytest.approx(f_h, abs=1e-15)
    form = profile_deviation_m(u, 0.0, f_f, 2.0, 0.3)
    assert form.max() - form.min() == pytest.approx(f_f, rel=1e-6)
    a, e = PAIR.contact_start_m, PAIR.contact_end_m
    assert profile_fraction(PAIR, "pinion", np.array([a, e])) == pytest.approx([0.0, 1.0], abs=1e-12)
    assert profile_fraction(PAIR, "wheel", np.array([e, a])) == pytest.approx([0.0, 1.0], abs=1e-12)


def test_profile_error_is_the_same_on_every_tooth():
    """Module docstring: identical on all teeth (deviation period 1 mesh cycle); both gears add; abs 1e-18 m."""
    ctx = fx.EffectContext(pair=PAIR, speed_rpm=RPM, torque_nm=TORQUE)
    g = np.linspace(PAIR.contact_start_m, PAIR.contact_end_m, 50)
    both = ProfileError(gears="both")
    e0 = both.tooth_deviation_m(g, np.zeros(50, int), np.zeros(50, int), ctx)
    e7 = both.tooth_deviation_m(g, np.full(50, 7), np.full(50, 61), ctx)
    assert np.allclose(e0, e7, atol=1e-18, rtol=0)
    parts = sum(ProfileError(gears=w).tooth_deviation_m(g, np.zeros(50, int), np.zeros(50, int), ctx)
                for w in ("pinion", "wheel"))
    assert np.allclose(e0, parts, atol=1e-18, rtol=0)
    assert both.deviation_period_cycles(ctx) == 1


def test_pitch_error_tooth_table():
    """Module docstring: e_j = cos(alpha_t) [(F_p/2) sin(2 pi j/z + phi) + c f_pt [j = 0]]; the range of the
    cumulative part is F_p cos(alpha_t) and the period is z of the erroneous gear(s); rel 1e-9."""
    ctx = fx.EffectContext(pair=PAIR, speed_rpm=RPM, torque_nm=TORQUE)
    tol = gear_tolerances(PAIR, "wheel", 6.0)
    cos_a = math.cos(PAIR.pressure_angle_t_rad)
    plain = PitchError(grade=6.0, gears="wheel").tooth_table_m(PAIR, "wheel")
    assert plain.max() - plain.min() == pytest.approx(tol.cumulative_pitch_m * cos_a, rel=1e-9)
    bumped = PitchError(grade=6.0, gears="wheel", single_tooth_factor=1.5).tooth_table_m(PAIR, "wheel")
    assert bumped - plain == pytest.approx(np.r_[1.5 * tol.single_pitch_m * cos_a, np.zeros(99)], abs=1e-15)
    assert PitchError(gears="both").deviation_period_cycles(ctx) == math.lcm(25, 100)
    assert PitchError(gears="pinion").deviation_period_cycles(ctx) == 25


def test_tip_relief_profile():
    """Module docstring: e = C_a (d / L_a)^p inside the relief zone, 0 outside; pinion tip at E, wheel
    tip at A; L_a = (eps_alpha - 1) p_bt for length_fraction 1; abs 1e-18 m."""
    ctx = fx.EffectContext(pair=PAIR, speed_rpm=RPM, torque_nm=TORQUE)
    a, e = PAIR.contact_start_m, PAIR.contact_end_m
    la = relief_length_m(PAIR, 1.0)
    assert la == pytest.approx((e - a) - PAIR.base_pitch_m, rel=1e-12)
    z = np.zeros(5, int)
    g = np.array([a, a + la / 2, (a + e) / 2, e - la / 2, e])
    lin = TipRelief(amount_m=8e-6, shape="linear").tooth_deviation_m(g, z, z, ctx)
    assert lin == pytest.approx([8e-6, 4e-6, 0.0, 4e-6, 8e-6], abs=1e-18)
    par = TipRelief(amount_m=8e-6, shape="parabolic", gears="pinion").tooth_deviation_m(g, z, z, ctx)
    assert par == pytest.approx([0.0, 0.0, 0.0, 2e-6, 8e-6], abs=1e-18)


def test_eccentricity_deviation():
    """Module docstring: e = a sin(theta + phi) of that gear's angle, period z of that gear; abs 1e-18 m."""
    ctx = fx.EffectContext(pair=PAIR, speed_rpm=RPM, torque_nm=TORQUE)
    th = np.linspace(0, 2 * np.pi, 9)
    ep, ew = EccentricityPinion(amplitude_m=5e-6, phase_rad=0.5), EccentricityWheel(amplitude_m=5e-6, phase_rad=0.5)
    assert ep.angle_deviation_m(th, 0 * th, ctx) == pytest.approx(5e-6 * np.sin(th + 0.5), abs=1e-18)
    assert ew.angle_deviation_m(th, 0 * th, ctx) == pytest.approx(np.full(9, 5e-6 * np.sin(0.5)), abs=1e-18)
    assert (ep.deviation_period_cycles(ctx), ew.deviation_period_cycles(ctx)) == (25, 100)


def test_fluctuation_needs_a_frequency():
    """Contract: bad input raises InputError naming the field (a zero frequency would be a constant offset)."""
    with pytest.raises(InputError, match="frequency_hz"):
        fx.EffectSpec.from_dict({"name": "speed_fluctuation", "frequency_hz": 0.0, "order": 0.0}).build()
    with pytest.raises(InputError, match="amplitude_fraction"):
        fx.EffectSpec.from_dict({"name": "torque_fluctuation", "amplitude_fraction": 2.0}).build()


def test_hertz_nonlinear_single_contact_compliance():
    """Spur paper / Ma & Zeng: where one pair carries the whole load F = T / rb1, its compliance grows by
    exactly 1 / k_h(E, b, F) - 4 (1 - nu^2) / (pi E b) (nonlinear minus linear Hertz compliance of the
    pair); rel 1e-9. Quadrupling the torque shrinks the mean-stiffness loss (k_h ~ F^0.1)."""
    ms = mesh_stiffness(PAIR, positions_per_cycle=PPC)
    hz = hertz_nonlinear_stiffness(ms, TORQUE)
    single = np.count_nonzero(ms.k_slots_n_per_m > 0, axis=1) == 1
    assert single.any()
    b = PAIR.contact_face_width_m
    E, nu = PAIR.material.youngs_modulus_pa, PAIR.material.poisson
    kh = float(ma_zeng_hertz_stiffness_n_per_m(E, b, TORQUE / PAIR.base_radius_m("pinion")))
    expected = 1.0 / kh - 4 * (1 - nu**2) / (math.pi * E * b)
    got = 1.0 / hz.k_n_per_m[single] - 1.0 / ms.k_n_per_m[single]
    assert got == pytest.approx(np.full(got.size, expected), rel=1e-9)
    loss_20 = 1 - hz.mean_n_per_m / ms.mean_n_per_m
    loss_80 = 1 - hertz_nonlinear_stiffness(ms, 4 * TORQUE).mean_n_per_m / ms.mean_n_per_m
    assert 0.03 < loss_80 < loss_20 < 0.3
    with pytest.raises(InputError, match="torque_nm"):
        hertz_nonlinear_stiffness(ms, 0.0)


# ---------------------------------------------------------------------- simulated signatures
def test_profile_error_raises_mesh_harmonics_only():
    """profile_error signature (its module docstring): mesh harmonics 1..3 rise (each > +2 dB, their rss
    > +6 dB at grade 6; measured +17.7, +3.2, +9.2 dB); no shaft-order sidebands: fm +/- fr of both
    shafts stay 80 dB below fm (measured < -95 dB)."""
    h, p = stationary()["healthy"], stationary()["profile_error"]
    harm = [FM, 2 * FM, 3 * FM]
    ah, ap = lines(h, harm), lines(p, harm)
    assert np.all(db(ap, ah) > 2.0), db(ap, ah)
    assert db(np.linalg.norm(ap), np.linalg.norm(ah)) > 6.0
    sb = lines(p, [FM - FR1, FM + FR1, FM - FR2, FM + FR2])
    assert np.all(db(sb, ap[0]) < -80.0), db(sb, ap[0])


def test_pitch_error_wheel_sidebands_and_pinion_comb():
    """pitch_error signature (module docstring; McFadden & Smith 1985 sideband families): a wheel
    cumulative error raises fm +/- fr_wheel by > 60 dB to within 20 dB of fm (measured -16, -11 dB),
    leaving fm +/- fr_pinion 60 dB below fm (the periodic solver's numerical floor is ~ -80 dB); one
    displaced pinion tooth gives a comb of pinion orders 1..5 (each > 40 dB above the healthy line)
    and fm +/- fr_pinion sidebands within 20 dB of fm (measured -10.5, -8.8 dB)."""
    st = stationary()
    h, w, p = st["healthy"], st["pitch_error_wheel"], st["pitch_error_pinion_tooth"]
    side2 = [FM - FR2, FM + FR2]
    assert np.all(db(lines(w, side2), lines(h, side2)) > 60.0)
    assert np.all(db(lines(w, side2), lines(w, [FM])) > -20.0)
    assert np.all(db(lines(w, [FM - FR1, FM + FR1]), lines(w, [FM])) < -60.0)
    orders = [k * FR1 for k in range(1, 6)]
    assert np.all(db(lines(p, orders), lines(h, orders)) > 40.0), db(lines(p, orders), lines(h, orders))
    assert np.all(db(lines(p, [FM - FR1, FM + FR1]), lines(p, [FM])) > -20.0)


@pytest.mark.parametrize("gear", ["pinion", "wheel"])
def test_eccentricity_sidebands_of_its_shaft(gear):
    """eccentricity signature (module docstring; Randall 1982, McFadden & Smith 1985): the transmission
    error carries 1x of that shaft with amplitude a (kinematic: the train follows a slow error; rel 5 %);
    fm +/- fr of that shaft rise by > 20 dB over the healthy record (weak in absolute terms: measured
    -60/-55 dB re fm for the pinion, -73/-71 dB for the wheel at a = 10 um); the other shaft's
    sidebands stay 60 dB below fm (the periodic solver's numerical floor is ~ -80 dB)."""
    st = stationary()
    h, e = st["healthy"], st[f"eccentricity_{gear}"]
    fr, other = (FR1, FR2) if gear == "pinion" else (FR2, FR1)
    assert lines(e, [fr], channel="dte_m")[0] == pytest.approx(10e-6, rel=0.05)
    own = [FM - fr, FM + fr]
    assert np.all(db(lines(e, own), lines(h, own)) > 20.0), db(lines(e, own), lines(h, own))
    assert np.all(db(lines(e, [FM - other, FM + other]), lines(e, [FM])) < -60.0)


def test_tip_relief_lowers_fm_at_design_load_and_raises_it_at_light_load():
    """tip_relief signature (module docstring; Tavakoli & Houser 1986): long linear relief of the
    single-pair static deflection at the design load lowers the fm line by > 10 dB (about -15 dB
    here); at a quarter of that load the same relief raises fm by > 6 dB."""
    r = relief_runs()
    at_design = db(lines(r[("relief", TORQUE)], [FM]), lines(r[("healthy", TORQUE)], [FM]))[0]
    light = db(lines(r[("relief", TORQUE / 4)], [FM]), lines(r[("healthy", TORQUE / 4)], [FM]))[0]
    assert at_design < -10.0, at_design
    assert light > 6.0, light


def test_hertz_nonlinear_lowers_stiffness_and_mesh_mode():
    """hertz_nonlinear signature (module docstring): mean mesh stiffness falls by 5-30 %; the mesh mode
    (the highest mode here, ~95 % of its strain energy in the mesh spring) falls with it: f'/f =
    sqrt(1 + 0.95 dk/k) (Rayleigh quotient), rel 1 %."""
    h, n = stationary()["healthy"], stationary()["hertz_nonlinear"]
    k0, k1 = h.metadata["mean_mesh_stiffness_n_per_m"], n.metadata["mean_mesh_stiffness_n_per_m"]
    assert 0.70 < k1 / k0 < 0.95
    f0, f1 = h.metadata["solver"]["natural_frequencies_hz"][-1], n.metadata["solver"]["natural_frequencies_hz"][-1]
    assert f1 / f0 == pytest.approx(math.sqrt(1 + 0.95 * (k1 / k0 - 1)), rel=0.01)


def test_speed_fluctuation_fm_sidebands():
    """speed_fluctuation signature (module docstring; Randall 2011, FM sidebands): fm +/- f_s rise by > 40 dB;
    their mean ratio to fm matches the phase-modulation value J1(beta)/J0(beta) with beta = a fm / f_s
    and a the pinion speed fluctuation actually measured (the motor follows the modulated reference
    through its speed loop), within 10 % (measured: 1 %; the load's inertia torque adds a little AM)."""
    h, s = transient()["healthy"], transient()["speed_fluctuation"]
    side = [FM - F_FLUCT, FM + F_FLUCT]
    assert np.all(db(lines(s, side, window="hann"), lines(h, side, window="hann")) > 40.0)
    a = lines(s, [F_FLUCT], channel="speed_pinion_rpm", window="hann")[0] / RPM
    assert 0.001 < a < 0.02
    beta = a * FM / F_FLUCT
    ratio = lines(s, side, window="hann").mean() / lines(s, [FM], window="hann")[0]
    assert ratio == pytest.approx(jv(1, beta) / jv(0, beta), rel=0.1)


def test_torque_fluctuation_line_and_sidebands():
    """torque_fluctuation signature (module docstring): the mesh force carries a line at f_t (> 60 dB
    above the healthy record there; within a factor 3 of the applied ripple a T / rb1, the train's
    torsion modes shaping it) and fm +/- f_t rise by > 30 dB in the housing acceleration."""
    h, t = transient()["healthy"], transient()["torque_fluctuation"]
    ft_h = lines(h, [F_FLUCT], channel="mesh_force_n", window="hann")[0]
    ft = lines(t, [F_FLUCT], channel="mesh_force_n", window="hann")[0]
    assert db(ft, ft_h) > 60.0
    ripple = 0.2 * TORQUE / PAIR.base_radius_m("pinion")
    assert ripple / 3 < ft < 3 * ripple
    side = [FM - F_FLUCT, FM + F_FLUCT]
    assert np.all(db(lines(t, side, window="hann"), lines(h, side, window="hann")) > 30.0)


def test_random_single_pitch_deviations_have_the_asked_spread_and_close():
    """pitch_error's random single pitch deviations (module docstring of datagen.effects.pitch_error). Source: the
    definition: a single pitch deviation is the position difference of adjacent teeth; with random_single_factor r
    their standard deviation is r f_pt (ISO 1328-1 tolerance of the grade) along the line of action times
    cos(alpha_t), to 1e-9; once round they sum to zero (the teeth close the circle); the draw is the seed's; with
    r = 0 the table is the sinusoid alone, as before."""
    from datagen.geometry import preset

    pair = preset("spur-gds")
    tol = gear_tolerances(pair, "pinion", 5.0)
    plain = PitchError(grade=5.0).tooth_table_m(pair, "pinion")
    ref = 0.5 * tol.cumulative_pitch_m * np.sin(2 * np.pi * np.arange(29) / 29) * math.cos(pair.pressure_angle_t_rad)
    np.testing.assert_allclose(plain, ref, atol=1e-15)
    a = PitchError(grade=5.0, random_single_factor=0.5, random_seed=12).tooth_table_m(pair, "pinion")
    steps = np.diff(np.r_[a - plain, (a - plain)[0]])
    assert abs(steps.sum()) < 1e-15
    assert np.std(steps) == pytest.approx(0.5 * tol.single_pitch_m * math.cos(pair.pressure_angle_t_rad), rel=1e-9)
    b = PitchError(grade=5.0, random_single_factor=0.5, random_seed=12).tooth_table_m(pair, "pinion")
    c = PitchError(grade=5.0, random_single_factor=0.5, random_seed=13).tooth_table_m(pair, "pinion")
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - c)) > 0.3 * tol.single_pitch_m
