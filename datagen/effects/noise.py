"""Measurement noise: white Gaussian noise at a signal-to-noise ratio (hook 7).

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
    signature = "broadband floor: raises all bands evenly, no orders, no envelope lines"
    snr_db: float = field(default=40.0, metadata={"unit": "dB", "bounds": (-20.0, 120.0)})
    channels: str = field(default="acceleration", metadata={"unit": "-", "choices": ("acceleration", "all")})

    def measurement(self, channels, fs_hz, rng, ctx):
        out = dict(channels)
        for key in sorted(channels):  # sorted: the draw order (and bytes) do not depend on dict order
            if key.startswith("tacho_") or (self.channels == "acceleration" and not key.startswith("acc_")):
                continue
            x = channels[key]
            rms = float(np.std(x))
            out[key] = x + rng.standard_normal(x.shape) * rms * 10.0 ** (-self.snr_db / 20.0)
        return out
