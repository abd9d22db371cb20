"""Classifiers' input representations (models/representations.py, models/tsa.py, models/order_filters.py): order
and envelope spectra, the TSA and its difference signal, the order filters, shaft-line removal, normalisation."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from gearpit.errors import InputError
from models.data import PairInfo, SignalSet
from models.representation_spec import RepresentationSpec
from models.representations import represent
from models.toy import toy_signal_set

SMALL_REP = RepresentationSpec(kind="order", n_revs=4, max_order=30.0)

# ------------------------------------------------------------------ representations


def _tone_set(order: float, speed_rpm: float, fs_hz: float, n: int = 8192) -> SignalSet:
    t = np.arange(n) / fs_hz
    x = np.cos(2 * np.pi * order * speed_rpm / 60.0 * t)[None, :]
    return SignalSet(x, fs_hz, PairInfo("toy", 13, 29), pd.DataFrame({"speed_rpm": [speed_rpm]}))


@pytest.mark.parametrize("speed_rpm,fs_hz", [(900.0, 4096.0), (1500.0, 4096.0), (1200.0, 8192.0)])
def test_order_spectrum_peak_at_the_tone_order_for_any_speed_and_fs(speed_rpm, fs_hz):
    """A pure tone at shaft order 13 peaks at grid index 13 * n_revs whatever the speed and sampling rate
    (order tracking, Randall 2011 s. 3.6); exact index."""
    d = _tone_set(13.0, speed_rpm, fs_hz)
    r = represent(d.signals, SMALL_REP, fs_hz=fs_hz, shaft_hz=d.shaft_hz())
    assert r.shape == (1, 2, 120)
    assert int(np.argmax(r[0, 0])) == 13 * SMALL_REP.n_revs


def test_mesh_order_axis_needs_only_cycles_per_sample():
    """mesh_order: a tone at twice the mesh frequency peaks at index 2 * n_mesh_periods, for a record given
    only its mesh frequency in cycles/sample (fs set to 1); exact index."""
    spec = RepresentationSpec(kind="mesh_order", n_mesh_periods=64, max_order=4.0)
    k = np.arange(8192)
    x = np.cos(2 * np.pi * 2 * 0.0741 * k)[None, :]
    r = represent(x, spec, fs_hz=1.0, mesh_cps=0.0741)
    assert r.shape == (1, 2, 256) and int(np.argmax(r[0, 0])) == 128


def test_speed_factor_moves_the_order_axis():
    """With speed factor s the representation assumes a speed s times the label: a tone at order 12
    appears at order 12 / s (s = 1.2 -> order 10, index 40); exact index."""
    d = _tone_set(12.0, 1200.0, 4096.0)
    r = represent(d.signals, SMALL_REP, fs_hz=4096.0, shaft_hz=d.shaft_hz(), speed_factors=1.2)
    assert int(np.argmax(r[0, 0])) == 40


def test_envelope_order_channel_sees_the_modulation_order():
    """AM tone (carrier order 20, modulation at shaft order 1, depth 0.5): the envelope channel peaks at
    order 1 (Bedrosian; envelope = 1 + 0.5 cos theta), index n_revs; exact index."""
    fs, fr = 4096.0, 16.0
    t = np.arange(8192) / fs
    x = (1 + 0.5 * np.cos(2 * np.pi * fr * t)) * np.cos(2 * np.pi * 20 * fr * t)
    r = represent(x[None, :], SMALL_REP, fs_hz=fs, shaft_hz=fr)
    assert int(np.argmax(r[0, 1, 2:])) + 2 == SMALL_REP.n_revs


def test_tsa_keeps_the_synchronous_waveform_and_rejects_noise():
    """TSA over 16 revolutions of (order-3 tone + white noise of equal power): correlation with the tone
    > 0.95 (noise power reduced ~16x: expected correlation ~ sqrt(16/17) = 0.97)."""
    fs, fr = 4096.0, 16.0
    n = 4096
    t = np.arange(n) / fs
    tone = np.cos(2 * np.pi * 3 * fr * t)
    x = tone + np.random.default_rng(0).standard_normal(n) * np.sqrt(0.5)
    spec = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256)
    avg = represent(x[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=13)[0, 0]
    ref = np.cos(3 * 2 * np.pi * np.arange(256) / 256)
    assert np.corrcoef(avg, ref)[0, 1] > 0.95


def test_tsa_difference_channel_drops_mesh_harmonics_and_keeps_the_rest():
    """Difference signal (Lebold et al. 2000): orders 0-2 and m z + {-1, 0, 1} removed. For z = 13, a record of
    orders 1, 12, 13, 14, 26 leaves nothing (max |diff| < 1e-9 of the TSA scale), while an added order-7 tone
    passes unchanged (channel 1 equals the order-7 part of channel 0, atol 1e-9)."""
    fs, fr, z = 4096.0, 16.0, 13
    t = np.arange(4096) / fs
    mesh = sum(np.cos(2 * np.pi * k * fr * t + 0.1 * k) for k in (1, 12, 13, 14, 26))
    spec = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256)
    r = represent(mesh[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=z)[0]
    assert np.abs(r[1]).max() < 1e-9
    tone = 0.3 * np.cos(2 * np.pi * 7 * fr * t)
    r2 = represent((mesh + tone)[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=z)[0]
    scale = (mesh + tone)[:256].std()  # channels are scaled by the TSA's standard deviation
    theta = 2 * np.pi * np.arange(256) / 256
    np.testing.assert_allclose(r2[1], 0.3 * np.cos(7 * theta) / scale, atol=1e-9)


def test_tsa_lowpass_keeps_orders_below_the_cutoff_and_removes_those_above():
    """lowpass_mesh_orders = 2, z = 13: orders <= 0.75 * 26 = 19.5 pass with gain 1, orders >= 26 are removed,
    and the roll-off is the cosine 0.5 (1 + cos(pi (k - 19.5) / 6.5)) (order 23: 0.5 (1 + cos(pi 3.5 / 6.5))).
    Record = orders 5 + 23 + 40; the low-passed TSA equals 5 + g(23) 23 (atol 1e-9 of the TSA scale)."""
    fs, fr, z = 4096.0, 16.0, 13
    t = np.arange(4096) / fs
    x = sum(np.cos(2 * np.pi * k * fr * t + 0.2 * k) for k in (5, 23, 40))
    spec = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256, lowpass_mesh_orders=2.0)
    avg = represent(x[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=z)[0, 0]
    theta = 2 * np.pi * np.arange(256) / 256
    g23 = 0.5 * (1 + np.cos(np.pi * 3.5 / 6.5))
    kept = np.cos(5 * theta + 1.0) + g23 * np.cos(23 * theta + 4.6)
    np.testing.assert_allclose(avg, kept / kept.std(), atol=1e-9)
    # no low-pass (the default): bit-identical to the spec without the field
    plain = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256)
    assert np.array_equal(represent(x[None, :], plain, fs_hz=fs, shaft_hz=fr, z_pinion=z),
                          represent(x[None, :], replace(spec, lowpass_mesh_orders=0.0), fs_hz=fs, shaft_hz=fr,
                                    z_pinion=z))


def test_tsa_integrated_twice_is_the_angle_integral_of_the_synchronous_average():
    """integrate = 2: the record's orders 5, 13 (mesh, z = 13) and 23 come out divided by -(k^2) (the second
    integral over the angle of cos(k theta + p) is -cos(k theta + p) / k^2, calculus); orders 1-2 dropped (the
    shafts' once- and twice-per-revolution content the integration would raise above the rest). The difference
    channel is the integrated order-5 and order-23 content (mesh harmonic and its first sidebands dropped as in
    Lebold et al. 2000). atol 1e-9 of the TSA scale."""
    fs, fr, z = 4096.0, 16.0, 13
    t = np.arange(4096) / fs
    parts = {1: 4.0, 2: 2.0, 5: 1.0, 13: 3.0, 23: 0.5}
    x = sum(a * np.cos(2 * np.pi * k * fr * t + 0.2 * k) for k, a in parts.items())
    spec = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256, integrate=2)
    r = represent(x[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=z)[0]
    theta = 2 * np.pi * np.arange(256) / 256
    expect = {k: -a * np.cos(k * theta + 0.2 * k) / k ** 2 for k, a in parts.items() if k > 2}
    avg = sum(expect.values())
    np.testing.assert_allclose(r[0], avg / avg.std(), atol=1e-9)
    np.testing.assert_allclose(r[1], (expect[5] + expect[23]) / avg.std(), atol=1e-9)
    # once integrated: order k divided by i k, i.e. cos -> sin / k
    r1 = represent(x[None, :], replace(spec, integrate=1), fs_hz=fs, shaft_hz=fr, z_pinion=z)[0]
    once = sum(a * np.sin(k * theta + 0.2 * k) / k for k, a in parts.items() if k > 2)
    np.testing.assert_allclose(r1[0], once / once.std(), atol=1e-9)


@pytest.mark.parametrize("kind,value", [("tsa", 3), ("tsa", -1), ("tsa", 1.5), ("tsa", True), ("order", 2)])
def test_tsa_integration_bad_values_are_refused(kind, value):
    """integrate outside 0-2, not an integer, or on a representation other than the TSA: InputError naming the
    field."""
    with pytest.raises(InputError, match="integrate"):
        RepresentationSpec(kind=kind, integrate=value)


def _encoder_like_record(fs=4096.0, fr=16.0, n=8192):
    """Pinion order 1 (10 units) + wheel order 1 at pinion order 29/100 (30 units) + order 7 (1 unit): what a
    transmission error measured with eccentric encoders looks like to a tooth-fault detector."""
    t = np.arange(n) / fs
    big = 10 * np.cos(2 * np.pi * fr * t + 0.4) + 30 * np.cos(2 * np.pi * 0.29 * fr * t - 1.0)
    return big, np.cos(2 * np.pi * 7 * fr * t + 0.2), fs, fr


def test_tsa_highpass_removes_both_shafts_once_per_revolution_lines():
    """highpass_orders = 2.5: the TSA of (pinion order 1 x10 + wheel order 1 x30 + order 7 x1) is the order-7 tone
    (correlation > 0.9999; the 8th-order zero-phase high-pass takes 64 dB off order 1 and > 140 dB off order 0.29,
    and passes order 7 within 0.01 dB); without it the order-7 tone is under 5 % of the TSA's variance."""
    big, tone, fs, fr = _encoder_like_record()
    spec = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256, highpass_orders=2.5)
    avg = represent((big + tone)[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=13)[0, 0]
    ref = np.cos(7 * 2 * np.pi * np.arange(256) / 256 + 0.2)
    assert np.corrcoef(avg, ref)[0, 1] > 0.9999
    plain = represent((big + tone)[None, :], replace(spec, highpass_orders=0.0), fs_hz=fs, shaft_hz=fr,
                      z_pinion=13)[0, 0]
    assert np.corrcoef(plain, ref)[0, 1] ** 2 < 0.05


def test_signal_rms_hp_is_the_level_without_the_shaft_lines():
    """signal_rms_hp of (pinion order 1 x10 + wheel order 1 x30 + order 7 x1) is the order-7 tone's RMS 1/sqrt(2)
    (within 1 %: the filter's edge transients over the first and last 1/25 s); signal_rms is 23 times that."""
    from models.operating import fit_operating, _column

    big, tone, fs, fr = _encoder_like_record()
    d = SignalSet((big + tone)[None, :], fs, PairInfo("toy", 13, 29), pd.DataFrame({"speed_rpm": [fr * 60.0]}))
    assert _column(d, "signal_rms_hp")[0] == pytest.approx(1 / np.sqrt(2), rel=0.01)
    assert _column(d, "signal_rms")[0] > 20 * _column(d, "signal_rms_hp")[0]
    assert fit_operating(d, ["signal_rms_hp"])["columns"] == ["signal_rms_hp"]


def test_remove_shaft_1x_takes_out_both_shafts_lines_and_keeps_their_neighbours():
    """remove_shaft_1x (z = 13 / 29, wheel line at pinion order 13/29 = 0.448): the TSA of (pinion order 1 x10 +
    wheel order 1 x30 + order 2 x0.3 + order 7 x1) equals that of (order 2 x0.3 + order 7 x1) within 1e-3 of its
    unit scale (the wheel line makes 14.3 cycles in the record, so its regressors are orthogonal to the kept tones
    only to ~1/(pi 1.55 32) = 0.6 %, times their small share of the fit), while without the removal the two
    differ by more than 1: the least-squares sinusoids remove the two lines and leave order 2, which a high-pass
    at 2.5 orders takes away (the low orders of a pit's dip)."""
    fs, fr, n = 4096.0, 16.0, 8192
    t = np.arange(n) / fs
    lines = 10 * np.cos(2 * np.pi * fr * t + 0.4) + 30 * np.cos(2 * np.pi * 13 / 29 * fr * t - 1.0)
    keep = 0.3 * np.cos(2 * np.pi * 2 * fr * t + 0.7) + np.cos(2 * np.pi * 7 * fr * t + 0.2)
    spec = RepresentationSpec(kind="tsa", n_revs=16, samples_per_rev=256, remove_shaft_1x=True)
    got = represent((lines + keep)[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=13, z_wheel=29)
    want = represent(keep[None, :], replace(spec, remove_shaft_1x=False), fs_hz=fs, shaft_hz=fr, z_pinion=13)
    np.testing.assert_allclose(got, want, atol=1e-3)
    plain = represent((lines + keep)[None, :], replace(spec, remove_shaft_1x=False), fs_hz=fs, shaft_hz=fr,
                      z_pinion=13)
    assert np.abs(plain - want).max() > 1.0
    with pytest.raises(InputError, match="z_wheel"):
        represent((lines + keep)[None, :], spec, fs_hz=fs, shaft_hz=fr, z_pinion=13)


@pytest.mark.parametrize("n", [12800, 12799, 40])
def test_remove_shaft_lines_is_the_least_squares_fit_of_numpy(n):
    """models.order_filters.remove_shaft_lines (normal equations on regressors built from block phasors) equals the
    residual of numpy's lstsq on cos/sin columns built sample by sample, to 1e-12 of the record's scale."""
    from models.order_filters import remove_shaft_lines

    rng = np.random.default_rng(n)
    fs, freqs = 12800.0, (16.7, 4.85)
    t = np.arange(n) / fs
    x = rng.standard_normal(n) + 3.0 * np.sin(2 * np.pi * 16.7 * t + 0.4) + 2.0 * np.cos(2 * np.pi * 4.85 * t)
    a = np.column_stack([np.ones(n)] + [g(2 * np.pi * f * t) for f in freqs for g in (np.cos, np.sin)])
    coef, *_ = np.linalg.lstsq(a, x, rcond=None)
    np.testing.assert_allclose(remove_shaft_lines(x, fs, freqs), x - a @ coef, atol=1e-12 * np.abs(x).max())


def test_signal_rms_no1x_is_the_level_without_the_two_shaft_lines():
    """signal_rms_no1x of (pinion order 1 x10 + wheel order 1 x30 + order 7 x1) on a 13/29 pair is the order-7
    tone's RMS 1/sqrt(2) within 1e-3 (least-squares removal; see the test above for the small non-orthogonality);
    the plain RMS is 22 times larger."""
    from models.operating import _column

    fs, fr, n = 4096.0, 16.0, 8192
    t = np.arange(n) / fs
    x = (10 * np.cos(2 * np.pi * fr * t + 0.4) + 30 * np.cos(2 * np.pi * 13 / 29 * fr * t - 1.0)
         + np.cos(2 * np.pi * 7 * fr * t + 0.2))
    d = SignalSet(x[None, :], fs, PairInfo("toy", 13, 29), pd.DataFrame({"speed_rpm": [fr * 60.0]}))
    assert _column(d, "signal_rms_no1x")[0] == pytest.approx(1 / np.sqrt(2), abs=1e-3)
    assert _column(d, "signal_rms")[0] > 20 / np.sqrt(2)


@pytest.mark.parametrize("field", ["lowpass_mesh_orders", "highpass_orders"])
@pytest.mark.parametrize("kind,value", [("tsa", -1.0), ("tsa", float("nan")), ("order", 2.0)])
def test_tsa_order_filter_bad_values_are_refused(field, kind, value):
    """A negative or NaN cut-off, or a cut-off on a representation without order filters: InputError naming
    the field."""
    with pytest.raises(InputError, match=field):
        RepresentationSpec(kind=kind, **{field: value})


def test_representations_are_normalised_per_signal():
    """Per-signal normalisation: a record scaled by 1000 gives the same representation (rtol 1e-4)."""
    d = toy_signal_set(n_per_class=1, seed=3)
    for kind in ("raw", "envelope", "tsa", "order"):
        spec = RepresentationSpec(kind=kind, n_samples=1024, n_revs=4, samples_per_rev=128, max_order=30.0)
        a = represent(d.signals, spec, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz(), z_pinion=13)
        b = represent(d.signals * 1000.0, spec, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz(), z_pinion=13)
        np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-4)
