"""Example sweeps shared by the demo (``gearpit demo``), tests and docs.

:data:`DEMO_TOML` is also shipped as ``experiments/sweeps/demo.toml`` (a test
keeps the two identical).
"""
from __future__ import annotations

import tomllib

from datagen.sweep import Sweep, sweep_from_dict

#: the README main job's sweep: 2 severity classes x 1 or 2 pitted teeth x 3 samples, half-second signals
DEMO_TOML = """\
# Demo sweep for the README's main job: 2 severity classes x 2 teeth classes x 3 samples, ~10 s.
[sweep]
name = "demo"
seed = 1
samples_per_class = 3
shard_size = 6
fs_hz = 12800.0
duration_s = 0.5
pairs = ["spur-gds"]
channels = ["acc_pinion_loa_m_s2", "tacho_pinion"]

[classes]
shapes = ["ellipse"]
teeth = ["1", "2"]
[classes.severity_bins]          # pitted fraction of one flank, [min, max)
minor = [0.03, 0.08]
severe = [0.15, 0.25]

[pits]
grid_px = [44, 120]
depth_mm = [0.1, 0.3]

[operating]
speed_rpm = [1000.0, 1200.0]
torque_nm = [20.0, 60.0]

[effects.transmission_path]
housing_frequency_hz = [2500.0, 4000.0]

[effects.noise]
snr_db = [20.0, 40.0]
"""


def demo_sweep() -> Sweep:
    """The demo sweep (12 samples; a few seconds on one core).

    Examples
    --------
    >>> demo_sweep().n_samples
    12
    """
    return sweep_from_dict(tomllib.loads(DEMO_TOML))
