"""Transmission-path augmentation (models/augment.py): shapes, seeds, the documented spectrum, off when disabled,
input checks, recorded in the saved training configuration, same seed -> same weights with it on."""
import dataclasses
import json

import numpy as np
import pytest
import torch
from scipy.signal import csd, welch

from gearpit.errors import InputError
from models.augment import AugmentConfig, augment_batch, lowpass_filter, mount_transmissibility, path_filter
from models.io import load_model, save_model
from models.representation_spec import RepresentationSpec
from models.toy import toy_signal_set
from models.train import TrainConfig, train_cnn

FS = 12800.0
PATH_ONLY = dataclasses.replace(AugmentConfig.none(), path_probability=1.0)


def _white(n_records: int, n_samples: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).standard_normal((n_records, n_samples))


def test_transmissibility_is_the_sdof_formula():
    """T = (1 + 2i zeta r) / (1 - r^2 + 2i zeta r): 1 at DC, sqrt(1 + 4 zeta^2) / (2 zeta) at f_n, ~2 zeta / r far above."""
    z = 0.05
    assert mount_transmissibility(0.0, 3000.0, z) == pytest.approx(1.0)
    assert abs(mount_transmissibility(3000.0, 3000.0, z)) == pytest.approx(np.sqrt(1 + 4 * z * z) / (2 * z), rel=1e-12)
    assert abs(mount_transmissibility(300000.0, 3000.0, z)) == pytest.approx(2 * z / 100.0, rel=0.01)


def test_path_filter_steady_sine_has_the_analytic_gain_from_the_first_sample():
    """A sine at f_n (odd about the record start, so the mirrored history is its true history): output amplitude
    |T(f_n)| within 1e-4 relative, already over the first 50 samples; a cosine (whose mirrored history is wrong)
    settles to it within 1 % after 5 decay times."""
    fn, z = 3000.0, 0.05
    t = np.arange(25600) / FS
    gain = abs(mount_transmissibility(fn, fn, z))
    y = path_filter(np.sin(2 * np.pi * fn * t)[None, :], FS, fn, z)[0]
    assert np.abs(y[:50]).max() == pytest.approx(gain, rel=1e-4)
    assert np.abs(y).max() == pytest.approx(gain, rel=1e-4)
    yc = path_filter(np.cos(2 * np.pi * fn * t)[None, :], FS, fn, z)[0]
    settle = int(np.ceil(5 / (2 * np.pi * z * fn) * FS))
    assert np.abs(yc[settle:]).max() == pytest.approx(gain, rel=0.01)


def test_augmented_spectrum_matches_the_drawn_resonance():
    """White noise through the augmentation (path only): the transfer function estimated from input and output
    (cross-spectrum / input PSD, Welch) equals the analytic transmissibility of the DRAWN f_n and zeta times the
    RMS rescaling, within 2 % over 50 Hz .. 0.45 fs, and peaks where the analytic curve does (one bin), within 1 %
    of the drawn f_n, which lies inside the documented range."""
    x = _white(3, 1 << 16, seed=11)
    info = {}
    y, _, _ = augment_batch(x, PATH_ONLY, np.random.default_rng(3), fs_hz=FS, info=info)
    assert info["path_applied"].all()
    for i in range(x.shape[0]):
        fn, z = info["path_hz"][i, 0], info["path_damping"][i, 0]
        assert 1000.0 <= fn <= 0.45 * FS and 0.02 <= z <= 0.10
        f, pxy = csd(x[i], y[i].astype(float), fs=FS, nperseg=4096)
        _, pxx = welch(x[i], fs=FS, nperseg=4096)
        est = np.abs(pxy / pxx)
        model = np.abs(mount_transmissibility(f, fn, z)) * info["path_rms_scale"][i]
        band = (f >= 50.0) & (f <= 0.45 * FS)
        assert np.max(np.abs(est[band] / model[band] - 1.0)) < 0.02
        # |T| peaks slightly below f_n (r = sqrt(sqrt(1 + 8 zeta^2) - 1) / (2 zeta), within 1 % of f_n here)
        assert abs(f[np.argmax(est)] - f[np.argmax(model)]) <= f[1]
        assert abs(f[np.argmax(est)] - fn) <= 0.01 * fn + f[1]
        # the RMS rescaling keeps the record's level
        assert np.std(y[i]) == pytest.approx(np.std(x[i]), rel=1e-5)


