"""Test-time crops (models/classifier.py, models/representations.py): the batched crop path against a
per-crop reference.

Reference (the oracle below): the per-record, one-segment-at-a-time representation code as it stood
before the crops were batched (``models/representations.py`` at commit 904a59f, ``_one`` and its helpers,
copied unchanged apart from the name), and that commit's prediction loop: one representation and one
network pass per crop, the probabilities summed crop by crop. Tolerances: representations bit for bit (the
batched code runs the same numpy operations per row, so the training inputs are unchanged); predictions
``atol=1e-6`` (float32 round-off: the network sees batches of another size).
"""
import numpy as np
import pytest
import torch
from scipy.signal import resample

from gearpit.errors import InputError
from models.classifier import crop_starts
from models.operating import operating_features
from models.representation_spec import RepresentationSpec
from models.representations import LOG_FLOOR, represent, represent_crops
from models.toy import toy_signal_set
from models.train import TrainConfig, train_cnn

SPECS = {"raw": RepresentationSpec(kind="raw", n_samples=1024),
         "envelope": RepresentationSpec(kind="envelope", n_samples=1024),
         "tsa": RepresentationSpec(kind="tsa", n_revs=4, samples_per_rev=256),
         "order": RepresentationSpec(kind="order", n_revs=4, max_order=30.0),
         "mesh_order": RepresentationSpec(kind="mesh_order", n_mesh_periods=32, max_order=3.0)}


# ------------------------------------------------------------------ the reference (commit 904a59f)


def _normalise(seg: np.ndarray) -> np.ndarray:
    s = seg - seg.mean()
    sd = s.std()
    return s / sd if sd > 0 else s


def _standardise(v: np.ndarray) -> np.ndarray:
    sd = v.std()
    return (v - v.mean()) / sd if sd > 0 else v - v.mean()


def _hann_amplitude(seg: np.ndarray) -> np.ndarray:
    w = np.hanning(seg.size + 1)[:-1]  # periodic Hann
    return 2.0 * np.abs(np.fft.rfft(seg * w)) / w.sum()


