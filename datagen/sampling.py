"""Sample ``i`` of a sweep: its class, labels and every drawn parameter, from ``(sweep, i)`` alone.

Class assignment is deterministic and interleaved: sample ``i`` belongs to
class ``i % n_classes`` of :func:`datagen.class_grid.class_grid`, so every class
holds exactly ``samples_per_class`` samples and every shard mixes classes.
Everything random comes from independent streams of
``SeedSequence(sweep.seed, spawn_key=(i, stream))`` (one per group of
parameters, effects keyed by a CRC-32 of their name), so adding a nuisance
effect to a sweep leaves the operating points and the pits of every sample
unchanged. Draw order inside a stream is fixed (see :func:`draw_sample`).

Pitted teeth: ``n`` distinct teeth of the pitted gear drawn uniformly without
replacement (``n`` fixed by the teeth class, or uniform in ``k .. max`` for a
``"k+"`` class); each tooth's target severity is uniform in
``[min + 1.1 tol, max - 1.1 tol]`` of the bin, so the achieved severity (the
pit generator lands within ``tol``) stays inside the bin.
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass, replace

import numpy as np

from datagen.class_grid import HEALTHY_SHAPE, ClassKey, class_grid
from datagen.flank import PitMap
from datagen.pits import make_pit_map
from datagen.sweep import Sweep

#: spawn-key streams of one sample
STREAM_OPERATING, STREAM_PITS, STREAM_DRIVE_TRAIN, STREAM_SIMULATION, STREAM_EFFECTS, STREAM_REFERENCE = range(6)
#: margin of the target severities inside their bin, in units of the generator tolerance
BIN_MARGIN = 1.1


def sample_rng(seed: int, index: int, stream: int, key: int | None = None) -> np.random.Generator:
    """Generator of one stream of sample ``index``: ``SeedSequence(seed, spawn_key=(index, stream[, key]))``."""
    spawn = (int(index), int(stream)) if key is None else (int(index), int(stream), int(key))
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=spawn))


@dataclass(frozen=True)
class SampleSpec:
    """Everything that defines sample ``index`` (SI units).

    Parameters
    ----------
    index : int
    class_index : int
        Position in :func:`datagen.class_grid.class_grid`.
    key : ClassKey
        Pair, severity class, teeth class and shape.
    severity_class_index, teeth_class_index : int
        Positions of the bin in ``severity_bins`` and of the teeth class in ``teeth_classes``.
    teeth : tuple of int
        Pitted teeth (sorted, mesh order).
    target_severity : tuple of float
        Requested pitted fraction of each pitted tooth.
    depth_m, aspect_w_to_s, profile, pit_seed
        Pit depth (m), width/length ratio (None = flank proportions), depth profile, pit generator seed.
    speed_rpm, torque_nm : float
        Pinion speed (rpm) and pinion torque (N m).
    effects : tuple of (name, tuple of (parameter, value))
        The sweep's effects with the values drawn for this sample.
    drive_train : tuple of (field, value)
    simulation_seed : int
        Seed of the simulation case (measurement noise).
    """

    index: int
    class_index: int
    key: ClassKey
    severity_class_index: int
    teeth_class_index: int
    teeth: tuple[int, ...]
    target_severity: tuple[float, ...]
    depth_m: float
    aspect_w_to_s: float | None
    profile: str
    pit_seed: int
    speed_rpm: float
    torque_nm: float
    effects: tuple
    drive_train: tuple
    simulation_seed: int


def draw_sample(sweep: Sweep, index: int) -> SampleSpec:
    """Draw sample ``index`` of ``sweep`` (a pure function of the two)."""
    classes = class_grid(sweep)
    ci = index % len(classes)
    key = classes[ci]
    seed = sweep.seed
    rng = sample_rng(seed, index, STREAM_OPERATING)
    speed = sweep.speed_rpm.draw(rng)
    torque = sweep.torque_nm.draw(rng)

    rng = sample_rng(seed, index, STREAM_PITS)
    sev_i = next(i for i, b in enumerate(sweep.severity_bins) if b.name == key.severity_class)
    teeth_i = next(i for i, t in enumerate(sweep.teeth_classes) if t.name == key.teeth_class)
    bin_, tclass = sweep.severity_bins[sev_i], sweep.teeth_classes[teeth_i]
    pair = sweep.pair(key.pair)
    depth = sweep.depth_m.draw(rng)
    aspect = sweep.aspect_w_to_s.draw(rng) if sweep.aspect_w_to_s is not None else None
    profile = sweep.profile.draw(rng)
    pit_seed = int(rng.integers(2**31))
    n = int(rng.integers(tclass.low, tclass.high + 1))
    z = pair._gear(sweep.gear).teeth
    teeth = tuple(sorted(int(t) for t in rng.choice(z, size=n, replace=False))) if n else ()
    margin = BIN_MARGIN * sweep.tolerance_for(pair)
    targets = tuple(float(v) for v in rng.uniform(bin_.min_fraction + margin, bin_.max_fraction - margin, size=n)) \
        if n else ()

    effects = []
    for name, draws in sweep.effects:
        erng = sample_rng(seed, index, STREAM_EFFECTS, zlib.crc32(name.encode()))
        effects.append((name, tuple((d.name, d.draw(erng)) for d in draws)))
    rng = sample_rng(seed, index, STREAM_DRIVE_TRAIN)
    drive = tuple((d.name, d.draw(rng)) for d in sweep.drive_train)
    sim_seed = int(sample_rng(seed, index, STREAM_SIMULATION).integers(2**31))
    if key.shape == HEALTHY_SHAPE:
        aspect = None
    return SampleSpec(index=index, class_index=ci, key=key, severity_class_index=sev_i, teeth_class_index=teeth_i,
                      teeth=teeth, target_severity=targets, depth_m=depth, aspect_w_to_s=aspect, profile=profile,
                      pit_seed=pit_seed, speed_rpm=speed, torque_nm=torque, effects=tuple(effects),
                      drive_train=drive, simulation_seed=sim_seed)


def build_pit_map(sweep: Sweep, spec: SampleSpec) -> PitMap:
    """The pit map of a sample (healthy samples: an empty map)."""
    pair = sweep.pair(spec.key.pair)
    grid = sweep.flank_grid(pair)
    if not spec.teeth:
        return PitMap.healthy(grid, sweep.gear)
    return make_pit_map(grid, shape=spec.key.shape, severity=dict(zip(spec.teeth, spec.target_severity)),
                        gear=sweep.gear, seed=spec.pit_seed, depth_m=spec.depth_m, tolerance=sweep.tolerance,
                        aspect_w_to_s=spec.aspect_w_to_s, profile=spec.profile)


def effect_column(effect: str, parameter: str) -> str:
    """Index column of an effect parameter: ``"<effect>_<parameter>"`` (the parameter carries its unit)."""
    return f"{effect}_{parameter}"


def reference_seed(sweep: Sweep, spec: SampleSpec) -> int:
    """Simulation seed of a sample's healthy twin (``[sweep] healthy_reference``): its own stream."""
    return int(sample_rng(sweep.seed, spec.index, STREAM_REFERENCE).integers(2**31))


