"""The design of the sensor protocol (``experiments/sensor_protocol.py``): what it trains, and on which records.

- the two channels (``CHANNELS``) and the CNN variants (``SENSOR_VARIANTS``: name -> representation and side
  inputs; ``CHANNEL_VARIANTS``: those each channel runs);
- the three splits, and the model-selection split inside the speed split's training condition (:func:`splits`);
- the extra draws of the default sweep (:func:`second_draw`: a second draw for more training records, the same
  records through eccentric shaft encoders, ``ENCODERS``) and the training and test records built from them
  (:func:`training_and_test`);
- the one-run ablations (``ABLATIONS``: a split, a change of the training configuration, the draws it trains on).

Nothing here trains or scores; ``sensor_protocol.py`` runs the design and writes its table.
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from classifier_runs import SEED, log, strata  # noqa: E402
from classifier_runs import VARIANTS as VARIANTS_ALL  # noqa: E402
from eval_protocol import CONDITION_SPLITS  # noqa: E402

from models.augment import AugmentConfig  # noqa: E402
from models.data import SignalSet, concat  # noqa: E402
from models.operating import HIGHPASS_ORDERS  # noqa: E402
from models.representation_spec import RepresentationSpec  # noqa: E402
from models.sources import load_dataset  # noqa: E402
from models.train import stratified_split  # noqa: E402

CHANNELS = {"acc_pinion_loa_m_s2": "housing accelerometer (pinion, line of action)",
            "dte_m": "transmission error (two shaft encoders)"}
VARIANTS = ("tsa_op", "tsa_level", "tsa_lp_load", "tsa_te", "tsa_lp_profile")


def _tsa_lowpass(c: float) -> RepresentationSpec:
    """The TSA of tsa_level low-passed below ``c`` mesh orders (models/representations.py)."""
    return replace(VARIANTS_ALL["tsa_level"][0], lowpass_mesh_orders=c)


#: the side inputs of tsa_level without the speed (across speeds the speed input is out of its training range)
NO_SPEED = ("torque_nm", "signal_rms")
#: CNN variants of this protocol: eval_protocol's (classifier_runs.VARIANTS); ``tsa_lp_load``: the TSA low-passed
#: below 1.25 mesh orders with the load and the record's RMS as side inputs, not the speed; ``tsa_te``: as
#: ``tsa_lp_load``, but both shafts'
#: first order removed from the record first and from its RMS (``signal_rms_no1x``), so that the encoders'
#: once-per-revolution errors reach neither input (a high-pass at 2.5 orders did that too, but also took the low
#: orders of the pit's dip: ablations te_hp_*; why: RESULTS.md, sensor section)
#: ``tsa_lp_profile``: as ``tsa_lp_load``, with the pitted-teeth profile (models/tooth_profile.py: how many tooth
#: pitches the TSA's deviation covers, after both shafts' first order is removed) as 12 more side inputs;
#: ``tsa_te_profile``: ``tsa_te`` with the profile too (blind to encoder eccentricity; run as ablations
#: ``tsa_te_profile*``, not in the protocol's own runs); ``tsa_te_diff``: ``tsa_te_profile`` with the RMS of the
#: TSA's difference signal in metres as one more side input (``tsa_diff_rms``: the pit's deviation on an absolute
#: scale, without the shafts' first orders; ablations ``tsa_te_diff*``)
PROFILE = NO_SPEED + ("tooth_profile",)
SENSOR_VARIANTS = {"tsa_op": VARIANTS_ALL["tsa_op"], "tsa_level": VARIANTS_ALL["tsa_level"],
                   "tsa_lp_load": (_tsa_lowpass(1.25), NO_SPEED),
                   "tsa_te": (replace(_tsa_lowpass(1.25), remove_shaft_1x=True), ("torque_nm", "signal_rms_no1x")),
                   "tsa_lp_profile": (_tsa_lowpass(1.25), PROFILE),
                   "tsa_te_profile": (replace(_tsa_lowpass(1.25), remove_shaft_1x=True),
                                      ("torque_nm", "signal_rms_no1x", "tooth_profile")),
                   "tsa_te_diff": (replace(_tsa_lowpass(1.25), remove_shaft_1x=True),
                                   ("torque_nm", "signal_rms_no1x", "tsa_diff_rms", "tooth_profile"))}
#: the variants each channel runs (the low-passed one is a transmission-error model: on the accelerometer the
#: pit's quasi-static dip is not what the sensor sees)
CHANNEL_VARIANTS = {"acc_pinion_loa_m_s2": ("tsa_op", "tsa_level"), "dte_m": VARIANTS}
SWEEPS = ROOT / "experiments" / "models_sweeps"
#: model selection for the speed split without its test records: inside its training condition (< 1200 rpm),
#: train below 900 rpm and test at 900-1200 rpm (name, column, edge, top, unit)
INNER_SPEED = ("speed_inner", "speed_rpm", 900.0, 1200.0, "rpm")
#: seed offset of the second draw of the default sweep (more training records: the learning curve of
#: RESULTS.md still rises at 838 training records, the teeth accuracy by ~4 points per doubling)
EXTRA_SEED_OFFSET = 100
#: cross-physics on the transmission error: the default's records measured by encoders with disc eccentricity
#: (datagen/effects/shaft_encoder_error.py): 10-60 arcsec on each shaft (5-10 um mounting eccentricity on a disc read
#: at ~30 mm), phases uniform; the same records otherwise (seed offset 0)
ENCODERS = {"shaft_encoder_error": {"pinion_rad": [5e-5, 3e-4], "wheel_rad": [5e-5, 3e-4],
                              "pinion_phase_rad": [-3.14159, 3.14159], "wheel_phase_rad": [-3.14159, 3.14159]}}


def splits(data, inner: bool = False) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """name -> (train rows, test rows, rule) of the three protocols; ``inner``: also the model-selection split
    inside the speed split's training condition (:data:`INNER_SPEED`), which never sees its test records."""
    tr, te = stratified_split(strata(data), 0.3, SEED)
    out = {"in_domain": (tr, te, "stratified 70/30")}
    lab = data.labels
    for name, col, edge, unit in CONDITION_SPLITS:
        v = lab[col].to_numpy()
        out[name] = (np.nonzero(v < edge)[0], np.nonzero(v >= edge)[0],
                     f"train {col} < {edge:g} {unit}, test >= {edge:g} {unit}")
    if inner:
        name, col, edge, top, unit = INNER_SPEED
        v = lab[col].to_numpy()
        out[name] = (np.nonzero(v < edge)[0], np.nonzero((v >= edge) & (v < top))[0],
                     f"train {col} < {edge:g} {unit}, test {edge:g}-{top:g} {unit}")
    return out


