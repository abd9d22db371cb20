"""A simulation asked for a few channels (``simulate(cases, channels=...)``) makes only what they are made of.

The contract (datagen.simulate.simulate, Effect.channels_read): every asked channel is the same to the bit as in a
simulation of every channel, on both solution paths, through the output hooks that rename or mix channels
(housing path: acceleration from the bearing force), draw noise (one generator over every acceleration, in
sorted order) or read other channels (encoder error: the shaft speeds); a plugin output hook that says nothing
about what it reads sees every channel; an unknown name is an error naming the field.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from datagen.effects import get
from datagen.effects.base import Effect, register, unregister
from datagen.geometry import helical_pair_example, spur_pair_example
from datagen.simulate import Case, OperatingPoint, simulate, solver_channels
from gearpit.errors import InputError


def _case(pair, effects, speed_rpm=1000.0):
    return Case(pair, OperatingPoint(speed_rpm, 50.0), duration_s=0.15, fs_hz=20000.0, seed=3, effects=tuple(effects))


@pytest.mark.parametrize("label, pair, effects, wanted, method", [
    # periodic path; the noise is drawn over both accelerations, which the housing path makes from the forces
    ("spur, housing path, noise", spur_pair_example(), lambda: [get("transmission_path")(), get("noise")(snr_db=30.0)],
     ("acc_pinion_loa_m_s2",), "periodic"),
    # time-stepped; helical: the axial acceleration sorts before the line-of-action one, so its noise draw comes
    # first and must be made even though it is not asked for
    ("helical, speed fluctuation, housing path, noise", helical_pair_example(),
     lambda: [get("speed_fluctuation")(frequency_hz=10.0, amplitude_fraction=0.01), get("transmission_path")(),
              get("noise")(snr_db=25.0)], ("acc_pinion_loa_m_s2", "tacho_pinion"), "transient"),
    # the encoder error reads the shaft speeds
    ("spur, torque fluctuation, encoder error", spur_pair_example(),
     lambda: [get("torque_fluctuation")(), get("shaft_encoder_error")(pinion_rad=1e-4, wheel_rad=5e-5)],
     ("dte_m",), "transient"),
])
def test_asked_channels_equal_those_of_a_full_simulation_to_the_bit(label, pair, effects, wanted, method):
    case = _case(pair, effects())
    full = simulate([case])[0]
    sub = simulate([case], channels=wanted)[0]
    assert full.metadata["solver"]["method"] == method
    for name in wanted:
        assert np.array_equal(sub.channels[name], full.channels[name]), (label, name)
    assert len(sub.channels) < len(full.channels), sorted(sub.channels)   # the point: fewer channels made


def test_solver_channels_walk_the_output_hooks_back():
    path, noise, enc = get("transmission_path")(), get("noise")(), get("shaft_encoder_error")()
    assert solver_channels((path,), ["acc_wheel_loa_m_s2"]) == {"force_bearing_wheel_loa_n"}
    assert solver_channels((enc,), ["dte_m"]) == {"dte_m", "speed_pinion_rpm", "speed_wheel_rpm"}
    # the noise needs every acceleration; the path (applied before it) makes them from the forces
    assert solver_channels((path, noise), ["dte_m"]) == {"dte_m", "force_bearing_pinion_loa_n",
                                                         "force_bearing_wheel_loa_n", "force_bearing_pinion_axial_n",
                                                         "force_bearing_wheel_axial_n"}
    assert solver_channels((get("noise")(channels="all"),), ["dte_m"]) is None
    assert solver_channels((path,), None) is None


def test_a_plugin_output_hook_that_declares_nothing_sees_every_channel():
    seen = []

    @register
    @dataclass(frozen=True)
    class Spy(Effect):
        name = "test_channel_spy"
        signature = "records the channels its output hook is given"

        def output_path(self, channels, fs_hz, ctx):
            seen.append(sorted(channels))
            return channels

    try:
        case = _case(spur_pair_example(), [get("test_channel_spy")()])
        full = simulate([case])[0]
        sub = simulate([case], channels=["dte_m"])[0]
    finally:
        unregister("test_channel_spy")
    assert seen[0] == seen[1] and "acc_pinion_loa_m_s2" in seen[1]
    assert np.array_equal(sub.channels["dte_m"], full.channels["dte_m"])


def test_an_unknown_channel_is_an_error_naming_the_field_and_the_channels():
    with pytest.raises(InputError, match=r"channels.*acc_nowhere.*acc_pinion_loa_m_s2"):
        simulate([_case(spur_pair_example(), [])], channels=["acc_nowhere"])


@pytest.mark.parametrize("q", [1, 2, 3, 7])
def test_a_decimated_column_does_not_depend_on_how_many_are_decimated_with_it(q):
    """A batch of one case asked for one channel decimates one column, which BLAS would take as a matrix-vector
    product, summed in another order (2e-16 apart): a chaotic model's record must equal its realisations' first
    to the bit (compare.chaos), so one column is padded (datagen.decimation.FirDecimator._filter)."""
    from datagen.decimation import FirDecimator

    x = np.random.default_rng(0).standard_normal((4000, 16))
    every = FirDecimator(6)._filter(x, 600)
    assert np.array_equal(FirDecimator(6)._filter(np.ascontiguousarray(x[:, :q]), 600), every[:, :q])


@pytest.mark.parametrize("pair, effects", [
    (spur_pair_example(), lambda: [get("pitch_error")(grade=6.0)]),                       # periodic path
    (helical_pair_example(), lambda: [get("pitch_error")(grade=6.0)]),                    # periodic, 8 DOFs
    (helical_pair_example(), lambda: [get("speed_fluctuation")(frequency_hz=12.0)]),      # time-stepped
])
def test_every_channel_asked_alone_equals_its_full_simulation(pair, effects):
    """Each channel alone: the solver stores only the state components it is made of (the periodic path's
    datagen.output_channels.state_rows) and decimates only it; a component missed would leave zeros."""
    case = _case(pair, effects())
    full = simulate([case])[0]
    for name, x in full.channels.items():
        sub = simulate([case], channels=[name])[0]
        assert np.array_equal(sub.channels[name], x), name
