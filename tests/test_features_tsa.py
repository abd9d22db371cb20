"""Angular resampling, time-synchronous averaging and the TSA split (features.tsa)."""
import numpy as np
import pytest
from scipy.interpolate import PchipInterpolator

from features import tsa
from features.synthetic import gear_signal_example
from gearpit.errors import InputError


#: samples the synchronous average leaves out at each end of a record (the upsampling filter's edge effect)
EDGE = tsa.TimeInterpolant.UPSAMPLING_HALF_TAPS


def _tone_tsa_amplitude(order: float, n_rev: int, n_per_rev: int = 256) -> float:
    """Amplitude of a unit tone at a (possibly non-integer) shaft order after TSA, by least squares (a record of
    ``n_rev`` revolutions plus the two edges the average skips)."""
    fr = 16.0
    fs = fr * n_per_rev
    t = np.arange(n_rev * n_per_rev + 2 * EDGE) / fs
    x = np.cos(2 * np.pi * order * fr * t + 0.3)
    track = tsa.angle_track_constant_speed(x.size, fs, fr)
    avg = tsa.synchronous_average(x, fs, track, samples_per_rev=n_per_rev)
    assert avg.n_revolutions == n_rev
    avg = avg.average
    theta = 2 * np.pi * np.arange(n_per_rev) / n_per_rev
    basis = np.column_stack([np.cos(order * theta), np.sin(order * theta)])
    coef, *_ = np.linalg.lstsq(basis, avg, rcond=None)
    return float(np.hypot(*coef))


def test_non_synchronous_tone_follows_comb_filter():
    """A tone at order k + delta is scaled by |sin(pi R delta) / (R sin(pi delta))| (McFadden 1987);
    R = 16 revolutions, fs / fr integer; tol 3e-5 (resampling filter ripple ~1e-5 and edge samples)."""
    R = 16
    for delta in (0.1, 0.25, 0.5, 0.73):
        expected = abs(np.sin(np.pi * R * delta) / (R * np.sin(np.pi * delta)))
        assert _tone_tsa_amplitude(5 + delta, R) == pytest.approx(expected, abs=3e-5)
    assert _tone_tsa_amplitude(5.0, R) == pytest.approx(1.0, abs=3e-5)  # synchronous: kept


def test_non_synchronous_tone_attenuated_by_one_over_sqrt_revolutions():
    """Power gain of TSA averaged over the tone's offset delta in (0, 1) is 1/R exactly (a midpoint grid of
    M >= R points integrates the Fejer kernel exactly), i.e. amplitude ~ 1/sqrt(R); measured, tol 1 %."""
    R = 16
    deltas = (np.arange(R) + 0.5) / R
    power = np.mean([_tone_tsa_amplitude(7 + d, R) ** 2 for d in deltas])
    assert np.sqrt(power) == pytest.approx(1 / np.sqrt(R), rel=0.01)


def test_white_noise_rms_falls_as_one_over_sqrt_revolutions():
    """TSA of white noise over R = 64 revolutions has RMS sigma / sqrt(R) (McFadden 1987); tol 10 %, seeded."""
    fs, fr, n_per_rev, R = 4096.0, 16.0, 256, 64
    x = np.random.default_rng(5).standard_normal(R * n_per_rev + 2 * EDGE)
    avg = tsa.synchronous_average(x, fs, tsa.angle_track_constant_speed(x.size, fs, fr), samples_per_rev=n_per_rev)
    assert avg.n_revolutions == R
    assert np.std(avg.average) == pytest.approx(1 / np.sqrt(R), rel=0.10)


