"""A velocity or displacement sensor read as acceleration (features.derivative; sidecar ``sensor_quantity``).
Source: the analytic derivative of a sine; and a rig's acceleration integrated in the frequency domain (an
independent route) and declared as velocity."""
from __future__ import annotations

import numpy as np
import pytest

from features.derivative import HALF_TAPS, derivative
from gearpit.errors import InputError

FS = 20000.0


@pytest.mark.parametrize("f_hz", [2.5, 50.0, 483.0, 3000.0, 9000.0])
def test_the_derivative_of_a_sine_is_its_cosine_to_0_2_percent_up_to_0_45_fs(f_hz):
    """d/dt sin(w t) = w cos(w t), d2/dt2 = -w^2 sin(w t): within 0.2 % (0.4 % for the second) of w, w^2 at every
    sample the filter forms, from 2.5 Hz to 0.45 fs (a central difference is 90 % low at 0.45 fs)."""
    t = np.arange(40000) / FS
    w = 2 * np.pi * f_hz
    x = np.sin(w * t)
    d1 = derivative(x, FS)
    assert d1.size == t.size - 2 * HALF_TAPS
    assert np.max(np.abs(d1 - w * np.cos(w * t[HALF_TAPS:-HALF_TAPS]))) <= 2e-3 * w
    d2 = derivative(x, FS, 2)
    assert np.max(np.abs(d2 + w ** 2 * np.sin(w * t[2 * HALF_TAPS:-2 * HALF_TAPS]))) <= 4e-3 * w ** 2


def _integrated(a: np.ndarray, fs: float, order: int) -> np.ndarray:
    """``a`` integrated ``order`` times in the frequency domain (mean removed): the test's own route."""
    spec = np.fft.rfft(a - a.mean())
    f = np.fft.rfftfreq(a.size, 1.0 / fs)
    spec[1:] /= (2j * np.pi * f[1:]) ** order
    spec[0] = 0.0
    return np.fft.irfft(spec, n=a.size)


@pytest.mark.parametrize("quantity,order", [("velocity", 1), ("displacement", 2)])
def test_a_velocity_or_displacement_recording_compares_as_its_acceleration_would(tmp_path, quantity, order):
    """The suite's test rig with a hidden grade-8 pitch error, its acceleration integrated (frequency domain)
    and written as a velocity (displacement) file in mm/s (um). Declared as such in the sidecar, the loaded
    signal is the acceleration again (to 0.5 % of its RMS, up to the gain) and every view's error is within
    0.15 dB of the acceleration file's; read as an acceleration the band view (the spectrum between the orders,
    tilted by f or f^2) is more than 6 dB worse (velocity: 18.8 against 0.24 dB) and the total more than 1 dB. A value the sidecar does not know is refused."""
    from compare.comparison import compare
    from compare.measurement import load_measurement
    from compare.model import ComparisonModel
    from compare.synthetic import rig_measurement
    from compare.workflow import write_rig_files

    m = rig_measurement(({"name": "pitch_error", "grade": 8.0},))
    acc = write_rig_files(m, tmp_path / "acc")
    v = _integrated(m.signal, m.fs_hz, order) * (1e3 if order == 1 else 1e6)
    csv = write_rig_files(m.__class__(**{**m.__dict__, "channels": {**m.channels, m.sensor: v}}), tmp_path / "vel")
    side = csv.with_suffix(".toml")
    plain = side.read_text()
    side.write_text(plain + f'sensor_quantity = "{quantity}"\n')
    mv = load_measurement(csv)
    cut = order * HALF_TAPS
    a_ref = m.signal[cut:-cut] - m.signal.mean()
    gain = float(np.dot(mv.signal, a_ref) / np.dot(a_ref, a_ref))
    assert np.std(mv.signal / gain - a_ref) <= 5e-3 * np.std(a_ref)
    ca = compare(load_measurement(acc), ComparisonModel())
    cv = compare(mv, ComparisonModel())
    for view, e in ca.error_db.items():
        assert abs(cv.error_db[view] - e) <= 0.15, (view, e, cv.error_db[view])
    side.write_text(plain)
    wrong = compare(load_measurement(csv), ComparisonModel())
    assert wrong.error_db["band"] > ca.error_db["band"] + 6.0, (wrong.error_db, ca.error_db)
    assert wrong.error_db["total"] > ca.error_db["total"] + 1.0
    side.write_text(plain + 'sensor_quantity = "jerk"\n')
    with pytest.raises(InputError, match="sensor_quantity"):
        load_measurement(csv)
