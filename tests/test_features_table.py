"""Feature table and scikit-learn transformer (features.table)."""
import numpy as np
import pandas as pd
import pytest
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from features.synthetic import gear_signal_example
from features.table import FeatureConfig, FeatureExtractor, column_names, extract_features, feature_units, \
    signal_features
from gearpit.errors import InputError


def _batch(depths=(0.0, 0.5), duration_s=0.5, **kw):
    sigs = [gear_signal_example(fault_depth=d, duration_s=duration_s, snr_db=15, seed=i, **kw)
            for i, d in enumerate(depths)]
    return np.stack([s.x for s in sigs]), sigs


def test_columns_units_and_fault_response():
    """Keys of one feature vector = feature_units(config) in order; names carry units; the synthetic pinion fault
    (depth 0.5) raises the pinion FM4 above 6 while the healthy record stays at 3 +/- 1 (Gaussian difference
    signal) and the wheel FM4 stays at 3 +/- 1 for both (the fault is on the pinion)."""
    X, sigs = _batch()
    cfg = FeatureConfig(fs_hz=12800.0, z_pinion=28, z_wheel=37, envelope_band="auto")
    row = signal_features(X[0], cfg, fr_pinion_hz=25.0)
    assert list(row) == list(feature_units(cfg))
    table = extract_features(X, cfg, fr_pinion_hz=25.0)
    assert list(table.columns) == column_names(cfg)
    assert "tsa_pinion_fm4[1]" in table.columns and "raw_rms[m/s^2]" in table.columns
    assert "imf_energy_mean[(m/s^2)^2]" in table.columns
    fm4 = table["tsa_pinion_fm4[1]"].to_numpy()
    assert abs(fm4[0] - 3) < 1 and fm4[1] > 6
    assert np.all(np.abs(table["tsa_wheel_fm4[1]"].to_numpy() - 3) < 1)
    assert np.all(np.isfinite(table.to_numpy()))


def test_parallel_equals_serial_with_eemd():
    """Per-record seeds make the table independent of n_jobs: EEMD (3 trials) table with n_jobs=2 equals n_jobs=1
    exactly; a different root seed changes the IMF features."""
    X, _ = _batch(duration_s=0.25)
    cfg = FeatureConfig(fs_hz=12800.0, z_pinion=28, z_wheel=37, hht_method="eemd", hht_trials=3, seed=5)
    a = extract_features(X, cfg, fr_pinion_hz=25.0, n_jobs=1)
    b = extract_features(X, cfg, fr_pinion_hz=25.0, n_jobs=2)
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    c = extract_features(X, FeatureConfig(**{**cfg.to_dict(), "seed": 6}), fr_pinion_hz=25.0)
    assert not np.array_equal(a["imf_rms[m/s^2]"], c["imf_rms[m/s^2]"])


def test_tacho_and_mesh_phase_speed_sources_match_nominal_at_constant_speed():
    """At constant speed (noise-free record) the tacho- and mesh-phase-driven TSAs give the nominal-speed values of
    the pinion energy ratio and NB4 within 2 % and the mesh line within 0.5 %. (Peak-based FM0/FM4 are not
    compared: half-sample tacho timing jitter smears the 3.5 kHz ring by up to 0.9 rad.)"""
    s = gear_signal_example(fault_depth=0.5, duration_s=1.0, snr_db=None)
    base = dict(fs_hz=12800.0, z_pinion=28, z_wheel=37, hht_method="none")
    nominal = extract_features(s.x[None, :], FeatureConfig(**base), fr_pinion_hz=25.0)
    others = [extract_features(s.x[None, :], FeatureConfig(**base, speed_source="tacho"), tachos=s.tacho[None, :]),
              extract_features(s.x[None, :], FeatureConfig(**base, speed_source="mesh_phase"), fr_pinion_hz=25.0)]
    for other in others:
        for col in ("tsa_pinion_energy_ratio[1]", "tsa_pinion_nb4[1]"):
            assert other[col][0] == pytest.approx(nominal[col][0], rel=0.02)
        assert other["spec_mesh1[m/s^2]"][0] == pytest.approx(nominal["spec_mesh1[m/s^2]"][0], rel=0.005)


