"""A gear-like synthetic vibration record for tests, benchmarks and examples.

Not a physical model (that is ``datagen``): a phenomenological signal with the
ingredients the features are meant to see, at known values.

- mesh harmonics ``sum_m a_m cos(m z_p theta_p(t))`` of the pinion angle;
- a faulty pinion tooth (or several adjacent ones): while it is in mesh the mesh
  harmonics dip by ``fault_depth`` (a smooth amplitude window one tooth pitch
  wide), and each passage rings a structural resonance (decaying sine);
- a small once-per-revolution modulation of the wheel (run-out);
- white Gaussian noise at a given SNR (dB, relative to the noise-free record);
- optional sinusoidal speed fluctuation, and the matching once-per-rev tacho.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import fftconvolve

from gearpit.errors import require, require_positive, require_range

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class ExampleSignal:
    """A synthetic record and the operating values that made it.

    Attributes
    ----------
    x : ndarray
        Vibration record (arbitrary acceleration unit).
    tacho : ndarray
        Once-per-pinion-revolution square wave (1 during the first half turn).
    fs_hz, fr_pinion_hz, fr_wheel_hz, fm_hz : float
        Sampling rate and the mean shaft and mesh frequencies (Hz).
    z_pinion, z_wheel : int
        Tooth counts.
    """

    x: np.ndarray
    tacho: np.ndarray
    fs_hz: float
    fr_pinion_hz: float
    fr_wheel_hz: float
    fm_hz: float
    z_pinion: int
    z_wheel: int


def gear_signal_example(*, fs_hz: float = 12800.0, duration_s: float = 1.0, fr_pinion_hz: float = 25.0,
                        z_pinion: int = 28, z_wheel: int = 37, mesh_amplitudes=(1.0, 0.5, 0.25),
                        fault_depth: float = 0.0, n_faulty_teeth: int = 1, resonance_hz: float = 3500.0,
                        ring_amplitude: float = 2.0, runout: float = 0.05, speed_fluctuation: float = 0.0,
                        fluctuation_hz: float = 2.0, snr_db: float | None = 20.0, seed: int = 0) -> ExampleSignal:
    """Make a gear-like record (see module docstring).

    Parameters
    ----------
    fs_hz, duration_s : float
        Sampling rate (Hz) and length (s).
    fr_pinion_hz : float
        Mean pinion shaft frequency (Hz).
    z_pinion, z_wheel : int
        Tooth counts.
    mesh_amplitudes : sequence of float
        Amplitude of mesh harmonic 1, 2, ...
    fault_depth : float
        Relative dip of the mesh harmonics while a faulty tooth meshes, in [0, 1];
        0 is a healthy pair. Also scales the resonance ringing.
    n_faulty_teeth : int
        Adjacent faulty pinion teeth.
    resonance_hz, ring_amplitude : float
        Frequency (Hz) of the rung resonance (damping ratio 0.05) and the peak of
        one ring at ``fault_depth = 1``.
    runout : float
        Relative once-per-revolution amplitude modulation by the wheel.
    speed_fluctuation, fluctuation_hz : float
        Peak relative speed fluctuation and its frequency (Hz).
    snr_db : float or None
        Signal-to-noise ratio (dB); None adds no noise.
    seed : int
        Seed of the noise.
    """
    require_positive("fs_hz", fs_hz)
    require_positive("duration_s", duration_s)
    require_positive("fr_pinion_hz", fr_pinion_hz)
    require(isinstance(z_pinion, int) and z_pinion >= 4, "z_pinion", z_pinion, "an integer >= 4")
    require(isinstance(z_wheel, int) and z_wheel >= 4, "z_wheel", z_wheel, "an integer >= 4")
    require_range("fault_depth", fault_depth, 0.0, 1.0)
    require(isinstance(n_faulty_teeth, int) and 1 <= n_faulty_teeth <= z_pinion, "n_faulty_teeth", n_faulty_teeth,
            f"an integer in [1, {z_pinion}]")
    require_range("speed_fluctuation", speed_fluctuation, 0.0, 0.5, hi_open=True)
    fm = z_pinion * fr_pinion_hz
    require(len(mesh_amplitudes) * fm < fs_hz / 2, "mesh_amplitudes", len(mesh_amplitudes),
            f"harmonics below Nyquist: at most {int((fs_hz / 2) // fm)} for fm = {fm} Hz")
    require(0 < resonance_hz < fs_hz / 2, "resonance_hz", resonance_hz, f"(0, {fs_hz / 2}) Hz")

    n = int(round(duration_s * fs_hz))
    t = np.arange(n) / fs_hz
    theta = TWO_PI * fr_pinion_hz * t
    if speed_fluctuation > 0:
        theta = theta + speed_fluctuation * fr_pinion_hz / fluctuation_hz * (1.0 - np.cos(TWO_PI * fluctuation_hz * t))
    theta_wheel = theta * z_pinion / z_wheel

    # faulty teeth window: centred on pinion angle pi (tooth 0 at angle pi), one pitch per tooth
    pitch = TWO_PI / z_pinion
    phase = np.mod(theta - np.pi + 0.5 * pitch, TWO_PI)  # tooth 0 spans [0, pitch)
    span = n_faulty_teeth * pitch
    inside = phase < span
    window = np.where(inside, np.sin(np.pi * np.clip(phase / span, 0, 1)) ** 2, 0.0)
    am = (1.0 - fault_depth * window) * (1.0 + runout * np.cos(theta_wheel))
    x = np.zeros(n)
    for m, a in enumerate(mesh_amplitudes, start=1):
        x += a * np.cos(m * z_pinion * theta)
    x *= am

    if fault_depth > 0:
        # one ring per faulty tooth entering mesh
        starts = []
        for k in range(n_faulty_teeth):
            crossing = np.mod(theta - np.pi + 0.5 * pitch - k * pitch, TWO_PI)
            starts.extend(np.nonzero(np.diff(crossing) < 0)[0] + 1)
        impulses = np.zeros(n)
        impulses[np.asarray(starts, dtype=int)] = 1.0
        tr = np.arange(int(0.02 * fs_hz)) / fs_hz
        wn = TWO_PI * resonance_hz
        zeta = 0.05
        ring = np.exp(-zeta * wn * tr) * np.sin(wn * np.sqrt(1 - zeta**2) * tr)
        x += ring_amplitude * fault_depth * fftconvolve(impulses, ring)[:n]

    if snr_db is not None:
        rng = np.random.default_rng(seed)
        noise_std = np.sqrt(np.mean(x**2) / 10 ** (snr_db / 10))
        x = x + noise_std * rng.standard_normal(n)

    tacho = (np.mod(theta, TWO_PI) < np.pi).astype(float)
    return ExampleSignal(x=x, tacho=tacho, fs_hz=float(fs_hz), fr_pinion_hz=float(fr_pinion_hz),
                         fr_wheel_hz=float(fr_pinion_hz * z_pinion / z_wheel), fm_hz=float(fm),
                         z_pinion=z_pinion, z_wheel=z_wheel)
