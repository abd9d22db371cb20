"""Saving and loading trained models without pickling any Python object.

A model is a directory:

- ``model.json``: the :class:`~models.spec.ModelSpec` (input spec, class names,
  ranges, training configuration and history), and under ``files`` the size and
  SHA-256 of every other file written with it; written last;
- CNN: ``weights.pt``, the network's ``state_dict`` (tensors only), read back with
  ``torch.load(..., weights_only=True)``, which refuses anything but tensors and
  plain containers;
- ``novelty.npz`` (optional): the novelty model of :mod:`models.novelty` (class means, precision matrix,
  held-out distances), read with ``numpy.load(..., allow_pickle=False)``;
- feature baselines: ``arrays.npz`` (fitted parameters as plain arrays: scaler,
  linear coefficients, tree node tables; see :mod:`models.baselines`), read with
  ``numpy.load(..., allow_pickle=False)``.

Every file is written whole or not at all (:func:`gearpit.atomic.atomic_path`), and
its bytes depend on its content only (``weights.pt`` is serialised in memory, so
its archive holds no temporary name; an ``.npz`` member carries a fixed date):
the same training gives the same files. Loading checks every file against the
digest ``model.json`` recorded (a file copied in from another model directory
is refused by name), then that it can be read and that its tensors fit the spec.
A model saved before the digests were recorded is loaded without that check.
"""
from __future__ import annotations

import hashlib
import io
import json
import pickle
import zipfile
import zlib
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
#: key of ``model.json`` holding ``file name -> {"bytes": n, "sha256": hex}`` of the files written with it
FILES_KEY = "files"
#: what reading a damaged torch or npz file raises (a truncated zip, a pickled object refused, ...)
_READ_ERRORS = (OSError, EOFError, ValueError, RuntimeError, KeyError, pickle.UnpicklingError, zipfile.BadZipFile,
                zlib.error)


def check_out_dir(path: str | Path, field: str, *, file: bool = False) -> Path:
    """``path`` as a directory to write into (``file``: as a file to write): refused, naming ``field`` and the path,
    when it is an existing file (``file``: an existing directory) or its nearest existing parent is a file."""
    out = Path(path)
    if file:
        require(not out.is_dir(), field, str(out), "a file to write (this is a directory)")
    for p in (out.parents if file else (out, *out.parents)):
        if p.exists():
            require(p.is_dir(), field, str(out), ("a file path in a directory" if file else
                                                  "a directory (or a path to create)")
                    + ("" if p == out else f"; {p} is a file"))
            break
    return out


def save_model(model, path: str | Path) -> Path:
    """Write ``model`` (a :class:`CNNClassifier` or :class:`models.baselines.FeatureClassifier`) to directory ``path``."""
    from models.baselines import FeatureClassifier

    out = check_out_dir(path, "MODEL")
    if isinstance(model, CNNClassifier):
        files = {WEIGHTS_FILE: _torch_bytes(model.network.state_dict())}
        if model.novelty is not None:
            files[NOVELTY_FILE] = _npz_bytes(model.novelty.to_arrays())
    elif isinstance(model, FeatureClassifier):
        files = {ARRAYS_FILE: _npz_bytes(model.arrays)}
    else:
        raise InputError("model", type(model).__name__, "a CNNClassifier or FeatureClassifier")
    out.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        with atomic_path(out / name) as tmp:
            tmp.write_bytes(data)
    if isinstance(model, CNNClassifier) and model.novelty is None:
        (out / NOVELTY_FILE).unlink(missing_ok=True)    # a stale one of an earlier model
    doc = {**model.spec.to_dict(), FILES_KEY: {name: _digest(data) for name, data in files.items()}}
    with atomic_path(out / SPEC_FILE) as tmp:
        tmp.write_text(json.dumps(doc, indent=1, sort_keys=True))
    return out


def read_spec(path: str | Path) -> ModelSpec:
    """The :class:`ModelSpec` of a saved model directory."""
    return _read_model_json(path)[0]


def load_model(path: str | Path):
    """Load a model saved by :func:`save_model`; never unpickles arbitrary objects.

    Raises
    ------
    InputError
        Naming the file: missing, not the one ``model.json`` was written with (digest), unreadable (truncated or
        corrupt), or holding tensors / arrays that do not fit ``model.json``.
    """
    from models.baselines import FeatureClassifier

    spec, digests = _read_model_json(path)
    if spec.model_type == "cnn":
        raw = _read_checked(path, WEIGHTS_FILE, digests)
        try:
            state = torch.load(io.BytesIO(raw), map_location="cpu", weights_only=True)
        except _READ_ERRORS as exc:
            raise _unreadable(path, WEIGHTS_FILE, exc) from None
        net = build_network(spec)
        _check_state(path, state, net.state_dict())
        net.load_state_dict(state)
        net.eval()
        return CNNClassifier(net, spec, _load_novelty(path, spec, digests))
    arrays = _read_npz(path, ARRAYS_FILE, _read_checked(path, ARRAYS_FILE, digests))
    n_features = len(spec.representation.get("feature_names", ()))
    impute = arrays.get("impute")
    require(impute is not None and impute.shape == (n_features,), ARRAYS_FILE, str(Path(path) / ARRAYS_FILE),
            f"the arrays of a baseline with the {n_features} features of {SPEC_FILE} (these have "
            f"{'no impute array' if impute is None else f'{impute.size} features'}: another model's?)")
    return FeatureClassifier(spec, arrays)


