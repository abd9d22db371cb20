"""The operating point (speed, load) as side inputs of the CNN (models/operating.py)."""
import numpy as np
import pandas as pd
import pytest
import torch

from gearpit.errors import InputError
from models.cnn import GearCNN
from models.data import PairInfo, SignalSet
from models.io import load_model, save_model
from models.operating import fit_operating, operating_features
from models.representation_spec import RepresentationSpec
from models.toy import toy_signal_set
from models.train import TrainConfig, train_cnn

SMALL_REP = RepresentationSpec(kind="order", n_revs=4, max_order=30.0)


def _config(**kw) -> TrainConfig:
    base = dict(representation=SMALL_REP, max_epochs=15, patience=15, batch_size=16, learning_rate=3e-3,
                widths=(8, 16, 16, 24, 32), hidden=32, seed=0)
    base.update(kw)
    return TrainConfig(**base)


def _load_labelled(seed: int) -> SignalSet:
    """One healthy toy record repeated, labelled by the load alone: "high" at 100 N m, "low" at 50 N m.
    Only a model that sees the torque can tell them apart."""
    d = toy_signal_set(n_per_class=48, classes=(("healthy", 0.0),), snr_db=20.0, seed=seed)
    x = np.repeat(d.signals[:1], len(d), axis=0)
    lab = d.labels.copy()
    high = lab["torque_nm"].to_numpy() > 75.0
    lab["severity_class"] = np.where(high, "high", "low")
    lab["severity_class_index"] = high.astype(int)
    return SignalSet(x, d.fs_hz, d.pair, lab, d.source, d.channel)


@pytest.fixture(scope="module")
def load_task():
    return _load_labelled(1), _load_labelled(2)


def _records(labels: dict, gains=None) -> SignalSet:
    n = len(next(iter(labels.values())))
    x = np.sin(np.arange(256) * 0.3)[None, :] * (np.ones(n) if gains is None else np.asarray(gains))[:, None]
    return SignalSet(x, 1000.0, PairInfo("toy", 13, 29), pd.DataFrame(labels))


def test_side_inputs_are_standardised_log_values():
    """log10 of each column, zero mean and unit standard deviation on the fitting records."""
    d = _records({"speed_rpm": [600.0, 900.0, 1800.0], "torque_nm": [20.0, 40.0, 80.0]})
    st = fit_operating(d, ["speed_rpm", "torque_nm"])
    f = operating_features(d, st)
    assert f.shape == (3, 2) and f.dtype == np.float32
    np.testing.assert_allclose(f.mean(axis=0), 0.0, atol=1e-6)
    np.testing.assert_allclose(f.std(axis=0), 1.0, rtol=1e-5)
    # log scale: equal ratios give equal steps (40/20 = 80/40)
    assert f[1, 1] - f[0, 1] == pytest.approx(f[2, 1] - f[1, 1], rel=1e-5)
    assert fit_operating(d, []) == {} and operating_features(d, {}).shape == (3, 0)


def test_signal_rms_input_follows_the_record_level():
    """signal_rms: log10 of the record's RMS; records 10x and 100x louder step by equal amounts, and the
    mean of a record does not count."""
    d = _records({"speed_rpm": [600.0, 600.0, 600.0]}, gains=[1.0, 10.0, 100.0])
    st = fit_operating(d, ["signal_rms"])
    f = operating_features(d, st).ravel()
    assert st["mean"][0] == pytest.approx(np.log10(np.sqrt(0.5)) + 1.0, abs=0.01)
    assert f[1] - f[0] == pytest.approx(f[2] - f[1], rel=1e-5) and f[2] > f[0]
    shifted = SignalSet(d.signals + 5.0, d.fs_hz, d.pair, d.labels)
    np.testing.assert_allclose(operating_features(shifted, st).ravel(), f, atol=1e-5)


def test_unknown_or_missing_side_input_is_an_error():
    d = _records({"speed_rpm": [600.0, 900.0]})
    with pytest.raises(InputError, match="operating_inputs"):
        fit_operating(d, ["snr_db"])
    with pytest.raises(InputError, match="torque_nm"):
        fit_operating(d, ["torque_nm"])
    with pytest.raises(InputError, match="operating_inputs"):
        TrainConfig(operating_inputs=("speed_rpm", "speed_rpm"))


def test_network_uses_the_side_inputs_and_checks_their_shape():
    torch.manual_seed(0)
    net = GearCNN(2, 3, 4, n_side=2).eval()
    x = torch.randn(4, 2, 64)
    a = net(x, torch.zeros(4, 2))["severity_class"]
    b = net(x, torch.ones(4, 2))["severity_class"]
    assert a.shape == (4, 3) and not torch.allclose(a, b)
    with pytest.raises(InputError, match="side"):
        net(x)
    # without side inputs the network is the plain one (same parameter count as before)
    assert sum(p.numel() for p in GearCNN(2, 3, 4).parameters()) + 2 * 64 == sum(p.numel() for p in net.parameters())


def test_only_the_model_with_the_load_input_learns_a_load_defined_class(load_task):
    """Classes defined by the torque alone: with the side input >= 0.95 held out, without it chance (<= 0.75)."""
    train, test = load_task
    y = test.labels["severity_class"].to_numpy()
    with_op = train_cnn(train, _config(max_epochs=60, patience=60, operating_inputs=("torque_nm",)))
    without = train_cnn(train, _config())
    assert np.mean(with_op.predict(test).severity_class == y) >= 0.95
    assert np.mean(without.predict(test).severity_class == y) <= 0.75
    assert with_op.spec.operating_inputs["columns"] == ["torque_nm"]


def test_side_inputs_survive_save_load_and_are_required_at_prediction(load_task, tmp_path):
    train, test = load_task
    model = train_cnn(train.subset(np.arange(24)), _config(max_epochs=2, operating_inputs=("speed_rpm", "torque_nm")))
    save_model(model, tmp_path / "m")
    loaded = load_model(tmp_path / "m")
    assert loaded.spec == model.spec
    np.testing.assert_array_equal(model.predict(test).severity_proba, loaded.predict(test).severity_proba)
    no_torque = SignalSet(test.signals, test.fs_hz, test.pair, test.labels.drop(columns=["torque_nm"]))
    with pytest.raises(InputError, match="torque_nm"):
        loaded.predict(no_torque)
