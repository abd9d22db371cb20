"""A trained CNN together with its spec: predictions on a :class:`~models.data.SignalSet`.

Prediction averages the class probabilities (and the severity) over ``n_crops``
segments at evenly spaced positions of each record (test-time crops), without
augmentation; all on the CPU. The crops of a record are represented together
(:func:`~models.representations.represent_crops`: the work that does not depend
on the crop is done once) and go through the network in one pass with the other
records of their batch.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
import torch
from threadpoolctl import threadpool_limits

from gearpit.errors import require
from models.cnn import GearCNN
from models.data import SignalSet
from models.novelty import NoveltyModel, join_warnings, novelty_warning
from models.operating import n_operating, operating_features
from models.representations import represent_crops
from models.tsa import represent_crops_and_difference, represent_crops_and_residual
from models.tooth_profile import PROFILE_SPEC, profile_of_difference
from models.spec import ModelSpec, Predictions, bounded_severity, check_input


def build_network(spec: ModelSpec) -> GearCNN:
    """An untrained network of the architecture recorded in ``spec``."""
    rep = spec.representation_spec()
    arch = spec.train_config.get("architecture", {})
    return GearCNN(rep.n_channels, len(spec.severity_classes), len(spec.teeth_classes),
                   widths=tuple(arch.get("widths", (16, 32, 48, 64, 96))), hidden=int(arch.get("hidden", 64)),
                   dropout=float(arch.get("dropout", 0.2)), circular=rep.kind == "tsa",
                   n_side=n_operating(spec.operating_inputs))


def crop_starts(n_crops: int) -> tuple[float, ...]:
    """Starts of the ``n_crops`` test-time crops, fractions of the free room: the centre for one crop,
    else evenly spaced from 0 to 1."""
    require(isinstance(n_crops, int) and n_crops >= 1, "n_crops", n_crops, "an integer >= 1")
    return (0.5,) if n_crops == 1 else tuple(float(v) for v in np.linspace(0.0, 1.0, n_crops))


def represent_batch(data: SignalSet, spec: ModelSpec, sl: slice, crops: tuple[float, ...]):
    """``(tensor, side)`` of the records ``sl`` of ``data``: the tensor holds the representation of each record
    at each start of ``crops``, ``(records * len(crops), channels, length)``, record by record (the crops of a
    record adjacent); ``side`` the side inputs (:mod:`models.operating`) repeated for every crop, or None.
    Every value depends on its own record only, so batches can be computed in any order or in parallel.

    Where the model reads the pitted-teeth profile or the level of its difference signal (``tsa_diff_rms``) and
    its own representation is the profile's TSA (up to the removal of the shaft lines), they are read from the
    first crop's FFT
    (:func:`models.tsa.represent_crops_and_difference`) instead of a second TSA of the record."""
    rep = spec.representation_spec()
    part = data.subset(np.arange(sl.start, sl.stop))
    fr, mc = part.shaft_hz(), part.mesh_cps()
    zp, zw = part.pair.z_pinion or None, part.pair.z_wheel or None
    known = None
    if _profile_shares_fft(spec) and fr is not None and zp and zw:
        # the difference signal is read at start 0: without a crop there, one is added and its representation dropped
        lead = crops if crops[0] == 0.0 else (0.0,) + tuple(crops)
        x, diff = represent_crops_and_difference(part.signals, rep, fs_hz=part.fs_hz, crops=lead, shaft_hz=fr,
                                                 z_pinion=zp, z_wheel=zw, difference_spec=PROFILE_SPEC)
        x = x[:, len(lead) - len(crops):]
        # the difference signal is that of the normalised record: its RMS times the record's standard deviation is
        # tsa_diff_rms (the difference holds no order 0, so the record's mean does not enter)
        known = {"tooth_profile": profile_of_difference(diff, int(zp)),
                 "tsa_diff_rms": np.sqrt(np.mean(diff ** 2, axis=1)) * np.asarray(part.signals, float).std(axis=1)}
    elif _residual_shares_fft(spec) and fr is not None and zp and zw:
        # the residual side inputs from the first crop's combs (start 0, added and dropped if not asked for)
        lead = crops if crops[0] == 0.0 else (0.0,) + tuple(crops)
        x, diff = represent_crops_and_residual(part.paired_signals(), rep, fs_hz=part.fs_hz, crops=lead,
                                               shaft_hz=fr, z_pinion=zp, z_wheel=zw)
        x = x[:, len(lead) - len(crops):]
        known = {"residual_rms": np.sqrt(np.mean(diff ** 2, axis=1)),
                 "residual_profile": profile_of_difference(diff, int(zp))}
    else:
        x = represent_crops(part.paired_signals() if rep.reference else part.signals, rep, fs_hz=part.fs_hz,
                            crops=crops, shaft_hz=fr, mesh_cps=mc, z_pinion=zp, z_wheel=zw)
    x = torch.from_numpy(x.reshape(-1, *x.shape[2:]))
    if not spec.operating_inputs:
        return x, None
    side = operating_features(part, spec.operating_inputs, known)
    return x, torch.from_numpy(np.repeat(side, len(crops), axis=0))


def _residual_shares_fft(spec: ModelSpec) -> bool:
    """Whether the residual side inputs can be read with the network's crops (:func:`represent_batch`): the
    network reads the residual's TSA with the filters the side inputs use."""
    if not spec.operating_inputs or not {"residual_rms", "residual_profile"} & set(spec.operating_inputs["columns"]):
        return False
    rep = spec.representation_spec()
    return rep.kind == "tsa" and rep.reference and replace(rep, reference=False) == PROFILE_SPEC