def healthy_twin(sweep: Sweep, spec: SampleSpec) -> SampleSpec:
    """The sample without its pits, simulated from :func:`reference_seed` (everything else as drawn)."""
    return replace(spec, teeth=(), target_severity=(), simulation_seed=reference_seed(sweep, spec))


def sample_row(sweep: Sweep, spec: SampleSpec, pit_map: PitMap) -> dict:
    """The index row of a sample: labels (from the achieved pit map) and every drawn parameter."""
    achieved = [pit_map.severity(t) for t in spec.teeth]
    row = {
        "sample_index": spec.index, "seed": sweep.seed, "shard": spec.index // sweep.shard_size,
        "class_index": spec.class_index, "pair": spec.key.pair, "gear": sweep.gear,
        "severity": max(achieved, default=0.0), "severity_mean": float(np.mean(achieved)) if achieved else 0.0,
        "severity_class": spec.key.severity_class, "severity_class_index": spec.severity_class_index,
        "n_pitted_teeth": len(spec.teeth), "teeth_class": spec.key.teeth_class,
        "teeth_class_index": spec.teeth_class_index, "shape": spec.key.shape,
        "pitted_teeth": list(spec.teeth), "severity_by_tooth": achieved,
        "target_severity_by_tooth": list(spec.target_severity),
        "pit_depth_m": spec.depth_m if spec.teeth else 0.0,
        "pit_aspect_w_to_s": np.nan if spec.aspect_w_to_s is None else spec.aspect_w_to_s,
        "pit_profile": spec.profile if spec.teeth else "none", "pit_seed": spec.pit_seed,
        "speed_rpm": spec.speed_rpm, "torque_nm": spec.torque_nm, "fs_hz": sweep.fs_hz,
        "duration_s": sweep.duration_s, "simulation_seed": spec.simulation_seed,
    }
    if sweep.healthy_reference:
        row["reference_simulation_seed"] = reference_seed(sweep, spec)
    params = {name: dict(values) for name, values in spec.effects}
    row["snr_db"] = float(params["noise"].get("snr_db", np.inf)) if "noise" in params else np.inf
    for name, values in spec.effects:
        for p, v in values:
            row[effect_column(name, p)] = v
    for f, v in spec.drive_train:
        row[f"drive_train_{f}"] = v
    return row


def column_units(sweep: Sweep) -> dict[str, str]:
    """Unit of every index column ("-" for labels, counts and dimensionless values)."""
    units = {"severity": "fraction of flank area", "severity_mean": "fraction of flank area",
             "severity_by_tooth": "fraction of flank area", "target_severity_by_tooth": "fraction of flank area",
             "pit_depth_m": "m", "speed_rpm": "rpm", "torque_nm": "N m", "fs_hz": "Hz", "duration_s": "s",
             "snr_db": "dB"}
    for name, draws in sweep.effects:
        for d in draws:
            units[effect_column(name, d.name)] = d.unit
    for d in sweep.drive_train:
        units[f"drive_train_{d.name}"] = d.unit
    return units