def _envelope(seg: np.ndarray) -> np.ndarray:
    n = seg.size
    spec = np.fft.fft(seg)
    gain = np.zeros(n)
    gain[0] = 1.0
    gain[1:(n + 1) // 2] = 2.0
    if n % 2 == 0:
        gain[n // 2] = 1.0
    e = np.abs(np.fft.ifft(spec * gain))
    return e - e.mean()


def _log_on_grid(amp: np.ndarray, bin_units: float, length: int, step: float) -> np.ndarray:
    """Log amplitude interpolated from FFT bins (spacing ``bin_units``) onto ``k * step``, k < length."""
    grid = np.arange(length) * step
    src = np.arange(amp.size) * bin_units
    return _standardise(np.log10(np.interp(grid, src, amp) + LOG_FLOOR))


def _difference_mask(n_orders: int, z_pinion: int) -> np.ndarray:
    """True for the orders kept in the difference signal (not 0-2, not ``m z + {-1, 0, 1}``)."""
    k = np.arange(n_orders)
    near_mesh = np.minimum(k % z_pinion, z_pinion - k % z_pinion) <= 1
    return (k > 2) & ~near_mesh


def _starts(size: int, n_seg: int, start: float, average: bool) -> list[int]:
    """Segment starts: one at ``start`` of the free room, or (``average``) one every half
    segment, the first shifted by ``start`` of at most half a segment."""
    room = size - n_seg
    if not average:
        return [int(np.floor(start * room + 1e-9))]
    hop = max(n_seg // 2, 1)
    first = int(np.floor(start * min(room, hop - 1) + 1e-9))
    return list(range(first, room + 1, hop))


def _mean_amplitude(x: np.ndarray, n_seg: int, starts: list[int], envelope: bool) -> np.ndarray:
    """Root-mean-square over the segments of the Hann amplitude spectrum (of the envelope if asked)."""
    power = 0.0
    for i0 in starts:
        seg = x[i0:i0 + n_seg]
        power = power + _hann_amplitude(_envelope(seg) if envelope else seg - seg.mean()) ** 2
    return np.sqrt(power / len(starts))


def _reference_one(x: np.ndarray, spec: RepresentationSpec, fs_hz: float, shaft_hz: float | None, mesh_cps: float | None,
         start: float, speed_factor: float, z_pinion: int) -> np.ndarray:
    x = _normalise(x.astype(float))
    k = spec.kind
    n_seg = spec.segment_length(fs_hz, shaft_hz, mesh_cps, speed_factor)
    if k == "raw":
        i0 = _starts(x.size, n_seg, start, False)[0]
        seg = x[i0:i0 + n_seg]
        return _normalise(resample(seg, spec.n_samples) if n_seg != spec.n_samples else seg)[None, :]
    if k == "envelope":
        if n_seg != spec.n_samples:  # speed error: stretch the record, then cut as usual
            x = resample(x, int(round(x.size * spec.n_samples / n_seg)))
        amp = _mean_amplitude(x, spec.n_samples, _starts(x.size, spec.n_samples, start, True), True)
        return _standardise(np.log10(amp[:spec.length] + LOG_FLOOR))[None, :]
    if k == "tsa":
        # as many whole revolutions as the record holds, less one (room for the start phase), >= n_revs
        rev = fs_hz / (shaft_hz * speed_factor)
        n_rev = max(spec.n_revs, int(np.floor(x.size / rev)) - 1)
        n_seg = min(int(round(n_rev * rev)), x.size)
        i0 = _starts(x.size, n_seg, start, False)[0]
        spec_c = np.fft.rfft(x[i0:i0 + n_seg])
        # bin j of the segment is shaft order j / (revolutions it holds): keep the integer orders
        bins = np.arange(spec.samples_per_rev // 2 + 1) * (n_seg / rev)
        idx = np.arange(spec_c.size)
        comb = np.interp(bins, idx, spec_c.real, right=0.0) + 1j * np.interp(bins, idx, spec_c.imag, right=0.0)
        avg = np.fft.irfft(comb, n=spec.samples_per_rev)
        diff = np.fft.irfft(comb * _difference_mask(comb.size, z_pinion), n=spec.samples_per_rev)
        # both scaled by the TSA's standard deviation: the difference keeps its level relative to the mesh tone
        sd = avg.std()
        sd = sd if sd > 0 else 1.0
        return np.stack([(avg - avg.mean()) / sd, (diff - diff.mean()) / sd])
    if k == "order":
        # bin j of the segment is shaft order j * (revolutions in the segment)^-1
        unit = 1.0 / (n_seg * (shaft_hz * speed_factor) / fs_hz)
        step = 1.0 / spec.n_revs
    else:
        unit = 1.0 / (n_seg * mesh_cps * speed_factor)
        step = 1.0 / spec.n_mesh_periods
    starts = _starts(x.size, n_seg, start, True)
    a = _log_on_grid(_mean_amplitude(x, n_seg, starts, False), unit, spec.length, step)
    e = _log_on_grid(_mean_amplitude(x, n_seg, starts, True), unit, spec.length, step)
    return np.stack([a, e])


def _reference_represent(d, spec: RepresentationSpec, starts, speed_factors=1.0) -> np.ndarray:
    st = np.broadcast_to(np.asarray(starts, dtype=float), (len(d),))
    sf = np.broadcast_to(np.asarray(speed_factors, dtype=float), (len(d),))
    fr, mc = d.shaft_hz(), d.mesh_cps()
    return np.stack([_reference_one(d.signals[i], spec, d.fs_hz, fr[i], mc[i], st[i], sf[i], d.pair.z_pinion)
                     for i in range(len(d))]).astype(np.float32)


def _reference_predict(model, d, n_crops: int) -> np.ndarray:
    """Severity and teeth probabilities and severity, side by side: one representation and one network
    pass per crop over all records."""
    spec = model.spec
    starts = [0.5] if n_crops == 1 else list(np.linspace(0.0, 1.0, n_crops))
    side = torch.from_numpy(operating_features(d, spec.operating_inputs)) if spec.operating_inputs else None
    p_sev = np.zeros((len(d), len(spec.severity_classes)))
    p_teeth = np.zeros((len(d), len(spec.teeth_classes)))
    sev = np.zeros(len(d))
    model.network.eval()
    with torch.no_grad():
        for st in starts:
            out = model.network(torch.from_numpy(_reference_represent(d, spec.representation_spec(), st)), side)
            p_sev += torch.softmax(out["severity_class"], dim=1).numpy()
            p_teeth += torch.softmax(out["teeth"], dim=1).numpy()
            sev += out["severity"].numpy()
    k = len(starts)
    return np.column_stack([p_sev / k, p_teeth / k, np.clip(sev / k * spec.severity_scale, 0.0, None)])


def _columns(pred) -> np.ndarray:
    return np.column_stack([pred.severity_proba, pred.teeth_proba, pred.severity])


@pytest.fixture(scope="module")
def records():
    """Toy records of 2 s at three speeds, with a random start and speed factor each."""
    d = toy_signal_set(n_per_class=4, duration_s=2.0, seed=3)
    rng = np.random.default_rng(0)
    return d, rng.uniform(0.0, 1.0, len(d)), rng.uniform(0.85, 1.15, len(d))


# ------------------------------------------------------------------ representations


@pytest.mark.parametrize("kind", list(SPECS))
def test_represent_is_bit_identical_to_the_per_record_reference(kind, records):
    """The training inputs (random starts and speed factors) did not change: bit for bit."""
    d, starts, factors = records
    spec = SPECS[kind]
    got = represent(d.signals, spec, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz(), mesh_cps=d.mesh_cps(),
                    z_pinion=d.pair.z_pinion, starts=starts, speed_factors=factors)
    np.testing.assert_array_equal(got, _reference_represent(d, spec, starts, factors))


@pytest.mark.parametrize("kind", list(SPECS))
def test_each_crop_is_bit_identical_to_the_reference_at_its_start(kind, records):
    """``represent_crops(...)[:, c]`` is the reference at start ``crops[c]``, with and without a speed error;
    two equal starts (a segment shared by two crops) included."""
    d, _, factors = records
    spec = SPECS[kind]
    crops = (0.0, 0.25, 0.5, 0.5, 1.0)
    for sf in (1.0, factors):
        got = represent_crops(d.signals, spec, fs_hz=d.fs_hz, crops=crops, shaft_hz=d.shaft_hz(),
                              mesh_cps=d.mesh_cps(), z_pinion=d.pair.z_pinion, speed_factors=sf)
        assert got.shape == (len(d), len(crops), spec.n_channels, spec.length) and got.dtype == np.float32
        for c, st in enumerate(crops):
            np.testing.assert_array_equal(got[:, c], _reference_represent(d, spec, st, sf))
    # the crops do differ (else the test would prove little)
    assert not np.array_equal(got[:, 0], got[:, -1])


def test_bad_crops_are_input_errors(records):
    d, _, _ = records
    for crops in ((), (0.5, 1.5), (-0.1,)):
        with pytest.raises(InputError, match="crops|starts"):
            represent_crops(d.signals, SPECS["order"], fs_hz=d.fs_hz, crops=crops, shaft_hz=d.shaft_hz())
    with pytest.raises(InputError, match="n_crops"):
        crop_starts(0)
    assert crop_starts(1) == (0.5,) and crop_starts(3) == (0.0, 0.5, 1.0)


# ------------------------------------------------------------------ predictions


@pytest.fixture(scope="module")
def separable():
    """Healthy versus severe toy records of 2 s (20 dB SNR): a task a small CNN learns in a few epochs, so
    that its outputs move with the input and 1e-6 is a tight check."""
    classes = (("healthy", 0.0), ("severe", 0.35))
    return (toy_signal_set(n_per_class=24, classes=classes, snr_db=20.0, duration_s=2.0, seed=1),
            toy_signal_set(n_per_class=6, classes=classes, snr_db=20.0, duration_s=2.0, seed=2))


@pytest.mark.parametrize("kind,side", [("tsa", ("speed_rpm",)), ("order", ())])
def test_predict_with_crops_matches_the_per_crop_reference(kind, side, separable):
    """A small trained CNN: 1, 2 and 3 crops, one big and several small batches (a batch smaller than the
    crops of one record included), against one network pass per crop; atol 1e-6."""
    train, test = separable
    cfg = TrainConfig(representation=SPECS[kind], max_epochs=12, patience=12, batch_size=16, learning_rate=3e-3,
                      widths=(8, 16, 16, 24, 32), hidden=32, seed=0, operating_inputs=side)
    model = train_cnn(train, cfg)
    for n_crops in (1, 2, 3):
        ref = _reference_predict(model, test, n_crops)
        for batch_size in (256, 7, 2):
            got = _columns(model.predict(test, n_crops=n_crops, batch_size=batch_size))
            np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6)
    # the crops matter (three crops against one differ by far more than the tolerance)
    assert np.abs(_reference_predict(model, test, 3) - _reference_predict(model, test, 1)).max() > 1e-3