def test_synchronous_tone_survives_non_integer_resampling():
    """fr = 23.7 Hz at fs = 12.8 kHz (540.08 samples/rev, resampled to 1024): orders 28 and 84 keep amplitude
    1 and 0.3 within 2e-3 (polyphase x4 + cubic-spline interpolation error)."""
    fs, fr = 12800.0, 23.7
    t = np.arange(12800) / fs
    x = np.cos(2 * np.pi * 28 * fr * t) + 0.3 * np.sin(2 * np.pi * 84 * fr * t)
    n = tsa.default_samples_per_rev(fs, fr)
    assert n == 1024
    avg = tsa.synchronous_average(x, fs, tsa.angle_track_constant_speed(x.size, fs, fr), samples_per_rev=n)
    amp = tsa.order_amplitudes(avg.average)
    assert amp[28] == pytest.approx(1.0, abs=2e-3)
    assert amp[84] == pytest.approx(0.3, abs=2e-3)


def test_tacho_and_mesh_phase_tracks_follow_speed_fluctuation():
    """Pinion speed fluctuating +/-1 % at 2 Hz: TSA from the tacho or from the mesh phase keeps the mesh tone
    (amplitude 1) within 3 %; the nominal-speed TSA smears it below 0.5 (it is what angular resampling is for)."""
    s = gear_signal_example(speed_fluctuation=0.01, snr_db=None, runout=0.0, mesh_amplitudes=(1.0,))
    n = tsa.default_samples_per_rev(s.fs_hz, s.fr_pinion_hz)
    tracks = {
        "tacho": tsa.angle_track_from_tacho(s.tacho, s.fs_hz),
        "mesh": tsa.angle_track_from_mesh_phase(s.x, s.fs_hz, mesh_order=28, shaft_hz_nominal=s.fr_pinion_hz,
                                                half_band_hz=12.0),
        "nominal": tsa.angle_track_constant_speed(s.x.size, s.fs_hz, s.fr_pinion_hz),
    }
    amp = {k: tsa.order_amplitudes(tsa.synchronous_average(s.x, s.fs_hz, tr, samples_per_rev=n).average)[28]
           for k, tr in tracks.items()}
    assert amp["tacho"] == pytest.approx(1.0, abs=0.03)
    assert amp["mesh"] == pytest.approx(1.0, abs=0.03)
    assert amp["nominal"] < 0.5


def test_tacho_pulse_times_are_sub_sample_accurate():
    """Rising edges of a sampled sine 'tacho' at 10.3 Hz are found within 1e-3 sample periods of k / f."""
    fs, f = 1000.0, 10.3
    t = np.arange(2000) / fs
    from features.tacho import tacho_pulse_times

    times = tacho_pulse_times(np.sin(2 * np.pi * f * t), fs, threshold=0.0)
    expected = np.arange(1, times.size + 1) / f
    assert np.max(np.abs(times - expected)) < 1e-3 / fs * 10  # linear interpolation of a sine near zero


def test_split_tsa_separates_regular_residual_difference():
    """Order-domain split (Lebold 2000): with z = 16, N = 256 and components at orders 1 (shaft), 16, 32 (mesh),
    15, 17 (first sidebands) and 7 (fault), residual = sidebands + order 7, difference = order 7,
    regular = orders 1, 15, 16, 17, 32; tol 1e-12."""
    th = 2 * np.pi * np.arange(256) / 256
    shaft, mesh = 0.3 * np.cos(th), np.cos(16 * th) + 0.5 * np.cos(32 * th)
    sb, fault = 0.2 * np.cos(15 * th) + 0.1 * np.sin(17 * th), 0.25 * np.cos(7 * th)
    parts = tsa.split_tsa(2.0 + shaft + mesh + sb + fault, 16, n_shaft_orders=2, n_sideband_orders=1)
    np.testing.assert_allclose(parts.residual, sb + fault, atol=1e-12)
    np.testing.assert_allclose(parts.difference, fault, atol=1e-12)
    np.testing.assert_allclose(parts.regular, shaft + mesh + sb, atol=1e-12)


def test_bad_tracks_and_short_records_raise():
    """A shaft turning backwards, or a record shorter than one revolution, is an InputError."""
    with pytest.raises(InputError):
        tsa.AngleTrack(np.array([0.0, 1.0]), np.array([1.0, 0.0]))
    x = np.zeros(100)
    with pytest.raises(InputError):
        tsa.angular_resample(x, 1000.0, tsa.angle_track_constant_speed(100, 1000.0, 5.0), samples_per_rev=64)