def test_two_modes_multiply():
    """path_modes=2: the transfer function is the product of both drawn transmissibilities (2 %)."""
    x = _white(1, 1 << 16, seed=12)
    info = {}
    cfg = dataclasses.replace(PATH_ONLY, path_modes=2)
    y, _, _ = augment_batch(x, cfg, np.random.default_rng(4), fs_hz=FS, info=info)
    f, pxy = csd(x[0], y[0].astype(float), fs=FS, nperseg=4096)
    _, pxx = welch(x[0], fs=FS, nperseg=4096)
    fn, z = info["path_hz"][0], info["path_damping"][0]
    model = (np.abs(mount_transmissibility(f, fn[0], z[0]) * mount_transmissibility(f, fn[1], z[1]))
             * info["path_rms_scale"][0])
    band = (f >= 50.0) & (f <= 0.45 * FS)
    assert np.max(np.abs(np.abs(pxy / pxx)[band] / model[band] - 1.0)) < 0.02


def test_path_augmentation_keeps_shapes_and_is_seeded():
    """Same generator seed -> identical batch (records, starts, speeds); another seed -> different; shapes and
    dtype as without the path; about path_probability of the records filtered."""
    x = toy_signal_set(n_per_class=2, seed=4).signals
    cfg = dataclasses.replace(AugmentConfig(), path_probability=0.5)
    a = augment_batch(x, cfg, np.random.default_rng(5), fs_hz=4096.0)
    b = augment_batch(x, cfg, np.random.default_rng(5), fs_hz=4096.0)
    c = augment_batch(x, cfg, np.random.default_rng(6), fs_hz=4096.0)
    assert a[0].shape == x.shape and a[0].dtype == np.float32 and a[1].shape == a[2].shape == (x.shape[0],)
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)
    assert not np.array_equal(a[0], c[0])
    info = {}
    augment_batch(_white(400, 256, 1), PATH_ONLY.__class__(path_probability=0.5, random_start=False, gain_db=0.0,
                                                           noise_probability=0.0, speed_error=0.0,
                                                           polarity_flip_probability=0.0),
                  np.random.default_rng(7), fs_hz=FS, info=info)
    assert 0.4 < info["path_applied"].mean() < 0.6


def test_path_off_changes_nothing():
    """path_probability and lowpass_probability 0 (the default): no draws from the generator, no info, the batch of the other
    augmentations unchanged; everything off and the path off -> the records themselves."""
    x = toy_signal_set(n_per_class=2, seed=4).signals
    r1, r2 = np.random.default_rng(9), np.random.default_rng(9)
    info = {}
    a = augment_batch(x, AugmentConfig(), r1, info=info)   # no fs needed with the path off
    b = augment_batch(x, dataclasses.replace(AugmentConfig(), path_hz_range=(500.0, 900.0), path_modes=3,
                                             lowpass_fs_fraction_range=(0.1, 0.2)), r2)
    for u, v in zip(a, b):
        np.testing.assert_array_equal(u, v)
    assert info == {} and r1.uniform() == r2.uniform()
    y, _, _ = augment_batch(x, AugmentConfig.none(), np.random.default_rng(0), fs_hz=4096.0)
    np.testing.assert_array_equal(y, x.astype(np.float32))


def _amplitude(y: np.ndarray, f_hz: float) -> float:
    """Least-squares amplitude of a sine of frequency f_hz in y (sampled at FS)."""
    t = np.arange(y.size) / FS
    basis = np.column_stack([np.sin(2 * np.pi * f_hz * t), np.cos(2 * np.pi * f_hz * t)])
    return float(np.hypot(*np.linalg.lstsq(basis, y, rcond=None)[0]))


@pytest.mark.parametrize("ratio", [0.5, 1.0, 1.5])
def test_lowpass_gain_is_the_documented_zero_phase_butterworth(ratio):
    """Bandwidth augmentation's filter: gain 1 / (1 + (tan(pi f / fs) / tan(pi f_c / fs))^16) (digital order-8
    Butterworth forwards and backwards) within 1e-3 absolute, away from the record ends, and no phase shift (the peak stays in place)."""
    fc = 0.2 * FS
    t = np.arange(25600) / FS
    x = np.sin(2 * np.pi * ratio * fc * t)
    y = lowpass_filter(x[None, :], 0.2)[0]
    mid = slice(4000, -4000)
    gain = _amplitude(y[mid], ratio * fc)
    w = np.tan(np.pi * ratio * 0.2) / np.tan(np.pi * 0.2)
    assert gain == pytest.approx(1.0 / (1.0 + w ** 16), abs=1e-3)
    if ratio <= 1.0:
        assert _amplitude(y[mid] - gain * x[mid], ratio * fc) < 1e-3   # zero phase: y = gain * x


