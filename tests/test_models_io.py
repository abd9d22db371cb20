"""Saved models (models/io.py) and the model-facing parts of ``gearpit train / evaluate / predict``: damaged or
mixed model files refused by name, byte-identical files for identical trainings, ``--out`` checks, the trained
channel, incomplete datasets and truncated shards, models without a novelty check, several dataset directories."""
import hashlib
import json
import shutil

import numpy as np
import pandas as pd
import pytest

from gearpit.cli import main
from gearpit.errors import InputError
from models.io import load_model, save_model
from models.representation_spec import RepresentationSpec
from models.toy import toy_signal_set
from models.train import TrainConfig, train_cnn

FS = 4096.0
TINY = dict(representation=RepresentationSpec(kind="order", n_revs=4, max_order=30.0), max_epochs=2, patience=2,
            batch_size=8, widths=(8, 8, 8, 8, 8), hidden=8, val_fraction=0.5)
CONFIG = """
[train]
max_epochs = 2
patience = 2
batch_size = 8
widths = [8, 8, 8, 8, 8]
hidden = 8
[train.representation]
kind = "order"
n_revs = 4
max_order = 30.0
"""


THREE = (("healthy", 0.0), ("minor", 0.1), ("severe", 0.35))


def _toy(seed: int, n: int = 12, classes=(("healthy", 0.0), ("severe", 0.35))):
    return toy_signal_set(n_per_class=n, fs_hz=FS, z_pinion=29, z_wheel=100, speeds_rpm=(1200.0, 1500.0),
                          classes=classes, snr_db=20.0, seed=seed)


def _write_dataset(root, data, *, channels=("acc",), n_shards=1, finished=None):
    """A dataset directory in the layout of datagen.dataset; ``finished``: the shards written (default all,
    and then the merged index)."""
    from datagen.dataset import finalize, write_shard

    root.mkdir()
    n = len(data)
    size = n // n_shards
    meta = {"format": "gearpit-dataset", "format_version": 1, "name": "toy", "channels": list(channels), "fs_hz": FS,
            "n_time": data.n_samples, "n_samples": n, "shard_size": size, "n_shards": n_shards,
            "pairs": {"spur-gds": {"z_pinion": 29, "z_wheel": 100}}, "seed": 0, "software": {"gearpit": "test"},
            "fingerprint": "toy", "classes": [], "samples_per_class": n}
    (root / "metadata.json").write_text(json.dumps(meta))
    (root / "shards").mkdir()
    rows = data.labels.assign(sample_index=np.arange(n), pair="spur-gds", shape="ellipse").to_dict(orient="records")
    x = np.repeat(data.signals[:, None, :], len(channels), axis=1)
    for k in (range(n_shards) if finished is None else finished):
        write_shard(root, k, x[k * size:(k + 1) * size], rows[k * size:(k + 1) * size], [])
    if finished is None:
        finalize(root)


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """Two tiny three-class CNNs (seeds 0 and 1, novelty fitted on 12 validation records) and a binary one."""
    root = tmp_path_factory.mktemp("io")
    data = _toy(1, n=8, classes=THREE)
    for name, kw in (("a", {}), ("b", {"seed": 1}), ("bin", {"task": "binary"})):
        save_model(train_cnn(data, TrainConfig(**TINY, **kw)), root / name)
    _write_dataset(root / "ds", data)
    return root


def _old_style(src, dst):
    """A copy of a model directory as saved before the digests were recorded (no ``files`` in model.json)."""
    shutil.copytree(src, dst)
    doc = json.loads((dst / "model.json").read_text())
    doc.pop("files", None)
    (dst / "model.json").write_text(json.dumps(doc))
    return dst


def test_a_file_of_another_model_is_refused_by_its_digest(models, tmp_path):
    """weights.pt (or novelty.npz) copied from another model directory: refused naming the file and the digest;
    model.json records size and SHA-256 of each file; a model saved without digests still loads."""
    doc = json.loads((models / "a" / "model.json").read_text())
    assert set(doc["files"]) == {"weights.pt", "novelty.npz"}
    assert doc["files"]["weights.pt"]["sha256"] == _sha(models / "a" / "weights.pt")
    for name in ("weights.pt", "novelty.npz"):
        mixed = tmp_path / name
        shutil.copytree(models / "a", mixed)
        shutil.copy(models / "b" / name, mixed / name)
        with pytest.raises(InputError, match=rf"^{name}: .*SHA-256 differs"):
            load_model(mixed)
    old = _old_style(models / "a", tmp_path / "old")
    assert load_model(old).novelty is not None


