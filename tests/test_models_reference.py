"""Models that read a record against a healthy reference of the same machine (``reference = true``).

Checked against what a reference must do by construction (Randall 2011, chapter 5, spectrum comparison):
anything linear the machine adds to record and reference alike (sensor gain, mounting resonance) cancels in the
log ratio; a record of the healthy machine reads ~0 at every order with content; a fault raises its sidebands.
And against the problem it exists for: toy machines whose own tooth-to-tooth deviations are as strong as a fault
(``models.toy.toy_machines_with_references``), where a model without the reference cannot tell them apart.
"""
import numpy as np
import pandas as pd
import pytest

from gearpit.errors import InputError
from models.augment import path_filter
from models.data import SignalSet
from models.io import load_model, save_model
from models.representation_spec import RepresentationSpec
from models.representations import REFERENCE_CLIP, represent
from models.toy import toy_machines_with_references
from models.train import TrainConfig, train_cnn

REF = RepresentationSpec(kind="order", n_revs=8, max_order=30.0, reference=True)


def _config(rep: RepresentationSpec) -> TrainConfig:
    return TrainConfig(representation=rep, max_epochs=20, patience=20, batch_size=16, learning_rate=3e-3,
                       widths=(8, 16, 16, 24, 32), hidden=32, seed=0, task="binary")


@pytest.fixture(scope="module")
def machines():
    """60 training machines and 30 other ones for the test, each record with its reference."""
    return toy_machines_with_references(n_machines=60, seed=1), toy_machines_with_references(n_machines=30, seed=2)


@pytest.fixture(scope="module")
def referenced(machines):
    return train_cnn(machines[0], _config(REF))


def _content(rep_ref: np.ndarray, fraction: float = 0.2) -> np.ndarray:
    """Bins of the reference's strongest ``fraction`` (orders with content, not the noise floor)."""
    return rep_ref >= np.quantile(rep_ref, 1.0 - fraction)


def test_gain_and_mounting_resonance_of_the_machine_cancel(machines):
    """The same gain (x7) and mounting resonance (at shaft order 20, 3 %) applied to record and reference: the referenced
    representation moves by < 0.03 decades (median) at the orders with content, where the plain one would
    follow the resonance (tolerance: the two noise draws' different leakage)."""
    d = machines[1]
    i = int(np.nonzero(d.labels["severity_class"].to_numpy() == "damaged")[0][0])
    rec, ref = d.signals[i].astype(float), d.reference[i].astype(float)
    fr = d.shaft_hz()[i]
    # a resonance at shaft order 20, between the first two mesh harmonics (13, 26)
    moved = [7.0 * path_filter(v[None, :], d.fs_hz, 20.0 * fr, 0.03)[0] for v in (rec, ref)]
    a = represent(np.concatenate([rec, ref])[None], REF, fs_hz=d.fs_hz, shaft_hz=fr)[0]
    b = represent(np.concatenate(moved)[None], REF, fs_hz=d.fs_hz, shaft_hz=fr)[0]
    plain = RepresentationSpec(kind="order", n_revs=8, max_order=30.0)
    base = represent(ref[None], plain, fs_hz=d.fs_hz, shaft_hz=fr)[0, 0]
    keep = _content(base)
    assert np.median(np.abs(a[0, keep] - b[0, keep])) < 0.03
    # the resonance itself moves the record's own spectrum by far more than that
    ra = represent(rec[None], plain, fs_hz=d.fs_hz, shaft_hz=fr)[0, 0]
    rb = represent(moved[0][None], plain, fs_hz=d.fs_hz, shaft_hz=fr)[0, 0]
    assert np.median(np.abs(ra[keep] - rb[keep])) > 0.1


