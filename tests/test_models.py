"""Classifiers (models/): training, determinism, save/load, input checks, baselines, metrics (the representations:
tests/test_models_representations.py)."""
import numpy as np
import pandas as pd
import pytest
import torch

from gearpit.errors import InputError
from models.augment import AugmentConfig, augment_batch
from models.baselines import fit_baseline
from models.cnn import GearCNN, count_parameters
from models.data import PairInfo, SignalSet
from models.evaluate import evaluate
from models.io import load_model, save_model
from models.representation_spec import RepresentationSpec
from models.spec import Predictions
from models.toy import toy_signal_set
from models.train import TrainConfig, train_cnn

SMALL_REP = RepresentationSpec(kind="order", n_revs=4, max_order=30.0)


def _fast_config(**kw) -> TrainConfig:
    base = dict(representation=SMALL_REP, max_epochs=12, patience=12, batch_size=16, learning_rate=3e-3,
                widths=(8, 16, 16, 24, 32), hidden=32, seed=0)
    base.update(kw)
    return TrainConfig(**base)


@pytest.fixture(scope="module")
def separable():
    """Healthy versus severe toy records (20 dB SNR): separable by the envelope order spectrum."""
    classes = (("healthy", 0.0), ("severe", 0.35))
    train = toy_signal_set(n_per_class=24, classes=classes, snr_db=20.0, seed=1)
    test = toy_signal_set(n_per_class=12, classes=classes, snr_db=20.0, seed=2)
    return train, test


@pytest.fixture(scope="module")
def trained(separable):
    return train_cnn(separable[0], _fast_config())


def test_augmentation_is_seeded():
    """Same generator seed -> identical augmented batch; another seed -> different."""
    x = toy_signal_set(n_per_class=2, seed=4).signals
    cfg = AugmentConfig()
    a = augment_batch(x, cfg, np.random.default_rng(5))
    b = augment_batch(x, cfg, np.random.default_rng(5))
    c = augment_batch(x, cfg, np.random.default_rng(6))
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)
    assert not np.array_equal(a[0], c[0])


# ------------------------------------------------------------------ network and training


def test_network_is_small():
    """Default architecture below the issue's 300k parameter limit (measured ~1.2e5)."""
    assert count_parameters(GearCNN(2, 4, 4)) < 300_000


def test_learns_a_separable_toy_problem(trained, separable):
    """Healthy vs severe toy records: held-out accuracy >= 0.95 (a working model reaches 1.0; chance 0.5)."""
    _, test = separable
    pred = trained.predict(test)
    acc = np.mean(pred.severity_class == test.labels["severity_class"].to_numpy())
    assert acc >= 0.95
    assert trained.spec.training["best_epoch"] >= 1


def test_same_seed_same_weights(separable):
    """Two trainings with the same seed give bitwise identical weights; another seed does not."""
    train = separable[0].subset(np.arange(24))
    cfg = _fast_config(max_epochs=2)
    a = train_cnn(train, cfg).network.state_dict()
    b = train_cnn(train, cfg).network.state_dict()
    c = train_cnn(train, _fast_config(max_epochs=2, seed=1)).network.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_batches_made_alongside_training_are_the_ones_made_in_turn(separable, monkeypatch):
    """train._prefetched makes the next batch on a worker thread while the caller trains; the augmentation's draws
    come from one generator in the same order, so the batches, and a training's weights, are bitwise those made
    without the worker (forced off here by MAX_THREADS = 1: a 1-thread training then has no spare core)."""
    from concurrent.futures import ThreadPoolExecutor

    import models.train as train_mod

    batches = [np.arange(i, i + 3) for i in range(0, 30, 3)]

    with ThreadPoolExecutor(1) as pool:
        rng = np.random.default_rng(5)
        ahead = list(train_mod._prefetched(batches, lambda b: rng.normal(size=4) + b.sum(), pool))
    rng = np.random.default_rng(5)
    in_turn = list(train_mod._prefetched(batches, lambda b: rng.normal(size=4) + b.sum(), None))
    assert [b.tolist() for b, _ in ahead] == [b.tolist() for b in batches]
    assert all(np.array_equal(x, y) for (_, x), (_, y) in zip(ahead, in_turn))

    train = separable[0].subset(np.arange(24))
    a = train_cnn(train, _fast_config(max_epochs=2)).network.state_dict()
    monkeypatch.setattr(train_mod, "MAX_THREADS", 1)
    b = train_cnn(train, _fast_config(max_epochs=2)).network.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_training_leaves_the_global_torch_rng_alone(separable):
    """Training seeds torch inside fork_rng: the caller's global generator state is unchanged."""
    before = torch.random.get_rng_state().clone()
    train_cnn(separable[0].subset(np.arange(16)), _fast_config(max_epochs=1))
    assert torch.equal(before, torch.random.get_rng_state())


