"""Readers of files that store sample arrays: NPY, NPZ, WAV and MAT (v5 and v7.3/HDF5), each into a
:class:`compare.raw_record.RawRecord` (the layout is chosen by :func:`compare.formats.read_record`).

- NPY: a 1-D array (one channel) or 2-D (the longer axis is time).
- NPZ: one 2-D array, or several equal-length 1-D arrays (one channel each, named by
  key, in the order saved); a scalar ``fs_hz`` or ``fs`` entry gives the sampling rate
  (:data:`FS_KEYS`, a number or a text holding one; several must agree, :func:`_scalar_fs`).
- WAV: :func:`scipy.io.wavfile.read` (integer samples scaled to [-1, 1)).
- MAT: :func:`scipy.io.loadmat`; v7.3 files (HDF5) through ``h5py``. Numeric
  variables as in NPZ (text, logical and empty ones are no channel; in v7.3 by their
  ``MATLAB_class`` and ``MATLAB_empty`` attributes); a scalar ``fs``, ``fs_hz`` or ``Fs`` gives the
  sampling rate.
- NPZ and MAT alike: structs (MATLAB structs, HDF5 groups) are flattened, each variable
  named by its own name unless another has it too (then its dotted path, ``run1.acc``), in
  the file's order (MAT v7.3: where the file stores it, else :attr:`RawRecord.no_index`);
  a uniform ``time``/``t`` vector (``time_ms`` ...) gives the rate and is no channel.

A file is read whole and never unpickled; one its library cannot read (truncated, empty, corrupt) is refused
with a one-line :class:`gearpit.errors.InputError`.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from compare.raw_record import RawRecord
from compare.text_records import column_fs, seconds_per_unit
from gearpit.errors import InputError, require

#: names of an NPZ/MAT entry (at any struct depth) that gives the sampling rate (Hz)
FS_KEYS = ("fs_hz", "fs", "Fs", "FS", "sample_rate", "sampling_rate")

#: MATLAB classes of numeric arrays (a v7.3 dataset's ``MATLAB_class``): the ones read as data
MATLAB_NUMERIC_CLASSES = ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
                          "uint64")


def _unreadable(path: Path, kind: str, exc: BaseException) -> InputError:
    """The one-line error for a file its reader library could not read (truncated, empty, corrupt)."""
    if "allow_pickle" in str(exc):
        return InputError("measurement", str(path), f"numeric arrays only ({kind}: it holds an object array, "
                          "which only unpickling could read, and gearpit never unpickles a file)")
    return InputError("measurement", str(path), f"a readable {kind} file ({type(exc).__name__}: {exc})")


def _load_numpy(path: Path, kind: str):
    """An NPY array, or an NPZ file's arrays as a dict in the order saved, read whole, never unpickled."""
    try:
        if kind == "NPY":
            return np.load(path, allow_pickle=False)
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception as exc:   # noqa: BLE001 - numpy, zipfile and zlib raise many types on a damaged file
        raise _unreadable(path, kind, exc) from None


def _from_array(a: np.ndarray, names, where: str) -> RawRecord:
    a = np.asarray(a)
    require(a.dtype.kind in "fiu" and a.ndim in (1, 2) and a.size > 0, where, f"{a.dtype} {a.shape}",
            "a numeric 1-D or 2-D array")
    a = a.astype(float)
    if a.ndim == 1:
        a = a[:, None]
    elif a.shape[0] < a.shape[1]:  # the longer axis is time
        a = a.T
    names = tuple(names) if names is not None else tuple(f"ch{i}" for i in range(a.shape[1]))
    return RawRecord(names, a, None)


def _scalar_fs(mapping: dict, where: str, fs_hz: float | None = None) -> float | None:
    """The sampling rate (Hz) an NPZ/MAT file states: every entry named as in :data:`FS_KEYS` at any struct depth
    (``fs``, ``run1.fs``, ``sample_rate``), a number or a text holding one (``"12800"``, ``"12800 Hz"``); None if
    there is none. Entries that disagree (two structs' ``fs``, ``fs`` and ``sample_rate``) are refused naming
    each, unless the sidecar's ``fs_hz`` is one of them: None then, the sidecar's rate is used."""
    found = {path: _rate(v, f"{where}:{path}") for path, v in _leaves(mapping)
             if path.rsplit(".", 1)[-1] in FS_KEYS}
    rates = set(found.values())
    if len(rates) <= 1:
        return next(iter(rates), None)
    if fs_hz is not None and any(abs(r - fs_hz) <= 1e-3 * fs_hz for r in rates):
        return None
    named = ", ".join(f"{k} = {v:g}" for k, v in found.items())
    raise InputError(f"{where}: sampling rate", named,
                     "one rate: these entries of the file disagree, so which is the record's is not known; give it "
                     "as fs_hz in the sidecar" + (f" (its {fs_hz:g} Hz is none of them)" if fs_hz is not None else ""))