def test_healthy_record_reads_near_zero_and_a_fault_raises_its_sidebands(machines):
    """Healthy against its own machine: |log ratio| < 0.1 decade (median over the orders with content: two
    noise draws); damaged: the sidebands of the first mesh harmonic (orders 13 +/- k, k = 1..6) change by
    > 0.1 decade on average (up or down: the fault adds to sidebands the machine's own deviations already
    make), against < 0.03 for the healthy records (measured 0.157 vs 0.008); every value within the clip."""
    d = machines[1]
    lab = d.labels["severity_class"].to_numpy()
    pairs = d.paired_signals()
    r = represent(pairs, REF, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz())
    assert np.all(np.abs(r) <= REFERENCE_CLIP + 1e-6)
    plain = RepresentationSpec(kind="order", n_revs=8, max_order=30.0)
    healthy_dev, sideband = [], {"healthy": [], "damaged": []}
    sb = np.array([(13 + s * k) * REF.n_revs for k in range(1, 7) for s in (-1, 1)])
    for i in range(len(d)):
        base = represent(d.reference[i][None], plain, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz()[i])[0, 0]
        if lab[i] == "healthy":
            healthy_dev.append(np.median(np.abs(r[i, 0, _content(base)])))
        sideband[lab[i]].append(np.mean(np.abs(r[i, 0, sb])))
    assert np.median(healthy_dev) < 0.1
    assert np.mean(sideband["damaged"]) > 0.1
    assert np.mean(sideband["healthy"]) < 0.03


def test_the_reference_tells_a_fault_from_the_machines_own_deviations(machines, referenced):
    """On 30 machines it has not seen, read against their references: >= 90 % healthy vs damaged. The same
    network on the records alone: <= 75 % (each machine's tooth-to-tooth deviations look like a fault), so the
    toy problem needs the reference (measured: 98 % vs 55 %)."""
    train, test = machines
    truth = test.labels["severity_class"].to_numpy()
    acc_ref = np.mean(referenced.predict(test).severity_class == truth)
    plain = train_cnn(train, _config(RepresentationSpec(kind="order", n_revs=8, max_order=30.0)))
    acc_plain = np.mean(plain.predict(test).severity_class == truth)
    assert acc_ref >= 0.9
    assert acc_plain <= 0.75


def test_save_and_load_keeps_the_reference(machines, referenced, tmp_path):
    test = machines[1]
    save_model(referenced, tmp_path / "m")
    loaded = load_model(tmp_path / "m")
    assert loaded.spec.representation["reference"] is True
    np.testing.assert_array_equal(loaded.predict(test).severity_proba, referenced.predict(test).severity_proba)


def test_a_referenced_model_refuses_records_without_a_reference(machines, referenced):
    test = machines[1]
    bare = SignalSet(test.signals, test.fs_hz, test.pair, test.labels)
    with pytest.raises(InputError, match="reference"):
        referenced.predict(bare)
    with pytest.raises(InputError, match="reference"):
        train_cnn(bare, _config(REF))


def test_bad_references_are_refused(machines):
    test = machines[1]
    with pytest.raises(InputError, match="reference"):
        SignalSet(test.signals, test.fs_hz, test.pair, test.labels, reference=test.reference[:, :100])
    with pytest.raises(InputError, match="representation.reference"):
        RepresentationSpec(kind="raw", reference=True)


def _write_measurement(folder, name, speed_rpm, *, fault_depth=0.0, seed=0, reference=None, runout=0.15):
    """A spur-gds-like toy record (29 teeth) as an NPZ + JSON sidecar; the sidecar states the speed 0.5 % off
    (the loader measures it from the tachometer)."""
    import json

    from features.synthetic import gear_signal_example

    sig = gear_signal_example(fs_hz=12800.0, duration_s=2.0, fr_pinion_hz=speed_rpm / 60.0, z_pinion=29, z_wheel=100,
                              fault_depth=fault_depth, runout=runout, snr_db=30.0, seed=seed)
    np.savez(folder / f"{name}.npz", acc=sig.x, tacho=sig.tacho)
    meta = {"pair": "spur-gds", "speed_rpm": 1.005 * speed_rpm, "torque_nm": 50.0, "fs_hz": 12800.0,
            "sensor": "acc", "tacho": "tacho", "fault": "healthy" if fault_depth == 0 else "pitted"}
    if reference:
        meta["reference"] = reference
    (folder / f"{name}.json").write_text(json.dumps(meta))
    return folder / f"{name}.npz"


