"""Training of the multi-task CNN: split, augmentation, loss, early stopping, seeds.

- **Split**: a stratified (severity class x pitted-teeth class) validation split of
  ``val_fraction`` of the records, drawn from ``seed``.
- **Loss**: cross-entropy of the severity classes + ``teeth_weight`` x cross-entropy
  of the pitted-teeth classes + ``severity_weight`` x mean squared error of
  ``severity / severity_scale`` (``severity_scale`` = the largest training severity).
- **Optimiser**: AdamW, cosine-annealed learning rate over ``max_epochs``.
- **Early stopping**: after each epoch the validation loss (central segments, no
  augmentation) is computed; training stops after ``patience`` epochs without
  improvement and the best weights are kept.
- **Seeds**: the network's initialisation and dropout draw from torch's generator
  seeded with ``seed`` inside :func:`torch.random.fork_rng` (the caller's global
  state is restored afterwards); batches and augmentation draw from
  ``numpy.random.default_rng([seed, epoch])``. Same seed and thread count, same
  weights.
- **Novelty**: with the best weights, the pooled features of the training records'
  central segments fit the novelty model of :mod:`models.novelty`, scaled by the
  validation records' (at least :data:`models.novelty.MIN_HELD_OUT` of them).

References
----------
.. [1] Loshchilov, I., Hutter, F. (2019). Decoupled weight decay regularization.
   ICLR (AdamW).
.. [2] Prechelt, L. (1998). Early stopping - but when? In Neural Networks: Tricks
   of the Trade, Springer, 55-69.
"""
from __future__ import annotations

import contextlib
import copy
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field, fields

import numpy as np
import torch
from threadpoolctl import threadpool_limits
from torch import nn

from gearpit.errors import InputError, require, require_positive, require_range
from models.augment import AugmentConfig, augment_batch
from models.classifier import CNNClassifier, build_network
from models.data import TEETH_CLASSES, SignalSet
from models.input_checks import check_inputs
from models.novelty import MIN_HELD_OUT, NoveltyModel, fit_novelty
from models.operating import check_columns, fit_operating, operating_features
from models.representation_spec import RepresentationSpec
from models.representations import represent
from models.spec import TASKS, ModelSpec, training_ranges

MAX_THREADS = 2