def test_save_load_gives_identical_predictions(trained, separable, tmp_path):
    """Saved (state_dict + JSON, loaded with weights_only=True) and reloaded: identical probabilities."""
    test = separable[1]
    save_model(trained, tmp_path / "m")
    loaded = load_model(tmp_path / "m")
    p0, p1 = trained.predict(test), loaded.predict(test)
    np.testing.assert_array_equal(p0.severity_proba, p1.severity_proba)
    np.testing.assert_array_equal(p0.severity, p1.severity)
    assert loaded.spec == trained.spec


def test_predictions_do_not_depend_on_the_worker_threads_or_the_batch(separable):
    """predict with two worker threads gives bitwise the predictions of one thread at the same batch size (several
    batches per worker; side inputs, the pitted-teeth profile among them, computed per batch), and those of one
    big batch within float32 rounding (the network's matrix kernels block by batch size): every value depends
    on its own record only."""
    train, test = separable
    rep = RepresentationSpec(kind="tsa", n_revs=4, samples_per_rev=128, lowpass_mesh_orders=1.25)
    model = train_cnn(train, _fast_config(representation=rep, max_epochs=2,
                                          operating_inputs=("torque_nm", "signal_rms", "tooth_profile")))
    one = model.predict(test, threads=1, batch_size=9)             # 3 records per batch at 3 crops
    two = model.predict(test, threads=2, batch_size=9)
    whole = model.predict(test, threads=1, batch_size=256)
    for field in ("severity_proba", "teeth_proba", "severity"):
        np.testing.assert_array_equal(getattr(one, field), getattr(two, field))
        np.testing.assert_allclose(getattr(one, field), getattr(whole, field), rtol=1e-5, atol=1e-7)
    with pytest.raises(InputError, match="threads"):
        model.predict(test, threads=3)


def test_transmission_error_model_round_trips_its_filters_and_side_inputs(separable, tmp_path):
    """A tsa_te-like CNN (TSA high-passed at 2.5 orders, low-passed below 1.25 mesh orders; side inputs torque and
    signal_rms_hp) saves and reloads with the same spec (filters and side-input statistics included) and
    identical probabilities."""
    rep = RepresentationSpec(kind="tsa", n_revs=4, samples_per_rev=128, lowpass_mesh_orders=1.25,
                             highpass_orders=2.5)
    model = train_cnn(separable[0], _fast_config(representation=rep, max_epochs=2,
                                                 operating_inputs=("torque_nm", "signal_rms_hp")))
    save_model(model, tmp_path / "te")
    loaded = load_model(tmp_path / "te")
    assert loaded.spec == model.spec
    assert loaded.spec.representation_spec().highpass_orders == 2.5
    assert loaded.spec.operating_inputs["columns"] == ["torque_nm", "signal_rms_hp"]
    np.testing.assert_array_equal(model.predict(separable[1]).severity_proba,
                                  loaded.predict(separable[1]).severity_proba)


def test_saved_spec_records_the_input(trained, tmp_path):
    """model.json holds fs, record length, gear pair, representation, class names and the training config."""
    import json

    save_model(trained, tmp_path / "m")
    doc = json.loads((tmp_path / "m" / "model.json").read_text())
    assert doc["fs_hz"] == 4096.0 and doc["n_samples"] == 4096
    assert doc["pair"] == {"name": "toy", "z_pinion": 13, "z_wheel": 29}
    assert doc["representation"]["kind"] == "order"
    assert doc["severity_classes"] == ["healthy", "severe"]
    assert doc["train_config"]["seed"] == 0 and doc["ranges"]["speed_rpm"] == [900.0, 1500.0]