def _profile_shares_fft(spec: ModelSpec) -> bool:
    """Whether the profile side inputs can be read with the network's crops (:func:`represent_batch`)."""
    if not spec.operating_inputs or not {"tooth_profile", "tsa_diff_rms"} & set(spec.operating_inputs["columns"]):
        return False
    rep = spec.representation_spec()
    return rep.kind == "tsa" and rep.highpass_orders == 0 and replace(rep, remove_shaft_1x=True) == PROFILE_SPEC


@dataclass
class CNNClassifier:
    """A trained :class:`~models.cnn.GearCNN` and its :class:`~models.spec.ModelSpec`."""

    network: GearCNN
    spec: ModelSpec
    #: the distance to the training records (:mod:`models.novelty`); None for a model saved before it existed
    novelty: NoveltyModel | None = None

    def predict(self, data: SignalSet, *, n_crops: int = 3, allow_mismatch: bool = False,
                batch_size: int = 256, threads: int = 1) -> Predictions:
        """Predictions for every record of ``data`` (checked first, see :func:`models.spec.check_input`).

        ``batch_size``: segments per network pass (records x crops; the crops of a record are represented
        together and go through the network in the same pass; a larger pass was measured slower, its
        activations falling out of the cache); ``threads``: worker threads (1 or 2), each representing and
        classifying its own batches with one torch thread. The predictions do not depend on ``threads``: every
        batch is computed the same way whichever worker takes it (tested).
        """
        starts = crop_starts(n_crops)
        require(threads in (1, 2), "threads", threads, "1 or 2")
        warnings = check_input(self.spec, data, allow_mismatch=allow_mismatch)
        n, k = len(data), len(starts)
        p_sev = np.zeros((n, len(self.spec.severity_classes)))
        p_teeth = np.zeros((n, len(self.spec.teeth_classes)))
        sev = np.zeros(n)
        nov = np.zeros(n)
        self.network.eval()
        per = max(1, batch_size // k)

        def run(sl: slice) -> None:
            torch.set_num_threads(1)       # per thread: OpenMP's thread count is a per-thread setting
            x, side = represent_batch(data, self.spec, sl, starts)
            with torch.inference_mode():
                out = self.network(x, side)
            b = sl.stop - sl.start
            p_sev[sl] = torch.softmax(out["severity_class"], dim=1).numpy().reshape(b, k, -1).sum(axis=1)
            p_teeth[sl] = torch.softmax(out["teeth"], dim=1).numpy().reshape(b, k, -1).sum(axis=1)
            sev[sl] = out["severity"].numpy().reshape(b, k).sum(axis=1)
            if self.novelty is not None:    # a record's novelty: the median over its crops
                nov[sl] = np.median(self.novelty.novelty(out["features"].numpy()).reshape(b, k), axis=1)

        slices = [slice(i0, min(i0 + per, n)) for i0 in range(0, n, per)]
        # one torch thread per worker (set in run): the workers share nothing but the read-only network, so no
        # OpenMP barrier waits (train.py: two OpenMP threads on a loaded machine were measured 25x slower than one)
        # and one BLAS thread (the representation's small matrix products): OpenBLAS's threads fight the workers
        with threadpool_limits(limits=1, user_api="blas"):
            if threads == 1 or len(slices) == 1:
                for sl in slices:
                    run(sl)
            else:
                with ThreadPoolExecutor(threads) as pool:
                    list(pool.map(run, slices))
        severity, sev_notes = bounded_severity(sev / k * self.spec.severity_scale, self.spec.severity_scale)
        warnings = join_warnings(warnings, sev_notes)
        if self.novelty is not None:
            warnings = join_warnings(warnings, [novelty_warning(v, self.novelty.quantile) for v in nov])
        return Predictions(list(self.spec.severity_classes), list(self.spec.teeth_classes), p_sev / k,
                           p_teeth / k, severity, warnings, None if self.novelty is None else nov,
                           None if self.novelty is None else self.novelty.batch_shift(nov))

