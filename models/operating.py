"""The known operating point (speed, load) as side inputs of the CNN.

Why: a pit's excitation is a stiffness *loss* under load, so its vibration grows
with the transmitted torque, while the mesh tone that the per-record
normalisation divides by also carries the load-independent excitation of the
profile errors. After normalisation the same pit looks smaller at low load
(in the default dataset the CNN without side inputs misclassified 36 % of the
pitted test records in the lowest torque tercile, mostly as too mild, against
17-21 % above). The speed sets where the mesh harmonics fall relative to the
housing resonance. Both are known on a test rig (the dataset labels
``speed_rpm``, ``torque_nm``), so the network gets them beside the signal:
``log10`` of each, standardised with the training records' mean and standard
deviation, concatenated to the pooled convolution features.

``signal_rms``, the record's RMS in its own units, gives the network the
absolute level of the vibration, which the per-record normalisation of every
representation removes. On one rig with a fixed, calibrated sensor that is the
missing scale of the pit (default dataset: 87.6 % severity accuracy against
82.3 %, ``experiments/RESULTS.md``); on another sensor path it is wrong by the
path's gain (trained without the housing path, tested with it: 69.9 % against
81.5 %). Use it only where the sensor path does not change.

``signal_rms_hp`` is the same RMS after a high-pass at :data:`HIGHPASS_ORDERS`
pinion orders (:func:`models.order_filters.highpass`): the level without the
once-per-revolution lines of either shaft. On a measured transmission error
those lines are mostly the encoders' disc eccentricity and the shafts' run-out
(``datagen/effects/shaft_encoder_error.py``: 10-60 arcsec is 3-28 um, against a
loaded transmission error of a few um), which say nothing of the teeth.
``signal_rms_no1x`` is the RMS without just those two lines (least-squares
sinusoids at the pinion's and the wheel's shaft frequency removed,
:func:`models.order_filters.remove_shaft_lines`): the high-pass also takes
the low-order content of a pit's dip. Measured on the default dataset's
transmission error: both make a model blind to encoder eccentricity, and both
cost severity accuracy (experiments/RESULTS.md, section "Sensor").

``tsa_diff_rms`` is the RMS of the pinion's synchronous average's *difference signal* in the record's own
unit, read as the pitted-teeth profile reads it (:data:`models.tooth_profile.PROFILE_SPEC`: low-passed below
1.25 mesh orders, both shafts' first order removed from the record first): on a transmission error in metres,
the size of the deviation that the teeth do not share (a pit's dip, the pitch errors' tooth-to-tooth scatter)
without the mesh tone, the shafts' first orders (encoder eccentricity, run-out) or a housing path. On an
accelerometer it is as bound to the sensor path as ``signal_rms``.

``tooth_profile`` is a group of 12 values taken as they are (not ``log10``): how many tooth pitches the
deviation of the pinion's synchronous average covers (:mod:`models.tooth_profile`). It counts pitted teeth
independently of the record's scale, sign and speed: on the transmission error's speed split a logistic
regression on these 12 values alone counts the teeth of the records above 1200 rpm at 91.6 % (the CNN
without them 77-85 %; experiments/RESULTS.md, section "Sensor"). A transmission-error quantity: on the
housing accelerometer the same regression is at chance.

``residual_rms`` and ``residual_profile`` are ``tsa_diff_rms`` and ``tooth_profile`` read from the record's TSA
*less its healthy reference's* (:func:`models.tsa.residual_difference`, the same filters; records with a
reference, :mod:`models.representations`): the fault's share of the deviation, without the machine's own
tooth-to-tooth spacing errors, which ``tsa_diff_rms`` and ``tooth_profile`` read as much as a pit.

The standardisation is fitted once on the training records and stored in the
model (:attr:`models.spec.ModelSpec.operating_inputs`): ``{"columns": [...],
"mean": [...], "std": [...]}``; an empty dict means no side inputs.
"""
from __future__ import annotations

import numpy as np

