"""compare.modulation: amplitude or frequency modulation of the mesh tones, read from the sidebands' phases."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from compare.modulation import line, modulation_text, modulation_type

FS, FM, FSB = 20000.0, 483.3, 37.0


def tones(t, am=0.0, beta=0.0, phase_s=0.7, rng=None):
    """Eight mesh harmonics with random phases, amplitude-modulated by ``am`` and phase-modulated by ``beta k``
    (a speed swing modulates harmonic ``k`` by ``k`` times the phase of the first) at FSB."""
    rng = np.random.default_rng(0) if rng is None else rng
    x = np.zeros_like(t)
    for k in range(1, 9):
        p = rng.uniform(-np.pi, np.pi)
        x += (1.0 / k) * (1 + am * np.cos(2 * np.pi * FSB * t + phase_s)) * np.cos(
            2 * np.pi * k * FM * t + p + k * beta * np.sin(2 * np.pi * FSB * t + phase_s))
    return x


def test_line_reads_amplitude_and_phase():
    """A pure 0.3 cos(2 pi f t + 1.1) is read as 0.3 exp(1.1 i) (Hann-windowed DFT at the line's frequency; the
    window's scalloping on whole cycles is nil). Tolerance 1e-3."""
    t = np.arange(int(2 * FS)) / FS
    z = line(0.3 * np.cos(2 * np.pi * 500.0 * t + 1.1), FS, 500.0)
    assert abs(z - 0.3 * np.exp(1.1j)) < 1e-3


@pytest.mark.parametrize("phase_s", [0.0, 0.7, -2.5])
def test_amplitude_and_frequency_modulation_are_told_apart_at_any_phase(phase_s):
    """Analytic (Randall 2011, 3.6.2): amplitude modulation gives U = L = m C / 2, Q = U L / C^2 > 0 at every
    harmonic; phase modulation U = -L, Q < 0; neither depends on the carrier's or the modulation's phase. A 10 %
    amplitude modulation and a 0.02 rad (first harmonic) phase modulation, eight harmonics each: every harmonic
    read, all of one type; with the carriers' phases drawn anew the answer is the same."""
    t = np.arange(int(2 * FS)) / FS
    am = modulation_type(tones(t, am=0.1, phase_s=phase_s), FS, FM, FSB)
    fm = modulation_type(tones(t, beta=0.05, phase_s=phase_s, rng=np.random.default_rng(5)), FS, FM, FSB)
    assert am["type"] == "amplitude" and am["amplitude"] == am["read"] == 8, am
    assert fm["type"] == "frequency" and fm["frequency"] == fm["read"] >= 7, fm
    assert min(v for v in am["cos_arg_q"] if v is not None) > 0.99
    assert max(v for v in fm["cos_arg_q"] if v is not None) < -0.99


def test_a_smooth_linear_path_keeps_the_type_and_no_sidebands_read_none():
    """A housing resonance at 3 kHz (5 % damping, second-order band-pass; its phase turns by ~0.05 rad across
    2 f_s below it) keeps the type of every harmonic below it; a record without modulation reads nothing
    ("none"), and one with both modulations at similar strength reads "mixed" or the stronger one, never both."""
    t = np.arange(int(2 * FS)) / FS
    w0, z = 2 * np.pi * 3000.0, 0.05
    b, a = signal.bilinear([2 * z * w0, 0], [1, 2 * z * w0, w0 ** 2], FS)
    y = signal.lfilter(b, a, tones(t, am=0.1))[int(0.2 * FS):]
    assert modulation_type(y, FS, FM, FSB)["type"] == "amplitude"
    assert modulation_type(tones(t), FS, FM, FSB)["type"] == "none"
    both = modulation_type(tones(t, am=0.1, beta=0.05), FS, FM, FSB)
    assert both["type"] in ("mixed", "amplitude", "frequency") and both["amplitude"] + both["frequency"] <= both["read"]


def test_the_text_names_the_shafts_motion_when_rig_and_model_differ():
    """The diagnosis is added only when one side is amplitude and the other frequency modulation."""
    am = {"type": "amplitude", "amplitude": 8, "frequency": 0, "read": 9}
    fm = {"type": "frequency", "amplitude": 0, "frequency": 10, "read": 10}
    text = modulation_text(am, fm, "speed_fluctuation", 36.45)
    assert "measured amplitude modulation (8 of 9" in text and "the load swings while the speed holds" in text
    assert "drive train differs" not in modulation_text(fm, fm, "speed_fluctuation", 36.45)


def test_two_harmonics_of_the_other_kind_do_not_turn_the_reading():
    """The record's type is the median over the harmonics read: eight harmonics amplitude-modulated by 10 % and two
    (k = 1, 3) strongly frequency-modulated (as near a resonance or another line on the foreign torque record,
    where those two had the largest sidebands) read as amplitude modulation, balance above 0.9."""
    t = np.arange(int(2 * FS)) / FS
    rng = np.random.default_rng(2)
    x = np.zeros_like(t)
    for k in range(1, 11):
        p = rng.uniform(-np.pi, np.pi)
        if k in (1, 3):
            x += np.cos(2 * np.pi * k * FM * t + p + 0.6 * np.sin(2 * np.pi * FSB * t))
        else:
            x += (1 + 0.1 * np.cos(2 * np.pi * FSB * t)) * np.cos(2 * np.pi * k * FM * t + p)
    got = modulation_type(x, FS, FM, FSB)
    assert got["read"] >= 9 and got["frequency"] == 2, got
    assert got["type"] == "amplitude" and got["balance"] > 0.9, got