def test_damaged_or_mismatched_files_are_refused_by_name(models, tmp_path):
    """Truncated weights, a corrupt novelty file and a binary model's weights in a multi-class model's directory
    (saved without digests, so the reading itself is checked): one InputError naming the file, no traceback."""
    trunc = _old_style(models / "a", tmp_path / "trunc")
    (trunc / "weights.pt").write_bytes((models / "a" / "weights.pt").read_bytes()[:5000])
    with pytest.raises(InputError, match=r"^weights.pt: .*unreadable \(truncated or corrupt"):
        load_model(trunc)
    nov = _old_style(models / "a", tmp_path / "nov")
    with open(nov / "novelty.npz", "wb") as fh:
        np.savez(fh, means=np.array([{"a": 1}], dtype=object))
    with pytest.raises(InputError, match=r"^novelty.npz: .*unreadable"):
        load_model(nov)
    swap = _old_style(models / "a", tmp_path / "swap")
    shutil.copy(models / "bin" / "weights.pt", swap / "weights.pt")
    (swap / "novelty.npz").unlink()
    with pytest.raises(InputError, match=r"^weights.pt: .*tensors that match model.json.*severity_class"):
        load_model(swap)
    # a digest-checked directory with the truncated file: refused by its size
    cut = tmp_path / "cut"
    shutil.copytree(models / "a", cut)
    (cut / "weights.pt").write_bytes((models / "a" / "weights.pt").read_bytes()[:5000])
    with pytest.raises(InputError, match=r"^weights.pt: .*5000 bytes"):
        load_model(cut)


def test_truncated_baseline_arrays_are_refused_by_name(tmp_path):
    """A baseline's arrays.npz cut short: InputError naming arrays.npz."""
    from models.baselines import fit_baseline

    data = _toy(2, n=6)
    x = np.random.default_rng(0).standard_normal((len(data), 3)) + data.labels["severity"].to_numpy()[:, None]
    save_model(fit_baseline(data, "logreg", features=x, feature_names=["a", "b", "c"], feature_config={}),
               tmp_path / "lr")
    m = _old_style(tmp_path / "lr", tmp_path / "lr_old")
    (m / "arrays.npz").write_bytes((m / "arrays.npz").read_bytes()[:300])
    with pytest.raises(InputError, match=r"^arrays.npz: .*unreadable \(truncated or corrupt"):
        load_model(m)


def test_same_seed_gives_the_same_bytes(models, tmp_path):
    """The same training twice: every file of the model directory has the same SHA-256, except model.json, which
    differs only in the training time (training.seconds); weights.pt holds no temporary file name."""
    save_model(train_cnn(_toy(1, n=8, classes=THREE), TrainConfig(**TINY)), tmp_path / "again")
    for name in ("weights.pt", "novelty.npz"):
        assert _sha(tmp_path / "again" / name) == _sha(models / "a" / name)
    assert b".part" not in (tmp_path / "again" / "weights.pt").read_bytes()
    d1, d2 = (json.loads((p / "model.json").read_text()) for p in (models / "a", tmp_path / "again"))
    for d in (d1, d2):
        del d["training"]["seconds"]
    assert d1 == d2


def test_out_pointing_at_a_file_is_refused_before_any_work(models, tmp_path, capsys):
    """--out of evaluate / train naming an existing file, predict's --out naming a directory: exit 2, one line
    naming --out and the path."""
    afile = tmp_path / "afile"
    afile.write_text("x")
    for argv in (["evaluate", str(models / "a"), str(models / "ds"), "--out", str(afile)],
                 ["train", str(models / "ds"), "--out", str(afile), "--model", "logreg"],
                 ["predict", str(models / "a"), str(models / "ds"), "--out", str(tmp_path)],
                 ["predict", str(models / "a"), str(models / "ds"), "--out", str(afile / "p.csv")]):
        capsys.readouterr()
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "--out" in err and str(tmp_path) in err


