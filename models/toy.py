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

from features.synthetic import TWO_PI, gear_signal_example
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


def toy_machines_with_references(*, n_machines: int = 40, fs_hz: float = 4096.0, duration_s: float = 2.0,
                                 speeds_rpm=(900.0, 1200.0, 1500.0), z_pinion: int = 13,
                                 spacing_deviation: float = 0.25, fault_depth: float = 0.35,
                                 snr_db: float = 30.0, seed: int = 0) -> SignalSet:
    """Healthy and damaged records of ``n_machines`` toy gearboxes, each with its healthy reference.

    Each machine has its own fingerprint, drawn once: a sensor gain (x0.2-5), a mounting resonance
    (0.1-0.4 fs, damping 2-8 %), a once-per-revolution modulation of the mesh (eccentricity, 0-20 %) and a
    tooth-to-tooth amplitude deviation of every pinion tooth (normal, standard deviation
    ``spacing_deviation``: on its own as strong as a fault). A damaged record of that machine lacks
    ``fault_depth`` of the mesh harmonics while one of 1-3 adjacent faulty teeth meshes (``severity_class``
    ``damaged``, ``n_pitted_teeth``). Every record (half healthy, half damaged) gets a reference: the same
    machine, healthy, at the same speed, at another start angle and with other noise. Without the reference a
    record's fingerprint and its fault look alike; with it the fingerprint cancels (``tests/test_models_reference.py``).
    """
    from models.augment import path_filter

    require(isinstance(n_machines, int) and n_machines >= 2, "n_machines", n_machines, "an integer >= 2")
    rng = np.random.default_rng(seed)
    n = int(round(fs_hz * duration_s))
    t = np.arange(n) / fs_hz
    harmonics = ((1, 1.0), (2, 0.5), (3, 0.25))
    sigs, refs, rows = [], [], []

    def record(fr, dev, ecc, psi, faulty, depth, phases):
        theta = TWO_PI * fr * t + rng.uniform(0, TWO_PI)
        tooth = np.floor(theta / TWO_PI * z_pinion).astype(int) % z_pinion
        amp = 1.0 + ecc * np.cos(theta + psi) + dev[tooth]
        if faulty:
            amp = amp - depth * np.isin(tooth, faulty)
        width = max(1, int(round(fs_hz / (fr * z_pinion) / 4)))   # quarter-pitch smoothing of the tooth steps
        amp = np.convolve(amp, np.ones(width) / width, mode="same")
        return sum(a * amp * np.cos(h * z_pinion * theta + phases[k]) for k, (h, a) in enumerate(harmonics))

    for m in range(n_machines):
        gain = 10.0 ** rng.uniform(np.log10(0.2), np.log10(5.0))
        f_path, z_path = rng.uniform(0.1, 0.4) * fs_hz, rng.uniform(0.02, 0.08)
        ecc, psi = rng.uniform(0.0, 0.2), rng.uniform(0, TWO_PI)
        dev = spacing_deviation * rng.standard_normal(z_pinion)
        phases = rng.uniform(0, TWO_PI, len(harmonics))
        fr = float(speeds_rpm[m % len(speeds_rpm)]) / 60.0
        for damaged in (False, True):
            k = int(rng.integers(1, 4)) if damaged else 0
            first = int(rng.integers(z_pinion))
            faulty = [(first + j) % z_pinion for j in range(k)]
            pair = []
            for faults in (faulty, []):
                x = record(fr, dev, ecc, psi, faults, fault_depth, phases)
                x = path_filter(x[None, :], fs_hz, f_path, z_path)[0] * gain
                p = np.mean(x ** 2)
                pair.append(x + np.sqrt(p / 10.0 ** (snr_db / 10.0)) * rng.standard_normal(n))
            sigs.append(pair[0].astype(np.float32))
            refs.append(pair[1].astype(np.float32))
            rows.append({"speed_rpm": 60.0 * fr, "torque_nm": 50.0, "severity": fault_depth if damaged else 0.0,
                         "severity_class": "damaged" if damaged else "healthy", "severity_class_index": int(damaged),
                         "n_pitted_teeth": k, "machine": m})
    labels = pd.DataFrame(rows)
    labels["teeth_class"] = teeth_class_of(labels["n_pitted_teeth"])
    return SignalSet(np.stack(sigs), float(fs_hz), PairInfo("toy", z_pinion, 29), labels,
                     source=f"models.toy.toy_machines_with_references(seed={seed})", reference=np.stack(refs))
