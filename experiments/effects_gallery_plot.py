"""Figures of the effects gallery (no computation here beyond dB conversion)."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _db(a: np.ndarray) -> np.ndarray:
    return 20.0 * np.log10(np.maximum(a, 1e-300))


def plot_effect_spectra(path, *, title: str, spectrum: dict, envelope: dict, lines: dict, f_max_hz: float,
                        env_max_hz: float, unit: str) -> None:
    """Amplitude spectrum (dB) and envelope spectrum of the healthy and the effect's signal.

    ``spectrum`` and ``envelope`` map a label to ``(freqs_hz, amplitude)``; ``lines`` maps a line
    name to its frequency (Hz), drawn as dotted markers.
    """
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 6.5))
    for label, (f, a) in spectrum.items():
        keep = f <= f_max_hz
        ax1.plot(f[keep], _db(a[keep]), lw=0.8, label=label, alpha=0.85)
    for label, (f, a) in envelope.items():
        keep = f <= env_max_hz
        ax2.plot(f[keep], a[keep], lw=0.9, label=label, alpha=0.85)
    for name, f in lines.items():
        for ax, top in ((ax1, f_max_hz), (ax2, env_max_hz)):
            if 0 < f <= top:
                ax.axvline(f, color="grey", lw=0.5, ls=":")
        if 0 < f <= f_max_hz:
            ax1.annotate(name, (f, 1.0), xycoords=("data", "axes fraction"), fontsize=6, rotation=90,
                         va="top", ha="right", color="grey")
    ax1.set_xlabel("frequency (Hz)")
    ax1.set_ylabel(f"amplitude (dB re 1 {unit})")
    ax1.set_title(title, fontsize=10)
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8, loc="lower right")
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_ylabel(f"envelope amplitude ({unit})")
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