def test_binary_baseline_without_healthy_records_is_refused_before_the_features(tmp_path, capsys, monkeypatch):
    """--task binary --model logreg on damaged records only: the CNN's clean error, before the feature table."""
    import models.baselines

    _write_dataset(tmp_path / "ds", _toy(3, n=4, classes=(("minor", 0.1), ("severe", 0.35))))
    monkeypatch.setattr(models.baselines, "feature_table", lambda *a, **k: pytest.fail("feature table computed"))
    capsys.readouterr()
    assert main(["train", str(tmp_path / "ds"), "--out", str(tmp_path / "m"), "--task", "binary",
                 "--model", "logreg"]) == 2
    err = capsys.readouterr().err
    assert "severity_class" in err and "at least two classes" in err and "healthy and damaged" in err
    assert not (tmp_path / "m").exists()


def test_a_truncated_shard_is_named_and_reported_by_dataset_info(tmp_path, capsys):
    """A signals shard cut short: train refuses naming the file with its size and the size its header declares;
    dataset info lists it as damaged and the dataset as not complete."""
    from datagen.dataset import dataset_info

    _write_dataset(tmp_path / "ds", _toy(4, n=4), n_shards=2)
    shard = tmp_path / "ds" / "shards" / "signals-000001.npy"
    full = shard.stat().st_size
    shard.write_bytes(shard.read_bytes()[:500])
    capsys.readouterr()
    assert main(["train", str(tmp_path / "ds"), "--out", str(tmp_path / "m"), "--model", "logreg"]) == 2
    err = capsys.readouterr().err
    assert "signals-000001.npy holds 500 bytes" in err and f"declares {full}" in err
    info = dataset_info(tmp_path / "ds")
    assert list(info["damaged_shards"]) == [1] and info["complete"] is False


def test_evaluate_uses_the_trained_channel_or_refuses(models, tmp_path, capsys):
    """A model trained on 'acc' evaluated on a dataset storing 'other' then 'acc': the trained channel is read,
    not the first stored; a dataset without it is refused naming both, unless --channel names one."""
    from dataclasses import replace

    from gearpit.commands.evaluate import resolve_channel

    model = load_model(models / "a")
    model.spec = replace(model.spec, channel="acc")
    save_model(model, tmp_path / "m")
    _write_dataset(tmp_path / "two", _toy(5, n=2), channels=("other", "acc"))
    assert resolve_channel(model, [tmp_path / "two"], None) == "acc"
    _write_dataset(tmp_path / "one", _toy(5, n=2), channels=("wheel_acc",))
    capsys.readouterr()
    assert main(["evaluate", str(tmp_path / "m"), str(tmp_path / "one"), "--out", str(tmp_path / "e")]) == 2
    err = capsys.readouterr().err
    assert "acc (the model's training channel)" in err and "it stores wheel_acc" in err and "--channel" in err
    assert main(["evaluate", str(tmp_path / "m"), str(tmp_path / "one"), "--out", str(tmp_path / "e"),
                 "--channel", "wheel_acc"]) == 0


def test_messages_name_the_flag_and_say_an_acceleration(models):
    """The quantity check reads 'an acceleration'; a pair or fs mismatch points to --allow-mismatch."""
    from dataclasses import replace

    from models.data import PairInfo, SignalSet
    from models.spec import check_input

    spec = replace(load_model(models / "a").spec, channel="dte_m")
    d = _toy(6, n=1)
    with pytest.raises(InputError, match=r"\(this one is an acceleration\)"):
        check_input(spec, SignalSet(d.signals, d.fs_hz, d.pair, d.labels, channel="acc_pinion_loa_m_s2"))
    with pytest.raises(InputError, match="or --allow-mismatch"):
        check_input(spec, SignalSet(d.signals, d.fs_hz, PairInfo("x", 31, 100), d.labels))


