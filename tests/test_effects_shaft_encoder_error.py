"""shaft_encoder_error (datagen/effects/shaft_encoder_error.py): the once-per-revolution eccentricity error of two shaft
encoders on the measured transmission error.

Reference: the encoder model of Remond (2000), TE = rb1 theta1_meas - rb2 theta2_meas with an eccentric disc
reading theta + (e / r) sin(theta + psi); so the added lines are rb1 a1 at fr_pinion and rb2 a2 at fr_wheel,
exactly. Test case as tests/test_effects_signatures.py: spur-gds with a 25-tooth pinion (ratio 4), 1500 rpm,
0.48 s at 10 kHz = 12 pinion / 3 wheel revolutions, so both shaft lines sit on FFT bins (rectangular window,
no leakage).
"""
from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np
import pytest

from datagen.effects.shaft_encoder_error import ShaftEncoderError, shaft_angle_rad
from datagen.geometry import spur_pair_example
from datagen.simulate import Case, OperatingPoint, SolverOptions, StiffnessOptions, simulate
from features.spectra import line_amplitudes
from gearpit.errors import InputError

_SPUR = spur_pair_example()
PAIR = replace(_SPUR, pinion=replace(_SPUR.pinion, teeth=25), name="spur-gds-z25")
RPM, FS, DURATION = 1500.0, 10000.0, 0.48
FR1, FR2 = RPM / 60.0, RPM / 60.0 * 25 / 100
A1, A2 = 2e-4, 1e-4


def _case(effects):
    return Case(pair=PAIR, operating=OperatingPoint(RPM, 40.0), duration_s=DURATION, fs_hz=FS, effects=effects,
                stiffness=StiffnessOptions(positions_per_cycle=32), solver=SolverOptions(omega_dt=0.6))


@lru_cache(maxsize=None)
def runs():
    enc = {"name": "shaft_encoder_error", "pinion_rad": A1, "wheel_rad": A2, "pinion_phase_rad": 0.3,
           "wheel_phase_rad": -1.1}
    zero = {"name": "shaft_encoder_error", "pinion_rad": 0.0, "wheel_rad": 0.0}
    # each case alone: in one batch a case's place can change the last bits of every channel (measured on a fresh
    # install with numpy 2.4.6, numba 0.68.1: the third case 5e-11 of 214 m/s^2 off the first), and this test is
    # about the effect, not the batch
    return [simulate([_case(effects)])[0] for effects in ((), (enc,), (zero,))]


def test_shaft_lines_of_the_transmission_error_are_rb_times_the_angle_error():
    """The difference with/without the effect has amplitude rb1 a1 at fr_pinion and rb2 a2 at fr_wheel (Remond
    2000; tolerance 0.5 %: the speed channels carry the vibration's tiny speed ripple), and nothing at the mesh
    frequency (< 1e-3 of the pinion line)."""
    base, enc, _ = runs()
    d = enc.channels["dte_m"] - base.channels["dte_m"]
    a = line_amplitudes(d - d.mean(), FS, [FR1, FR2, 25 * FR1], window="boxcar")
    rb1, rb2 = PAIR.base_radius_m("pinion"), PAIR.base_radius_m("wheel")
    np.testing.assert_allclose(a[:2], [rb1 * A1, rb2 * A2], rtol=5e-3)
    assert a[2] < 1e-3 * a[0]


def test_only_the_transmission_error_changes_and_zero_amplitudes_change_nothing():
    """Every channel but dte_m is bit-identical with the effect on; with both amplitudes 0 every channel is."""
    base, enc, zero = runs()
    for k, v in base.channels.items():
        if k != "dte_m":
            assert np.array_equal(v, enc.channels[k]), k
        assert np.array_equal(v, zero.channels[k]), k
    assert not np.array_equal(base.channels["dte_m"], enc.channels["dte_m"])


def test_shaft_angle_integrates_the_speed():
    """A constant 600 rpm for 1 s at 1 kHz is 10 revolutions: the angle at the last sample is 2 pi 10 (999/1000)
    (trapezoid rule exact for a constant), 0 at the first."""
    th = shaft_angle_rad(np.full(1000, 600.0), 1000.0)
    assert th[0] == 0.0
    assert th[-1] == pytest.approx(2 * np.pi * 10 * 999 / 1000, rel=1e-12)


@pytest.mark.parametrize("field,value", [("pinion_rad", -1e-5), ("wheel_rad", 5e-3), ("pinion_phase_rad", 4.0)])
def test_out_of_range_parameters_are_refused(field, value):
    """Bounds from the field metadata: InputError naming the field."""
    with pytest.raises(InputError, match=field):
        ShaftEncoderError(**{field: value})