def test_a_sidecars_reference_is_loaded_and_brought_to_the_records_speed(tmp_path):
    """Sidecar key ``reference``: the healthy recording, made at 1 % more speed than the record, is resampled to
    the record's measured speed, so the healthy pair reads < 0.1 decade (median over the orders with content,
    as above) and its first two mesh lines < 0.01 decade; without the resampling they sit 0.29 and 0.58 orders off
    and read > 0.5 decade."""
    from models.sources import load_measurements

    ref = _write_measurement(tmp_path, "ref", 1010.0, seed=1)
    rec = _write_measurement(tmp_path, "rec", 1000.0, seed=2, reference=ref.name)
    d = load_measurements([rec])
    assert d.reference is not None and d.reference.shape == d.signals.shape
    rep = RepresentationSpec(kind="order", n_revs=8, max_order=60.0, reference=True)
    r = represent(d.paired_signals(), rep, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz())[0, 0]
    base = represent(d.reference, RepresentationSpec(kind="order", n_revs=8, max_order=60.0), fs_hz=d.fs_hz,
                     shaft_hz=d.shaft_hz())[0, 0]
    assert np.median(np.abs(r[_content(base)])) < 0.1
    mesh = np.array([29, 58]) * rep.n_revs              # the first two mesh lines
    assert np.all(np.abs(r[mesh]) < 0.01)
    # the same reference taken as it is (no resampling): the mesh lines do not line up (measured 1.1 and 2)
    raw = load_measurements([ref])
    n = min(raw.n_samples, d.n_samples)
    off = represent(np.concatenate([d.signals[:, :n], raw.signals[:, :n]], axis=1), rep, fs_hz=d.fs_hz,
                    shaft_hz=d.shaft_hz())[0, 0]
    assert np.all(np.abs(off[mesh]) > 0.5)


def test_bad_sidecar_references_are_refused(tmp_path):
    from models.sources import load_measurements

    ref = _write_measurement(tmp_path, "ref", 1000.0, seed=1)
    a = _write_measurement(tmp_path, "a", 1000.0, seed=2, reference="missing.npz")
    with pytest.raises(InputError, match="reference"):
        load_measurements([a])
    b = _write_measurement(tmp_path, "b", 1000.0, seed=3, reference=ref.name)
    other = _write_measurement(tmp_path, "other", 1000.0, seed=6)
    with pytest.raises(InputError, match="other.npz: reference"):
        load_measurements([b, other])                      # one record with a reference, one without
    fast = _write_measurement(tmp_path, "fast", 1100.0, seed=4)
    c = _write_measurement(tmp_path, "c", 1000.0, seed=5, reference=fast.name)
    with pytest.raises(InputError, match="speed_rpm"):
        load_measurements([c])                             # 10 % faster: not the same operating point


def test_records_and_their_references_share_a_folder(tmp_path):
    """A file another file's sidecar names as its ``reference`` is that reference only, not a record of the run:
    a folder of records with their references beside them (all with sidecars) reads as the records alone, each
    with its reference; before, the references were records too and were refused for having no reference."""
    from models.measurement_files import folder_files
    from models.sources import load_measurements

    refs = [_write_measurement(tmp_path, f"healthy{i}", 1000.0, seed=10 + i) for i in range(2)]
    recs = [_write_measurement(tmp_path, f"r{i}", 1000.0, seed=20 + i, fault_depth=0.3, reference=refs[i].name)
            for i in range(2)]
    files, skipped = folder_files(tmp_path)
    assert len(files) == 4 and skipped == []
    d = load_measurements(files)
    assert list(d.labels["file"]) == [r.name for r in recs]
    alone = load_measurements([recs[1]])
    np.testing.assert_array_equal(d.reference[1], alone.reference[0])


