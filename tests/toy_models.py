"""A small model trained the user's way (``gearpit train``) on a toy signal set, for the tests of the
measurement-file paths (``tests/test_models_measurement_files.py``, ``tests/test_models_sensor_unit.py``)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from gearpit.cli import main


def trained_toy_model(root: Path, data, fs_hz: float, *, model: str = "logreg") -> Path:
    """``data`` (a :class:`models.data.SignalSet` of the spur-gds pair, one acceleration channel) written as a
    one-shard dataset under ``root / "ds"`` and trained by ``gearpit train --model model``; the model folder."""
    from datagen.dataset import finalize, write_shard

    ds = root / "ds"
    (ds / "shards").mkdir(parents=True)
    n = len(data)
    meta = {"format": "gearpit-dataset", "format_version": 1, "name": "toy", "channels": ["acc_m_s2"],
            "fs_hz": fs_hz, "n_time": data.n_samples, "n_samples": n, "shard_size": n, "n_shards": 1,
            "pairs": {"spur-gds": {"z_pinion": 29, "z_wheel": 100}}}
    (ds / "metadata.json").write_text(json.dumps(meta))
    write_shard(ds, 0, data.signals[:, None, :], data.labels.assign(sample_index=np.arange(n), pair="spur-gds")
                .to_dict(orient="records"), [])
    finalize(ds)
    assert main(["train", str(ds), "--out", str(root / "m"), "--model", model]) == 0
    return root / "m"