@dataclass(frozen=True)
class TrainConfig:
    """Everything that decides a trained CNN (besides the data).

    Attributes
    ----------
    representation : RepresentationSpec
    task : {"multi", "binary"}
        The dataset's severity classes, or healthy versus damaged.
    augment : AugmentConfig
    max_epochs, patience : int
        Epoch limit and early-stopping patience (epochs).
    batch_size : int
    learning_rate, weight_decay : float
    val_fraction : float
        Fraction of the records held out for early stopping.
    severity_weight, teeth_weight : float
        Weights of the severity regression and pitted-teeth losses.
    widths : tuple of int
        Channels of the convolution blocks; ``hidden`` and ``dropout`` of the head.
    operating_inputs : tuple of str
        Side inputs of the network (:mod:`models.operating`): ``speed_rpm``,
        ``torque_nm`` (label columns), ``signal_rms`` (the record's level, which
        binds the model to the sensor path), ``signal_rms_hp`` (the level above
        2.5 pinion orders, without the shafts' once-per-revolution lines); empty: none.
    seed : int
    threads : int
        torch CPU threads (at most 2). Default 1: on a shared, loaded machine two
        OpenMP threads waiting for each other were measured 25x slower than one.
    max_seconds : float
        Wall-time budget; training stops after the epoch that exceeds it.
    """

    representation: RepresentationSpec = field(default_factory=RepresentationSpec)
    task: str = "multi"
    augment: AugmentConfig = field(default_factory=AugmentConfig)
    max_epochs: int = 150
    patience: int = 25
    batch_size: int = 64
    learning_rate: float = 2e-3
    weight_decay: float = 1e-4
    val_fraction: float = 0.2
    severity_weight: float = 1.0
    teeth_weight: float = 1.0
    widths: tuple[int, ...] = (16, 32, 48, 64, 96)
    hidden: int = 64
    dropout: float = 0.1
    operating_inputs: tuple[str, ...] = ()
    seed: int = 0
    threads: int = 1
    max_seconds: float = 900.0

    def __post_init__(self):
        require(isinstance(self.representation, RepresentationSpec), "representation", self.representation,
                "a RepresentationSpec")
        require(isinstance(self.augment, AugmentConfig), "augment", self.augment, "an AugmentConfig")
        require(self.task in TASKS, "task", self.task, "one of: " + ", ".join(TASKS))
        for name in ("max_epochs", "patience", "batch_size", "hidden", "threads"):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1, name, v, "an integer >= 1")
        require(self.threads <= MAX_THREADS, "threads", self.threads, f"an integer in [1, {MAX_THREADS}]")
        require_positive("learning_rate", self.learning_rate)
        require_range("weight_decay", self.weight_decay, 0.0, 1.0)
        require_range("val_fraction", self.val_fraction, 0.0, 0.5, lo_open=True)
        require_range("severity_weight", self.severity_weight, 0.0, 100.0)
        require_range("teeth_weight", self.teeth_weight, 0.0, 100.0)
        require_range("dropout", self.dropout, 0.0, 0.9)
        object.__setattr__(self, "widths", tuple(int(w) for w in self.widths))
        object.__setattr__(self, "operating_inputs", check_columns(self.operating_inputs))
        require(len(self.widths) >= 1 and all(w >= 1 for w in self.widths), "widths", self.widths, "positive integers")
        require(isinstance(self.seed, (int, np.integer)) and 0 <= self.seed < 2**32, "seed", self.seed,
                "an integer in [0, 2**32)")
        require_positive("max_seconds", self.max_seconds)

    @classmethod
    def from_dict(cls, values: dict) -> "TrainConfig":
        """Build from a mapping (TOML ``[train]`` table with ``[train.representation]``,
        ``[train.augment]`` sub-tables); unknown keys are errors."""
        known = {f.name for f in fields(cls)}
        v = dict(values)
        for key in v:
            if key not in known:
                raise InputError(f"train.{key}", v[key], "one of: " + ", ".join(sorted(known)))
        if isinstance(v.get("representation"), dict):
            v["representation"] = RepresentationSpec.from_dict(v["representation"])
        if isinstance(v.get("augment"), dict):
            v["augment"] = AugmentConfig.from_dict(v["augment"])
        if "widths" in v:
            v["widths"] = tuple(v["widths"])
        if "operating_inputs" in v:
            v["operating_inputs"] = tuple(v["operating_inputs"])
        return cls(**v)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["representation"] = self.representation.to_dict()
        d["augment"] = self.augment.to_dict()
        d["widths"] = list(self.widths)
        d["operating_inputs"] = list(self.operating_inputs)
        return d


