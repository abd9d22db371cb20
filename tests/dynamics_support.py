"""Shared by tests/test_dynamics.py and tests/test_dynamics_paths.py: the example spur pair, its torque, its linear
lumped model and a least-squares line reader."""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from datagen.geometry import helical_pair_example, spur_pair_example
from datagen.lumped_model import DriveTrain, build_model
from datagen.stiffness import mesh_stiffness

SPUR = spur_pair_example()
TORQUE = 11.3


@lru_cache(maxsize=None)
def _model(helical: bool = False, drive: DriveTrain = DriveTrain()):
    pair = helical_pair_example() if helical else SPUR
    ms = mesh_stiffness(pair)
    return build_model(pair, drive, k_mean_n_per_m=ms.mean_n_per_m, torque_nm=TORQUE), ms


def _lsq_amplitudes(x, fs, freqs):
    """Amplitudes of sinusoids at ``freqs`` fitted by least squares (with a constant)."""
    t = np.arange(x.size) / fs
    cols = [np.ones_like(t)]
    for f in freqs:
        cols += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    c, *_ = np.linalg.lstsq(np.column_stack(cols), x, rcond=None)
    return np.hypot(c[1::2], c[2::2])