def _rate(value, where: str) -> float:
    """A sampling rate entry as a number (Hz): a numeric scalar, or a text holding one (``"12800"``, ``"12.8e3
    Hz"``)."""
    a = np.asarray(value)
    if a.dtype.kind in "US" and a.size == 1:
        text = a.ravel()[0]
        text = text.decode("utf-8", "replace") if isinstance(text, bytes) else str(text)
        m = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:hz)?\s*", text, re.IGNORECASE)
        require(m is not None, where, text, "a sampling rate in Hz: a number, or a text holding one ('12800')")
        return float(m.group(1))
    require(a.dtype.kind in "fiu" and a.size == 1, where, a.ravel().tolist()[:4] if a.dtype.kind != "O" else a.dtype,
            "a scalar sampling rate (Hz)")
    return float(a.ravel()[0])


def _leaves(mapping: dict, prefix: str = ""):
    """``(dotted path, value)`` of every entry of a file's mapping, structs (dicts) walked into."""
    for k, v in mapping.items():
        if k.startswith("__"):
            continue
        if isinstance(v, dict):
            yield from _leaves(v, f"{prefix}{k}.")
        else:
            yield prefix + k, v


def _flatten(mapping: dict, prefix: str = "") -> dict:
    """Nested structs (a MAT struct, an HDF5 group) as one level: ``{"data.acc": ...}``; numeric leaves only."""
    out = {}
    for k, v in mapping.items():
        if k.startswith("__"):
            continue
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
            continue
        try:
            a = np.asarray(v)
        except (ValueError, TypeError):     # ragged cell arrays
            continue
        if a.dtype.kind in "fiu":
            out[prefix + k] = a
    return out


def _from_mapping(mapping: dict, variable: str | None, where: str, fs_hz: float | None = None,
                  unordered: frozenset = frozenset()) -> RawRecord:
    """Numeric variables of an NPZ/MAT file, in the file's order (``mapping``'s); nested structs flattened (a
    variable keeps its own name when no other leaf has it, else its dotted path); a scalar ``fs`` or a uniform
    ``time``/``t`` vector gives the rate. ``unordered``: dotted paths of the structs (``""``: the file) whose
    members' order the file does not store; channels that only they order get no index (:attr:`RawRecord.no_index`)."""
    flat = _flatten(mapping)
    leaf = [k.rsplit(".", 1)[-1] for k in flat]
    named = {(lf if leaf.count(lf) == 1 else k): v for k, lf, v in zip(flat, leaf, flat.values())}
    fs = _scalar_fs(mapping, where, fs_hz)
    arrays = {k: v for k, v in named.items() if k not in FS_KEYS and v.size > 1}
    times = [k for k, v in arrays.items() if seconds_per_unit(k.rsplit(".", 1)[-1]) is not None
             and np.squeeze(v).ndim == 1 and k != variable]
    if len(times) == 1:
        t = arrays.pop(times[0])
        fs_t = column_fs(np.squeeze(t), f"{where}:{times[0]}", unit_s=seconds_per_unit(times[0].rsplit(".", 1)[-1]),
                         fs_hz=fs_hz)
        if fs is not None and fs_t is not None:
            require(abs(fs_t - fs) <= 0.01 * fs, f"{where}:{times[0]}", f"a rate of {fs_t:.6g} Hz",
                    f"the file's fs ({fs:.6g} Hz) within 1 %")
        fs = fs if fs is not None or fs_t is None else fs_t
    if variable is not None:
        require(variable in arrays, "variable", variable, "one of: " + ", ".join(sorted(arrays)))
        rec = _from_array(arrays[variable], None, f"{where}:{variable}")
        return RawRecord(rec.names, rec.data, fs)
    require(arrays, where, "no numeric arrays", "at least one numeric array")
    matrices = {k: v for k, v in arrays.items() if np.squeeze(v).ndim == 2}
    if len(matrices) == 1 and len(arrays) == 1:
        rec = _from_array(np.squeeze(next(iter(matrices.values()))), None, where)
        return RawRecord(rec.names, rec.data, fs)
    vectors = {k: np.squeeze(v) for k, v in arrays.items() if np.squeeze(v).ndim == 1}
    require(vectors and not matrices, where, sorted(arrays),
            "one 2-D array, or 1-D arrays of equal length (else name one with 'variable')")
    lengths = {v.size for v in vectors.values()}
    require(len(lengths) == 1, where, {k: v.size for k, v in vectors.items()}, "1-D arrays of equal length")
    names = tuple(vectors)       # the file's order: a column index counts them as written
    paths = {k: p for k, p in zip(named, flat)}
    unknown = sorted({_common_struct(paths[a], paths[b]) for i, a in enumerate(names) for b in names[i + 1:]}
                     & set(unordered))
    no_index = ("this MAT v7.3 (HDF5) file does not store the order of "
                + " or ".join(f"struct {u}'s fields" if u else "its variables" for u in unknown)) if unknown else ""
    return RawRecord(names, np.column_stack([vectors[k].astype(float) for k in names]), fs, no_index=no_index)


def _common_struct(a: str, b: str) -> str:
    """The dotted path of the innermost struct holding both leaves ``a`` and ``b`` (``""``: the file's top level)."""
    pa, pb = a.split(".")[:-1], b.split(".")[:-1]
    n = 0
    while n < min(len(pa), len(pb)) and pa[n] == pb[n]:
        n += 1
    return ".".join(pa[:n])