def test_train_evaluate_predict_with_references_through_the_cli(machines, tmp_path, capsys):
    """``gearpit train --reference`` on a dataset that stores healthy twins writes a model read against the
    reference; ``evaluate`` reads the twins from the dataset, ``predict`` the sidecars' ``reference``; on the
    toy machines' training records it scores >= 90 % (the same machines it was trained on). A dataset without
    twins is refused before training, naming the reference."""
    import json

    from gearpit.cli import main
    from toy_files import evaluate_and_predict, write_toy_dataset

    train = machines[0]
    root = tmp_path / "ds"
    write_toy_dataset(root, train)
    cfg = tmp_path / "train.toml"
    cfg.write_text('[train]\nmax_epochs = 20\npatience = 20\nbatch_size = 16\nlearning_rate = 3e-3\ntask = "binary"\n'
                   'widths = [8, 16, 16, 24, 32]\nhidden = 32\n'
                   '[train.representation]\nkind = "order"\nn_revs = 8\nmax_order = 30.0\n')
    assert main(["train", str(root), "--out", str(tmp_path / "m"), "--config", str(cfg), "--reference",
                 "--quiet"]) == 0
    spec = json.loads((tmp_path / "m" / "model.json").read_text())
    assert spec["representation"]["reference"] is True
    # evaluate on the dataset; predict a measurement file (record + reference as NPZ, sidecars)
    evaluate_and_predict(tmp_path / "m", root, train, tmp_path, capsys)
    plain = tmp_path / "plain"
    write_toy_dataset(plain, train, references=False)
    capsys.readouterr()
    assert main(["train", str(plain), "--out", str(tmp_path / "m2"), "--config", str(cfg), "--reference",
                 "--quiet"]) == 2
    assert "reference" in capsys.readouterr().err and not (tmp_path / "m2").exists()


def test_align_comb_recovers_an_angle_shift_off_the_grid():
    """A random TSA comb turned by 0.3719 rad (not a grid point): the aligned reference equals the record to
    1e-4 of its RMS (parabolic refinement of the cross-correlation peak; without the refinement the error is
    of the grid step times the highest order)."""
    from models.tsa import align_comb

    rng = np.random.default_rng(4)
    k = np.arange(129)
    ref = (rng.standard_normal(129) + 1j * rng.standard_normal(129)) / (1 + k / 20.0)
    ref[0] = 0
    rec = ref * np.exp(-1j * k * 0.3719)
    aligned = align_comb(rec[None], ref)[0]
    assert np.sqrt(np.mean(np.abs(aligned - rec) ** 2)) < 1e-3 * np.sqrt(np.mean(np.abs(rec) ** 2))


def test_tsa_residual_holds_the_fault_not_the_machine(machines):
    """``tsa`` read against the reference, crops at random angles (the toy records start anywhere): the residual
    channel's RMS is < 0.02 for every healthy record (noise and alignment only; measured ~0.008) and > 5 times
    the healthy median for 90 % of the damaged ones (measured 0.09-0.23)."""
    d = machines[1]
    spec = RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=256, reference=True)
    r = represent(d.paired_signals(), spec, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz(), z_pinion=13, starts=0.7)
    lab = d.labels["severity_class"].to_numpy()
    res = np.sqrt(np.mean(r[:, 1] ** 2, axis=1))
    assert np.all(res[lab == "healthy"] < 0.02)
    assert np.mean(res[lab == "damaged"] > 5 * np.median(res[lab == "healthy"])) >= 0.9


