"""Labelled records as the classifiers see them: one :class:`SignalSet`.

A signal set is records ``(n_records, n_samples)`` at one sampling rate, one
gear pair, and a label table with one row per record. Columns used:

- ``speed_rpm`` (pinion speed, rpm; needed by the order-domain representations),
  ``torque_nm`` (load, N m; breakdowns only);
- ``severity`` (pitted fraction, 0 = healthy), ``severity_class`` (name),
  ``severity_class_index`` (order of the classes), ``n_pitted_teeth`` and/or
  ``teeth_class`` (the classifiers' classes ``"0"``, ``"1"``, ``"2"``, ``"3+"``;
  the count decides where both are given, :meth:`SignalSet.teeth_classes`); all
  optional for unlabelled records;
- ``mesh_cps`` (mesh frequency in cycles per sample), optional: overrides the
  value computed from the speed, for records whose sampling rate or tooth counts
  are unknown.

A record may come with a *healthy reference* (``reference``): a recording of the same machine
at the same operating point with no fault (a commissioning record), the same length, which
models read the record against (:mod:`models.representations`, ``reference = true``).

Where the records come from (a generated dataset, measurement files) is the job
of :mod:`models.sources`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from gearpit.errors import require, require_positive

TEETH_CLASSES: tuple[str, ...] = ("0", "1", "2", "3+")
#: the two classes of the healthy-versus-damaged task
BINARY_CLASSES: tuple[str, ...] = ("healthy", "damaged")


@dataclass(frozen=True)
class PairInfo:
    """What a model needs to know about the gear pair: a name and the tooth counts
    (0 = not known, e.g. a recording whose gearbox is not documented)."""

    name: str
    z_pinion: int
    z_wheel: int

    def __post_init__(self):
        require(isinstance(self.name, str) and self.name != "", "pair.name", self.name, "a non-empty string")
        for f in ("z_pinion", "z_wheel"):
            v = getattr(self, f)
            require(isinstance(v, (int, np.integer)) and v >= 0, f"pair.{f}", v, "an integer >= 1 (0 = unknown)")

    @property
    def known(self) -> bool:
        return self.z_pinion > 0 and self.z_wheel > 0

    def to_dict(self) -> dict:
        return {"name": self.name, "z_pinion": int(self.z_pinion), "z_wheel": int(self.z_wheel)}


def teeth_class_of(n_pitted_teeth) -> np.ndarray:
    """``"0"``, ``"1"``, ``"2"`` or ``"3+"`` for each count of pitted teeth."""
    n = np.asarray(n_pitted_teeth, dtype=int)
    return np.array([TEETH_CLASSES[min(int(k), 3)] for k in n.ravel()], dtype=object)


@dataclass(frozen=True)
class SignalSet:
    """Records, their sampling rate, the gear pair and one label row per record.

    Attributes
    ----------
    signals : ndarray, shape (n_records, n_samples)
    fs_hz : float
        Sampling rate (Hz).
    pair : PairInfo
    labels : pandas.DataFrame
        One row per record (columns in the module docstring).
    source : str
        Where the records came from (path or description), for reports.
    channel : str or None
        Which sensor channel the records are (dataset channel name), if known.
    reference : ndarray or None, shape (n_records, n_samples)
        Healthy reference of each record (module docstring), or None.
    """

    signals: np.ndarray
    fs_hz: float
    pair: PairInfo
    labels: pd.DataFrame
    source: str = ""
    channel: str | None = None
    reference: np.ndarray | None = None

    def __post_init__(self):
        x = self.signals
        require(isinstance(x, np.ndarray) and x.ndim == 2 and x.shape[0] >= 1, "signals",
                getattr(x, "shape", type(x).__name__), "a 2-D array (records, samples)")
        require_positive("fs_hz", float(self.fs_hz))
        require(len(self.labels) == x.shape[0], "labels", f"{len(self.labels)} rows", f"{x.shape[0]} (one per record)")
        if "speed_rpm" in self.labels:
            sp = self.labels["speed_rpm"].to_numpy(dtype=float)
            require(bool(np.all(np.isfinite(sp) & (sp > 0))), "speed_rpm", "non-positive", "speeds > 0 rpm")
        r = self.reference
        require(r is None or (isinstance(r, np.ndarray) and r.shape == x.shape), "reference",
                getattr(r, "shape", type(r).__name__), f"None or an array of the records' shape {x.shape}")

    def __len__(self) -> int:
        return int(self.signals.shape[0])

    @property
    def n_samples(self) -> int:
        return int(self.signals.shape[1])

    def subset(self, idx) -> "SignalSet":
        """The records at positions ``idx`` (labels re-indexed from 0)."""
        idx = np.asarray(idx)
        return SignalSet(np.asarray(self.signals[idx]), self.fs_hz, self.pair,
                         self.labels.iloc[idx].reset_index(drop=True), self.source,
                         self.channel, None if self.reference is None else np.asarray(self.reference[idx]))

    def paired_signals(self, idx=None) -> np.ndarray:
        """Each record followed by its reference, ``(n, 2 n_samples)``: what a representation read against the
        reference takes (:mod:`models.representations`); ``idx``: those records only."""
        require(self.reference is not None, "reference", None,
                "a healthy reference for every record (a model read against a reference needs one: a dataset "
                "generated with [sweep] healthy_reference = true, or a sidecar key 'reference')")
        sl = slice(None) if idx is None else idx
        return np.concatenate([self.signals[sl], self.reference[sl]], axis=1)

    def shaft_hz(self) -> np.ndarray | None:
        """Pinion shaft frequency (Hz) per record, or None without a ``speed_rpm`` column."""
        if "speed_rpm" not in self.labels:
            return None
        return self.labels["speed_rpm"].to_numpy(dtype=float) / 60.0

    def mesh_cps(self) -> np.ndarray | None:
        """Mesh frequency (cycles per sample) per record: the ``mesh_cps`` column, else from the speed."""
        if "mesh_cps" in self.labels:
            return self.labels["mesh_cps"].to_numpy(dtype=float)
        fr = self.shaft_hz()
        return None if fr is None or not self.pair.known else fr * self.pair.z_pinion / self.fs_hz

    def has_labels(self) -> bool:
        """True if severity classes are present."""
        return "severity_class" in self.labels

    def has_teeth_labels(self) -> bool:
        """True if every record has a pitted-teeth label."""
        for col in ("teeth_class", "n_pitted_teeth"):
            if col in self.labels:
                return bool(self.labels[col].notna().all())
        return False

    def severity_class_names(self) -> list[str]:
        """Class names, ordered by ``severity_class_index`` if present, else by mean severity."""
        lab = self.labels
        require("severity_class" in lab, "labels", list(lab.columns), "a severity_class column")
        if "severity_class_index" in lab:
            pairs = lab[["severity_class_index", "severity_class"]].drop_duplicates().sort_values("severity_class_index")
            return [str(c) for c in pairs["severity_class"]]
        if "severity" in lab:
            return [str(c) for c in lab.groupby("severity_class")["severity"].mean().sort_values().index]
        return sorted(str(c) for c in lab["severity_class"].unique())

    def teeth_classes(self) -> np.ndarray:
        """Pitted-teeth class per record in the classifiers' vocabulary :data:`TEETH_CLASSES` (``"0"`` .. ``"3+"``).

        A record's count ``n_pitted_teeth``, where it has one, decides (:func:`teeth_class_of`): a dataset's own
        teeth classes are the sweep's sampling strata (any ``"k"`` or ``"k+"``, e.g. ``"5"`` or ``"1+"``,
        :mod:`datagen.class_grid`) and each record's count places it in the classifiers' classes. A record
        without a count takes its ``teeth_class``, which must then be one of :data:`TEETH_CLASSES`.
        """
        lab = self.labels
        require("teeth_class" in lab or "n_pitted_teeth" in lab, "labels", list(lab.columns),
                "teeth_class or n_pitted_teeth")
        n = (pd.to_numeric(lab["n_pitted_teeth"], errors="coerce").to_numpy(dtype=float) if "n_pitted_teeth" in lab
             else np.full(len(lab), np.nan))
        named = lab["teeth_class"].astype(str).to_numpy(dtype=object) if "teeth_class" in lab else None
        out = np.empty(len(lab), dtype=object)
        for i, k in enumerate(n):
            if np.isfinite(k):
                require(k >= 0 and k == int(k), "labels.n_pitted_teeth", k, "an integer >= 0")
                out[i] = teeth_class_of([int(k)])[0]
            else:
                require(named is not None and named[i] in TEETH_CLASSES, "labels.teeth_class",
                        None if named is None else named[i],
                        f"one of: {', '.join(TEETH_CLASSES)} (or an n_pitted_teeth count)")
                out[i] = named[i]
        return out

    def as_binary(self) -> "SignalSet":
        """The same records with the classes ``healthy`` (severity 0) and ``damaged`` (anything else)."""
        lab = self.labels.copy()
        if "severity_class" in lab:
            damaged = lab["severity_class"].astype(str).to_numpy() != "healthy"
        else:
            require("severity" in lab, "labels", list(lab.columns), "a severity_class or severity column")
            damaged = lab["severity"].to_numpy(dtype=float) > 0
        lab["severity_class"] = np.where(damaged, BINARY_CLASSES[1], BINARY_CLASSES[0])
        lab["severity_class_index"] = damaged.astype(int)
        return SignalSet(self.signals, self.fs_hz, self.pair, lab, self.source, self.channel, self.reference)


def concat(sets: list[SignalSet]) -> SignalSet:
    """Records of several sets with the same sampling rate, pair and record length."""
    require(len(sets) >= 1, "sets", 0, "at least one signal set")
    first = sets[0]
    for s in sets[1:]:
        require(s.fs_hz == first.fs_hz, "fs_hz", s.fs_hz, f"{first.fs_hz} (all sets alike)")
        require(s.pair == first.pair, "pair", s.pair.name, f"{first.pair.name} (all sets alike)")
        require(s.n_samples == first.n_samples, "n_samples", s.n_samples, f"{first.n_samples} (all sets alike)")
    refs = [s.reference is not None for s in sets]
    require(all(refs) or not any(refs), "reference", f"{sum(refs)} of {len(sets)} sets",
            "a reference in every set or in none")
    return SignalSet(np.concatenate([s.signals for s in sets]), first.fs_hz, first.pair,
                     pd.concat([s.labels for s in sets], ignore_index=True), first.source, first.channel,
                     np.concatenate([s.reference for s in sets]) if all(refs) else None)
