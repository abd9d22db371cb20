"""The novelty warning (models/novelty.py): the Mahalanobis distance against an independent implementation, its
false-alarm rate on records of the training distribution, its alarms on records of another, and its round trip
through a saved model."""
import numpy as np
import pytest
from scipy.spatial.distance import mahalanobis

from gearpit.errors import InputError
from models.data import SignalSet
from models.io import load_model, save_model
from models.novelty import QUANTILE, NoveltyModel, fit_novelty
from models.representation_spec import RepresentationSpec
from models.toy import toy_signal_set
from models.train import TrainConfig, train_cnn


def _blobs(rng, n, means, scale):
    """``n`` records of each class: Gaussian around its mean, correlated features (a random mixing matrix)."""
    y = np.repeat(np.arange(len(means)), n)
    x = means[y] + rng.standard_normal((y.size, means.shape[1])) @ scale
    return x, y


@pytest.fixture(scope="module")
def gaussian():
    rng = np.random.default_rng(0)
    d = 12
    means = 3.0 * rng.standard_normal((3, d))
    scale = np.eye(d) + 0.3 * rng.standard_normal((d, d))
    x, y = _blobs(rng, 200, means, scale)
    held, _ = _blobs(rng, 170, means, scale)
    return rng, means, scale, fit_novelty(x, y, held)


def test_distance_is_the_mahalanobis_distance_to_the_nearest_class(gaussian):
    """Against scipy's mahalanobis (an independent implementation) with the fitted means and precision matrix,
    to 1e-9 relative."""
    rng, means, scale, model = gaussian
    pts = rng.standard_normal((7, means.shape[1])) * 4.0
    ref = [min(mahalanobis(p, mu, model.precision) for mu in model.means) for p in pts]
    np.testing.assert_allclose(model.distance(pts), ref, rtol=1e-9)


def test_records_of_the_training_distribution_are_flagged_at_the_stated_rate(gaussian):
    """Fresh draws of the training distribution: about 1 - QUANTILE = 1 % flagged. The threshold is a quantile
    of 510 held-out distances, so the rate is itself uncertain (standard deviation ~0.45 %); accepted: 0.2-3 %
    of 6000 fresh records. A novelty that ignored the class structure or the covariance would be off by far."""
    rng, means, scale, model = gaussian
    x, _ = _blobs(rng, 2000, means, scale)
    rate = float(np.mean(model.novelty(x) > 1.0))
    assert 0.002 <= rate <= 0.03, rate


def test_records_of_another_distribution_are_flagged(gaussian):
    """Records with three times the spread (chi with 12 degrees of freedom: 99.8 % beyond
    the 99 % quantile of the training spread), or shifted by two standard deviations in every feature, are flagged (>= 95 %
    of them)."""
    rng, means, scale, model = gaussian
    x, _ = _blobs(rng, 300, means, 3.0 * scale)
    assert np.mean(model.novelty(x) > 1.0) >= 0.95
    x, _ = _blobs(rng, 300, means + 2.0 * np.sqrt((scale ** 2).sum(axis=0)), scale)
    assert np.mean(model.novelty(x) > 1.0) >= 0.95


def test_arrays_round_trip_and_bad_input(gaussian):
    """to_arrays/from_arrays keeps every distance; features of the wrong width and non-finite training
    features are errors naming the field."""
    rng, means, _, model = gaussian
    back = NoveltyModel.from_arrays(model.to_arrays())
    pts = rng.standard_normal((5, means.shape[1]))
    np.testing.assert_array_equal(back.novelty(pts), model.novelty(pts))
    assert back.quantile == QUANTILE
    with pytest.raises(InputError, match="features"):
        model.distance(np.zeros((2, means.shape[1] + 1)))
    bad = np.zeros((5, 3))
    bad[0, 0] = np.nan
    with pytest.raises(InputError, match="features"):
        fit_novelty(bad, np.zeros(5), np.zeros((2, 3)))


# ------------------------------------------------------------------ in a trained CNN

SMALL_REP = RepresentationSpec(kind="order", n_revs=4, max_order=30.0)


@pytest.fixture(scope="module")
def toy_model():
    classes = (("healthy", 0.0), ("severe", 0.35))
    train = toy_signal_set(n_per_class=40, classes=classes, snr_db=20.0, seed=1)
    test = toy_signal_set(n_per_class=16, classes=classes, snr_db=20.0, seed=2)
    cfg = TrainConfig(representation=SMALL_REP, max_epochs=12, patience=12, batch_size=16, learning_rate=3e-3,
                      widths=(8, 16, 16, 24, 32), hidden=32, seed=0)
    return train_cnn(train, cfg), test


