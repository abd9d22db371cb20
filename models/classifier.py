"""A trained CNN together with its spec: predictions on a :class:`~models.data.SignalSet`.

Prediction averages the class probabilities (and the severity) over ``n_crops``
segments at evenly spaced positions of each record (test-time crops), without
augmentation; all on the CPU.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from gearpit.errors import require
from models.cnn import GearCNN
from models.data import SignalSet
from models.operating import n_operating, operating_features
from models.representations import represent
from models.spec import ModelSpec, Predictions, check_input


def build_network(spec: ModelSpec) -> GearCNN:
    """An untrained network of the architecture recorded in ``spec``."""
    rep = spec.representation_spec()
    arch = spec.train_config.get("architecture", {})
    return GearCNN(rep.n_channels, len(spec.severity_classes), len(spec.teeth_classes),
                   widths=tuple(arch.get("widths", (16, 32, 48, 64, 96))), hidden=int(arch.get("hidden", 64)),
                   dropout=float(arch.get("dropout", 0.2)), circular=rep.kind == "tsa",
                   n_side=n_operating(spec.operating_inputs))


def representation_batches(data: SignalSet, spec: ModelSpec, *, starts: float, batch_size: int = 256):
    """Yield ``(slice, tensor, side)`` of the representation of ``data`` in batches; ``side`` is the
    tensor of side inputs (:mod:`models.operating`) or None."""
    rep = spec.representation_spec()
    fr, mc = data.shaft_hz(), data.mesh_cps()
    side = operating_features(data, spec.operating_inputs) if spec.operating_inputs else None
    for i0 in range(0, len(data), batch_size):
        sl = slice(i0, min(i0 + batch_size, len(data)))
        x = represent(data.signals[sl], rep, fs_hz=data.fs_hz, shaft_hz=None if fr is None else fr[sl],
                      mesh_cps=None if mc is None else mc[sl], z_pinion=data.pair.z_pinion or None, starts=starts)
        yield sl, torch.from_numpy(x), None if side is None else torch.from_numpy(side[sl])


@dataclass
class CNNClassifier:
    """A trained :class:`~models.cnn.GearCNN` and its :class:`~models.spec.ModelSpec`."""

    network: GearCNN
    spec: ModelSpec

    def predict(self, data: SignalSet, *, n_crops: int = 3, allow_mismatch: bool = False,
                batch_size: int = 256, threads: int = 1) -> Predictions:
        """Predictions for every record of ``data`` (checked first, see :func:`models.spec.check_input`).

        ``threads``: torch CPU threads (1 or 2).
        """
        require(isinstance(n_crops, int) and n_crops >= 1, "n_crops", n_crops, "an integer >= 1")
        require(threads in (1, 2), "threads", threads, "1 or 2")
        torch.set_num_threads(threads)
        warnings = check_input(self.spec, data, allow_mismatch=allow_mismatch)
        n = len(data)
        p_sev = np.zeros((n, len(self.spec.severity_classes)))
        p_teeth = np.zeros((n, len(self.spec.teeth_classes)))
        sev = np.zeros(n)
        starts = [0.5] if n_crops == 1 else list(np.linspace(0.0, 1.0, n_crops))
        self.network.eval()
        with torch.no_grad():
            for st in starts:
                for sl, x, side in representation_batches(data, self.spec, starts=st, batch_size=batch_size):
                    out = self.network(x, side)
                    p_sev[sl] += torch.softmax(out["severity_class"], dim=1).numpy()
                    p_teeth[sl] += torch.softmax(out["teeth"], dim=1).numpy()
                    sev[sl] += out["severity"].numpy()
        k = len(starts)
        severity = np.clip(sev / k * self.spec.severity_scale, 0.0, None)
        return Predictions(list(self.spec.severity_classes), list(self.spec.teeth_classes), p_sev / k,
                           p_teeth / k, severity, warnings)
