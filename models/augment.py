"""Training-time augmentation that mimics what changes between runs of a rig.

For each record of a batch, drawn independently from the given generator:

- **phase / crop**: where the segment starts in the record (uniform fraction of
  the free room), i.e. the shaft angle at the start of the segment;
- **gain**: a sensor-sensitivity or mounting change, ``+/- gain_db`` (uniform in dB);
- **noise**: with probability ``noise_probability``, white Gaussian noise at an SNR
  drawn uniformly in ``snr_db_range`` (dB, relative to the record's power);
- **speed error**: the shaft turned at ``1 + u`` times the labelled speed, ``u``
  uniform in ``+/- speed_error`` (applied by the representation, see
  :mod:`models.representations`);
- **polarity**: with probability ``polarity_flip_probability`` the record is
  negated (an accelerometer mounted the other way round).

Per-signal normalisation in the representation removes the gain again for the
network; the gain still matters for the noise level and is kept so that
augmented records are plausible records.

The defaults are deliberately light (noise in a quarter of the records at
20-40 dB, speed error 0.2 %). Measured on the default dataset (CNN, tsa input,
experiments/RESULTS.md): light 82 % severity / 93 % teeth accuracy; none 77 % /
84 %; heavier (5-30 dB noise in half the records, 1 % speed error) 80 % / 81 %.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from gearpit.errors import InputError, require, require_range


@dataclass(frozen=True)
class AugmentConfig:
    """Augmentation ranges (see module docstring); ``AugmentConfig.none()`` switches all off."""

    random_start: bool = True
    gain_db: float = 3.0
    noise_probability: float = 0.25
    snr_db_range: tuple[float, float] = (20.0, 40.0)
    speed_error: float = 0.002
    polarity_flip_probability: float = 0.5

    def __post_init__(self):
        require(isinstance(self.random_start, bool), "augment.random_start", self.random_start, "true or false")
        require_range("augment.gain_db", self.gain_db, 0.0, 20.0)
        require_range("augment.noise_probability", self.noise_probability, 0.0, 1.0)
        r = tuple(self.snr_db_range)
        require(len(r) == 2 and float(r[0]) <= float(r[1]), "augment.snr_db_range", self.snr_db_range,
                "(lo, hi) with lo <= hi (dB)")
        object.__setattr__(self, "snr_db_range", (float(r[0]), float(r[1])))
        require_range("augment.speed_error", self.speed_error, 0.0, 0.2)
        require_range("augment.polarity_flip_probability", self.polarity_flip_probability, 0.0, 1.0)

    @classmethod
    def none(cls) -> "AugmentConfig":
        """No augmentation at all (segments start at the record's start)."""
        return cls(random_start=False, gain_db=0.0, noise_probability=0.0, speed_error=0.0,
                   polarity_flip_probability=0.0)

    @classmethod
    def from_dict(cls, values: dict) -> "AugmentConfig":
        known = {f.name for f in fields(cls)}
        for key in values:
            if key not in known:
                raise InputError(f"augment.{key}", values[key], "one of: " + ", ".join(sorted(known)))
        return cls(**values)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["snr_db_range"] = list(self.snr_db_range)
        return d


def augment_batch(x: np.ndarray, config: AugmentConfig, rng: np.random.Generator
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Augmented copy of the records ``x`` (n, n_samples), segment starts and speed factors.

    Returns
    -------
    records : ndarray, shape (n, n_samples), float32
    starts : ndarray, shape (n,)
        Segment start, fraction of the free room.
    speed_factors : ndarray, shape (n,)
    """
    a = np.asarray(x, dtype=np.float64)
    n = a.shape[0]
    starts = rng.uniform(0.0, 1.0, n) if config.random_start else np.zeros(n)
    gain = 10.0 ** (rng.uniform(-config.gain_db, config.gain_db, n) / 20.0)
    sign = np.where(rng.uniform(size=n) < config.polarity_flip_probability, -1.0, 1.0)
    out = a * (gain * sign)[:, None]
    noisy = rng.uniform(size=n) < config.noise_probability
    snr = rng.uniform(config.snr_db_range[0], config.snr_db_range[1], n)
    if noisy.any():
        power = np.mean(out[noisy] ** 2, axis=1)
        std = np.sqrt(power / 10.0 ** (snr[noisy] / 10.0))
        out[noisy] += std[:, None] * rng.standard_normal((int(noisy.sum()), a.shape[1]))
    speed = 1.0 + rng.uniform(-config.speed_error, config.speed_error, n)
    return out.astype(np.float32), starts, speed