def read_npy(path: Path) -> RawRecord:
    """NPY file: one numeric 1-D or 2-D array (module docstring)."""
    return _from_array(_load_numpy(path, "NPY"), None, str(path))


def read_npz(path: Path, variable: str | None = None, *, fs_hz: float | None = None) -> RawRecord:
    """NPZ file: its numeric arrays as channels, or ``variable`` alone (module docstring); ``fs_hz``: the
    sidecar's rate, if it gives one (:func:`_scalar_fs`)."""
    return _from_mapping(_load_numpy(path, "NPZ"), variable, str(path), fs_hz=fs_hz)


def read_wav(path: Path) -> RawRecord:
    """WAV file; integer PCM scaled to [-1, 1)."""
    from scipy.io import wavfile

    try:
        fs, data = wavfile.read(path)
    except ValueError as exc:
        raise InputError("measurement", str(path), f"a readable WAV file ({exc})") from None
    if data.dtype.kind in "iu":
        info = np.iinfo(data.dtype)
        data = (data.astype(float) - (info.max + info.min + 1) / 2) / ((info.max - info.min + 1) / 2)
    rec = _from_array(data, None, str(path))
    return RawRecord(rec.names, rec.data, float(fs))


def read_mat(path: Path, variable: str | None = None, *, fs_hz: float | None = None) -> RawRecord:
    """MATLAB file: v4-v7.2 through scipy, v7.3 (HDF5) through h5py."""
    import scipy.io

    try:
        mapping = scipy.io.loadmat(path, simplify_cells=True)
    except Exception as exc:   # noqa: BLE001 - v7.3 is HDF5 (NotImplementedError from scipy); a damaged v5 file
        mapping, unordered = _read_hdf5_mat(path, exc)     # raises anything from OSError to zlib.error
        return _from_mapping(mapping, variable, str(path), fs_hz=fs_hz, unordered=unordered)
    return _from_mapping(mapping, variable, str(path), fs_hz=fs_hz)     # scipy keeps the file's order


def _read_hdf5_mat(path: Path, exc: Exception) -> tuple[dict, frozenset]:
    try:
        import h5py
    except ImportError:  # pragma: no cover - h5py is a dependency
        raise InputError("measurement", str(path), "a MAT v7.3 file needs h5py (pip install h5py)") from None
    if not h5py.is_hdf5(path):
        raise _unreadable(path, "MAT", exc)
    unordered: set = set()
    try:
        with h5py.File(path, "r") as f:
            return _hdf5_group(f, h5py, unordered), frozenset(unordered)
    except Exception as exc73:   # noqa: BLE001 - h5py raises OSError, KeyError, RuntimeError on a damaged file
        raise _unreadable(path, "MAT v7.3 (HDF5)", exc73) from None


def _hdf5_group(group, h5py, unordered: set, path: str = "") -> dict:
    """A MAT v7.3 group (the file, a struct) as nested dicts of its numeric datasets, in the order MATLAB wrote
    them where the file stores it (a struct's ``MATLAB_fields`` attribute, or HDF5 link creation order); the
    dotted path of a group with more than one member whose order is not stored is added to ``unordered``.
    A dataset's ``MATLAB_class`` says what it holds: a char array (uint16 code units) is read as text, an empty
    array (``MATLAB_empty``, stored as its dimensions), a logical or any other class is no data; a dataset without
    the attribute (written by another HDF5 tool) is data if it is numeric."""
    keys = list(group.keys())       # h5py lists members in creation order where it is tracked, else by name
    fields = [_matlab_text(f) for f in group.attrs.get("MATLAB_fields", ())]
    tracked = (group["/"] if isinstance(group, h5py.File) else group).id.get_create_plist().get_link_creation_order()
    if fields and set(keys) <= set(fields):
        keys = [k for k in fields if k in keys]
    elif not tracked and len(keys) > 1:
        unordered.add(path)
    out = {}
    for k in keys:
        v = group[k]
        if isinstance(v, h5py.Group) and not k.startswith("#"):
            out[k] = _hdf5_group(v, h5py, unordered, f"{path}.{k}" if path else k)
        elif isinstance(v, h5py.Dataset) and not v.attrs.get("MATLAB_empty", 0):    # [] is stored as its dims
            cls = _matlab_text(v.attrs.get("MATLAB_class", b""))
            if cls == "char":                                   # text (uint16 code units), never a channel
                out[k] = "\n".join("".join(map(chr, row)) for row in np.atleast_2d(np.asarray(v[()]).T))
            elif cls in MATLAB_NUMERIC_CLASSES + ("",) and v.dtype.kind in "fiu":
                out[k] = np.asarray(v[()]).T  # MATLAB stores column-major
    return out


def _matlab_text(value) -> str:
    """A name as MATLAB stores it in an HDF5 attribute (an array of single bytes, bytes or str)."""
    if isinstance(value, np.ndarray):
        return b"".join(np.asarray(value).ravel().tolist()).decode("utf-8", "replace") if value.dtype.kind == "S" \
            else "".join(map(str, value.ravel().tolist()))
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)
