"""experiments/path_inverse_check.py: the Wiener estimate of one channel from another.

Source: Bendat & Piersol (2010), ch. 6: for ``y = h * a`` with no noise the optimum frequency response
``S_ay / S_aa`` is ``H`` itself and the ordinary coherence is 1; for independent records it tends to 0 (its
bias for ``n_d`` averaged segments is about ``1 / n_d``).
"""
import sys
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
from path_inverse_check import apply_fir, coherence_by_band, wiener_fir  # noqa: E402

FS = 12800.0


def _records(seed: int, n: int = 16, length: int = 12800) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal((n, length))


def test_the_wiener_fir_recovers_a_known_filter():
    """y = a through a 2nd-order resonance (1.5 kHz, 5 % damping; an IIR, so g must approximate its impulse
    response within NPERSEG taps): the filtered record matches y to 1 % of its RMS away from the record ends
    (a filter that ignored the phase, or an off-by-one centring of the taps, misses by tens of percent)."""
    a = _records(1)
    w0, z = 2 * np.pi * 1500.0, 0.05
    b_d, a_d = signal.bilinear([w0 ** 2], [1.0, 2 * z * w0, w0 ** 2], fs=FS)
    y = signal.lfilter(b_d, a_d, a, axis=-1)
    g = wiener_fir(a, y, FS)
    y_hat = apply_fir(a, g)
    core = slice(2048, -2048)
    err = np.sqrt(np.mean((y_hat[:, core] - y[:, core]) ** 2) / np.mean(y[:, core] ** 2))
    assert err < 0.01


def test_coherence_is_one_for_a_filtered_copy_and_small_for_independent_records():
    a = _records(2)
    y = signal.lfilter([1.0, 0.5], [1.0], a, axis=-1)
    assert min(coherence_by_band(a, y, FS).values()) > 0.999
    # 16 records x 11 segments each: the coherence of independent noise is about 1 / 176
    assert max(coherence_by_band(a, _records(3), FS).values()) < 0.05