def _read_model_json(path: str | Path) -> tuple[ModelSpec, dict | None]:
    """The spec and the recorded file digests (None for a model saved before they were recorded)."""
    p = Path(path) / SPEC_FILE
    require(p.is_file(), "MODEL", str(path), f"a model directory containing {SPEC_FILE}")
    try:
        doc = json.loads(p.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(SPEC_FILE, str(p), f"valid JSON ({exc})") from None
    digests = doc.pop(FILES_KEY, None) if isinstance(doc, dict) else None
    require(digests is None or isinstance(digests, dict), f"{SPEC_FILE}.{FILES_KEY}", digests,
            "a table of file name -> size and SHA-256")
    return ModelSpec.from_dict(doc), digests


def _digest(data: bytes) -> dict:
    return {"bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}


def _read_checked(path: str | Path, name: str, digests: dict | None) -> bytes:
    """The bytes of ``name`` in the model directory, checked against the digest recorded in ``model.json``."""
    f = Path(path) / name
    require(f.is_file(), "MODEL", str(path), f"a model directory containing {name}")
    data = f.read_bytes()
    if digests is None:          # saved before the digests were recorded: nothing to check against
        return data
    want = digests.get(name)
    require(want is not None, name, str(f), f"a file written with this {SPEC_FILE} (it records none: "
            "copied in from another model directory?)")
    if _digest(data) != want:
        size = f"{len(data)} bytes, {SPEC_FILE} records {want.get('bytes')}" if len(data) != want.get("bytes") \
            else "same size, other content"
        raise InputError(name, str(f), f"the file written with this {SPEC_FILE} (SHA-256 differs, {size}: "
                         "copied from another model directory, or damaged since)")
    return data


def _unreadable(path: str | Path, name: str, exc: Exception) -> InputError:
    detail = str(exc).strip().splitlines()[0][:160] if str(exc).strip() else type(exc).__name__
    return InputError(name, str(Path(path) / name), f"a readable file written by gearpit train; this one is "
                      f"unreadable (truncated or corrupt: {detail})")


def _check_state(path: str | Path, state, expected: dict) -> None:
    """Refuse a ``state_dict`` whose tensor names or shapes differ from the network ``model.json`` describes."""
    f = str(Path(path) / WEIGHTS_FILE)
    require(isinstance(state, dict) and all(isinstance(v, torch.Tensor) for v in state.values()), WEIGHTS_FILE, f,
            "a state_dict of tensors (this file holds something else)")
    problems = [f"{k}: stored {list(state[k].shape)}, {SPEC_FILE} needs {list(v.shape)}"
                for k, v in expected.items() if k in state and state[k].shape != v.shape]
    missing = [k for k in expected if k not in state]
    extra = [k for k in state if k not in expected]
    problems += ([f"missing {', '.join(missing[:3])}"] if missing else []) + \
        ([f"unexpected {', '.join(extra[:3])}"] if extra else [])
    require(not problems, WEIGHTS_FILE, f, f"tensors that match {SPEC_FILE}; these do not ("
            + "; ".join(problems[:3]) + (f"; {len(problems) - 3} more" if len(problems) > 3 else "")
            + "): the weights of another model?")


def _torch_bytes(state: dict) -> bytes:
    """``torch.save`` of ``state`` into memory: the archive's inner name is torch's fixed one, not a file name."""
    buf = io.BytesIO()
    torch.save(state, buf)
    return buf.getvalue()


def _npz_bytes(arrays: dict) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _read_npz(path: str | Path, name: str, data: bytes) -> dict:
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except _READ_ERRORS as exc:
        raise _unreadable(path, name, exc) from None


def _load_novelty(path: str | Path, spec: ModelSpec, digests: dict | None):
    """The saved novelty model, or None for a model saved without one."""
    f = Path(path) / NOVELTY_FILE
    if digests is not None and NOVELTY_FILE not in digests:
        require(not f.is_file(), NOVELTY_FILE, str(f), f"no such file: this model was saved without a novelty check "
                f"({SPEC_FILE} records none; copied in from another model directory?)")
        return None
    if not f.is_file():
        return None
    arrays = _read_npz(path, NOVELTY_FILE, _read_checked(path, NOVELTY_FILE, digests))
    try:
        model = NoveltyModel.from_arrays(arrays)
    except InputError as exc:
        raise _unreadable(path, NOVELTY_FILE, exc) from None
    recorded = spec.training.get("novelty")
    if isinstance(recorded, dict) and "n_features" in recorded:
        shape = (recorded.get("n_classes"), recorded["n_features"])
        require(tuple(model.means.shape) == shape, NOVELTY_FILE, str(f),
                f"class means of shape {list(shape)} as {SPEC_FILE} records (these are "
                f"{list(model.means.shape)}: another model's?)")
    return model
