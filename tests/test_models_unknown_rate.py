"""Tooth counts of an undocumented gearbox from its shaft sidebands (models.unknown_rate.estimate_tooth_count).

The truth is outside the estimator: the tooth counts of the simulated pairs (datagen presets) and of a
constructed modulated carrier; the records are given in cycles per sample (no sampling rate, no speed)."""
import numpy as np
import pytest

from gearpit.errors import InputError
from models.unknown_rate import estimate_tooth_count, tooth_count_scores


def _modulated(z: int, *, mesh_cps: float = 0.0613, n: int = 65536, seed: int = 0) -> np.ndarray:
    """Three mesh harmonics, each modulated once per turn of a ``z``-tooth gear (amplitude 30 %, and a weaker
    second order), in white noise at a tenth of the signal's RMS."""
    k = np.arange(n)
    shaft = 2 * np.pi * mesh_cps / z * k
    am = 1 + 0.3 * np.cos(shaft + 0.4) + 0.1 * np.cos(2 * shaft + 1.1)
    x = am * sum(np.cos(2 * np.pi * h * mesh_cps * k + h) / h for h in (1, 2, 3))
    return x + 0.1 * x.std() * np.random.default_rng(seed).standard_normal(n)


@pytest.mark.parametrize("z", [23, 37, 61])
def test_a_carrier_modulated_once_per_turn_gives_its_tooth_count_not_an_alias(z):
    """The comb of the true spacing wins by several dB over every other count; twice and half the teeth (the
    aliases a plain comb sum cannot tell apart) score lower."""
    x = _modulated(z)
    found, score, runner_up = estimate_tooth_count(x, 0.0613)
    assert found == z
    assert score - runner_up > 6.0
    s = tooth_count_scores(x, 0.0613, z_range=(8, 130))
    assert s[z] > s[2 * z] + 3.0 and (z // 2 < 8 or s[z] > s[z // 2] + 3.0)


@pytest.mark.parametrize("pair, effect, z", [
    ("spur-gds", {"name": "eccentricity_pinion", "amplitude_m": 20e-6}, 29),
    ("spur-gds", {"name": "pitch_error", "grade": 6.0}, 29),
    ("helical-dct", {"name": "pitch_error", "grade": 6.0}, 17),
])
def test_a_simulated_gearbox_gives_the_pinions_tooth_count(pair, effect, z):
    """A housing accelerometer of gearpit's rig (transmission path, noise, a sensor gain), read with the mesh
    frequency in cycles per sample only: the pinion's count, whose sidebands its run-out or pitch errors make.
    (The wheel's count, 60-100, is not resolved from its neighbours in 2 s: that needs about z / 3 of its
    revolutions, the docstring's limit.)"""
    from compare.synthetic import rig_measurement
    from datagen.geometry import preset

    m = rig_measurement([effect], pair=pair, duration_s=2.0, speed_rpm=1000.0)
    assert preset(pair).pinion.teeth == z
    mesh_cps = z * 1000.0 / 60.0 / m.fs_hz
    found, score, runner_up = estimate_tooth_count(m.signal, mesh_cps)
    assert found == z
    assert score - runner_up > 2.0


def test_bad_input_is_refused_before_any_work():
    x = _modulated(31, n=4096)
    with pytest.raises(InputError, match="mesh_cps"):
        estimate_tooth_count(x, 0.7)
    with pytest.raises(InputError, match="z_range"):
        tooth_count_scores(x, 0.0613, z_range=(50, 20))
    with pytest.raises(InputError, match="x"):
        estimate_tooth_count(x[:500], 0.0613)
    with pytest.raises(InputError, match="resolve"):      # 1100 samples: no count's spacing spans 4 bins
        tooth_count_scores(np.random.default_rng(0).standard_normal(1100), 0.0613, z_range=(100, 200))


@pytest.mark.parametrize("rig, z", [
    (dict(z1=31, z2=97, pitch_fp_m=20e-6), 31),
    (dict(z1=23, z2=71, eccentricity_m=(20e-6, 0.0), housing=(3000.0, 0.05)), 23),
])
def test_another_simulators_gearbox_gives_its_pinions_tooth_count(rig, z):
    """The independent textbook simulator of tests/foreign_rig.py at counts neither preset has (a random-walk
    pitch error; a run-out behind a housing mode), 1300 rpm, its own noise and gain."""
    import foreign_rig as fr

    r = fr.ForeignRig(speed_rpm=1300.0, **rig)
    x = fr.simulate_foreign(r)["acc"]
    found, score, runner_up = estimate_tooth_count(x, r.z1 * r.speed_rpm / 60.0 / r.fs_hz)
    assert found == z
    assert score - runner_up > 6.0
