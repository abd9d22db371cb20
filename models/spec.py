"""What a trained model knows about its inputs, and its predictions.

:class:`ModelSpec` is saved beside the weights as JSON (see :mod:`models.io`):
the input spec (sampling rate, record length, gear pair, representation or
feature configuration), the class names, the severity scale, the ranges of the
operating conditions seen in training and the training configuration.

:func:`check_input` compares a :class:`~models.data.SignalSet` with a spec before
any prediction: a different sampling rate, gear pair or a record shorter than
the trained record length is an error (:class:`~gearpit.errors.InputError`); with
``allow_mismatch`` each becomes a warning where the representation can still be
computed (a CNN needs one segment, a feature baseline half the trained length);
speeds or loads outside the trained ranges are always warnings, per record.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
import pandas as pd

from gearpit.errors import InputError, require
from models.data import PairInfo, SignalSet
from models.input_checks import check_inputs
from models.operating import LEVEL_COLUMNS, NEEDS_SPEED
from models.representation_spec import FS_BOUND, RepresentationSpec

FORMAT = "gearpit-model"
FORMAT_VERSION = 1
MODEL_TYPES: tuple[str, ...] = ("cnn", "logreg", "rf", "gb")
TASKS: tuple[str, ...] = ("multi", "binary")
#: label columns whose trained range is recorded and checked at prediction time
RANGE_COLUMNS: tuple[str, ...] = ("speed_rpm", "torque_nm", "snr_db")


@dataclass(frozen=True)
class ModelSpec:
    """Input spec, class names and training configuration of a trained model.

    Attributes
    ----------
    model_type : {"cnn", "logreg", "rf", "gb"}
    task : {"multi", "binary"}
        Severity classes of the dataset, or healthy versus damaged.
    fs_hz : float
        Sampling rate of the training records (Hz).
    n_samples : int
        Length of the training records (samples).
    pair : PairInfo
    representation : dict
        :class:`~models.representation_spec.RepresentationSpec` fields (CNN) or
        :class:`features.table.FeatureConfig` fields (feature baselines).
    severity_classes, teeth_classes : list of str
    severity_scale : float
        The severity head predicts ``severity / severity_scale``.
    channel : str or None
        The dataset channel the model was trained on (None: not recorded).
    ranges : dict
        ``column -> [min, max]`` over the training records (:data:`RANGE_COLUMNS`).
    train_config : dict
        The training configuration, as given.
    operating_inputs : dict
        Side inputs of the CNN and their standardisation (:mod:`models.operating`);
        empty: none.
    training : dict
        What happened in training (epochs, validation scores, time, sizes).
    """

    model_type: str
    task: str
    fs_hz: float
    n_samples: int
    pair: PairInfo
    representation: dict
    severity_classes: list[str]
    teeth_classes: list[str]
    severity_scale: float
    channel: str | None = None
    ranges: dict = field(default_factory=dict)
    train_config: dict = field(default_factory=dict)
    operating_inputs: dict = field(default_factory=dict)
    training: dict = field(default_factory=dict)

    def __post_init__(self):
        require(self.model_type in MODEL_TYPES, "model_type", self.model_type, "one of: " + ", ".join(MODEL_TYPES))
        require(self.task in TASKS, "task", self.task, "one of: " + ", ".join(TASKS))

    def representation_spec(self) -> RepresentationSpec:
        require(self.model_type == "cnn", "model_type", self.model_type, "cnn (only the CNN has a representation)")
        return RepresentationSpec.from_dict(self.representation)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["pair"] = self.pair.to_dict()
        return {"format": FORMAT, "format_version": FORMAT_VERSION, **d}

    @classmethod
    def from_dict(cls, d: dict) -> "ModelSpec":
        require(isinstance(d, dict) and d.get("format") == FORMAT, "model.json", d.get("format") if isinstance(d, dict)
                else type(d).__name__, f"a {FORMAT} file")
        require(d.get("format_version") == FORMAT_VERSION, "format_version", d.get("format_version"), str(FORMAT_VERSION))
        body = {k: v for k, v in d.items() if k not in ("format", "format_version")}
        known = set(cls.__dataclass_fields__)
        for key in body:
            if key not in known:
                raise InputError(f"model.json.{key}", body[key], "one of: " + ", ".join(sorted(known)))
        body["pair"] = PairInfo(**body["pair"])
        return cls(**body)


def training_ranges(labels: pd.DataFrame) -> dict:
    """``column -> [min, max]`` of the :data:`RANGE_COLUMNS` present in ``labels``."""
    out = {}
    for col in RANGE_COLUMNS:
        if col in labels:
            v = labels[col].to_numpy(dtype=float)
            v = v[np.isfinite(v)]
            if v.size:
                out[col] = [float(v.min()), float(v.max())]
    return out


#: physical quantity of a simulator channel, read from its unit suffix (datagen.output_channels)
CHANNEL_QUANTITIES = (("_m_s2", "acceleration"), ("_rpm", "speed"), ("_n", "force"), ("_m", "displacement"))


def channel_quantity(channel: str | None) -> str | None:
    """``"acceleration"``, ``"displacement"``, ``"force"`` or ``"speed"`` for a channel named with its unit
    (``acc_pinion_loa_m_s2``, ``dte_m``, ...); None for other names (a measurement's ``acc_x``)."""
    for suffix, quantity in CHANNEL_QUANTITIES:
        if channel and channel.endswith(suffix):
            return quantity
    return None


def _a(quantity: str) -> str:
    """``quantity`` with its indefinite article ("an acceleration", "a displacement")."""
    return f"{'an' if quantity[0] in 'aeiou' else 'a'} {quantity}"


def absolute_level_inputs(spec: ModelSpec) -> str:
    """What of ``spec``'s inputs reads the record's absolute level (its numbers in the trained channel's unit),
    in words; "" for a level-free model.

    A feature baseline reads its feature table, most of whose columns are levels in the record's unit (RMS, peaks,
    the amplitudes of mesh lines, sidebands and shaft orders: 56 of the 80 columns of a toy record change when it
    is written in g instead of m/s^2); with ``reference`` its own and its ``delta:`` columns still are. A CNN
    reads a representation normalised per record (a log ratio to the reference's spectrum, with a reference),
    free of the unit, unless a side input carries a level (:data:`models.operating.LEVEL_COLUMNS`:
    ``signal_rms``, ``signal_rms_hp``, ``signal_rms_no1x``, ``tsa_diff_rms``; e.g. the variants ``tsa_level``
    and ``tsa_te_diff``)."""
    if spec.model_type != "cnn":
        return f"its {spec.model_type} feature table (RMS, peaks, line amplitudes)"
    cols = [c for c in spec.operating_inputs.get("columns", ()) if c in LEVEL_COLUMNS]
    return f"the side input{'s' if len(cols) > 1 else ''} {', '.join(cols)}" if cols else ""


#: relative margin of the trained ranges (a measured speed of 1199.999 rpm is inside [1200, 1500])
RANGE_TOLERANCE = 1e-3


def check_input(spec: ModelSpec, data: SignalSet, *, allow_mismatch: bool = False) -> list[str]:
    """Check ``data`` against ``spec``; return one warning string per record ("" if none).

    Raises
    ------
    InputError
        Different tooth counts or sampling rate, records shorter than the trained ``spec.n_samples`` (unless
        ``allow_mismatch`` and the representation can be computed anyway: one segment of the CNN, half the
        trained length of a baseline), no healthy reference for a model read against one, a speed missing where the representation needs it, a channel of another physical
        quantity than the trained one (when both names carry a unit, :func:`channel_quantity`).
    """
    common: list[str] = []
    trained_q, given_q = channel_quantity(spec.channel), channel_quantity(data.channel)
    if trained_q and given_q and trained_q != given_q:  # e.g. a transmission-error model fed accelerations
        raise InputError("channel", data.channel, f"{_a(trained_q)} channel like the trained {spec.channel} "
                         f"(this one is {_a(given_q)})")
    p, q = spec.pair, data.pair
    if (p.z_pinion, p.z_wheel) != (q.z_pinion, q.z_wheel):
        msg = f"gear pair {q.name} ({q.z_pinion}/{q.z_wheel} teeth) differs from the trained {p.name} ({p.z_pinion}/{p.z_wheel})"
        if not allow_mismatch:
            raise InputError("pair", f"{q.name} {q.z_pinion}/{q.z_wheel}",
                             f"the trained pair {p.name} {p.z_pinion}/{p.z_wheel} teeth (or --allow-mismatch)")
        common.append(msg)
    elif p.name != q.name:
        common.append(f"gear pair named {q.name}, trained on {p.name} (same tooth counts)")
    if data.n_samples < spec.n_samples:    # every model type alike: the trained length, or a warning
        if not allow_mismatch:
            raise InputError("n_samples", data.n_samples,
                             f">= {spec.n_samples} samples (the model's trained record length), or allow_mismatch")
        common.append(f"record of {data.n_samples} samples, shorter than the trained {spec.n_samples}")
    kind = spec.representation.get("kind") if spec.model_type == "cnn" else "features"
    uses_mesh_only = kind == "mesh_order" and "mesh_cps" in data.labels
    if not np.isclose(data.fs_hz, spec.fs_hz, rtol=1e-9) and not uses_mesh_only:
        msg = f"fs {data.fs_hz:g} Hz differs from the trained {spec.fs_hz:g} Hz"
        if kind in FS_BOUND or not allow_mismatch:
            raise InputError("fs_hz", data.fs_hz, f"{spec.fs_hz:g} Hz (the model's training sampling rate)"
                             + ("" if kind in FS_BOUND else ", or --allow-mismatch"))
        common.append(msg)
    if spec.model_type == "cnn":
        if spec.representation.get("reference"):
            require(data.reference is not None, "reference", None,
                    "a healthy reference for every record: this model reads each record against a recording of the "
                    "same machine at the same operating point without the fault (sidecar key 'reference', or a "
                    "dataset generated with [sweep] healthy_reference = true)")
        check_inputs(spec.representation_spec(), data.n_samples, data.fs_hz, data.shaft_hz(), data.mesh_cps(),
                     z_pinion=data.pair.z_pinion or None, z_wheel=data.pair.z_wheel or None)
        for col in spec.operating_inputs.get("columns", ()):
            need = "speed_rpm" if col in NEEDS_SPEED else col
            require(col == "signal_rms" or need in data.labels, "labels", list(data.labels.columns),
                    f"a {need} column (the model takes the operating point as a side input)")
    else:
        need = int(np.ceil(spec.n_samples * 0.5))
        require(data.n_samples >= need, "n_samples", data.n_samples,
                f">= {need} samples (half the training record length {spec.n_samples}, with allow_mismatch)")
        require(data.shaft_hz() is not None, "speed_rpm", None, "the pinion speed of every record (features need it)")
    per_record = [list(common) for _ in range(len(data))]
    # a measurement whose channel name suggests another quantity than its sidecar's; whose sidecar speed the
    # spectrum did not confirm; whose sidecar pair it questions; clipped; whose drift was removed; cut to its reference
    # ... declared without a unit to a model that reads absolute levels
    for col in ("quantity_note", "unit_note", "speed_note", "pair_note", "clip_note", "drift_note", "length_note"):
        if col in data.labels:
            for i, note in enumerate(data.labels[col].fillna("").astype(str)):
                if note:
                    per_record[i].append(note)
    for col, (lo, hi) in spec.ranges.items():
        if col not in data.labels:
            continue
        v = data.labels[col].to_numpy(dtype=float)
        # a measured value (a speed from the spectrum) within RANGE_TOLERANCE of a bound is inside
        out = (v < lo - RANGE_TOLERANCE * abs(lo)) | (v > hi + RANGE_TOLERANCE * abs(hi))
        for i in np.nonzero(out)[0]:
            per_record[i].append(f"{col} {v[i]:g} outside the trained range [{lo:g}, {hi:g}]")
    return ["; ".join(w) for w in per_record]


#: a severity regression this far (a fraction of the flank) beyond [0, 1] is reported when it is clipped
SEVERITY_CLIP_NOTE = 0.1


def bounded_severity(raw: np.ndarray, trained_max: float) -> tuple[np.ndarray, list[str]]:
    """``(severity, notes)``: the severity regression of a batch clipped to ``[0, 1]`` (a pitted fraction of the
    flank; neither a ridge's linear extrapolation nor the CNN's linear head is bounded by construction), and per
    record a note where it had to be clipped from more than :data:`SEVERITY_CLIP_NOTE` beyond the interval (else
    ""): a regression far outside every fraction a flank can have is itself a sign that the record is unlike the
    training records. ``trained_max``: the largest training severity, named in the note."""
    raw = np.asarray(raw, dtype=float)
    notes = [f"severity regression {v:.3g} lies outside [0, 1] (the pitted fraction of a flank; trained up to "
             f"{trained_max:.3g}), clipped to {min(max(v, 0.0), 1.0):g}: the record is unlike the training records"
             if (v < -SEVERITY_CLIP_NOTE or v > 1.0 + SEVERITY_CLIP_NOTE) else "" for v in raw]
    return np.clip(raw, 0.0, 1.0), notes


@dataclass(frozen=True)
class Predictions:
    """Class probabilities, severity and warnings of a batch of records."""

    severity_classes: list[str]
    teeth_classes: list[str]
    severity_proba: np.ndarray
    teeth_proba: np.ndarray
    severity: np.ndarray
    warnings: list[str]
    #: how unlike the training records each record is (:mod:`models.novelty`; > 1 is warned), None for a model
    #: saved without a novelty model
    novelty: np.ndarray | None = None
    #: the batch test of :meth:`models.novelty.NoveltyModel.batch_shift` over these records, None without novelty
    novelty_batch: dict | None = None

    @property
    def severity_class(self) -> np.ndarray:
        return np.asarray(self.severity_classes, dtype=object)[np.argmax(self.severity_proba, axis=1)]

    @property
    def teeth_class(self) -> np.ndarray:
        return np.asarray(self.teeth_classes, dtype=object)[np.argmax(self.teeth_proba, axis=1)]

    @property
    def confidence(self) -> np.ndarray:
        """Probability of the predicted severity class."""
        return self.severity_proba.max(axis=1)

    def subset(self, idx) -> "Predictions":
        """The predictions of the records at positions ``idx`` (the batch test stays that of all records)."""
        idx = np.asarray(idx)
        return Predictions(self.severity_classes, self.teeth_classes, self.severity_proba[idx],
                           self.teeth_proba[idx], self.severity[idx], [self.warnings[i] for i in idx],
                           None if self.novelty is None else self.novelty[idx], self.novelty_batch)

    def to_frame(self) -> pd.DataFrame:
        """One row per record: predicted classes, confidences, severity, class probabilities, warning."""
        df = pd.DataFrame({
            "severity_class": self.severity_class,
            "confidence": self.confidence,
            "severity": self.severity,
            "teeth_class": self.teeth_class,
            "teeth_confidence": self.teeth_proba.max(axis=1),
        })
        for j, c in enumerate(self.severity_classes):
            df[f"p_{c}"] = self.severity_proba[:, j]
        if self.novelty is not None:
            df["novelty"] = self.novelty
        df["warning"] = self.warnings
        return df