from gearpit.errors import require
from models.order_filters import highpass, rms_without_lines
from models.tsa import residual_difference, tsa_difference
from models.tooth_profile import N_FEATURES, PROFILE_SPEC, profile_of_difference, tooth_profile

#: side inputs: label columns known at test time on a rig, and ``signal_rms``, the root-mean-square of
#: the record in its own units (m/s^2 for the simulator), which makes the model depend on the sensor's
#: calibration and on the transmission path (see the module docstring)
OPERATING_COLUMNS: tuple[str, ...] = ("speed_rpm", "torque_nm", "signal_rms", "signal_rms_hp", "signal_rms_no1x",
                                      "tsa_diff_rms", "tooth_profile", "residual_rms", "residual_profile")
#: side inputs that carry the record's absolute level in its own unit (a sensor's unit and gain change them; the
#: others are levels of the operating point, ratios or shapes): a model reading one needs measurements in SI
#: (:func:`models.spec.absolute_level_inputs`, sidecar ``sensor_unit``)
LEVEL_COLUMNS: tuple[str, ...] = ("signal_rms", "signal_rms_hp", "signal_rms_no1x", "tsa_diff_rms")
#: side inputs that are a group of values taken as they are (not log10): name -> number of values
GROUPS = {"tooth_profile": N_FEATURES, "residual_profile": N_FEATURES}
#: side inputs computed from the record that need its speed (the ``speed_rpm`` label)
NEEDS_SPEED = ("signal_rms_hp", "signal_rms_no1x", "tsa_diff_rms", "tooth_profile", "residual_rms",
               "residual_profile")
#: cut-off of ``signal_rms_hp`` (pinion shaft orders): above the wheel's and the pinion's first order, below
#: the lowest pinion order a tooth fault spreads to that matters (the difference signal starts at 3)
HIGHPASS_ORDERS = 2.5


def check_columns(columns) -> tuple[str, ...]:
    """The column names as a tuple; each must be one of :data:`OPERATING_COLUMNS`, no repeats."""
    cols = tuple(str(c) for c in columns)
    for c in cols:
        require(c in OPERATING_COLUMNS, "operating_inputs", c, "one of: " + ", ".join(OPERATING_COLUMNS))
    require(len(set(cols)) == len(cols), "operating_inputs", list(cols), "distinct column names")
    return cols


def _speed_and_pair(data, c: str) -> np.ndarray:
    """The pinion shaft frequency of every record; an error naming ``c`` unless the speed and both tooth counts
    are known (the column reads both shafts' first order)."""
    fr = data.shaft_hz()
    require(fr is not None and data.pair.known, "speed_rpm / pair", None,
            f"the speed and both tooth counts ({c} removes both shafts' first order)")
    return fr