def test_a_trained_cnn_warns_on_records_unlike_its_training_records(toy_model, tmp_path):
    """The toy CNN: held-out toy records (the training distribution) mostly pass (<= 10 % flagged; by
    construction ~1 %, the threshold coming from 16 validation records); records of white noise at the same
    level, and toy records whose mesh tone is a square wave's harmonics instead of two, are flagged, every one,
    with the warning text. A saved and reloaded model gives the same novelty."""
    model, test = toy_model
    assert model.novelty is not None and model.spec.training["novelty"]["quantile"] == QUANTILE
    p = model.predict(test)
    assert p.novelty is not None and np.mean(p.novelty > 1.0) <= 0.10
    rng = np.random.default_rng(7)
    noise = rng.standard_normal(test.signals.shape).astype(np.float32) * test.signals.std(axis=1, keepdims=True)
    q = model.predict(SignalSet(noise, test.fs_hz, test.pair, test.labels))
    assert np.all(q.novelty > 1.0), np.sort(q.novelty)[:5]
    assert all("signal unlike the training records" in w for w in q.warnings)
    assert q.novelty_batch["shifted"] and not p.novelty_batch["shifted"]
    # another machine's signature: a sign-clipped record (odd harmonics of every line) at the same level
    clipped = (np.sign(test.signals) * test.signals.std(axis=1, keepdims=True)).astype(np.float32)
    r = model.predict(SignalSet(clipped, test.fs_hz, test.pair, test.labels))
    assert np.mean(r.novelty > 1.0) >= 0.9, np.sort(r.novelty)
    save_model(model, tmp_path / "m")
    back = load_model(tmp_path / "m")
    np.testing.assert_array_equal(back.predict(test).novelty, p.novelty)
    assert "novelty" in p.to_frame().columns


def test_a_feature_baseline_warns_on_records_unlike_its_training_records(tmp_path):
    """A logistic-regression baseline on a feature table of Gaussian classes: held-out rows of the same
    distribution mostly pass (<= 5 % flagged), rows with one feature 8 training standard deviations off are all
    flagged; the novelty survives save/load (arrays.npz, no pickling)."""
    import pandas as pd

    from models.baselines import fit_baseline
    from models.data import PairInfo

    rng = np.random.default_rng(3)
    n, d = 240, 6
    y = np.repeat([0, 1], n // 2)
    x = rng.standard_normal((n, d)) + 2.0 * y[:, None]
    labels = pd.DataFrame({"severity_class": np.where(y == 1, "severe", "healthy"),
                           "severity_class_index": y, "severity": 0.3 * y, "n_pitted_teeth": y,
                           "speed_rpm": 1000.0, "torque_nm": 50.0})
    data = SignalSet(np.zeros((n, 64), np.float32), 1000.0, PairInfo("toy", 13, 29), labels)
    model = fit_baseline(data, "logreg", features=x, feature_names=[f"f{i}" for i in range(d)],
                         feature_config={})
    fresh = rng.standard_normal((400, d)) + 2.0 * np.repeat([0, 1], 200)[:, None]
    assert np.mean(model.predict_features(fresh).novelty > 1.0) <= 0.05
    off = fresh.copy()
    off[:, 2] += 8.0
    p = model.predict_features(off)
    assert np.all(p.novelty > 1.0) and all("unlike the training records" in w for w in p.warnings)
    save_model(model, tmp_path / "b")
    np.testing.assert_array_equal(load_model(tmp_path / "b").predict_features(off).novelty, p.novelty)


def test_evaluation_counts_the_flagged_records_and_scores_them_apart():
    """evaluate() reports how many records the novelty flags and the severity accuracy on the flagged and the
    other records (a hand-made case: 4 records, 2 flagged, one of them right; both others right)."""
    import pandas as pd

    from models.data import PairInfo
    from models.evaluate import evaluate, report_markdown
    from models.spec import Predictions

    labels = pd.DataFrame({"severity_class": ["healthy", "severe", "severe", "healthy"], "severity": [0, .3, .3, 0]})
    data = SignalSet(np.zeros((4, 8), np.float32), 1000.0, PairInfo("toy", 13, 29), labels)
    proba = np.array([[0.9, 0.1], [0.2, 0.8], [0.7, 0.3], [0.6, 0.4]])     # right, right, wrong, right
    pred = Predictions(["healthy", "severe"], ["0", "1"], proba, np.ones((4, 2)) / 2, np.zeros(4), [""] * 4,
                       np.array([0.5, 1.5, 2.0, 0.9]))
    m = evaluate(data, pred)
    assert m["novelty"]["flagged"] == 2 and m["novelty"]["accuracy_flagged"] == 0.5
    assert m["novelty"]["accuracy_not_flagged"] == 1.0
    assert "unlike the training records (novelty > 1): 2" in report_markdown(m)


def test_a_batch_shifted_as_a_whole_is_reported_though_few_records_pass_one(gaussian):
    """Records with 1.35 times the training spread: few pass novelty 1 singly (< 30 %), but far more than the
    expected 10 % lie beyond the held-out 90th percentile, and the batch is reported (p < 1e-3); a batch of the
    training distribution is not (p > 1e-3), nor is a batch of fewer than 10 records however far out."""
    from models.novelty import batch_warning

    rng, means, scale, model = gaussian
    x, _ = _blobs(rng, 100, means, 1.35 * scale)
    nov = model.novelty(x)
    assert np.mean(nov > 1.0) < 0.30
    b = model.batch_shift(nov)
    assert b["shifted"] and b["beyond_fraction"] > 0.3 and b["p_value"] < 1e-3
    assert "as a whole are unlike the training records" in batch_warning(b)
    x, _ = _blobs(rng, 100, means, scale)
    b = model.batch_shift(model.novelty(x))
    assert not b["shifted"] and b["p_value"] > 1e-3 and batch_warning(b) == ""
    assert not model.batch_shift(np.full(9, 50.0))["shifted"]