def stratified_split(strata: np.ndarray, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Train and validation indices: ``fraction`` of every stratum (at least one if it has >= 2 records)."""
    rng = np.random.default_rng([int(seed), 1])
    train, val = [], []
    for s in sorted(set(strata.tolist())):
        idx = np.nonzero(strata == s)[0]
        idx = idx[rng.permutation(idx.size)]
        k = int(round(fraction * idx.size)) if idx.size >= 2 else 0
        k = max(k, 1) if idx.size >= 2 else 0
        val.extend(idx[:k])
        train.extend(idx[k:])
    return np.sort(np.asarray(train, dtype=int)), np.sort(np.asarray(val, dtype=int))


def _targets(data: SignalSet, classes: list[str], scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lut = {c: i for i, c in enumerate(classes)}
    names = data.labels["severity_class"].astype(str).to_numpy()
    unknown = sorted(set(names) - set(lut))
    require(not unknown, "severity_class", unknown[:3], "one of the training classes: " + ", ".join(classes))
    y_cls = np.array([lut[c] for c in names], dtype=np.int64)
    t_lut = {c: i for i, c in enumerate(TEETH_CLASSES)}
    y_teeth = np.array([t_lut[c] for c in data.teeth_classes()], dtype=np.int64)
    sev = data.labels["severity"].to_numpy(dtype=float) if "severity" in data.labels else np.zeros(len(data))
    return y_cls, (sev / scale).astype(np.float32), y_teeth


def _loss(out: dict, y_cls, y_sev, y_teeth, config: TrainConfig) -> torch.Tensor:
    ce = nn.functional.cross_entropy
    return (ce(out["severity_class"], y_cls) + config.teeth_weight * ce(out["teeth"], y_teeth)
            + config.severity_weight * nn.functional.mse_loss(out["severity"], y_sev))


def _prefetched(batches: list, make, pool: ThreadPoolExecutor | None):
    """``(b, make(b))`` for every ``b`` of ``batches`` in order; with a ``pool``, the next batch is made on its
    thread while the caller trains on this one (the representation is numpy, the network torch: on two cores
    they overlap). ``make`` draws its augmentation from one generator, and the batches are made one after the
    other in the same order either way, so the draws, hence the weights, are the same (tested)."""
    if pool is None:
        for b in batches:
            yield b, make(b)
        return
    nxt = pool.submit(make, batches[0]) if batches else None
    for i, b in enumerate(batches):
        x = nxt.result()
        nxt = pool.submit(make, batches[i + 1]) if i + 1 < len(batches) else None
        yield b, x


def train_cnn(data: SignalSet, config: TrainConfig = TrainConfig(), *, log=None) -> CNNClassifier:
    """Train the multi-task CNN on ``data`` (labelled); return it with its spec.

    Parameters
    ----------
    data : SignalSet
        Labelled records (``severity_class`` and ``teeth_class`` or ``n_pitted_teeth``;
        ``severity`` optional, 0 if absent).
    config : TrainConfig
    log : callable, optional
        Called with one line of text per epoch.
    """
    require(data.has_labels() and data.has_teeth_labels(), "labels", list(data.labels.columns),
            "severity_class and teeth_class (or n_pitted_teeth) columns")
    rep: RepresentationSpec = config.representation
    if rep.reference:
        data.paired_signals(slice(0, 1))   # refused, naming the field, when the records have no reference
    # validate before any work: every record must give a segment, with the speed-error margin
    check_inputs(rep, data.n_samples, data.fs_hz, data.shaft_hz(), data.mesh_cps(), z_pinion=data.pair.z_pinion or None,
                 z_wheel=data.pair.z_wheel or None,
                 max_speed_factor=1.0 + config.augment.speed_error)
    if config.task == "binary":
        data = data.as_binary()
    classes = data.severity_class_names()
    require(len(classes) >= 2, "severity_class", classes, "at least two classes in the training data"
            + (" (--task binary needs healthy and damaged records)" if config.task == "binary" else ""))
    sev_all = data.labels["severity"].to_numpy(dtype=float) if "severity" in data.labels else np.zeros(len(data))
    scale = float(sev_all.max()) if sev_all.max() > 0 else 1.0
    y_cls, y_sev, y_teeth = _targets(data, classes, scale)
    strata = y_cls * len(TEETH_CLASSES) + y_teeth
    tr, va = stratified_split(strata, config.val_fraction, config.seed)
    require(tr.size >= 2 and va.size >= 1, "records", len(data), "enough records for a validation split")

    torch.set_num_threads(config.threads)
    arch = {"widths": list(config.widths), "hidden": config.hidden, "dropout": config.dropout}
    spec = ModelSpec(model_type="cnn", task=config.task, fs_hz=float(data.fs_hz), n_samples=data.n_samples,
                     pair=data.pair, representation=rep.to_dict(), severity_classes=classes,
                     teeth_classes=list(TEETH_CLASSES), severity_scale=scale, channel=data.channel,
                     ranges=training_ranges(data.labels),
                     train_config={**config.to_dict(), "architecture": arch},
                     operating_inputs=fit_operating(data.subset(tr), config.operating_inputs))
    side_all = operating_features(data, spec.operating_inputs)
    fr, mc, z = data.shaft_hz(), data.mesh_cps(), data.pair.z_pinion or None
    zw = data.pair.z_wheel or None
    records = (lambda idx: data.paired_signals(idx)) if rep.reference else (lambda idx: data.signals[idx])
    x_val = torch.from_numpy(represent(records(va), rep, fs_hz=data.fs_hz,
                                       shaft_hz=None if fr is None else fr[va], mesh_cps=None if mc is None else mc[va],
                                       z_pinion=z, starts=0.5, z_wheel=zw))
    yv = [torch.from_numpy(a[va]) for a in (y_cls, y_sev, y_teeth)]
    side_val = torch.from_numpy(side_all[va]) if config.operating_inputs else None

    t0 = time.perf_counter()
    history: list[dict] = []
    # with one torch thread, the next batch is represented on a second thread meanwhile (numpy releases the
    # GIL), with one BLAS thread: OpenBLAS's own threads fought torch's for the cores (6 epochs of tsa_te_diff:
    # 15.9 s with its threads, 14.5 s without, 11.9 s without and with the batch made alongside; measured)
    prefetch = ThreadPoolExecutor(max_workers=1) if config.threads < MAX_THREADS else None
    with (torch.random.fork_rng(devices=[]), (prefetch or contextlib.nullcontext()),
          threadpool_limits(limits=1, user_api="blas")):
        torch.manual_seed(int(config.seed))
        net = build_network(spec)
        opt = torch.optim.AdamW(net.parameters(), lr=config.learning_rate, weight_decay=config.weight_decay)
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=config.max_epochs)
        best, best_state, best_epoch, stale = np.inf, copy.deepcopy(net.state_dict()), 0, 0
        for epoch in range(config.max_epochs):
            rng = np.random.default_rng([int(config.seed), 2, epoch])
            order = tr[rng.permutation(tr.size)]
            net.train()
            total, n_seen = 0.0, 0

            def batch(b, rng=rng):
                # a pair (record, reference) is augmented as one record: the same gain, polarity, filters, speed
                xb, starts, speed = augment_batch(records(b), config.augment, rng, fs_hz=data.fs_hz)
                return torch.from_numpy(represent(xb, rep, fs_hz=data.fs_hz, shaft_hz=None if fr is None else fr[b],
                                                  mesh_cps=None if mc is None else mc[b], z_pinion=z, starts=starts,
                                                  speed_factors=speed, z_wheel=zw))

            # batch normalisation needs two records per batch
            batches = [b for b in np.array_split(order, range(config.batch_size, order.size, config.batch_size))
                       if b.size >= 2]
            for b, x in _prefetched(batches, batch, prefetch):
                out = net(x, torch.from_numpy(side_all[b]) if config.operating_inputs else None)
                loss = _loss(out, torch.from_numpy(y_cls[b]), torch.from_numpy(y_sev[b]),
                             torch.from_numpy(y_teeth[b]), config)
                opt.zero_grad()
                loss.backward()
                opt.step()
                total += float(loss.detach()) * b.size
                n_seen += b.size
            sched.step()
            net.eval()
            with torch.no_grad():
                out = net(x_val, side_val)
                vloss = float(_loss(out, *yv, config))
                vacc = float((out["severity_class"].argmax(1) == yv[0]).float().mean())
                vacc_t = float((out["teeth"].argmax(1) == yv[2]).float().mean())
            history.append({"epoch": epoch + 1, "train_loss": total / max(n_seen, 1), "val_loss": vloss,
                            "val_accuracy": vacc, "val_teeth_accuracy": vacc_t})
            if log is not None:
                log(f"epoch {epoch + 1:3d}  train loss {total / max(n_seen, 1):.4f}  val loss {vloss:.4f}  "
                    f"val acc {vacc:.3f}  teeth {vacc_t:.3f}")
            if vloss < best - 1e-6:
                best, best_state, best_epoch, stale = vloss, copy.deepcopy(net.state_dict()), epoch + 1, 0
            else:
                stale += 1
            if stale >= config.patience or time.perf_counter() - t0 > config.max_seconds:
                break
        net.load_state_dict(best_state)
        net.eval()
        novelty = _fit_novelty(net, lambda idx: represent(records(idx), rep, fs_hz=data.fs_hz,
                                                          shaft_hz=None if fr is None else fr[idx],
                                                          mesh_cps=None if mc is None else mc[idx], z_pinion=z,
                                                          starts=0.5, z_wheel=zw),
                               tr, y_cls[tr], x_val, config.batch_size) if va.size >= MIN_HELD_OUT else None
    elapsed = time.perf_counter() - t0
    best_row = history[best_epoch - 1] if best_epoch else history[-1]
    training = {"epochs_run": len(history), "best_epoch": best_epoch, "seconds": round(elapsed, 2),
                "n_train": int(tr.size), "n_val": int(va.size), "val_loss": best_row["val_loss"],
                "val_accuracy": best_row["val_accuracy"], "val_teeth_accuracy": best_row["val_teeth_accuracy"],
                "n_parameters": int(sum(p.numel() for p in net.parameters())), "torch_version": torch.__version__,
                "source": data.source, "history": history,
                "novelty": novelty.summary() if novelty is not None else
                f"not fitted: {va.size} validation records, fewer than {MIN_HELD_OUT}"}
    spec = ModelSpec(**{**spec.__dict__, "training": training})
    return CNNClassifier(net, spec, novelty)


def _fit_novelty(net, represent_idx, tr: np.ndarray, classes: np.ndarray, x_val: torch.Tensor,
                 batch: int) -> NoveltyModel:
    """The novelty model (:mod:`models.novelty`) of the trained ``net``: class means and covariance of the
    pooled features of the training records (central segment, no augmentation), scaled by the validation
    records' distances."""
    with torch.no_grad():
        f_tr = np.concatenate([net.pooled(torch.from_numpy(represent_idx(tr[i:i + batch]))).numpy()
                               for i in range(0, tr.size, batch)])
        f_val = net.pooled(x_val).numpy()
    return fit_novelty(f_tr, classes, f_val)