def _wheel_comb(t, z1=19, fr=25.0, ratio=19 / 67):
    """Mesh harmonics 1-4 of a 19-tooth pinion at 25 Hz with wheel-rate sidebands: periodic in the wheel angle."""
    ph = np.random.default_rng(2).uniform(0, 2 * np.pi, 40)
    x = np.zeros_like(t)
    for m in range(1, 5):
        x += np.cos(2 * np.pi * m * z1 * fr * t + ph[m]) / m
        for k in (-2, -1, 1, 2):
            x += 0.02 / m * np.cos(2 * np.pi * (m * z1 * fr + k * fr * ratio) * t + ph[10 + 4 * m + k])
    return x


@pytest.mark.parametrize("dc", [0.0, 10.0])
def test_skip_edges_keeps_the_upsampling_filters_edge_out_of_the_average(dc):
    """The upsampling filter takes the record as zero outside it, so the first and last UPSAMPLING_HALF_TAPS samples
    ring in proportion to the record's end values; ``skip_edges`` starts and ends the revolutions that far inside.

    Reference: the exact average of a line comb periodic in the wheel angle (14 wheel revolutions of 2 s at
    12.8 kHz) from the time the resampling starts. Tolerances: 2e-4 of the RMS with the edges skipped, whatever the
    record's mean (measured 5e-5 without a mean); without skipping, a mean of 10 x the RMS puts >= 1e-2 into the
    average's first samples (measured 0.038)."""
    fs, fr, ratio, n_per_rev = 12800.0, 25.0, 19 / 67, 2048
    t = np.arange(int(2.0 * fs) + 1) / fs
    x = _wheel_comb(t) + dc
    wheel = tsa.AngleTrack(np.array([0.0, t[-1]]), np.array([0.0, 2 * np.pi * fr * ratio * t[-1]]))
    rec = tsa.TimeInterpolant(x, fs, oversample=2)
    assert rec.edge_s == pytest.approx(tsa.TimeInterpolant.UPSAMPLING_HALF_TAPS / fs)
    rms = _wheel_comb(t).std()
    for skip, start_s in ((True, rec.edge_s), (False, 0.0)):
        revs = rec.resample(wheel, samples_per_rev=n_per_rev, skip_edges=skip)
        exact = _wheel_comb(start_s + np.arange(n_per_rev) / n_per_rev / (fr * ratio)) + dc
        err = np.abs(revs.mean(axis=0) - exact).max() / rms
        if skip:
            assert err < 2e-4
            # the last revolution ends before the last UPSAMPLING_HALF_TAPS samples
            a0, a1 = tsa.usable_angle_span(wheel, rec.edge_s)
            assert revs.shape[0] == int(np.floor((a1 - a0) / (2 * np.pi) + 1.0 / n_per_rev + 1e-9))
            assert a1 == pytest.approx(2 * np.pi * fr * ratio * (t[-1] - rec.edge_s))
        elif dc:
            assert err > 1e-2


def test_usable_angle_span_inverts_the_tracks_time_interpolation():
    """On a track with a varying speed, the span's ends are the angles whose PCHIP times are the margins (to 1e-12 s):
    the resampling starts exactly ``margin_s`` after the first time."""
    t = np.linspace(0.0, 1.0, 33)
    track = tsa.AngleTrack(t, 2 * np.pi * (20.0 * t + 0.3 * np.sin(2 * np.pi * 3 * t)))
    a0, a1 = tsa.usable_angle_span(track, 0.01)
    time_of = PchipInterpolator(track.angle_rad, track.time_s)
    assert float(time_of(a0)) == pytest.approx(0.01, abs=1e-12)
    assert float(time_of(a1)) == pytest.approx(0.99, abs=1e-12)
    with pytest.raises(InputError, match="track"):
        tsa.usable_angle_span(track, 0.6)


