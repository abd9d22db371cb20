"""Figure of one simulated channel: time signal, amplitude spectrum, envelope spectrum.

Spectra come from :mod:`features.spectra` and :mod:`features.envelope`; this
module only draws.
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_signals(signals, path, *, channel: str = "acc_pinion_loa_m_s2", title: str = "") -> None:
    """Three panels for ``channel`` of a :class:`datagen.simulate.Signals`, marking f_m and its harmonics."""
    from features.envelope import envelope_spectrum
    from features.spectra import amplitude_spectrum

    x = signals.channels[channel]
    fs = signals.fs_hz
    t = signals.time_s
    f, a = amplitude_spectrum(x - x.mean(), fs)
    fe, ae = envelope_spectrum(x, fs)
    fm = signals.metadata.get("mesh_frequency_hz")
    fig, axes = plt.subplots(3, 1, figsize=(9, 8))
    n_show = min(x.size, int(0.1 * fs))
    axes[0].plot(t[:n_show] * 1e3, x[:n_show], lw=0.7)
    axes[0].set_xlabel("time (ms)")
    axes[0].set_ylabel(channel)
    axes[1].semilogy(f, np.maximum(a, 1e-300), lw=0.7)
    axes[1].set_xlabel("frequency (Hz)")
    axes[1].set_ylabel("amplitude")
    if fm:
        for k in range(1, int(f[-1] // fm) + 1):
            axes[1].axvline(k * fm, color="r", lw=0.5, alpha=0.4)
    fr = signals.metadata.get("shaft_frequency_pinion_hz")
    sel = fe <= (20 * fr if fr else fe[-1])
    axes[2].plot(fe[sel], ae[sel], lw=0.7)
    axes[2].set_xlabel("envelope frequency (Hz)")
    axes[2].set_ylabel("envelope amplitude")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(title or channel)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