def _column(data, c: str, cache: dict | None = None) -> np.ndarray:
    """Side input ``c`` of every record; ``cache`` keeps what two columns share (the residual difference signal)."""
    if c in ("residual_rms", "residual_profile"):
        cache = {} if cache is None else cache
        if "residual" not in cache:
            fr = _speed_and_pair(data, c)
            require(data.reference is not None, "reference", None, f"a healthy reference of every record ({c})")
            cache["residual"] = residual_difference(data.signals, data.reference, PROFILE_SPEC, fs_hz=data.fs_hz,
                                                    shaft_hz=fr, z_pinion=int(data.pair.z_pinion),
                                                    z_wheel=int(data.pair.z_wheel))
        d = cache["residual"]
        return np.sqrt(np.mean(d ** 2, axis=1)) if c == "residual_rms" else profile_of_difference(d, int(data.pair.z_pinion))
    if c == "tooth_profile":
        fr = _speed_and_pair(data, c)
        return tooth_profile(data.signals, fs_hz=data.fs_hz, shaft_hz=fr, z_pinion=int(data.pair.z_pinion),
                             z_wheel=int(data.pair.z_wheel))
    if c == "tsa_diff_rms":
        fr = _speed_and_pair(data, c)
        d = tsa_difference(data.signals, PROFILE_SPEC, fs_hz=data.fs_hz, shaft_hz=fr,
                           z_pinion=int(data.pair.z_pinion), z_wheel=int(data.pair.z_wheel))
        return np.sqrt(np.mean(d ** 2, axis=1))
    if c == "signal_rms":
        x = np.asarray(data.signals, dtype=float)
        return np.sqrt(np.mean((x - x.mean(axis=1, keepdims=True)) ** 2, axis=1))
    if c == "signal_rms_hp":
        fr = data.shaft_hz()
        require(fr is not None, "labels", list(data.labels.columns), "a speed_rpm column (signal_rms_hp needs it)")
        x = np.asarray(data.signals, dtype=float)
        return np.array([np.sqrt(np.mean(highpass(x[i], data.fs_hz, fr[i], HIGHPASS_ORDERS) ** 2))
                         for i in range(len(x))])
    if c == "signal_rms_no1x":
        fr = _speed_and_pair(data, c)
        ratio = data.pair.z_pinion / data.pair.z_wheel
        x = np.asarray(data.signals, dtype=float)
        return np.array([rms_without_lines(x[i], data.fs_hz, (fr[i], fr[i] * ratio)) for i in range(len(x))])
    labels = data.labels
    require(c in labels, "labels", list(labels.columns), f"a {c} column (the model takes it as a side input)")
    return labels[c].to_numpy(dtype=float)


def _values(data, cols: tuple[str, ...], known: dict | None = None) -> np.ndarray:
    """``log10`` of each scalar side input, the values of each group (:data:`GROUPS`) as they are; a column in
    ``known`` (name -> values) is taken from there instead of computed."""
    parts, cache = [], {}
    for c in cols:
        v = known[c] if known and c in known else _column(data, c, cache)
        if c in GROUPS:
            require(bool(np.all(np.isfinite(v))), c, "non-finite values", "finite values for every record")
            parts.append(v.reshape(len(data), GROUPS[c]))
        else:
            require(bool(np.all(np.isfinite(v) & (v > 0))), c, "non-positive or missing values",
                    "positive values for every record (side inputs of the model)")
            parts.append(np.log10(v)[:, None])
    return np.hstack(parts) if parts else np.zeros((len(data), 0))


def fit_operating(data, columns) -> dict:
    """Standardisation of the side inputs fitted on the training records ``data`` (a
    :class:`~models.data.SignalSet`); empty dict for no columns."""
    cols = check_columns(columns)
    if not cols:
        return {}
    v = _values(data, cols)
    sd = v.std(axis=0)
    return {"columns": list(cols), "mean": [float(m) for m in v.mean(axis=0)],
            "std": [float(s) if s > 0 else 1.0 for s in sd]}


def operating_features(data, stats: dict, known: dict | None = None) -> np.ndarray:
    """Side inputs ``(n_records, n_columns)`` float32 of the records ``data`` (a
    :class:`~models.data.SignalSet`) with fitted ``stats``; ``known``: columns already computed (name -> values,
    e.g. the pitted-teeth profile read from the network's own TSA, :func:`models.classifier.represent_batch`).

    Examples
    --------
    >>> from models.toy import toy_signal_set
    >>> d = toy_signal_set(n_per_class=6, torques_nm=(20.0, 80.0))
    >>> st = fit_operating(d, ["torque_nm"])
    >>> sorted(set(operating_features(d, st).ravel().round(3).tolist()))
    [-1.0, 1.0]
    """
    if not stats:
        return np.zeros((len(data), 0), dtype=np.float32)
    cols = check_columns(stats["columns"])
    v = _values(data, cols, known)
    return ((v - np.asarray(stats["mean"])) / np.asarray(stats["std"])).astype(np.float32)


def n_operating(stats: dict) -> int:
    """Number of side input values of fitted ``stats`` (a group counts its values)."""
    return len(stats.get("mean", ())) if stats else 0