def test_residual_difference_is_the_faults_own_difference_signal():
    """Superposition (the TSA is linear): a transmission-error-like record = the gear's own tooth-to-tooth
    deviations (random, 1 um) + a 0.3 um dip on two teeth; its reference = the same deviations at another start
    angle, other noise. The residual's difference signal equals that of the dip alone to 5 % of its RMS, and
    the ``residual_rms`` / ``residual_profile`` side inputs are those of the dip, while the record's own
    ``tsa_diff_rms`` is > 2 times larger (the deviations)."""
    from models.data import PairInfo, SignalSet
    from models.operating import _column
    from models.tooth_profile import PROFILE_SPEC, profile_of_difference
    from models.tsa import residual_difference, tsa_difference

    fs, fr, z1, z2, n = 12800.0, 20.0, 29, 100, 25600
    rng = np.random.default_rng(8)
    dev = 1e-6 * rng.standard_normal(z1)
    t = np.arange(n) / fs

    def steps(values, theta):
        """A smooth bump per tooth, analytic in the angle (band-limited: a shifted copy is an exact shift)."""
        pitch = 2 * np.pi / z1
        centres = (np.arange(z1) + 0.5) * pitch
        d = np.angle(np.exp(1j * (theta[:, None] - centres[None, :])))
        return (values[None, :] * np.exp(-(d / (0.4 * pitch)) ** 2)).sum(axis=1)

    theta = 2 * np.pi * fr * t
    dip = np.zeros(z1)
    dip[[5, 6]] = -0.3e-6
    mesh = 2e-6 * np.cos(z1 * theta)
    noise = 1e-9
    rec = mesh + steps(dev, theta) + steps(dip, theta) + noise * rng.standard_normal(n)
    ref = 2e-6 * np.cos(z1 * (theta + 1.234)) + steps(dev, theta + 1.234) + noise * rng.standard_normal(n)
    pit_only = steps(dip, theta)
    res = residual_difference(rec[None], ref[None], PROFILE_SPEC, fs_hz=fs, shaft_hz=fr, z_pinion=z1, z_wheel=z2)[0]
    own = tsa_difference(pit_only[None], PROFILE_SPEC, fs_hz=fs, shaft_hz=fr, z_pinion=z1, z_wheel=z2)[0]
    assert np.sqrt(np.mean((res - own) ** 2)) < 0.05 * np.sqrt(np.mean(own ** 2))
    d = SignalSet(rec[None].astype(np.float64), fs, PairInfo("spur-gds", z1, z2),
                  pd.DataFrame({"speed_rpm": [60 * fr]}), reference=ref[None])
    assert _column(d, "residual_rms")[0] == pytest.approx(np.sqrt(np.mean(own ** 2)), rel=0.05)
    np.testing.assert_allclose(_column(d, "residual_profile")[0], profile_of_difference(own[None], z1)[0], atol=0.05)
    assert _column(d, "tsa_diff_rms")[0] > 2 * np.sqrt(np.mean(own ** 2))


def test_residual_side_inputs_read_from_the_networks_own_crops_equal_the_direct_ones(machines, monkeypatch):
    """At prediction the residual side inputs of a model whose TSA is the profile's (``te_ref_res``) come from the
    network's first crop (``represent_crops_and_residual``) instead of two more TSAs per record: the
    representation is the same bit for bit, the residual difference signal within 1e-9 of its RMS, and the
    predictions of a model within 1e-6 of the direct path's."""
    import dataclasses

    import models.classifier as classifier
    from models.representations import represent_crops
    from models.tooth_profile import PROFILE_SPEC
    from models.tsa import represent_crops_and_residual, residual_difference

    d = machines[1].subset(np.arange(8))
    spec = dataclasses.replace(PROFILE_SPEC, reference=True)
    fr = d.shaft_hz()
    rep, diff = represent_crops_and_residual(d.paired_signals(), spec, fs_hz=d.fs_hz, crops=(0.0, 0.5, 1.0),
                                             shaft_hz=fr, z_pinion=13, z_wheel=29)
    direct = represent_crops(d.paired_signals(), spec, fs_hz=d.fs_hz, crops=(0.0, 0.5, 1.0), shaft_hz=fr,
                             z_pinion=13, z_wheel=29)
    np.testing.assert_array_equal(rep, direct)
    ref_diff = residual_difference(d.signals, d.reference, PROFILE_SPEC, fs_hz=d.fs_hz, shaft_hz=fr, z_pinion=13,
                                   z_wheel=29)
    scale = np.sqrt(np.mean(ref_diff ** 2, axis=1, keepdims=True))
    assert np.max(np.abs(diff - ref_diff) / scale) < 1e-9
    cfg = TrainConfig(representation=spec, operating_inputs=("residual_rms", "residual_profile"), max_epochs=2,
                      patience=2, batch_size=16, widths=(8, 8, 16, 16, 16), hidden=16, seed=0, task="binary")
    model = train_cnn(machines[0].subset(np.arange(40)), cfg)
    assert classifier._residual_shares_fft(model.spec)
    shared = model.predict(d, n_crops=3)
    monkeypatch.setattr(classifier, "_residual_shares_fft", lambda spec: False)
    plain = model.predict(d, n_crops=3)
    np.testing.assert_allclose(shared.severity_proba, plain.severity_proba, atol=1e-6)