def test_wrong_fs_length_or_pair_is_a_clear_error(trained, separable):
    """Different fs, too short records and another gear pair raise InputError naming the field."""
    test = separable[1]
    wrong_fs = SignalSet(test.signals, 8192.0, test.pair, test.labels)
    with pytest.raises(InputError, match="fs_hz"):
        trained.predict(wrong_fs)
    short = SignalSet(test.signals[:, :1000], test.fs_hz, test.pair, test.labels)
    with pytest.raises(InputError, match="n_samples"):
        trained.predict(short)
    other = SignalSet(test.signals, test.fs_hz, PairInfo("spur-gds", 29, 100), test.labels)
    with pytest.raises(InputError, match="pair"):
        trained.predict(other)
    # allowed as a warning on request, when the representation can still be computed
    p = trained.predict(other, allow_mismatch=True)
    assert all("gear pair" in w for w in p.warnings)


def test_a_channel_of_another_quantity_is_a_clear_error(trained, separable):
    """A model trained on the transmission error (``dte_m``, a displacement) refuses accelerations
    (``*_m_s2``) and forces (``*_n``); the same quantity, or a name without a unit, passes."""
    from dataclasses import replace

    from models.spec import channel_quantity, check_input

    assert [channel_quantity(c) for c in ("acc_pinion_loa_m_s2", "dte_m", "mesh_force_n", "speed_pinion_rpm",
                                          "acc_x", None)] == ["acceleration", "displacement", "force", "speed",
                                                               None, None]
    spec = replace(trained.spec, channel="dte_m")
    test = separable[1].subset(np.arange(4))

    def on(channel):
        return SignalSet(test.signals, test.fs_hz, test.pair, test.labels, channel=channel)

    for wrong in ("acc_pinion_loa_m_s2", "force_bearing_pinion_loa_n"):
        with pytest.raises(InputError, match="channel"):
            check_input(spec, on(wrong))
    for fine in ("mesh_deflection_m", "acc_x", None):
        assert len(check_input(spec, on(fine))) == 4


def test_out_of_range_speed_is_a_warning(trained, separable):
    """A speed outside the trained range [900, 1500] rpm gives a per-record warning, not an error."""
    test = separable[1].subset(np.arange(4))
    lab = test.labels.copy()
    lab.loc[0, "speed_rpm"] = 600.0
    p = trained.predict(SignalSet(test.signals, test.fs_hz, test.pair, lab))
    assert "speed_rpm 600 outside" in p.warnings[0] and p.warnings[1] == ""


def test_corrupt_model_directory_is_refused(tmp_path):
    """A model directory without model.json, or with another format, raises InputError."""
    with pytest.raises(InputError):
        load_model(tmp_path)
    (tmp_path / "model.json").write_text('{"format": "something-else"}')
    with pytest.raises(InputError, match="model.json"):
        load_model(tmp_path)


# ------------------------------------------------------------------ baselines


@pytest.mark.parametrize("kind", ["logreg", "rf", "gb"])
def test_baseline_arrays_reproduce_scikit_learn_and_survive_save_load(kind, tmp_path):
    """Exported baselines predict what scikit-learn predicts on unseen rows (atol 1e-9), and the same after
    a save/load through npz + JSON (no pickle)."""
    from models.baselines import _estimators

    rng = np.random.default_rng(0)
    n, f = 90, 6
    x = rng.standard_normal((n, f))
    sev = np.where(x[:, 0] > 0.3, 0.2, np.where(x[:, 0] > -0.3, 0.1, 0.0))
    cls = np.where(sev == 0.2, "severe", np.where(sev == 0.1, "minor", "healthy"))
    teeth = np.where(x[:, 1] > 0, "1", "2")
    teeth[sev == 0] = "0"
    labels = pd.DataFrame({"severity": sev, "severity_class": cls, "teeth_class": teeth,
                           "speed_rpm": 1000.0, "severity_class_index": [{"healthy": 0, "minor": 1, "severe": 2}[c] for c in cls]})
    data = SignalSet(np.zeros((n, 64), np.float32), 1000.0, PairInfo("toy", 13, 29), labels)
    model = fit_baseline(data, kind, features=x, feature_names=[f"f{i}" for i in range(f)],
                         feature_config={"fs_hz": 1000.0}, seed=3)
    xt = rng.standard_normal((40, f))
    ref_sev, ref_teeth, ref_reg = _estimators(kind, 3)
    y_sev = np.array([{"healthy": 0, "minor": 1, "severe": 2}[c] for c in cls])
    ref_sev.fit(x, y_sev)
    ref_reg.fit(x, sev)
    p = model.predict_features(xt)
    np.testing.assert_allclose(p.severity_proba, ref_sev.predict_proba(xt), atol=1e-9)
    np.testing.assert_allclose(p.severity, np.clip(ref_reg.predict(xt), 0, None), atol=1e-9)
    save_model(model, tmp_path / kind)
    q = load_model(tmp_path / kind).predict_features(xt)
    np.testing.assert_array_equal(p.severity_proba, q.severity_proba)
    np.testing.assert_array_equal(p.teeth_proba, q.teeth_proba)


