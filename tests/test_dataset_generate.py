"""Dataset generation: identical bytes for any execution, resume after a kill, labels vs masks, readers."""
from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from datagen import dataset
from datagen.generate import generate
from datagen.sweep import sweep_from_dict
from gearpit.errors import InputError

from test_dataset_config import BASE, REPO, base  # tests/ is on sys.path (conftest.py)


def digest(path: Path) -> dict[str, str]:
    """sha256 of every file under ``path`` (relative names)."""
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def sweep():
    return sweep_from_dict(BASE)


@pytest.fixture(scope="module")
def reference(sweep, tmp_path_factory):
    """The sweep generated in this process (workers=1): 18 samples in 5 shards."""
    out = tmp_path_factory.mktemp("ref") / "ds"
    report = generate(sweep, out, progress=False)
    assert report.computed == sweep.n_shards == 5
    return out


@pytest.mark.parametrize("start", ["fork", "forkserver"])
def test_two_workers_give_identical_bytes(sweep, reference, tmp_path, monkeypatch, start):
    """A 2-process pool writes byte-identical files (every file, metadata included) to the in-process run,
    with workers forked from this process and with workers from a fork server (:func:`pool_context` picks one).

    Source: issue 4 ("identical bytes for 1 and 2 workers"); exact (sha256).
    """
    import multiprocessing

    from datagen import generate as gen

    ctx = multiprocessing.get_context(start)
    monkeypatch.setattr(gen, "pool_context", lambda: ctx)
    generate(sweep, tmp_path / "ds", workers=2, progress=False)
    assert digest(tmp_path / "ds") == digest(reference)


def test_workers_fork_only_from_a_parent_without_threads_or_torch():
    """The pool forks from a single-threaded Linux parent without torch, and uses the fork server otherwise:
    a fork while another thread holds a lock, or after torch started its OpenMP pool, can hang the worker.

    Source: the Python documentation of ``multiprocessing`` (contexts and start methods); exact.
    """
    import threading

    code = ("import sys, threading; from datagen.generate import pool_context; a = pool_context().get_start_method();"
            " import torch; b = pool_context().get_start_method(); print(a, b)")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True)
    assert out.stdout.split() == (["fork", "forkserver"] if sys.platform == "linux" else ["forkserver"] * 2)
    from datagen.generate import pool_context

    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    try:
        assert pool_context().get_start_method() == "forkserver"
    finally:
        stop.set()
        t.join()