def second_draw(data_dir: Path, channel: str, *, seed_offset: int = EXTRA_SEED_OFFSET, tag: str = "second_draw",
                drive_train: dict | None = None, effects: dict | None = None, base: str = "default") -> SignalSet:
    """Another draw of the default sweep (its seeds + ``seed_offset``): same classes and physics (but for
    ``drive_train`` fields given as sweep draws, e.g. ``{"bearing_n_per_m": [3e7, 3e8]}``, and ``effects``
    tables added after the sweep's own, e.g. ``{"shaft_encoder_error": {...}}``), other records (with
    ``seed_offset = 0`` the same records, each effect drawing from its own stream: only the added effects
    differ); generated once into ``data_dir / f"{part}_{tag}"``, then read. ``base``: another sweep of
    ``experiments/models_sweeps/`` (with its ``_healthy`` part) in place of the default."""
    from datagen.generate import generate
    from datagen.sweep import sweep_from_dict
    from gearpit.tomlio import read_toml

    parts = []
    for part in (base, f"{base}_healthy"):
        doc = read_toml(SWEEPS / f"{part}.toml")
        doc["sweep"]["seed"] += seed_offset
        doc["sweep"]["name"] += "-" + tag.replace("_", "-")
        doc.setdefault("drive_train", {}).update(drive_train or {})
        doc.setdefault("effects", {}).update(effects or {})
        out = data_dir / f"{part}_{tag}"
        if not (out / "index.parquet").is_file():
            log(f"generating {out.name}")
            generate(sweep_from_dict(doc), out, progress=False)
        parts.append(load_dataset(out, channel=channel))
    return concat(parts)