def test_sklearn_transformer_and_pandas_output():
    """FeatureExtractor works in a Pipeline (fit is a no-op apart from validation); set_output('pandas') gives the
    name[unit] columns; same numbers as extract_features (exact)."""
    X, _ = _batch(duration_s=0.5)
    cfg = FeatureConfig(fs_hz=12800.0, z_pinion=28, z_wheel=37, hht_method="none")
    fx = FeatureExtractor(cfg, fr_pinion_hz=25.0)
    out = fx.fit(X).set_output(transform="pandas").transform(X)
    assert isinstance(out, pd.DataFrame) and list(out.columns) == column_names(cfg)
    np.testing.assert_array_equal(out.to_numpy(), extract_features(X, cfg, fr_pinion_hz=25.0).to_numpy())
    z = make_pipeline(FeatureExtractor(cfg, fr_pinion_hz=25.0), StandardScaler()).fit_transform(X)
    assert z.shape == (2, len(column_names(cfg)))


def test_config_and_input_errors():
    """Unknown config keys, bad options, a missing speed and a record shorter than one wheel revolution are
    InputErrors naming the field."""
    with pytest.raises(InputError, match="features.hht_mthod"):
        FeatureConfig.from_dict({"fs_hz": 12800.0, "z_pinion": 28, "z_wheel": 37, "hht_mthod": "emd"})
    with pytest.raises(InputError, match="hht_method"):
        FeatureConfig(fs_hz=12800.0, z_pinion=28, z_wheel=37, hht_method="vmd")
    cfg = FeatureConfig(fs_hz=12800.0, z_pinion=28, z_wheel=37, hht_method="none")
    with pytest.raises(InputError, match="fr_pinion_hz"):
        extract_features(np.zeros((1, 12800)), cfg)
    with pytest.raises(InputError, match="wheel revolution"):
        signal_features(np.random.default_rng(0).standard_normal(400), cfg, fr_pinion_hz=25.0)


def test_spectrum_and_envelope_features_ignore_the_records_mean():
    """A record's mean (an accelerometer's bias, a transmission error's static part) carries no line. Lines at the
    wheel's orders 1 and 2 (7.25, 14.5 Hz: 3.6 and 7.2 bins of a 0.5 s record from DC) and an AM mesh tone: the
    spectrum reads the wheel's and the pinion's order 1 at their 0.01 (tolerance 2e-4: Hann leakage of the other
    lines, measured 1.4e-6) and the envelope's order 1 the modulation 0.3 x 0.1 of the mesh tone (Bedrosian's
    theorem; tolerance 5e-4, measured 1.4e-4 with the low lines in the envelope's band), with or without an offset
    of 10; every spec_/env_ feature is the same with the offset (rel 1e-6). Before, the record went in with its
    mean: spec_wheel_order1 read 0.138 (audit t13b: an AM depth of 0.3 read 0.078 with an offset of 2, the offset
    then a carrier of the envelope)."""
    fs, fr_p = 12800.0, 25.0
    fr_w = fr_p * 29 / 100
    t = np.arange(6400) / fs
    x = (0.01 * np.cos(2 * np.pi * fr_w * t) + 0.01 * np.cos(2 * np.pi * fr_p * t)
         + 0.1 * (1 + 0.3 * np.cos(2 * np.pi * fr_p * t + 0.4)) * np.cos(2 * np.pi * 29 * fr_p * t))
    cfg = FeatureConfig(fs_hz=fs, z_pinion=29, z_wheel=100, hht_method="none")
    plain = signal_features(x, cfg, fr_pinion_hz=fr_p)
    offset = signal_features(x + 10.0, cfg, fr_pinion_hz=fr_p)
    for row in (plain, offset):
        assert row["spec_wheel_order1"] == pytest.approx(0.01, abs=2e-4)
        assert row["spec_pinion_order1"] == pytest.approx(0.01, abs=2e-4)
        assert row["env_pinion_order1"] == pytest.approx(0.1 * 0.3, abs=5e-4)
    for k in plain:
        if k.startswith(("spec_", "env_")):
            assert offset[k] == pytest.approx(plain[k], rel=1e-6, abs=1e-12), k
