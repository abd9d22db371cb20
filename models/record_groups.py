"""The measurement files of one call as groups a model reads at once, each file's prediction independent of the
others.

A :class:`~models.data.SignalSet` holds records of one sampling rate, pair and length. Measurement files of one
call need not share them: every file is cut to the model's trained record length, but with ``allow_mismatch`` a
shorter file, or one at another rate, is read as it is, on its own. :class:`RecordGroups` keeps the files in
groups of equal rate, pair, length and reference, checks every group against the model before any is predicted
(:func:`models.spec.check_input`; an error names the group's files), predicts each group and puts the predictions
back in the order of the call.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pandas as pd

from gearpit.errors import InputError, require
from models.data import SignalSet
from models.spec import Predictions, check_input


def named(exc: InputError, names: list[str]) -> InputError:
    """``exc`` with the file names in front of its field (unless it names one of them already)."""
    if any(n in str(exc.field) for n in names):
        return exc
    shown = ", ".join(names[:3]) + (f" (+{len(names) - 3})" if len(names) > 3 else "")
    return InputError(f"{shown}: {exc.field}", exc.value, exc.allowed)


@dataclass(frozen=True)
class RecordGroups:
    """Signal sets of equal rate, pair, length and reference, and where their records stand in the call.

    Attributes
    ----------
    sets : tuple of SignalSet
    positions : tuple of ndarray of int
        Position in the call of each record of each set.
    skipped : tuple of str
        Files of a folder that were not read, each with the reason (a data file with no sidecar, not in
        ``labels.csv``).
    source : str
        The files, for reports.
    """

    sets: tuple
    positions: tuple
    skipped: tuple = ()
    source: str = ""

    def __len__(self) -> int:
        return int(sum(len(s) for s in self.sets))

    def _order(self) -> np.ndarray:
        """Index into the concatenated sets that gives the call's order."""
        return np.argsort(np.concatenate(self.positions), kind="stable")

    def merged(self) -> SignalSet:
        """All records in the order of the call: one signal set when the groups can share one (same rate, pair and
        length), else their labels with no samples (``n_samples`` 0: for scores and reports only)."""
        order = self._order()
        labels = pd.concat([s.labels for s in self.sets], ignore_index=True).iloc[order].reset_index(drop=True)
        first = self.sets[0]
        if len(self.sets) == 1:
            return replace(first, labels=labels, source=self.source)
        refs = [s.reference is not None for s in self.sets]
        same = all(s.fs_hz == first.fs_hz and s.pair == first.pair and s.n_samples == first.n_samples
                   for s in self.sets) and (all(refs) or not any(refs))
        if same:
            x = np.concatenate([s.signals for s in self.sets])[order]
            ref = np.concatenate([s.reference for s in self.sets])[order] if all(refs) else None
            return SignalSet(x, first.fs_hz, first.pair, labels, self.source, first.channel, ref)
        return SignalSet(np.zeros((len(labels), 0), np.float32), first.fs_hz, first.pair, labels, self.source,
                         first.channel)

    def check(self, spec, *, allow_mismatch: bool = False) -> None:
        """:func:`models.spec.check_input` of every group before any work; an error names the group's files."""
        for s in self.sets:
            try:
                check_input(spec, s, allow_mismatch=allow_mismatch)
            except InputError as exc:
                raise named(exc, [str(v) for v in s.labels["file"]]) from None

    def predict(self, predict: Callable[[SignalSet], Predictions], spec, *, allow_mismatch: bool = False,
                novelty=None) -> Predictions:
        """Predictions of every record in the order of the call: every group checked first (:meth:`check`), then
        ``predict`` on each. ``novelty``: the model's :class:`models.novelty.NoveltyModel`, whose batch test is
        made again over all records when there are several groups."""
        self.check(spec, allow_mismatch=allow_mismatch)
        preds = []
        for s in self.sets:
            try:
                preds.append(predict(s))
            except InputError as exc:
                raise named(exc, [str(v) for v in s.labels["file"]]) from None
        if len(preds) == 1:
            return preds[0]
        order = self._order()
        p0 = preds[0]
        nov = None if p0.novelty is None else np.concatenate([p.novelty for p in preds])[order]
        return Predictions(p0.severity_classes, p0.teeth_classes,
                           np.concatenate([p.severity_proba for p in preds])[order],
                           np.concatenate([p.teeth_proba for p in preds])[order],
                           np.concatenate([p.severity for p in preds])[order],
                           [str(w) for w in np.asarray([w for p in preds for w in p.warnings], dtype=object)[order]],
                           nov, None if nov is None or novelty is None else novelty.batch_shift(nov))

    def single(self) -> SignalSet:
        """The one signal set of a call whose files share rate, pair and length (else refused)."""
        require(len(self.sets) == 1, "FILES", self.source,
                "files of one sampling rate, gear pair and record length (or give the model: each is then cut to "
                "its trained length)")
        return self.merged()


__all__ = ["RecordGroups", "named"]