def training_and_test(split: str, data: SignalSet, more: SignalSet
                      ) -> tuple[SignalSet, SignalSet, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Training records (the default's training part + ``more``'s: all of it in-domain, its rows of the
    training condition across conditions), test records (the default's test part, as in eval_protocol) and
    the training rows of each part, for the feature table."""
    tr, te, _ = splits(data, inner=True)[split]
    tr_more = draw_training_rows(split, more)
    return concat([data.subset(tr), more.subset(tr_more)]), data.subset(te), (tr, te, tr_more)


def draw_training_rows(split: str, draw: SignalSet) -> np.ndarray:
    """The rows of an extra draw that join the training set: all of them in-domain (the test records are the
    default's), those of the training condition across conditions."""
    return np.arange(len(draw)) if split == "in_domain" else splits(draw, inner=True)[split][0]


#: one-run ablations on the transmission error (``--ablation NAME``): protocol split, TrainConfig fields,
#: whether the default's training part is in the training set, and the extra draws of the default sweep
#: that join it: (seed offset, tag, drive-train draws[, added effects])
BEARINGS = {"bearing_n_per_m": [3e7, 3e8]}   # moves the 2.2 kHz bearing-mesh mode to 1.3-3.6 kHz
SECOND = ((EXTRA_SEED_OFFSET, "second_draw", None),)
BEARING_DRAWS = ((2 * EXTRA_SEED_OFFSET, "bearings", BEARINGS), (3 * EXTRA_SEED_OFFSET, "bearings2", BEARINGS))


def _lp_load(c: float, **more) -> dict:
    """TrainConfig overrides of tsa_lp_load with the low-pass at ``c`` mesh orders (and ``more`` fields)."""
    return {"representation": _tsa_lowpass(c), "operating_inputs": NO_SPEED, **more}


ABLATIONS = {
    "tsa_lp2": ("speed", {"representation": _tsa_lowpass(2.0)}, True, SECOND),
    "tsa_lp1.25": ("speed", {"representation": _tsa_lowpass(1.25)}, True, SECOND),
    "tsa_lp1.25_bearings_all": ("speed", {"representation": _tsa_lowpass(1.25)}, False, BEARING_DRAWS),
    "tsa_lp2_bearings_all": ("speed", {"representation": _tsa_lowpass(2.0)}, False, BEARING_DRAWS),
    "tsa_lp1.25_nospeed": ("speed", _lp_load(1.25), True, SECOND),
    "nospeed": ("speed", {"operating_inputs": NO_SPEED}, True, SECOND),
    "tsa_lp1.25_nospeed_bearings_all": ("speed", _lp_load(1.25), False, BEARING_DRAWS),
    "nospeed_bearings_all": ("speed", {"operating_inputs": NO_SPEED}, False, BEARING_DRAWS),
    "inner_tsa_level": ("speed_inner", {}, True, SECOND),
    "inner_nospeed": ("speed_inner", {"operating_inputs": NO_SPEED}, True, SECOND),
    "inner_tsa_lp2_nospeed": ("speed_inner", _lp_load(2.0), True, SECOND),
    "inner_tsa_lp1.25_nospeed": ("speed_inner", _lp_load(1.25), True, SECOND),
    "inner_tsa_lp1.25": ("speed_inner", {"representation": _tsa_lowpass(1.25)}, True, SECOND),
    # which of tsa_te's two changes against tsa_lp_load costs severity in-domain: the high-pass of the record, or
    # the level above 2.5 orders as side input
    "te_hp_rep_only": ("in_domain", {"representation": replace(_tsa_lowpass(1.25), highpass_orders=HIGHPASS_ORDERS),
                                     "operating_inputs": NO_SPEED}, True, SECOND),
    "te_hp_rms_only": ("in_domain", {"representation": _tsa_lowpass(1.25),
                                     "operating_inputs": ("torque_nm", "signal_rms_hp")}, True, SECOND),
    # training with encoder errors: the default's training part as it is, the second draw through eccentric encoders
    "train_encoders": ("in_domain", _lp_load(1.25), True,
                       ((EXTRA_SEED_OFFSET, "second_draw_encoders", None, ENCODERS),)),
    # run-to-run scatter of tsa_lp_load across speeds: other training seeds (initialisation, batches, augmentation)
    "tsa_lp_load_seed1": ("speed", _lp_load(1.25, seed=1), True, SECOND),
    "tsa_lp_load_seed2": ("speed", _lp_load(1.25, seed=2), True, SECOND),
    "tsa_lp_load_in_domain_seed1": ("in_domain", _lp_load(1.25, seed=1), True, SECOND),
    "tsa_lp_load_in_domain_seed2": ("in_domain", _lp_load(1.25, seed=2), True, SECOND),
    "tsa_lp2_nospeed": ("speed", _lp_load(2.0), True, SECOND),
    "path": ("speed", {"augment": AugmentConfig(path_probability=0.5)}, True, SECOND),
    "lowpass": ("speed", {"augment": AugmentConfig(lowpass_probability=0.5)}, True, SECOND),
    "bearings": ("speed", {}, True, BEARING_DRAWS[:1]),
    "bearings_all": ("speed", {}, False, BEARING_DRAWS),
    "epochs75": ("in_domain", {"max_epochs": 75}, True, SECOND),
}
# tsa_lp_load with the pitted-teeth profile (models/tooth_profile.py) as further side inputs, and tsa_te with it too
# (both shafts' first order removed from the TSA input and the RMS, so blind to encoder eccentricity; the profile
# removes them itself), on each split and training seed: "<name>[_load|_in_domain][_seedN]" (the speed split and
# seed 0 carry no suffix)
_PROFILE_MODELS = {name: {"representation": SENSOR_VARIANTS[name][0], "operating_inputs": SENSOR_VARIANTS[name][1]}
                   for name in ("tsa_lp_profile", "tsa_te_profile", "tsa_te_diff")}
ABLATIONS.update({name + ("" if split == "speed" else f"_{split}") + (f"_seed{seed}" if seed else ""):
                  (split, {**cfg, "seed": seed}, True, SECOND)
                  for name, cfg in _PROFILE_MODELS.items() for split in ("speed", "load", "in_domain")
                  for seed in (0, 1, 2)})
