"""Writers of the toy machines (``models.toy.toy_machines_with_references``) as a user would hand them to the CLI:
a dataset directory in the layout of ``datagen.dataset`` with each record's healthy twin as the channel
``acc@reference``, and measurement files with sidecars naming their reference. Shared by the tests of the
referenced CNN and of the referenced baselines."""
import json

import numpy as np


def write_toy_dataset(root, data, *, references: bool = True) -> None:
    """``data`` (a SignalSet of the 13/29-tooth toy pair, with ``reference`` when ``references``) as a dataset."""
    from datagen.dataset import finalize, write_shard

    (root / "shards").mkdir(parents=True)
    n = len(data)
    channels = ["acc", "acc@reference"] if references else ["acc"]
    meta = {"format": "gearpit-dataset", "format_version": 1, "name": "toy", "channels": channels,
            "fs_hz": data.fs_hz, "n_time": data.n_samples, "n_samples": n, "shard_size": n, "n_shards": 1,
            "pairs": {"toy": {"z_pinion": 13, "z_wheel": 29}}}
    (root / "metadata.json").write_text(json.dumps(meta))
    rows = data.labels.assign(sample_index=np.arange(n), pair="toy").to_dict(orient="records")
    x = np.stack([data.signals, data.reference], axis=1) if references else data.signals[:, None, :]
    write_shard(root, 0, x, rows, [])
    finalize(root)


def write_toy_measurement(folder, data, i: int = 0) -> None:
    """Record ``i`` of ``data`` and its reference as ``rec.npz`` / ``ref.npz`` with JSON sidecars (the pair
    described in full: spur-gds cut to 13 / 29 teeth); ``rec.json`` names ``ref.npz`` as its reference."""
    from datagen.geometry import preset

    folder.mkdir()
    pair = preset("spur-gds").to_dict()
    pair.update(name="toy13", pinion={**pair["pinion"], "teeth": 13, "profile_shift": 0.3, "bore_radius_mm": 6.0},
                wheel={**pair["wheel"], "teeth": 29, "bore_radius_mm": 15.0})
    side = {"pair": pair, "speed_rpm": float(data.labels.speed_rpm[i]), "torque_nm": 50.0, "fs_hz": data.fs_hz,
            "sensor": "acc"}
    for name, x in (("rec", data.signals[i]), ("ref", data.reference[i])):
        np.savez(folder / f"{name}.npz", acc=x)
        (folder / f"{name}.json").write_text(json.dumps({**side, **({"reference": "ref.npz"} if name == "rec" else {})}))


def evaluate_and_predict(model_dir, root, data, tmp_path, capsys):
    """What every referenced model must do through the CLI: ``gearpit evaluate`` on the toy dataset ``root`` (its
    training machines) scores >= 90 % healthy vs damaged, and ``gearpit predict`` reads a measurement file's
    reference from its sidecar and names a class. Returns the measurement folder (``rec``/``ref`` files)."""
    from gearpit.cli import main

    assert main(["evaluate", str(model_dir), str(root), "--out", str(tmp_path / "ev")]) == 0
    assert json.loads((tmp_path / "ev" / "metrics.json").read_text())["severity_class"]["accuracy"] >= 0.9
    meas = tmp_path / "meas"
    write_toy_measurement(meas, data)
    capsys.readouterr()
    rc = main(["predict", str(model_dir), str(meas / "rec.npz"), "--json", "--sidecar-speed"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert json.loads(cap.out.strip().splitlines()[-1])["severity_class"] in ("healthy", "damaged")
    return meas