def test_feature_table_tsa_indicators_ignore_a_sensor_offset():
    """An accelerometer's bias carries nothing of the gears. The feature table takes the record's mean off before
    its synchronous averages, so the TSA indicators of a healthy noise-free record with an offset of 20 x its RMS
    equal those without (to 1e-6 relative; measured 4e-12). Without that the upsampling filter's ring at the
    record's ends, in proportion to the offset, lands in the averages' first samples (checked: the wheel TSA's
    energy ratio then moves by a factor 10, NA4 by 29 %, M8A by 5 %)."""
    from features.table import FeatureConfig, signal_features

    s = gear_signal_example(fault_depth=0.0, duration_s=1.0, snr_db=None)
    cfg = FeatureConfig(fs_hz=12800.0, z_pinion=28, z_wheel=37, hht_method="none")
    a = signal_features(s.x, cfg, fr_pinion_hz=25.0)
    b = signal_features(s.x + 20.0 * s.x.std(), cfg, fr_pinion_hz=25.0)
    keys = [k for k in a if k.startswith("tsa_")]
    assert len(keys) >= 10
    for k in keys:
        assert b[k] == pytest.approx(a[k], rel=1e-6, abs=1e-12), k


def test_wheel_average_of_a_mesh_comb_has_no_edge_ring():
    """A record of pure mesh harmonics (29-tooth pinion at 25 Hz, 100-tooth wheel, 0.5 s at 12.8 kHz: 3.6 wheel
    revolutions) is periodic in the wheel angle with only orders 100 and 200, so the wheel average's difference
    signal (Lebold et al. 2000: TSA less mean, shaft orders 1-2, mesh harmonics and first sidebands) is zero
    analytically; measured 3.5e-6 of the mesh amplitude (spline interpolation error), tolerance 1e-4. With
    1e-3 white noise (seeded) the difference signal is Gaussian, so FM4 (its kurtosis) is 3; tolerance 0.6,
    > 5 standard errors of a kurtosis estimate from 2048 samples (sqrt(24 / 2048) = 0.11). The upsampling filter's
    ring at the record's ends, averaged in (before: no edge skipped), gave a difference signal of 2.3e-2 and
    FM4 230; the feature table's tsa_wheel_fm4 is the same quantity (230.6 before)."""
    from features import indicators
    from features.table import FeatureConfig, signal_features

    fs, zp, zw, fr_p = 12800.0, 29, 100, 25.0
    fr_w = fr_p * zp / zw
    t = np.arange(int(0.5 * fs)) / fs
    th = 2 * np.pi * fr_p * t
    x = np.cos(zp * th + 0.7) + 0.5 * np.cos(2 * zp * th + 0.2)
    noisy = x + 1e-3 * np.random.default_rng(0).standard_normal(t.size)
    n = tsa.default_samples_per_rev(fs, fr_w)
    track = tsa.angle_track_constant_speed(t.size, fs, fr_w)
    avg = tsa.synchronous_average(x, fs, track, samples_per_rev=n)
    # the whole revolutions between the skipped edges: floor((3200 - 1 - 40) / 1765.5)
    assert avg.n_revolutions == 3
    assert np.abs(tsa.split_tsa(avg.average, zw).difference).max() < 1e-4
    fm4 = indicators.gear_condition_indicators(
        tsa.synchronous_average(noisy, fs, track, samples_per_rev=n).average, zw)["fm4"]
    assert fm4 == pytest.approx(3.0, abs=0.6)
    row = signal_features(noisy, FeatureConfig(fs_hz=fs, z_pinion=zp, z_wheel=zw, hht_method="none"),
                          fr_pinion_hz=fr_p)
    assert row["tsa_wheel_fm4"] == pytest.approx(3.0, abs=0.6)
    assert row["tsa_pinion_fm4"] == pytest.approx(3.0, abs=0.6)
