"""Saving and loading trained models without pickling any Python object.

A model is a directory:

- ``model.json``: the :class:`~models.spec.ModelSpec` (input spec, class names,
  ranges, training configuration and history), written last;
- CNN: ``weights.pt``, the network's ``state_dict`` (tensors only), read back with
  ``torch.load(..., weights_only=True)``, which refuses anything but tensors and
  plain containers;
- ``novelty.npz`` (optional): the novelty model of :mod:`models.novelty` (class means, precision matrix,
  held-out distances), read with ``numpy.load(..., allow_pickle=False)``;
- feature baselines: ``arrays.npz`` (fitted parameters as plain arrays: scaler,
  linear coefficients, tree node tables; see :mod:`models.baselines`), read with
  ``numpy.load(..., allow_pickle=False)``.

Every file is written whole or not at all (:func:`gearpit.atomic.atomic_path`).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from gearpit.atomic import atomic_path
from gearpit.errors import InputError, require
from models.classifier import CNNClassifier, build_network
from models.novelty import NOVELTY_FILE, NoveltyModel
from models.spec import ModelSpec

SPEC_FILE = "model.json"
WEIGHTS_FILE = "weights.pt"
ARRAYS_FILE = "arrays.npz"


def save_model(model, path: str | Path) -> Path:
    """Write ``model`` (a :class:`CNNClassifier` or :class:`models.baselines.FeatureClassifier`) to directory ``path``."""
    from models.baselines import FeatureClassifier

    out = Path(path)
    require(not out.exists() or out.is_dir(), "MODEL", str(out), "a directory (or a path to create)")
    out.mkdir(parents=True, exist_ok=True)
    if isinstance(model, CNNClassifier):
        with atomic_path(out / WEIGHTS_FILE) as tmp:
            torch.save(model.network.state_dict(), tmp)
        _save_novelty(model.novelty, out)
    elif isinstance(model, FeatureClassifier):
        with atomic_path(out / ARRAYS_FILE) as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, **model.arrays)
    else:
        raise InputError("model", type(model).__name__, "a CNNClassifier or FeatureClassifier")
    with atomic_path(out / SPEC_FILE) as tmp:
        tmp.write_text(json.dumps(model.spec.to_dict(), indent=1, sort_keys=True))
    return out


def read_spec(path: str | Path) -> ModelSpec:
    """The :class:`ModelSpec` of a saved model directory."""
    p = Path(path) / SPEC_FILE
    require(p.is_file(), "MODEL", str(path), f"a model directory containing {SPEC_FILE}")
    try:
        doc = json.loads(p.read_text())
    except json.JSONDecodeError as exc:
        raise InputError(SPEC_FILE, str(p), f"valid JSON ({exc})") from None
    return ModelSpec.from_dict(doc)


def load_model(path: str | Path):
    """Load a model saved by :func:`save_model`; never unpickles arbitrary objects."""
    from models.baselines import FeatureClassifier

    spec = read_spec(path)
    if spec.model_type == "cnn":
        w = Path(path) / WEIGHTS_FILE
        require(w.is_file(), "MODEL", str(path), f"a model directory containing {WEIGHTS_FILE}")
        state = torch.load(w, map_location="cpu", weights_only=True)
        net = build_network(spec)
        net.load_state_dict(state)
        net.eval()
        return CNNClassifier(net, spec, _load_novelty(path))
    a = Path(path) / ARRAYS_FILE
    require(a.is_file(), "MODEL", str(path), f"a model directory containing {ARRAYS_FILE}")
    with np.load(a, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    return FeatureClassifier(spec, arrays)


def _save_novelty(novelty, out: Path) -> None:
    """The novelty model's arrays (:mod:`models.novelty`), or no file when there is none (a stale one removed)."""
    target = out / NOVELTY_FILE
    if novelty is None:
        target.unlink(missing_ok=True)
        return
    with atomic_path(target) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **novelty.to_arrays())


def _load_novelty(path: str | Path):
    """The saved novelty model, or None for a model saved without one."""
    f = Path(path) / NOVELTY_FILE
    if not f.is_file():
        return None
    with np.load(f, allow_pickle=False) as z:
        return NoveltyModel.from_arrays({k: z[k] for k in z.files})
