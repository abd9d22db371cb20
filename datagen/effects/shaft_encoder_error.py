"""Shaft-encoder errors of a measured transmission error (hook 7, the ``dte_m`` channel only).

A test rig measures the transmission error with one optical encoder per shaft,
``TE = rb1 theta1_measured - rb2 theta2_measured`` (Remond 2000). Each encoder
reads its shaft angle with an error of its own; the largest, and the one that
reaches the frequencies a gear diagnosis reads, is the *eccentricity* of the
graduated disc on its shaft (mounting run-out and disc centring): a disc whose
centre sits ``e`` off the axis, read at radius ``r``, reports the angle with the
error ``(e / r) sin(theta + psi)``, once per revolution of that shaft (Remond
2000, sec. 3; Heidenhain's "eccentricity error" of rotary encoders). With
``a = e / r`` in rad:

    dte_measured = dte + rb1 a1 sin(theta1 + psi1) - rb2 a2 sin(theta2 + psi2)

``theta`` is the shaft's rotation angle, the integral of its speed channel
(``speed_pinion_rpm``, ``speed_wheel_rpm``), so a speed fluctuation is followed.
Typical values: 5-20 um mounting eccentricity on a disc read at 20-40 mm gives
1e-4 to 1e-3 rad (20-200 arcsec): at ``rb1`` = 27 mm that is 3-27 um, as large
as or larger than the whole loaded transmission error of a spur pair (a few um)
and a pit's share of it (well under 1 um).

Not modelled: the graduation (line) errors of the disc, the interpolation error
at the line frequency (far above the orders a TSA keeps), and the time-interval
quantisation (``omega / f_clock`` rad: 2e-6 rad at 30 Hz and an 80 MHz counter,
below the sensor noise of the ``noise`` effect).

Signature (checked in ``tests/test_effects_shaft_encoder_error.py``)

===========================  =====================================================
line                         change
===========================  =====================================================
``dte_m`` at ``fr_pinion``   ``rb1 a1`` added (phase ``psi1``)
``dte_m`` at ``fr_wheel``    ``rb2 a2`` added (phase ``psi2 + pi``)
every other channel          unchanged
===========================  =====================================================

It is part of the measurement chain of one channel, like ``noise``. In a sweep it applies after the
noise (a sweep's effects apply in name order), so the noise is drawn at the SNR of the true transmission
error, and a sweep that adds this effect keeps every other channel's bytes. The model-vs-measurement
comparison (:mod:`compare`, an accelerometer) never tries it as a candidate
(:data:`compare.fitspace.CHAIN_EFFECTS`).

References
----------
Remond, D. (1998/2000). Practical performances of high-speed measurement of gear transmission error or
    torsional vibrations with optical encoders. Measurement Science and Technology 9(3), 347-353.
Heidenhain (2017). Angle Encoders with Integral Bearing, "Eccentricity of the graduation to the bearing".
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from datagen.effects.base import Effect, register

#: the channel encoders measure
TE_CHANNEL = "dte_m"


def shaft_angle_rad(speed_rpm: np.ndarray, fs_hz: float) -> np.ndarray:
    """Rotation angle (rad, 0 at the first sample) integrated from a speed channel (trapezoid rule)."""
    w = np.asarray(speed_rpm, dtype=float) * (2.0 * np.pi / 60.0)
    out = np.zeros_like(w)
    out[1:] = np.cumsum(0.5 * (w[1:] + w[:-1])) / fs_hz
    return out


@register
@dataclass(frozen=True)
class ShaftEncoderError(Effect):
    """Once-per-revolution eccentricity error of the pinion and the wheel encoder on ``dte_m`` (module docstring).

    Parameters
    ----------
    pinion_rad : float
        Angle error amplitude ``a1 = e1 / r1`` of the pinion encoder (rad).
    wheel_rad : float
        Angle error amplitude ``a2 = e2 / r2`` of the wheel encoder (rad).
    pinion_phase_rad : float
        Phase ``psi1`` of the pinion encoder's error at the first sample (rad).
    wheel_phase_rad : float
        Phase ``psi2`` of the wheel encoder's error at the first sample (rad).
    """

    name = "shaft_encoder_error"
    signature = "transmission error channel only: lines at fr_pinion and fr_wheel (encoder disc eccentricity)"
    #: measurement chain of the transmission-error channel: never a candidate of the comparison
    fit_parameters = ()
    pinion_rad: float = field(default=1e-4, metadata={"unit": "rad", "bounds": (0.0, 2e-3)})
    wheel_rad: float = field(default=1e-4, metadata={"unit": "rad", "bounds": (0.0, 2e-3)})
    pinion_phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-np.pi, np.pi)})
    wheel_phase_rad: float = field(default=0.0, metadata={"unit": "rad", "bounds": (-np.pi, np.pi)})

    def measurement(self, channels, fs_hz, rng, ctx):
        if TE_CHANNEL not in channels or (self.pinion_rad == 0.0 and self.wheel_rad == 0.0):
            return channels
        te = channels[TE_CHANNEL]
        n = te.size
        z1, z2 = ctx.pair.pinion.teeth, ctx.pair.wheel.teeth
        if "speed_pinion_rpm" in channels:
            th1 = shaft_angle_rad(channels["speed_pinion_rpm"], fs_hz)
        else:
            th1 = 2.0 * np.pi * ctx.speed_rpm / 60.0 * np.arange(n) / fs_hz
        th2 = shaft_angle_rad(channels["speed_wheel_rpm"], fs_hz) if "speed_wheel_rpm" in channels else th1 * z1 / z2
        rb1, rb2 = ctx.pair.base_radius_m("pinion"), ctx.pair.base_radius_m("wheel")
        out = dict(channels)
        out[TE_CHANNEL] = (te + rb1 * self.pinion_rad * np.sin(th1 + self.pinion_phase_rad)
                           - rb2 * self.wheel_rad * np.sin(th2 + self.wheel_phase_rad))
        return out

    def channels_read(self, wanted):
        """The transmission error is corrected with the shafts' angles, integrated from their speeds."""
        extra = {"speed_pinion_rpm", "speed_wheel_rpm"} if TE_CHANNEL in wanted else set()
        return frozenset(wanted) | extra
