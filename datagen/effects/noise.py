"""Measurement noise: white or coloured Gaussian noise at a signal-to-noise ratio (hook 7).

Coloured noise has a power spectral density ~ 1/f^alpha: ``pink`` (alpha = 1) and ``brown`` (alpha = 2),
made by shaping white Gaussian noise in the frequency domain (amplitude ~ f^(-alpha/2), DC removed) and
scaling the result to the requested SNR over the whole record.

References
----------
Randall, R. B. (2011). Vibration-based Condition Monitoring, ch. 3 (additive sensor noise).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, register


@register
@dataclass(frozen=True)
class Noise(Effect):
    """White Gaussian noise added to the acceleration channels (or to all channels).

    Parameters
    ----------
    snr_db : float
        Ratio of each channel's rms (mean removed) to the noise rms (dB).
    channels : {"acceleration", "all"}
        Which channels receive noise (tacho pulses never do).
    """

    name = "noise"
    signature = "broadband floor (white: flat; pink/brown: rising towards low frequencies), no orders, no envelope lines"
    #: measurement chain: matched in every comparison (compare.comparison), never a candidate effect
    fit_parameters = ()
    snr_db: float = field(default=40.0, metadata={"unit": "dB", "bounds": (-20.0, 120.0)})
    channels: str = field(default="acceleration", metadata={"unit": "-", "choices": ("acceleration", "all")})
    colour: str = field(default="white", metadata={"unit": "-", "choices": ("white", "pink", "brown")})

    def measurement(self, channels, fs_hz, rng, ctx):
        out = dict(channels)
        for key in sorted(channels):  # sorted: the draw order (and bytes) do not depend on dict order
            if key.startswith("tacho_") or (self.channels == "acceleration" and not key.startswith("acc_")):
                continue
            x = channels[key]
            rms = float(np.std(x))
            n = coloured_noise(x.size, self.colour, rng)
            out[key] = x + n * rms * 10.0 ** (-self.snr_db / 20.0)
        return out

    def channels_read(self, wanted):
        """Every acceleration (their noise is drawn from one generator in sorted order, so each draw depends on
        which of them exist); with ``channels = "all"`` every channel."""
        from datagen.output_channels import channel_names

        if self.channels != "acceleration":
            return None
        return frozenset(wanted) | {k for k in channel_names(8) if k.startswith("acc_")}


#: PSD exponent alpha of each noise colour (PSD ~ 1 / f^alpha)
COLOUR_EXPONENT = {"white": 0.0, "pink": 1.0, "brown": 2.0}


def coloured_noise(n: int, colour: str, rng: np.random.Generator) -> np.ndarray:
    """Unit-rms Gaussian noise of ``n`` samples with PSD ~ 1/f^alpha (``white``, ``pink``, ``brown``)."""
    w = rng.standard_normal(n)
    alpha = COLOUR_EXPONENT[colour]
    if alpha == 0.0:
        return w
    spec = np.fft.rfft(w)
    f = np.arange(spec.size, dtype=float)
    f[0] = np.inf  # no DC
    y = np.fft.irfft(spec * f ** (-alpha / 2.0), n)
    return y / np.std(y)
