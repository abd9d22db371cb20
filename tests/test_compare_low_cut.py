"""Content below every shaft order (a sensor's drift, an offset, a foundation's sway) is removed before the views
and reported when the measurement holds enough of it (compare.spectra.high_passed, compare.comparison
.BELOW_SHAFTS_REMOVED, below_shafts_message)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from compare.spectra import LOW_CUT_ORDER, LOW_CUT_POLES, high_passed, low_cut_hz


def test_the_low_cut_follows_the_butterworth_response_applied_twice():
    """Source: a Butterworth high-pass of n poles has |H(f)|^2 = 1 / (1 + (fc/f)^(2n)); forwards and backwards
    the amplitude is |H|^2. Tones at 1/5, 1, 2 and 4 times the cut (the slower shaft's first order is at 2):
    measured amplitude ratio within 1 % of it."""
    fs = 2000.0
    plan = SimpleNamespace(fr_pinion_hz=10.0, fr_wheel_hz=4.0)       # the wheel is the slower shaft
    fc = low_cut_hz(plan)
    assert fc == pytest.approx(LOW_CUT_ORDER * 4.0)
    t = np.arange(int(60 * fs)) / fs
    for k in (0.2, 1.0, 2.0, 4.0):
        f = k * fc
        x = np.sin(2 * np.pi * f * t)
        y = high_passed(x, fs, fc)
        mid = slice(t.size // 4, 3 * t.size // 4)       # away from the ends
        ratio = np.std(y[mid]) / np.std(x[mid])
        expected = 1.0 / (1.0 + (fc / f) ** (2 * LOW_CUT_POLES))
        assert ratio == pytest.approx(expected, rel=0.01, abs=1e-3), (k, ratio, expected)


@pytest.fixture(scope="module")
def rigs():
    from compare.synthetic import rig_measurement

    clean = rig_measurement(())
    rms = float(np.std(clean.signal))
    drift = rig_measurement((), extra=lambda t: 2.0 * rms * t / t[-1] + 1.5 * rms * np.sin(2 * np.pi * 0.7 * t)
                            + 3.0 * rms)
    return clean, drift


def test_a_drifting_sensor_leaves_the_comparison_as_the_clean_record_and_is_reported(rigs):
    """The suite's healthy test rig (wheel at 4.8 Hz), once as recorded and once with a ramp of 2 RMS, a 0.7 Hz
    wander of 1.5 RMS and an offset of 3 RMS added. Without the low cut the drift raised the total error from 0.46
    to 3.79 dB (the wheel TSA's strongest tooth +17 dB, its energy ratio +13 dB, the first wheel order +6 dB) and
    named none of it. Asserted: the clean record (0.7 % of its RMS below the cut) is read as it is, nothing
    removed or said; the drifting one has it removed and reported (ratio above 1, a message naming the cut), and
    every view's error is within 0.1 dB of the clean record's."""
    from compare.comparison import BELOW_SHAFTS_REMOVED, below_shafts_message, compare
    from compare.model import ComparisonModel

    clean, drift = rigs
    a = compare(clean, ComparisonModel())
    b = compare(drift, ComparisonModel())
    assert a.reference.below_shafts_ratio < BELOW_SHAFTS_REMOVED and a.reference.plan.low_cut_hz == 0.0
    assert below_shafts_message(a.reference) is None
    assert b.reference.below_shafts_ratio > 1.0
    assert b.reference.plan.low_cut_hz == pytest.approx(low_cut_hz(b.reference.plan))
    msg = below_shafts_message(b.reference)
    assert msg is not None and f"{b.reference.plan.low_cut_hz:.3g} Hz" in msg
    for view, e in a.error_db.items():
        assert abs(b.error_db[view] - e) <= 0.1, (view, e, b.error_db[view])


def test_the_json_document_carries_the_cut_and_the_removed_share(rigs):
    import jsonschema

    from compare.comparison import compare
    from compare.model import ComparisonModel
    from compare.report import document
    from compare.schema import SCHEMA

    _, drift = rigs
    c = compare(drift, ComparisonModel())
    doc = document(c)
    jsonschema.validate(doc, SCHEMA)
    assert doc["measurement"]["low_cut_hz"] == pytest.approx(0.5 * c.reference.plan.fr_wheel_hz)
    assert doc["measurement"]["below_shafts_ratio"] == pytest.approx(c.reference.below_shafts_ratio)
