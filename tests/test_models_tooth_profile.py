"""The pitted-teeth profile (models/tooth_profile.py) and its use as a side input of the CNN."""
import numpy as np
import pandas as pd
import pytest

from gearpit.errors import InputError
from models.data import PairInfo, SignalSet
from models.io import load_model, save_model
from models.operating import fit_operating, n_operating, operating_features
from models.tooth_profile import FEATURE_NAMES, N_FEATURES, profile_of_difference, tooth_profile

Z, N = 29, 1024


def _bumps(teeth, depth=1.0, width_pitches=1.4, noise=0.0, seed=0) -> np.ndarray:
    """A difference signal over one revolution with a raised-cosine bump (full width ``width_pitches``) centred on
    each tooth of ``teeth``, minus its mean, plus white noise of standard deviation ``noise``."""
    theta = np.arange(N) / N * Z                                   # tooth pitches
    x = np.zeros(N)
    for t, d in zip(teeth, np.broadcast_to(depth, (len(teeth),))):
        u = (theta - t + Z / 2) % Z - Z / 2                        # circular distance to the tooth's centre
        x += d * np.where(np.abs(u) < width_pitches / 2, 0.5 * (1 + np.cos(2 * np.pi * u / width_pitches)), 0.0)
    return x - x.mean() + noise * np.random.default_rng(seed).standard_normal(N)


def test_spans_and_tooth_values_count_separated_bumps():
    """Definition (module docstring): each separated bump of equal depth adds the same span at every level, and
    the sorted tooth values read ~1 for each bump and ~0 after them. Tolerances: 3 % on the spans (sampling of
    the levels on 1024 points), 0.1 on the tooth values."""
    one = profile_of_difference(_bumps([3]), Z)[0]
    for k, teeth in ((2, [3, 12]), (3, [3, 12, 21]), (4, [1, 8, 15, 23])):
        f = profile_of_difference(_bumps(teeth), Z)[0]
        np.testing.assert_allclose(f[:5], k * one[:5], rtol=0.03)
        tooth = f[5:11]
        assert np.all(tooth[:k] > 0.9) and np.all(tooth[k:] < 0.1)
    # a bump half as deep as the others counts half at the tooth values, and is missed by the 65 % span
    f = profile_of_difference(_bumps([3, 12, 21], depth=[1.0, 1.0, 0.5]), Z)[0]
    assert f[7] == pytest.approx(0.5, abs=0.1) and f[3] == pytest.approx(2 * one[3], rel=0.03)
    assert FEATURE_NAMES[0] == "span_20" and len(FEATURE_NAMES) == N_FEATURES == f.size


def test_profile_does_not_depend_on_scale_sign_or_where_the_teeth_sit():
    x = _bumps([2, 9, 17], depth=[1.0, 0.8, 0.6], noise=0.02)
    ref = profile_of_difference(x, Z)[0]
    for y in (1e-7 * x, -3.0 * x, np.roll(x, 337)):
        np.testing.assert_allclose(profile_of_difference(y, Z)[0], ref, rtol=1e-9, atol=1e-12)
    assert np.all(profile_of_difference(np.zeros(N), Z) == 0.0)


