"""Which input representation a classifier reads, and its size: :class:`RepresentationSpec`, checked when it is
built (each field against what its kind allows), and the vocabulary of representation kinds. What each kind
computes from a record, and why: :mod:`models.representations`.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Literal

import numpy as np

from gearpit.errors import InputError, require, require_positive

Kind = Literal["raw", "envelope", "tsa", "order", "mesh_order"]
KINDS: tuple[str, ...] = ("raw", "envelope", "tsa", "order", "mesh_order")
#: representations whose axis is tied to the sampling rate (input fs must equal the trained fs)
FS_BOUND: tuple[str, ...] = ("raw", "envelope")
#: representations that can be read relative to a healthy reference
REFERENCE_KINDS: tuple[str, ...] = ("order", "mesh_order", "tsa")


@dataclass(frozen=True)
class RepresentationSpec:
    """Which representation and its size.

    Attributes
    ----------
    kind : {"raw", "envelope", "tsa", "order", "mesh_order"}
    n_samples : int
        Segment length (samples) of ``raw`` and ``envelope``.
    n_revs : int
        Pinion revolutions per segment of ``tsa`` and ``order``; the order
        resolution is ``1 / n_revs``.
    samples_per_rev : int
        Samples per revolution of ``tsa`` (orders up to ``samples_per_rev / 2``).
    max_order : float
        Highest pinion shaft order (``order``) or mesh order (``mesh_order``) kept.
    n_mesh_periods : int
        Mesh periods per segment of ``mesh_order``.
    lowpass_mesh_orders : float
        ``tsa`` only: keep shaft orders below this many mesh orders (0 = all, up
        to ``samples_per_rev / 2``).
    highpass_orders : float
        ``tsa`` only: high-pass the record at this many pinion shaft orders
        first (0 = no high-pass).
    remove_shaft_1x : bool
        ``tsa`` only: subtract the pinion's and the wheel's first shaft order
        from the record first.
    reference : bool
        Read each record relative to its healthy reference (:mod:`models.representations`;
        ``order``, ``mesh_order``, ``tsa``); the records are then pairs.
    integrate : int
        ``tsa`` only: integrate the synchronous average this many times over the
        pinion's angle (0, 1 or 2; order ``k`` divided by ``(i k)^n``, orders 0-2
        dropped: :func:`models.tsa.integrated`). An accelerometer's record
        integrated twice undoes the acceleration's weighting by the frequency
        squared, which favours the sharpness of a pit's stiffness dip over its
        area; on the accelerometer it did not lift the severity accuracy
        (experiments/RESULTS.md, "Taking the nuisances away"). Off by default.
    whiten : bool
        ``tsa`` with ``reference`` only: divide every order of the record's TSA
        and of its residual by the reference's amplitude at the nearest mesh
        harmonic (:func:`models.tsa.mesh_whitening`): each harmonic region is
        read relative to the healthy mesh excitation that passed the same
        sensor path, so a housing resonance no longer sets which region the
        network sees.
    """

    kind: Kind = "order"
    n_samples: int = 4096
    n_revs: int = 8
    samples_per_rev: int = 512
    max_order: float = 100.0
    n_mesh_periods: int = 256
    lowpass_mesh_orders: float = 0.0
    highpass_orders: float = 0.0
    remove_shaft_1x: bool = False
    reference: bool = False
    whiten: bool = False
    integrate: int = 0

    def __post_init__(self):
        require(self.kind in KINDS, "representation.kind", self.kind, "one of: " + ", ".join(KINDS))
        for name, lo in (("n_samples", 64), ("n_revs", 1), ("samples_per_rev", 16), ("n_mesh_periods", 8)):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= lo,
                    f"representation.{name}", v, f"an integer >= {lo}")
        require_positive("representation.max_order", self.max_order)
        require(self.samples_per_rev % 2 == 0, "representation.samples_per_rev", self.samples_per_rev, "an even integer")
        for name, top, what in (("lowpass_mesh_orders", np.inf, "a number >= 0 mesh orders (0 = no low-pass)"),
                                ("highpass_orders", 10.0, "a number in [0, 10] pinion orders (0 = no high-pass)")):
            v = getattr(self, name)
            require(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
                    and np.isfinite(v) and 0 <= v <= top, f"representation.{name}", v, what)
            require(v == 0 or self.kind == "tsa", f"representation.{name}", v,
                    f"0 for representation {self.kind!r} (only 'tsa' has order filters)")
        require(isinstance(self.remove_shaft_1x, (bool, np.bool_)), "representation.remove_shaft_1x",
                self.remove_shaft_1x, "true or false")
        require(not self.remove_shaft_1x or self.kind == "tsa", "representation.remove_shaft_1x",
                self.remove_shaft_1x, f"false for representation {self.kind!r} (only 'tsa' removes shaft lines)")
        require(isinstance(self.reference, (bool, np.bool_)), "representation.reference", self.reference,
                "true or false")
        require(not self.reference or self.kind in REFERENCE_KINDS, "representation.reference", self.reference,
                f"false for representation {self.kind!r} (only " + ", ".join(REFERENCE_KINDS)
                + " are read against a reference)")

        require(isinstance(self.integrate, (int, np.integer)) and not isinstance(self.integrate, bool)
                and 0 <= self.integrate <= 2, "representation.integrate", self.integrate, "an integer 0, 1 or 2")
        require(self.integrate == 0 or self.kind == "tsa", "representation.integrate", self.integrate,
                f"0 for representation {self.kind!r} (only 'tsa' is integrated over the angle)")
        require(isinstance(self.whiten, (bool, np.bool_)), "representation.whiten", self.whiten, "true or false")
        require(not self.whiten or (self.kind == "tsa" and self.reference), "representation.whiten", self.whiten,
                "false unless kind = 'tsa' and reference = true (the whitening reads the reference's mesh harmonics)")

    @classmethod
    def from_dict(cls, values: dict) -> "RepresentationSpec":
        """Build from a mapping (TOML table, saved model); unknown keys are errors."""
        known = {f.name for f in fields(cls)}
        for key in values:
            if key not in known:
                raise InputError(f"representation.{key}", values[key], "one of: " + ", ".join(sorted(known)))
        return cls(**values)

    def to_dict(self) -> dict:
        return asdict(self)

    @property
    def n_channels(self) -> int:
        """Input channels of the network."""
        return 2 if self.kind in ("order", "mesh_order", "tsa") else 1

    @property
    def length(self) -> int:
        """Length of one channel."""
        if self.kind == "raw":
            return self.n_samples
        if self.kind == "envelope":
            return self.n_samples // 8
        if self.kind == "tsa":
            return self.samples_per_rev
        if self.kind == "order":
            return int(np.floor(self.max_order * self.n_revs))
        return int(np.floor(self.max_order * self.n_mesh_periods))

    @property
    def needs_speed(self) -> bool:
        """True if the shaft speed (or the mesh frequency) must be known."""
        return self.kind in ("tsa", "order", "mesh_order")

    def segment_length(self, fs_hz: float, shaft_hz: float | None = None, mesh_cps: float | None = None,
                       speed_factor: float = 1.0) -> int:
        """Samples of record one segment takes (before any resampling)."""
        if self.kind in ("raw", "envelope"):
            return int(round(self.n_samples * speed_factor))
        if self.kind in ("tsa", "order"):
            return int(round(self.n_revs * fs_hz / (shaft_hz * speed_factor)))
        return int(round(self.n_mesh_periods / (mesh_cps * speed_factor)))