def test_lowpass_augmentation_cuts_above_the_drawn_cutoff_and_keeps_the_rms():
    """Bandwidth only, probability 1: every record's power above 1.5 x the drawn cut-off falls below 1e-4 of
    the input's there (white noise), the RMS is kept, the cut-off lies in the documented fraction range."""
    x = _white(4, 1 << 14, seed=21)
    cfg = dataclasses.replace(AugmentConfig.none(), lowpass_probability=1.0)
    info = {}
    y, _, _ = augment_batch(x, cfg, np.random.default_rng(2), fs_hz=FS, info=info)
    assert info["lowpass_applied"].all()
    for i in range(x.shape[0]):
        c = info["lowpass_fs_fraction"][i]
        assert 0.15 <= c <= 0.45
        f, px = welch(x[i], fs=FS, nperseg=1024)
        _, py = welch(y[i].astype(float), fs=FS, nperseg=1024)
        above = f >= 1.5 * c * FS
        if above.any():
            assert py[above].max() < 1e-4 * px[above].mean()
        assert np.std(y[i]) == pytest.approx(np.std(x[i]), rel=1e-5)


@pytest.mark.parametrize("field, kw", [
    ("augment.lowpass_probability", {"lowpass_probability": -0.1}),
    ("augment.lowpass_fs_fraction_range", {"lowpass_fs_fraction_range": (0.3, 0.2)}),
    ("augment.lowpass_fs_fraction_range", {"lowpass_fs_fraction_range": (0.2, 0.5)}),
    ("augment.path_probability", {"path_probability": 1.5}),
    ("augment.path_hz_range", {"path_hz_range": (5000.0, 1000.0)}),
    ("augment.path_hz_range", {"path_hz_range": (1000.0,)}),
    ("augment.path_damping_range", {"path_damping_range": (0.0, 0.1)}),
    ("augment.path_damping_range", {"path_damping_range": (0.05, 0.9)}),
    ("augment.path_modes", {"path_modes": 4}),
    ("augment.path_modes", {"path_modes": 1.5}),
])
def test_bad_path_settings_are_clear_errors(field, kw):
    with pytest.raises(InputError, match=field.replace(".", r"\.")):
        AugmentConfig(**kw)


def test_path_needs_fs_and_a_range_below_nyquist():
    x = _white(2, 1024, 0)
    with pytest.raises(InputError, match="fs_hz"):
        augment_batch(x, PATH_ONLY, np.random.default_rng(0))
    with pytest.raises(InputError, match="path_hz_range"):
        augment_batch(x, PATH_ONLY, np.random.default_rng(0), fs_hz=2000.0)   # 1000 Hz > 0.45 fs
    with pytest.raises(InputError, match="natural_hz"):
        path_filter(x, 2000.0, 1500.0, 0.05)


def test_path_settings_are_recorded_and_same_seed_same_weights(tmp_path):
    """The path fields go into TrainConfig.to_dict / from_dict and the saved model's train_config; with the path
    on, two trainings with one seed give bitwise identical weights."""
    train = toy_signal_set(n_per_class=6, classes=(("healthy", 0.0), ("severe", 0.35)), snr_db=20.0, seed=1)
    aug = dataclasses.replace(AugmentConfig(), path_probability=0.7, path_hz_range=(800.0, 1800.0), path_modes=2)
    cfg = TrainConfig(representation=RepresentationSpec(kind="order", n_revs=4, max_order=30.0), augment=aug,
                      max_epochs=2, patience=2, batch_size=8, widths=(8, 8, 8, 8, 8), hidden=8, seed=0)
    assert TrainConfig.from_dict(cfg.to_dict()) == cfg
    m1, m2 = train_cnn(train, cfg), train_cnn(train, cfg)
    s1, s2 = m1.network.state_dict(), m2.network.state_dict()
    assert all(torch.equal(s1[k], s2[k]) for k in s1)
    off = train_cnn(train, dataclasses.replace(cfg, augment=dataclasses.replace(aug, path_probability=0.0)))
    assert not all(torch.equal(s1[k], v) for k, v in off.network.state_dict().items())
    save_model(m1, tmp_path / "m")
    doc = json.loads((tmp_path / "m" / "model.json").read_text())
    assert doc["train_config"]["augment"]["path_probability"] == 0.7
    assert doc["train_config"]["augment"]["path_hz_range"] == [800.0, 1800.0]
    assert doc["train_config"]["augment"]["path_modes"] == 2
    assert load_model(tmp_path / "m").spec.train_config["augment"] == aug.to_dict()