def test_killed_run_resumes_to_identical_bytes(reference, tmp_path):
    """`gearpit generate` killed (SIGKILL) after its first shard, then run again, equals the uninterrupted run.

    Also simulates a crash between the signal and the index writes of a shard (signals present,
    no index part, a stale temporary). Source: issue 4 ("killed midway and resumed"); exact (sha256).
    """
    toml = tmp_path / "sweep.toml"
    toml.write_text(_to_toml(BASE))
    out = tmp_path / "ds"
    proc = subprocess.Popen([sys.executable, "-m", "gearpit.cli", "generate", str(toml), "--out", str(out),
                             "--quiet"], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not (out.exists() and dataset.finished_shards(out)):
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline
        time.sleep(0.005)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done = dataset.finished_shards(out)
    assert 1 <= len(done) < 5 and not (out / dataset.INDEX).exists()
    k = max(done)  # crash between the writes of shard k: its commit mark is lost, a temporary is left
    (out / dataset.SHARDS / dataset.shard_name("index", k)).unlink()
    (out / dataset.SHARDS / ".signals-000004.npy.abc.part.npy").write_bytes(b"half")
    report = generate(sweep_from_dict(BASE), out, progress=False)
    assert report.skipped == len(done) - 1 and report.computed == 5 - report.skipped
    assert digest(out) == digest(reference)


def _to_toml(doc: dict) -> str:
    def value(v):
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []

    def table(name, t):
        plain = {k: v for k, v in t.items() if not isinstance(v, dict)}
        if plain or not t:
            lines.append(f"[{name}]")
            lines.extend(f"{k} = {value(v)}" for k, v in plain.items())
        for k, v in t.items():
            if isinstance(v, dict):
                table(f"{name}.{k}", v)

    for name, t in doc.items():
        table(name, t)
    return "\n".join(lines) + "\n"


def test_dask_cluster_gives_identical_bytes(sweep, reference, tmp_path):
    """On a Dask LocalCluster (2 worker processes) reached by its address (`--dask ADDRESS`), and on one
    started by generate itself (`--dask-local`, first 2 shards), the files equal the local run's.

    Source: issue 4 ("a Dask LocalCluster run equals the local run"); exact (sha256).
    """
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        generate(sweep, tmp_path / "ds", dask_address=cluster.scheduler_address, progress=False)
    assert digest(tmp_path / "ds") == digest(reference)
    report = generate(sweep, tmp_path / "part", dask_local_workers=1, progress=False, max_shards=2)
    assert report.computed == 2
    part, ref = digest(tmp_path / "part"), digest(reference)
    assert len(part) == 1 + 2 * 3 and all(ref[name] == h for name, h in part.items())


def test_labels_agree_with_stored_and_regenerated_masks(sweep, reference):
    """Severity recomputed from the stored masks (and from masks regenerated from (config, seed, index))
    equals the index labels; the severity class is the bin that holds it; teeth counts match the masks.

    Source: issue 4 ("labels agree with the masks"); severity exact (same pixel counts), bins [min, max).
    """
    index = dataset.load_index(reference)
    bins = sweep.severity_bins
    for row in index.itertuples():
        masks = dataset.load_masks(reference, row.sample_index)
        sev = {t: float(m.mean()) for t, m in masks.items()}
        assert sorted(sev) == list(row.pitted_teeth) and len(sev) == row.n_pitted_teeth
        assert max(sev.values(), default=0.0) == row.severity
        assert np.array_equal(list(sev.values()), row.severity_by_tooth) or not sev
        assert bins[row.severity_class_index].name == row.severity_class
        assert bins[row.severity_class_index].contains(row.severity)
        tc = sweep.teeth_classes[row.teeth_class_index]
        assert tc.name == row.teeth_class and tc.low <= row.n_pitted_teeth <= tc.high
    for i in (0, 4, 11):  # masks regenerate bit for bit from the stored config
        pm = dataset.regenerate_pit_map(reference, i)
        stored = dataset.load_masks(reference, i)
        assert pm.pitted_teeth == sorted(stored)
        assert all(np.array_equal(pm.mask(t), m) for t, m in stored.items())


def test_class_balance_as_configured(sweep, reference):
    """Every class of the grid holds exactly samples_per_class samples (dataset info counts them).

    Source: issue 4 ("class balance as configured"); exact counts.
    """
    info = dataset.dataset_info(reference)
    assert info["complete"] and info["n_finished"] == 18
    assert set(info["class_counts"].values()) == {sweep.samples_per_class}
    assert len(info["class_counts"]) == 9
    index = dataset.load_index(reference)
    assert (index["sample_index"].to_numpy() == np.arange(18)).all()
    assert index.groupby(["severity_class", "teeth_class", "shape"]).size().eq(2).all()


def test_readers_agree(sweep, reference):
    """load_signals, the memory-mapped shards and the torch Dataset return the same float32 samples.

    Source: datagen.dataset layout; exact equality.
    """
    torch = pytest.importorskip("torch")
    from datagen.torch_dataset import SignalDataset

    x_all = dataset.load_signals(reference)
    assert x_all.shape == (18, sweep.n_time) and x_all.dtype == np.float32
    assert np.all(np.isfinite(x_all)) and np.all(x_all.std(axis=1) > 0)
    tacho = dataset.load_signals(reference, [3, 17], channel="tacho_pinion")
    ds = SignalDataset(reference, labels=("severity_class_index", "severity", "speed_rpm"))
    x, y = ds[17]
    assert x.dtype == torch.float32 and x.shape == (2, sweep.n_time)
    assert np.array_equal(x[0].numpy(), x_all[17]) and np.array_equal(x[1].numpy(), tacho[1])
    index = dataset.load_index(reference)
    assert int(y["severity_class_index"]) == index.loc[17, "severity_class_index"]
    assert y["severity"].dtype == torch.float32
    with pytest.raises(InputError):
        dataset.load_signals(reference, [18])


def test_other_sweep_in_same_directory_is_refused(reference, tmp_path):
    """Generating another sweep into an existing dataset raises before writing anything."""
    other = sweep_from_dict(base(sweep__seed=99))
    before = digest(reference)
    with pytest.raises(InputError, match="another config or seed"):
        generate(other, reference, progress=False)
    assert digest(reference) == before


def test_info_cli(reference, capsys):
    """`gearpit dataset info DIR` prints class counts, parameter ranges with units and the size on disk."""
    from gearpit.cli import main

    assert main(["dataset", "info", str(reference)]) == 0
    out = capsys.readouterr().out
    assert "spur-gds/severe/2+/cluster" in out and "size on disk" in out
    assert "speed_rpm" in out and " rpm" in out
    assert main(["dataset", "info", str(reference / "shards")]) == 2  # not a dataset: one-line error


def test_second_channel_leaves_the_accelerometer_records_unchanged(reference, tmp_path):
    """Storing the transmission error beside the accelerometer, with noise on every channel (as the default
    classifier sweep does since the sensor protocol, experiments/sensor_protocol.py), gives the same
    accelerometer bytes as the accelerometer alone: the protocols on the earlier dataset stay valid. The
    transmission error carries its own noise at the record's SNR (against a generation at 120 dB: residual
    RMS / signal RMS = 10^(-SNR/20) within 4 sigma of the sample-RMS scatter, per record and on average)."""
    two = base(sweep__channels=["acc_pinion_loa_m_s2", "tacho_pinion", "dte_m"],
               effects__noise={"snr_db": [20.0, 30.0], "channels": "all"})
    out = tmp_path / "two"
    generate(sweep_from_dict(two), out, progress=False)
    rows = np.arange(sweep_from_dict(two).n_samples)
    assert np.array_equal(dataset.load_signals(out, rows, "acc_pinion_loa_m_s2"),
                          dataset.load_signals(reference, rows, "acc_pinion_loa_m_s2"))
    quiet = base(sweep__channels=["dte_m"], effects__noise={"snr_db": [120.0, 120.0], "channels": "all"})
    generate(sweep_from_dict(quiet), tmp_path / "quiet", progress=False)
    te = dataset.load_signals(out, rows, "dte_m").astype(float)
    clean = dataset.load_signals(tmp_path / "quiet", rows, "dte_m").astype(float)
    snr = dataset.load_index(out).sort_values("sample_index")["snr_db"].to_numpy()
    ratio = (te - clean).std(axis=1) / clean.std(axis=1) / 10.0 ** (-snr / 20.0)
    # the noise is a unit-variance draw, so its sample RMS over n samples scatters by 1 / sqrt(2 n) (3.5 %)
    sigma = 1.0 / np.sqrt(2 * te.shape[1])
    assert np.all(np.abs(ratio - 1.0) < 4 * sigma) and abs(ratio.mean() - 1.0) < 4 * sigma / np.sqrt(ratio.size)


def test_encoder_errors_change_only_the_transmission_error_by_their_shaft_lines(reference, tmp_path):
    """The cross-physics draw of the sensor protocol (experiments/sensor_protocol_design.py, ENCODERS): adding
    [effects.shaft_encoder_error] leaves the accelerometer bytes unchanged (each effect draws its parameters from
    its own stream, and effects apply in name order, so noise keeps its position and its draw) and changes the transmission error by exactly
    rb1 a1 sin(theta1 + psi1) - rb2 a2 sin(theta2 + psi2) with the recorded draws (Remond 2000; theta from the
    nominal speed: tolerance 1e-3 of the added error's peak plus float32 rounding of the stored record)."""
    from datagen.geometry import spur_pair_example

    channels = {"sweep__channels": ["acc_pinion_loa_m_s2", "dte_m"],
                "effects__noise": {"snr_db": [20.0, 30.0], "channels": "all"}}
    enc = {"pinion_rad": [5e-5, 3e-4], "wheel_rad": [5e-5, 3e-4], "pinion_phase_rad": [-3.0, 3.0],
           "wheel_phase_rad": [-3.0, 3.0]}
    plain, with_enc = base(**channels), base(**channels)
    with_enc["effects"]["shaft_encoder_error"] = enc
    generate(sweep_from_dict(plain), tmp_path / "plain", progress=False)
    generate(sweep_from_dict(with_enc), tmp_path / "enc", progress=False)
    rows = np.arange(sweep_from_dict(plain).n_samples)
    acc = [dataset.load_signals(tmp_path / d, rows, "acc_pinion_loa_m_s2") for d in ("plain", "enc")]
    assert np.array_equal(acc[0], acc[1])
    te = [dataset.load_signals(tmp_path / d, rows, "dte_m").astype(float) for d in ("plain", "enc")]
    idx = dataset.load_index(tmp_path / "enc").sort_values("sample_index")
    pair = spur_pair_example()
    rb1, rb2 = pair.base_radius_m("pinion"), pair.base_radius_m("wheel")
    t = np.arange(te[0].shape[1]) / BASE["sweep"]["fs_hz"]
    for i, (_, r) in enumerate(idx.iterrows()):
        th1 = 2 * np.pi * r["speed_rpm"] / 60.0 * t
        want = (rb1 * r["shaft_encoder_error_pinion_rad"] * np.sin(th1 + r["shaft_encoder_error_pinion_phase_rad"])
                - rb2 * r["shaft_encoder_error_wheel_rad"] * np.sin(th1 * 29 / 100 + r["shaft_encoder_error_wheel_phase_rad"]))
        tol = 1e-3 * np.abs(want).max() + 2 * np.finfo(np.float32).eps * np.abs(te[1][i]).max()
        assert np.abs(te[1][i] - te[0][i] - want).max() < tol, i


def test_healthy_references_are_the_samples_twins_without_pits(reference, tmp_path):
    """``[sweep] healthy_reference = true``: the records are unchanged (same bytes as without the twins), each
    twin can be simulated again from its index row alone (the drawn effect values, the operating point and
    ``reference_simulation_seed``, no pits; within 1 % of its RMS: a shard's cases share solver passes), a healthy sample and its twin differ by their two noise
    draws only (residual RMS / record RMS = sqrt(2) 10^(-SNR/20) within 4 sigma of the sample-RMS scatter), and
    the classifiers' reader attaches the twins as references."""
    from datagen.effects import get
    from datagen.geometry import preset
    from datagen.sampling import effect_column
    from datagen.simulate import Case, OperatingPoint, simulate
    from models.sources import load_dataset

    sw = sweep_from_dict(base(sweep__healthy_reference=True))
    assert sw.stored_channels == ("acc_pinion_loa_m_s2", "tacho_pinion",
                                  "acc_pinion_loa_m_s2@reference", "tacho_pinion@reference")
    out = tmp_path / "twins"
    generate(sw, out, progress=False)
    rows = np.arange(sw.n_samples)
    for ch in ("acc_pinion_loa_m_s2", "tacho_pinion"):
        assert np.array_equal(dataset.load_signals(out, rows, ch), dataset.load_signals(reference, rows, ch))
    index = dataset.load_index(out).sort_values("sample_index").reset_index(drop=True)
    twins = dataset.load_signals(out, rows, "acc_pinion_loa_m_s2@reference")
    records = dataset.load_signals(out, rows, "acc_pinion_loa_m_s2")
    pitted = int(np.nonzero(index["n_pitted_teeth"].to_numpy() > 0)[0][0])
    for i in (0, pitted):
        row = index.iloc[i]
        effects = tuple(get(name)(**{d.name: row[effect_column(name, d.name)] for d in draws})
                        for name, draws in sw.effects)
        case = Case(pair=preset("spur-gds"), operating=OperatingPoint(float(row.speed_rpm), float(row.torque_nm)),
                    duration_s=sw.duration_s, fs_hz=sw.fs_hz, effects=effects,
                    seed=int(row.reference_simulation_seed))
        again = simulate([case])[0].channels["acc_pinion_loa_m_s2"]
        # alone, not in its shard's batch (whose cases share their solver passes): within 1 % of the RMS, where
        # another noise draw (SNR 20-30 dB: 3-10 % of the RMS) would not be
        assert np.max(np.abs(again - twins[i])) < 0.01 * np.std(twins[i])
    healthy = index["n_pitted_teeth"].to_numpy() == 0
    snr = index["snr_db"].to_numpy()[healthy]
    ratio = (records[healthy] - twins[healthy]).astype(float).std(axis=1) / records[healthy].std(axis=1)
    ratio /= np.sqrt(2.0) * 10.0 ** (-snr / 20.0)
    sigma = 1.0 / np.sqrt(2 * records.shape[1])
    assert np.all(np.abs(ratio - 1.0) < 4 * sigma)
    assert not np.array_equal(records[pitted], twins[pitted])
    data = load_dataset(out)
    assert np.array_equal(data.reference, twins[index.sample_index.to_numpy()])
    assert load_dataset(reference).reference is None


def test_healthy_reference_must_be_a_bool():
    with pytest.raises(InputError, match="sweep.healthy_reference"):
        sweep_from_dict(base(sweep__healthy_reference="yes"))
