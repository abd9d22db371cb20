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
