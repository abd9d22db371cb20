"""A real tachometer's faults: noise on slow edges, a missing pulse, a spike between pulses, a wrong sidecar
(features.tacho.tacho_pulse_times / tacho_pulse_index, compare.speed.speed_from_tacho). Source: the pulse train is
written here from a known shaft angle, so the true speed is known exactly."""
from __future__ import annotations

import numpy as np
import pytest

from compare.speed import speed_from_tacho
from features.tacho import tacho_pulse_index, tacho_pulse_times
from gearpit.errors import InputError

FS = 20000.0
T = 2.0
RPM = 1000.0


def _pulses(*, ramp=0.0, noise=0.0, seed=0, duty=0.05, edge=0.01):
    """One pulse per revolution (``duty`` of it high), raised-cosine edges over ``edge`` of a revolution; the
    speed rises by ``ramp`` over the record. Returns the channel and the true mean speed (rpm)."""
    t = np.arange(int(FS * T)) / FS
    f0 = RPM / 60.0
    phase = f0 * (t + 0.5 * ramp * t ** 2 / T)
    frac = phase % 1.0
    up = np.clip(frac / edge, 0, 1)
    down = np.clip((duty + edge - frac) / edge, 0, 1)
    x = np.where(frac < duty + edge, np.minimum(0.5 - 0.5 * np.cos(np.pi * up), 0.5 - 0.5 * np.cos(np.pi * down)), 0.)
    x = x + noise * np.random.default_rng(seed).standard_normal(t.size)
    return x, 60.0 * phase[-1] / t[-1]


def _speed(x):
    return speed_from_tacho(x, FS, z_pinion=29, z_wheel=100, nominal_rpm=RPM).speed_rpm


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noise_on_slow_edges_counts_each_pulse_once(seed):
    """Noise of 10 % of the pulse height on edges lasting 1 % of a revolution: a single threshold counted 37
    edges for 34 pulses and read 1082 rpm for 1000; the Schmitt trigger counts 34 and the speed is within
    0.01 %."""
    x, true = _pulses(noise=0.10, seed=seed)
    assert tacho_pulse_times(x, FS).size == 34
    assert _speed(x) == pytest.approx(true, rel=1e-4)


def test_a_missing_pulse_skips_a_count_and_a_spike_is_dropped():
    """A pulse that drops out (read 968 rpm for 1000 before) leaves a gap of two intervals; a full-height spike
    half-way between two pulses (1025 rpm before) is no pulse. Both: the speed within 1e-6."""
    x, true = _pulses()
    i = int(10.5 / (RPM / 60) * FS)
    gap = x.copy()
    gap[i - int(0.6 * FS * 60 / RPM): i + int(0.3 * FS * 60 / RPM)] = 0.0
    times, index, _ = tacho_pulse_index(tacho_pulse_times(gap, FS), 60.0 / RPM)
    assert times.size == 33 and index[-1] == 33 and np.count_nonzero(np.diff(index) == 2) == 1
    assert _speed(gap) == pytest.approx(true, rel=1e-6)
    spike = x.copy()
    spike[int(12.5 / (RPM / 60) * FS)] = 1.0
    assert tacho_pulse_times(spike, FS).size == 35
    times, index, _ = tacho_pulse_index(tacho_pulse_times(spike, FS), 60.0 / RPM)
    assert times.size == 34 and index[-1] == 33
    assert _speed(spike) == pytest.approx(true, rel=1e-6)


def test_a_run_up_keeps_every_pulse():
    """The speed rising 10 % over the record: no pulse is taken for a spike (the pulses follow a smooth speed)."""
    x, true = _pulses(ramp=0.10)
    times, index, _ = tacho_pulse_index(tacho_pulse_times(x, FS), 60.0 / RPM)
    assert times.size == 35 and index[-1] == 34 and np.all(np.diff(index) == 1)
    assert _speed(x) == pytest.approx(true, rel=1e-5)


def test_a_tacho_unlike_the_sidecars_speed_is_refused_naming_the_keys():
    """One pulse per revolution declared as two: the tacho reads 500 rpm against the sidecar's 1000, refused with
    the keys to check. Two evenly spaced pulses declared as one: every other one is a revolution, 1000 rpm."""
    x1, _ = _pulses()
    with pytest.raises(InputError, match="tacho_pulses_per_rev"):
        speed_from_tacho(x1, FS, z_pinion=29, z_wheel=100, nominal_rpm=RPM, pulses_per_rev=2)
    x2 = np.maximum(x1, np.roll(x1, int(FS * 30.0 / RPM)))       # a second pulse half a revolution later
    for ppr in (1, 2):
        est = speed_from_tacho(x2, FS, z_pinion=29, z_wheel=100, nominal_rpm=RPM, pulses_per_rev=ppr)
        assert est.speed_rpm == pytest.approx(RPM, rel=1e-4)


@pytest.mark.parametrize("kind", ["rpm", "volts", "noise", "ramp"])
def test_a_channel_that_is_no_pulse_train_is_refused_saying_what_it_looks_like(kind):
    """An analogue speed channel (1000 rpm, or 1.0 V, with noise), a noise-only input or a run-up ramp given as the
    tacho had the Schmitt trigger read edges in the noise and were refused as "a pulse every 36.9 ms, i.e. 1625.9
    rpm ... check speed_rpm, tacho_pulses_per_rev..." (the audit's tacho_cases.py). Now: not a pulse train (the
    share of samples between its levels), and for a level in a plausible rpm range the suggestion of a speed
    channel, which the sidecar has no key for."""
    rng = np.random.default_rng(8)
    n = int(FS)
    x = {"rpm": RPM + 2.0 * rng.standard_normal(n), "volts": RPM / 1000.0 + 0.002 * rng.standard_normal(n),
         "noise": 0.05 * rng.standard_normal(n), "ramp": np.linspace(0.9, 1.1, n) * RPM + rng.standard_normal(n)}[kind]
    with pytest.raises(InputError, match="between its low and high levels") as exc:
        speed_from_tacho(x, FS, z_pinion=29, z_wheel=100, nominal_rpm=RPM)
    msg = str(exc.value)
    assert "channel tacho" in msg and "a pulse train" in msg and "pulse every" not in msg
    if kind in ("rpm", "ramp"):
        assert "a speed channel in rpm?" in msg and "no key for a speed channel" in msg
    elif kind == "volts":
        assert "a speed channel in volts" in msg
    else:
        assert "noise" in msg and "connected" in msg


def test_a_pulse_train_with_noise_or_a_sine_pickup_stays_a_pulse_train():
    """The check that refuses a speed channel leaves a TTL train with 10 % noise, an active-low one and an
    inductive pickup's sine alone."""
    t = np.arange(int(FS)) / FS
    phase = (RPM / 60.0 * t) % 1.0
    rng = np.random.default_rng(9)
    for x in (np.where(phase < 0.2, 5.0, 0.0) + 0.5 * rng.standard_normal(t.size),
              np.where(phase < 0.2, 0.0, 5.0), np.sin(2 * np.pi * RPM / 60.0 * t)):
        assert speed_from_tacho(x, FS, z_pinion=29, z_wheel=100, nominal_rpm=RPM).speed_rpm == pytest.approx(RPM,
                                                                                                            rel=2e-3)