def test_bad_tooth_count_is_an_error():
    with pytest.raises(InputError, match="z_pinion"):
        profile_of_difference(_bumps([1]), 1)
    with pytest.raises(InputError, match="z_pinion"):
        profile_of_difference(_bumps([1]), N // 2)


@pytest.fixture(scope="module")
def simulated_te():
    """The transmission error of spur-gds (29 teeth) with one and with three separated pitted pinion teeth
    (ellipses, 15 % of the flank), at 800 and 1700 rpm, 50 N m, 1 s at 12.8 kHz (the default dataset's
    records)."""
    from datagen.geometry import preset
    from datagen.pits import PitSpec
    from datagen.simulate import Case, OperatingPoint, simulate

    pair = preset("spur-gds")
    cases, counts, speeds = [], [], []
    for rpm in (800.0, 1700.0):
        for teeth in ((0,), (0, 10, 20)):
            cases.append(Case(pair=pair, operating=OperatingPoint(rpm, 50.0), duration_s=1.0, fs_hz=12800.0,
                              pits=PitSpec(shape="ellipse", teeth=teeth, severity=(0.15,) * len(teeth)),
                              pit_grid=(32, 32)))
            counts.append(len(teeth))
            speeds.append(rpm)
    sims = simulate(cases)
    x = np.stack([s.channels["dte_m"] for s in sims])
    return x, np.array(speeds), np.array(counts), pair.pinion.teeth


def test_profile_counts_pitted_teeth_in_the_simulated_transmission_error_at_two_speeds(simulated_te):
    """Physics: each pitted tooth adds a bump of the loaded transmission error while it meshes (stiffness loss,
    spur paper), and the count of tooth values above half the largest is the number of pitted teeth, at a speed
    below and one above the 787 Hz bearing mode's crossing (~1630 rpm)."""
    x, rpm, count, z = simulated_te
    f = tooth_profile(x, fs_hz=12800.0, shaft_hz=rpm / 60.0, z_pinion=z, z_wheel=100)
    tooth = f[:, 5:11]
    np.testing.assert_array_equal((tooth > 0.5).sum(axis=1), count)
    assert np.all(f[count == 3, 2] > 2.0 * f[count == 1, 2])      # the 50 % span grows with the teeth


def _set(x, rpm, z, count=None) -> SignalSet:
    count = np.ones(len(rpm), int) if count is None else np.asarray(count)
    lab = pd.DataFrame({"speed_rpm": rpm, "torque_nm": np.full(len(rpm), 50.0),
                        "severity_class": np.where(count > 1, "severe", "minor"),
                        "severity_class_index": (count > 1).astype(int), "severity": 0.15, "n_pitted_teeth": count})
    return SignalSet(x, 12800.0, PairInfo("spur-gds", z, 100), lab, "test", "dte_m")


def test_tooth_profile_side_input_is_twelve_standardised_values(simulated_te):
    x, rpm, _, z = simulated_te
    data = _set(x, rpm, z)
    stats = fit_operating(data, ["torque_nm", "tooth_profile"])
    assert n_operating(stats) == 1 + N_FEATURES and stats["columns"] == ["torque_nm", "tooth_profile"]
    v = operating_features(data, stats)
    assert v.shape == (len(data), 1 + N_FEATURES)
    raw = tooth_profile(x, fs_hz=12800.0, shaft_hz=rpm / 60.0, z_pinion=z, z_wheel=100)
    sd = raw.std(axis=0)
    ok = sd > 0
    np.testing.assert_allclose(v[:, 1:][:, ok], ((raw - raw.mean(axis=0)) / np.where(ok, sd, 1.0))[:, ok], atol=1e-5)
    no_speed = SignalSet(x, 12800.0, data.pair, data.labels.drop(columns=["speed_rpm"]))
    with pytest.raises(InputError, match="speed_rpm"):
        operating_features(no_speed, stats)


def test_a_model_with_the_profile_input_survives_save_and_load(simulated_te, tmp_path):
    from models.representation_spec import RepresentationSpec
    from models.train import TrainConfig, train_cnn

    x, rpm, count, z = simulated_te
    data = _set(np.repeat(x, 4, axis=0), np.repeat(rpm, 4), z, np.repeat(count, 4))
    cfg = TrainConfig(representation=RepresentationSpec(kind="tsa", n_revs=4, samples_per_rev=256), max_epochs=2,
                      patience=2, batch_size=8, widths=(8, 8, 8, 8, 8), hidden=8, seed=0,
                      operating_inputs=("torque_nm", "tooth_profile"))
    model = train_cnn(data, cfg)
    save_model(model, tmp_path / "m")
    loaded = load_model(tmp_path / "m")
    assert loaded.spec == model.spec
    np.testing.assert_array_equal(model.predict(data).severity_proba, loaded.predict(data).severity_proba)


def test_profile_ignores_the_shaft_encoders_disc_eccentricity(simulated_te):
    """Both shafts' once-per-revolution lines (encoder disc eccentricity, datagen/effects/shaft_encoder_error.py:
    here 20 um on each, ~20 times the pit's deviation) are removed before the average: the tooth count is
    unchanged and every feature moves by less than 0.05 (measured: below 0.01)."""
    x, rpm, count, z = simulated_te
    t = np.arange(x.shape[1]) / 12800.0
    fr = (rpm / 60.0)[:, None]
    ecc = 20e-6 * np.sin(2 * np.pi * fr * t + 0.3) + 20e-6 * np.sin(2 * np.pi * fr * z / 100 * t + 1.1)
    clean = tooth_profile(x, fs_hz=12800.0, shaft_hz=rpm / 60.0, z_pinion=z, z_wheel=100)
    dirty = tooth_profile(x + ecc, fs_hz=12800.0, shaft_hz=rpm / 60.0, z_pinion=z, z_wheel=100)
    np.testing.assert_array_equal((dirty[:, 5:11] > 0.5).sum(axis=1), count)
    np.testing.assert_allclose(dirty, clean, atol=0.05)


def test_profile_from_the_networks_fft_equals_a_second_tsa(simulated_te):
    """represent_crops_and_difference reads the profile's difference signal from the first crop's FFT, the two
    shaft lines taken off in closed form (models/tsa.py::_lines_comb, order_filters.shaft_line_fit), instead of a second
    TSA of the filtered record. Reference: the direct computation (tsa_difference of the normalised record);
    tolerance 1e-12 of its largest value (rounding), with encoder eccentricity of 20 um on both shafts (~20 times
    the pit's deviation, so a wrong line correction would show). The network's crops are bitwise those of
    represent_crops."""
    from dataclasses import replace

    from models.representations import represent_crops
    from models.segments import _normalise
    from models.tsa import represent_crops_and_difference, tsa_difference
    from models.tooth_profile import PROFILE_SPEC

    x, rpm, count, z = simulated_te
    t = np.arange(x.shape[1]) / 12800.0
    fr = rpm / 60.0
    x = x + 20e-6 * np.sin(2 * np.pi * fr[:, None] * t + 0.3) + 20e-6 * np.sin(2 * np.pi * fr[:, None] * z / 100 * t)
    ref = np.stack([tsa_difference(_normalise(r)[None], PROFILE_SPEC, fs_hz=12800.0, shaft_hz=f, z_pinion=z,
                                   z_wheel=100)[0] for r, f in zip(x, fr)])
    for spec in (replace(PROFILE_SPEC, remove_shaft_1x=False), PROFILE_SPEC):   # tsa_lp_profile, tsa_te_profile
        rep, diff = represent_crops_and_difference(x, spec, fs_hz=12800.0, crops=(0.0, 0.5, 1.0), shaft_hz=fr,
                                                   z_pinion=z, z_wheel=100, difference_spec=PROFILE_SPEC)
        assert np.abs(diff - ref).max() < 1e-12 * np.abs(ref).max()
        np.testing.assert_array_equal(rep, represent_crops(x, spec, fs_hz=12800.0, crops=(0.0, 0.5, 1.0),
                                                           shaft_hz=fr, z_pinion=z, z_wheel=100))
        np.testing.assert_allclose(profile_of_difference(diff, z), tooth_profile(x, fs_hz=12800.0, shaft_hz=fr,
                                   z_pinion=z, z_wheel=100), atol=1e-6)
    with pytest.raises(InputError, match="crops"):
        represent_crops_and_difference(x, PROFILE_SPEC, fs_hz=12800.0, crops=(0.5,), shaft_hz=fr, z_pinion=z,
                                       z_wheel=100, difference_spec=PROFILE_SPEC)
    with pytest.raises(InputError, match="difference_spec"):
        represent_crops_and_difference(x, replace(PROFILE_SPEC, n_revs=4), fs_hz=12800.0, crops=(0.0,),
                                       shaft_hz=fr, z_pinion=z, z_wheel=100, difference_spec=PROFILE_SPEC)


def test_closed_form_line_fit_and_dft_equal_the_sampled_ones():
    """shaft_line_fit (Gram matrix and projections without forming the regressors) equals the normal equations on
    the formed regressors, rms_without_lines the RMS of the filtered record, and geometric_sum equals the FFT of the sampled lines, to rounding (1e-12 relative), at a
    frequency on a bin and one off the bins."""
    from models.order_filters import (_fit, _line_regressors, geometric_sum, remove_shaft_lines, rms_without_lines,
                                      shaft_line_fit)

    rng = np.random.default_rng(1)
    n, fs = 12811, 12800.0
    k = np.arange(n)
    freqs = (16.9, 16.9 * 29 / 100)
    x = rng.normal(size=n) + 3 * np.cos(2 * np.pi * freqs[0] / fs * k + 0.4) + np.sin(2 * np.pi * freqs[1] / fs * k)
    ref = _fit(x, _line_regressors(n, fs, freqs))
    np.testing.assert_allclose(shaft_line_fit(x, fs, freqs), ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    direct = np.sqrt(np.mean(remove_shaft_lines(x, fs, freqs) ** 2))
    assert rms_without_lines(x, fs, freqs) == pytest.approx(direct, rel=1e-12) and 0.9 < direct < 1.1  # the noise
    m = np.arange(0, 300)
    for c in (37 / n, 0.0123457):
        plus, minus = geometric_sum(n, c - m / n), geometric_sum(n, -c - m / n)   # DFTs of exp(+/- 2 pi i c k)
        cos, sin = 0.5 * (plus + minus), (plus - minus) / 2j
        np.testing.assert_allclose(cos, np.fft.rfft(np.cos(2 * np.pi * c * k))[m], atol=1e-12 * n)
        np.testing.assert_allclose(sin, np.fft.rfft(np.sin(2 * np.pi * c * k))[m], atol=1e-12 * n)


def test_direct_dft_and_closed_form_lines_equal_the_sampled_ones():
    """order_filters.dft_at equals np.fft.fft at the asked bins, and lines_dft_at the FFT of the formed lines
    (coefficients referred to sample 0) over a segment that starts elsewhere, to rounding (1e-12 of the largest
    value), for a segment length with a large prime factor (10529 = 10529) and a power-of-two one."""
    from models.order_filters import _line_regressors, dft_at, lines_dft_at

    rng = np.random.default_rng(2)
    fs, freqs = 12800.0, (16.9, 16.9 * 29 / 100)
    coef = np.array([0.3, 1.0, -2.0, 0.5, 0.7])
    lines = coef @ _line_regressors(12800, fs, freqs)
    for n in (10529, 8192):
        x = rng.normal(size=n)
        m = np.concatenate([[0, 1, n // 2], rng.choice(n, 40, replace=False)])
        ref = np.fft.fft(x)[m]
        np.testing.assert_allclose(dft_at(x, m), ref, rtol=0, atol=1e-12 * np.abs(ref).max())
        for start in (0, 12800 - n):
            ref = np.fft.fft(lines[start:start + n])[m]
            np.testing.assert_allclose(lines_dft_at(coef, freqs, fs, n, m, start), ref, rtol=0,
                                       atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("remove, highpass", [(True, 0.0), (False, 0.0), (True, 2.5)])
def test_tsa_comb_from_the_direct_dft_equals_the_fft_path(simulated_te, monkeypatch, remove, highpass):
    """With the low-pass on, _tsa_comb reads its few kept orders by a direct DFT and takes the shaft lines off in
    closed form; reference: the FFT of the filtered segment (the path taken without the low-pass, forced here by
    DIRECT_MAX_ORDERS = 0). Records with encoder eccentricity of 20 um on both shafts (so a wrong line correction
    would show), three crops, speed errors of +/-2 %; tolerance 1e-12 of the comb's largest value."""
    from dataclasses import replace

    import models.segments
    import models.tsa as reps
    from models.tooth_profile import PROFILE_SPEC

    x, rpm, count, z = simulated_te
    t = np.arange(x.shape[1]) / 12800.0
    fr = rpm / 60.0
    x = x + 20e-6 * np.sin(2 * np.pi * fr[:, None] * t + 0.3) + 20e-6 * np.sin(2 * np.pi * fr[:, None] * z / 100 * t)
    spec = replace(PROFILE_SPEC, remove_shaft_1x=remove, highpass_orders=highpass)
    starts = (0.0, 0.37, 1.0)
    for i, factor in zip(range(x.shape[0]), (0.98, 1.0, 1.02) * x.shape[0]):
        xi = models.segments._normalise(x[i])
        direct = reps._tsa_comb(xi, spec, 12800.0, fr[i] * factor, starts, z, 100)
        with monkeypatch.context() as mp:
            mp.setattr(reps, "DIRECT_MAX_ORDERS", 0)
            ref = reps._tsa_comb(xi, spec, 12800.0, fr[i] * factor, starts, z, 100)
        assert np.abs(ref).max() > 0 and np.count_nonzero(ref[0]) < ref.shape[1] // 4   # the low-pass is on
        np.testing.assert_allclose(direct, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_prediction_reads_the_same_profile_as_training(simulated_te):
    """The side inputs at prediction (profile from the network's FFT, models/classifier.py::represent_batch) equal
    those computed as in training (operating_features, a second TSA) to float32 rounding, for a model whose
    representation is the profile's TSA without the shaft-line removal (tsa_lp_profile) and one with it that also
    reads the difference signal's level (tsa_te_diff)."""
    from dataclasses import replace

    from models.classifier import _profile_shares_fft, represent_batch
    from models.representations import represent_crops
    from models.tooth_profile import PROFILE_SPEC
    from models.train import TrainConfig, train_cnn

    x, rpm, count, z = simulated_te
    data = _set(np.repeat(x, 2, axis=0), np.repeat(rpm, 2), z, np.repeat(count, 2))
    for remove, side_inputs in ((False, ("torque_nm", "signal_rms", "tooth_profile")),              # tsa_lp_profile
                                (True, ("torque_nm", "signal_rms_no1x", "tsa_diff_rms", "tooth_profile"))):  # tsa_te_diff
        cfg = TrainConfig(representation=replace(PROFILE_SPEC, remove_shaft_1x=remove), max_epochs=1, patience=1,
                          batch_size=8, widths=(8, 8, 8, 8, 8), hidden=8, seed=0, operating_inputs=side_inputs)
        model = train_cnn(data, cfg)
        assert _profile_shares_fft(model.spec)
        rep = model.spec.representation_spec()
        for crops in ((0.0, 0.5, 1.0), (0.5,)):   # the second without a crop at 0: one is added, then dropped
            x_net, side = represent_batch(data, model.spec, slice(0, len(data)), crops)
            direct = np.repeat(operating_features(data, model.spec.operating_inputs), len(crops), axis=0)
            np.testing.assert_allclose(side.numpy(), direct, atol=1e-5)
            ref = represent_crops(data.signals, rep, fs_hz=data.fs_hz, crops=crops, shaft_hz=data.shaft_hz(),
                                  z_pinion=z, z_wheel=100)
            np.testing.assert_array_equal(x_net.numpy(), ref.reshape(-1, *ref.shape[2:]))


def test_difference_rms_is_blind_to_the_encoders_and_scales_with_the_record(simulated_te):
    """tsa_diff_rms (models/operating.py): the RMS of the profile's difference signal in the record's unit. The
    shaft lines of eccentric encoders (20 um on each shaft) move it by less than 1 % (they are removed before the
    average); it is proportional to the record (x 7.3 -> x 7.3 to 1e-9); three pitted teeth give a larger value
    than one at the same speed (the spur paper: each pitted tooth adds its own deviation)."""
    from models.operating import _column

    x, rpm, count, z = simulated_te
    t = np.arange(x.shape[1]) / 12800.0
    fr = (rpm / 60.0)[:, None]
    ecc = 20e-6 * np.sin(2 * np.pi * fr * t + 0.3) + 20e-6 * np.sin(2 * np.pi * fr * z / 100 * t + 1.1)
    clean = _column(_set(x, rpm, z), "tsa_diff_rms")
    np.testing.assert_allclose(_column(_set(x + ecc, rpm, z), "tsa_diff_rms"), clean, rtol=0.01)
    np.testing.assert_allclose(_column(_set(7.3 * x, rpm, z), "tsa_diff_rms"), 7.3 * clean, rtol=1e-9)
    for speed in np.unique(rpm):
        assert clean[(rpm == speed) & (count == 3)][0] > 1.5 * clean[(rpm == speed) & (count == 1)][0]