def test_whitening_by_the_reference_takes_out_a_housing_resonance(machines):
    """``whiten = true`` (``models.tsa.mesh_whitening``): record and reference of a damaged toy machine through a
    resonance (x5 gain; at shaft order 26 = the 2nd mesh harmonic, or 20, between harmonics; 5-10 % damping) and
    without: the whitened TSA channel changes by < 0.5 of its RMS (median over the records), the plain referenced
    one by > 1 (the resonance reshapes the waveform; measured 0.32-0.42 against 1.15-1.28), and the residual
    channel less than the plain one's (measured 0.68-0.87 against 1.07-1.47: the toy's sidebands span +/- 6
    orders, wider than these resonances, so the path is not flat over them and cannot cancel fully)."""
    from models.augment import path_filter

    d = machines[1]
    dam = np.nonzero(d.labels["severity_class"].to_numpy() == "damaged")[0][:12]
    for order, zeta in ((20.0, 0.05), (26.0, 0.1)):
        change = {}
        for whiten in (False, True):
            spec = RepresentationSpec(kind="tsa", n_revs=8, samples_per_rev=256, reference=True, whiten=whiten)
            errs = []
            for i in dam:
                rec, ref = d.signals[i].astype(float), d.reference[i].astype(float)
                fr = d.shaft_hz()[i]
                moved = [5.0 * path_filter(v[None, :], d.fs_hz, order * fr, zeta)[0] for v in (rec, ref)]
                a, b = (represent(np.concatenate(p)[None], spec, fs_hz=d.fs_hz, shaft_hz=fr, z_pinion=13,
                                  z_wheel=29)[0] for p in ((rec, ref), moved))
                errs.append([np.sqrt(np.mean((a[c] - b[c]) ** 2) / np.mean(a[c] ** 2)) for c in (0, 1)])
            change[whiten] = np.median(errs, axis=0)
        assert change[True][0] < 0.5 and change[False][0] > 1.0, (order, change)
        assert change[True][1] < change[False][1], (order, change)


def test_mesh_whitening_weights():
    """One over each mesh harmonic where the reference holds it (phase included), interpolated in log modulus
    between harmonics, weighted down (not blown up) where a harmonic is 60 dB under the strongest; whitening
    needs the reference: refused otherwise, naming the field."""
    from models.tsa import WHITEN_FLOOR, mesh_whitening

    z, K = 10, 40
    ref = np.zeros(K + 1, complex)
    ref[[10, 20, 30, 40]] = [2.0 * np.exp(0.3j), 0.5j, 1e-3, 1.0]
    w = mesh_whitening(ref, z)[0]
    np.testing.assert_allclose(w[[10, 20, 40]] * ref[[10, 20, 40]], 1.0, rtol=2 * WHITEN_FLOOR ** 2 * 16)
    assert abs(w[30]) < 0.02 * (1.0 / 1e-3)                 # regularised: far below 1 / 1e-3
    np.testing.assert_allclose(abs(w[15]), np.sqrt(abs(w[10]) * abs(w[20])), rtol=1e-9)   # log-linear between
    np.testing.assert_allclose(np.angle(w[:15]), -0.3, atol=1e-9)                         # phase of the nearest
    with pytest.raises(InputError, match="whiten"):
        RepresentationSpec(kind="tsa", whiten=True)
    with pytest.raises(InputError, match="whiten"):
        RepresentationSpec(kind="order", reference=True, whiten=True)