def test_a_baseline_severity_is_a_fraction_and_a_far_clip_is_said():
    """A ridge extrapolates linearly: a record 100 standard deviations out on the feature the severity follows gets
    a regression of ~20 (severity 0-0.2 trained); it is clipped to [0, 1] (a pitted fraction of a flank) and its
    warning says so, as for -20 (clipped to 0); records like the training ones are neither clipped nor warned."""
    rng = np.random.default_rng(0)
    n, f = 90, 3
    x = rng.standard_normal((n, f))
    sev = np.clip(0.1 + 0.05 * x[:, 0], 0.0, 0.2)
    cls = np.where(sev > 0.1, "severe", "minor")
    labels = pd.DataFrame({"severity": sev, "severity_class": cls, "teeth_class": np.where(x[:, 1] > 0, "1", "2"),
                           "speed_rpm": 1000.0, "severity_class_index": (cls == "severe").astype(int)})
    data = SignalSet(np.zeros((n, 64), np.float32), 1000.0, PairInfo("toy", 13, 29), labels)
    model = fit_baseline(data, "logreg", features=x, feature_names=[f"f{i}" for i in range(f)],
                         feature_config={"fs_hz": 1000.0})
    xt = np.zeros((3, f))
    xt[1, 0], xt[2, 0] = 100.0, -100.0
    p = model.predict_features(xt)
    assert p.severity[0] == pytest.approx(0.1, abs=0.02)
    assert list(p.severity[1:]) == [1.0, 0.0]
    assert p.warnings[0] == ""
    assert "severity regression" in p.warnings[1] and "clipped to 1" in p.warnings[1]
    assert "severity regression" in p.warnings[2] and "clipped to 0" in p.warnings[2]


def test_the_cnn_severity_head_is_clipped_to_a_fraction(trained, separable):
    """The CNN's severity head is a linear layer (unbounded by construction): with its bias raised by 100 it reads
    ~100 x the trained maximum for every record; every severity is clipped to 1 and warned about."""
    import copy

    model = copy.deepcopy(trained)
    with torch.no_grad():
        model.network.severity.bias += 100.0
    p = model.predict(separable[1].subset(np.arange(4)))
    assert list(p.severity) == [1.0] * 4
    assert all("severity regression" in w and "clipped to 1" in w for w in p.warnings)


# ------------------------------------------------------------------ metrics


def test_metrics_of_a_known_confusion():
    """Labels a,a,b,b predicted a,b,b,b: accuracy 0.75, confusion [[1,1],[0,2]], macro-F1 = mean(2/3, 4/5)
    = 0.7333 (hand computed); severity MAE = mean |pred - true| = 0.05."""
    labels = pd.DataFrame({"severity_class": ["a", "a", "b", "b"], "severity_class_index": [0, 0, 1, 1],
                           "teeth_class": ["0", "0", "1", "1"], "severity": [0.0, 0.0, 0.1, 0.1],
                           "speed_rpm": [600.0, 600.0, 1200.0, 1200.0]})
    data = SignalSet(np.zeros((4, 8), np.float32), 100.0, PairInfo("toy", 13, 29), labels)
    proba = np.array([[0.9, 0.1], [0.4, 0.6], [0.2, 0.8], [0.1, 0.9]])
    teeth = np.tile([[1.0, 0, 0, 0]], (4, 1))
    pred = Predictions(["a", "b"], ["0", "1", "2", "3+"], proba, teeth, np.array([0.0, 0.1, 0.1, 0.2]), [""] * 4)
    m = evaluate(data, pred)
    assert m["severity_class"]["accuracy"] == pytest.approx(0.75)
    assert m["severity_class"]["confusion"] == [[1, 1], [0, 2]]
    assert m["severity_class"]["macro_f1"] == pytest.approx((2 / 3 + 4 / 5) / 2)
    assert m["severity_mae"] == pytest.approx(0.05)
    assert [r["accuracy"] for r in m["breakdown"]["speed_rpm"]] == [0.5, 1.0]
    assert m["teeth"]["accuracy"] == pytest.approx(0.5)