def test_incomplete_dataset_and_missing_novelty_are_warned_and_recorded(tmp_path, capsys):
    """2 of 4 shards generated: train warns 'incomplete dataset: 12 of 24 samples' and model.json records it; too
    few validation records: train warns the novelty check was not fitted, predict says once the model has none."""
    _write_dataset(tmp_path / "ds", _toy(7, n=12), n_shards=4, finished=[0, 1])
    (tmp_path / "t.toml").write_text(CONFIG)
    capsys.readouterr()
    assert main(["train", str(tmp_path / "ds"), "--out", str(tmp_path / "m"), "--config", str(tmp_path / "t.toml"),
                 "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "warning: incomplete dataset: 12 of 24 samples" in err and "2 of 4 shards" in err
    assert "novelty check not fitted" in err
    spec = json.loads((tmp_path / "m" / "model.json").read_text())
    assert spec["training"]["incomplete_dataset"].startswith("incomplete dataset: 12 of 24 samples")
    assert main(["predict", str(tmp_path / "m"), str(tmp_path / "ds")]) == 0
    out = capsys.readouterr()
    assert out.err.count("this model has no novelty check (not fitted") == 1 and "novelty" not in out.out
    assert main(["evaluate", str(tmp_path / "m"), str(tmp_path / "ds"), "--out", str(tmp_path / "e")]) == 0
    assert capsys.readouterr().err.count("this model has no novelty check (not fitted") == 1


def test_a_missing_sidecar_is_not_sent_to_a_meta_flag_predict_lacks(models, tmp_path, capsys):
    """predict on a measurement file without a sidecar: the error names the sidecar files to write beside it and
    does not tell the user to pass --meta, which predict does not take."""
    np.savetxt(tmp_path / "rec.csv", _toy(10, n=1).signals[0], header="acc", comments="")
    capsys.readouterr()
    assert main(["predict", str(models / "a"), str(tmp_path / "rec.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("gearpit predict: error: rec.csv: sidecar:") and "rec.toml or rec.json" in err
    assert "--meta" not in err


def test_train_takes_several_datasets_and_defaults_to_the_main_jobs_tsa(tmp_path, capsys):
    """Two dataset directories are trained on as one (n_train + n_val = all records); without --representation
    or a [train.representation] kind the CNN reads the main job's TSA; a baseline warns of the CNN-only flags."""
    import argparse

    from gearpit.commands.train import train_config_from
    from models.workflow import DEFAULT_CONFIG

    _write_dataset(tmp_path / "a", _toy(8, n=4))
    _write_dataset(tmp_path / "b", _toy(9, n=6))
    (tmp_path / "t.toml").write_text(CONFIG)
    assert main(["train", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(tmp_path / "m"),
                 "--config", str(tmp_path / "t.toml"), "--quiet"]) == 0
    t = json.loads((tmp_path / "m" / "model.json").read_text())["training"]
    assert t["n_train"] + t["n_val"] == 20
    args = argparse.Namespace(config=None, representation=None, reference=False, task=None, epochs=None, seed=None)
    assert train_config_from(args).representation == DEFAULT_CONFIG.representation
    assert DEFAULT_CONFIG.representation.kind == "tsa"
    capsys.readouterr()
    assert main(["train", str(tmp_path / "a"), "--out", str(tmp_path / "rf"), "--model", "rf",
                 "--representation", "order", "--epochs", "3"]) == 0
    assert "--representation, --epochs do not apply to the rf baseline" in capsys.readouterr().err


def test_severity_mae_names_its_count_and_the_summary_names_the_notes():
    """metrics.md prints over how many records the severity MAE was computed; predict's summary counts the records
    by what their warnings are (a sidecar-speed note is not called 'unlike the training records')."""
    from types import SimpleNamespace

    from gearpit.commands.predict import warning_summary
    from models.evaluate import report_markdown

    metrics = {"n_records": 2, "source": "s", "severity_mae": 0.0, "severity_mae_n": 1, "mean_confidence": 0.5,
               "n_warnings": 0, "severity_class": {"accuracy": 1.0, "macro_f1": 1.0, "classes": ["a"],
                                                   "confusion": [[2]]}}
    assert "Severity MAE: 0.0000 (pitted fraction; over the 1 of 2 records with a known severity)" in \
        report_markdown(metrics)
    pred = SimpleNamespace(warnings=["speed not confirmed", ""], novelty=np.array([0.3, 0.2]))
    s = warning_summary(pred, _Sized(pd.DataFrame({"speed_note": ["speed not confirmed", ""]})))
    assert s == "1 of 2 records with warnings (1 a speed note)"


class _Sized:
    """A stand-in for a SignalSet: its labels and its length."""

    def __init__(self, labels):
        self.labels = labels

    def __len__(self):
        return len(self.labels)
