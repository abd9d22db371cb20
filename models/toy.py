"""A small labelled :class:`~models.data.SignalSet` of gear-like records, for
tests, benchmarks and examples of the classifiers.

Records come from :func:`features.synthetic.gear_signal_example` (mesh harmonics,
a dip of the mesh tone and a rung resonance while the faulty teeth mesh, noise):
a phenomenological signal, not the physical simulator. Severity ``s`` sets the
fault depth ``min(1, 2.5 s)``; damaged records have 1 to 3 adjacent faulty teeth.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from features.synthetic import gear_signal_example
from gearpit.errors import require
from models.data import PairInfo, SignalSet, teeth_class_of

TOY_CLASSES: tuple[tuple[str, float], ...] = (("healthy", 0.0), ("moderate", 0.15), ("severe", 0.35))


def toy_signal_set(*, n_per_class: int = 24, fs_hz: float = 4096.0, duration_s: float = 1.0,
                   speeds_rpm=(900.0, 1200.0, 1500.0), torques_nm=(50.0, 100.0), z_pinion: int = 13,
                   z_wheel: int = 29, snr_db: float = 10.0, classes=TOY_CLASSES, seed: int = 0) -> SignalSet:
    """Records of every class at every speed and torque, in a seeded random order.

    Parameters
    ----------
    n_per_class : int
        Records per class (spread over the speed x torque grid).
    fs_hz, duration_s : float
        Sampling rate (Hz) and record length (s).
    speeds_rpm, torques_nm : sequence of float
        Pinion speeds (rpm) and load torques (N m, a label only: the toy signal
        does not depend on it).
    z_pinion, z_wheel : int
        Tooth counts.
    snr_db : float
        Signal-to-noise ratio of every record (dB).
    classes : sequence of (name, severity)
        Severity classes, healthy first (severity 0).
    seed : int
        Seed of the labels, phases and noise.
    """
    require(isinstance(n_per_class, int) and n_per_class >= 1, "n_per_class", n_per_class, "an integer >= 1")
    rng = np.random.default_rng(seed)
    rows, sigs = [], []
    grid = [(s, t) for s in speeds_rpm for t in torques_nm]
    for ci, (name, sev) in enumerate(classes):
        for k in range(n_per_class):
            speed, torque = grid[k % len(grid)]
            n_teeth = 0 if sev == 0 else int(rng.integers(1, 4))
            sig = gear_signal_example(fs_hz=fs_hz, duration_s=duration_s, fr_pinion_hz=speed / 60.0,
                                      z_pinion=z_pinion, z_wheel=z_wheel, mesh_amplitudes=(1.0, 0.5),
                                      fault_depth=min(1.0, 2.5 * sev), n_faulty_teeth=max(n_teeth, 1),
                                      resonance_hz=0.3 * fs_hz, snr_db=snr_db, seed=int(rng.integers(2**31)))
            # a random shaft phase at t = 0
            shift = int(rng.integers(sig.x.size))
            sigs.append(np.roll(sig.x, shift).astype(np.float32))
            rows.append({"speed_rpm": float(speed), "torque_nm": float(torque), "severity": float(sev),
                         "severity_class": name, "severity_class_index": ci, "n_pitted_teeth": n_teeth,
                         "snr_db": float(snr_db)})
    order = rng.permutation(len(rows))
    labels = pd.DataFrame(rows).iloc[order].reset_index(drop=True)
    labels["teeth_class"] = teeth_class_of(labels["n_pitted_teeth"])
    return SignalSet(np.stack(sigs)[order], float(fs_hz), PairInfo("toy", z_pinion, z_wheel), labels,
                     source=f"models.toy.toy_signal_set(seed={seed})")
