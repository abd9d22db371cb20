"""NPY, NPZ and MAT files as they arrive damaged or written by MATLAB: one-line refusals, never a traceback and
never an unpickled object; MAT v7.3 structs with text and empty fields; the rate stored in the file
(compare.array_files).

Source of truth: the README's table of measurement files ("Refused with one line naming the field") and the MAT
v7.3 layout MATLAB writes (HDF5; a char array is a uint16 dataset with attribute MATLAB_class = "char", an empty
array a dataset of its dimensions with MATLAB_empty = 1). Each test writes its own small files.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from compare.measurement import Sidecar, load_measurement
from gearpit.cli import main
from gearpit.errors import InputError

FS = 5000.0
N = 5000   # 1 s: at 1500 rpm the spur-gds wheel turns 7.25 times
TONE = np.sin(2 * np.pi * 725.0 * np.arange(N) / FS)


def _side(**extra):
    return Sidecar.from_dict({"speed_rpm": 1500.0, "torque_nm": 20.0, "pair": "spur-gds", **extra})


class _Marker:
    """Unpickling this touches a file: proof that a loader unpickled."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (Path.touch, (Path(self.path),))


def _damaged(tmp_path, kind):
    """A file of ``kind`` as a crash, a copy or a careless save leaves it."""
    from scipy.io import savemat

    p = tmp_path / f"{kind}.{kind.split('_')[0]}"
    if kind == "npy_truncated":
        np.save(p, TONE)
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    elif kind == "npy_empty":
        p.write_bytes(b"")
    elif kind == "npy_object":
        np.save(p, np.array([TONE, _Marker(tmp_path / "unpickled")], dtype=object), allow_pickle=True)
    elif kind == "npz_object":
        np.savez(p, acc=TONE, meta=np.array([_Marker(tmp_path / "unpickled")], dtype=object), fs_hz=FS)
    elif kind == "npz_truncated":
        np.savez(p, acc=TONE, fs_hz=FS)
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    elif kind == "mat_truncated":
        savemat(p, {"acc": TONE, "fs": FS})
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    elif kind == "mat_empty":
        p.write_bytes(b"")
    elif kind == "mat_v73_truncated":
        h5py = pytest.importorskip("h5py")
        with h5py.File(p, "w", userblock_size=512) as f:
            f["acc"] = TONE[None, :]
            f["fs"] = np.array([[FS]])
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    return p


KINDS = ("npy_truncated", "npy_empty", "npy_object", "npz_object", "npz_truncated", "mat_truncated", "mat_empty",
         "mat_v73_truncated")


@pytest.mark.parametrize("kind", KINDS)
def test_a_damaged_or_object_file_is_refused_in_one_line_and_never_unpickled(tmp_path, kind):
    """Each raised numpy's, scipy's or zipfile's own error (a traceback, exit 1); now an InputError naming the
    file, and an object array is never unpickled (the marker file it would touch stays absent)."""
    p = _damaged(tmp_path, kind)
    allowed = "numeric arrays only" if kind.endswith("object") else "a readable"
    with pytest.raises(InputError, match=rf"measurement: got '.*{p.name}'; allowed: {allowed}"):
        load_measurement(p, _side(fs_hz=FS, sensor=0))
    assert not (tmp_path / "unpickled").exists()


@pytest.mark.parametrize("kind", ["npy_truncated", "npz_object", "mat_truncated"])
def test_gearpit_compare_on_a_damaged_file_exits_2_with_one_line(tmp_path, capsys, kind):
    """The CLI's promise: exit code 2 and one stderr line naming the file."""
    p = _damaged(tmp_path, kind)
    p.with_suffix(".toml").write_text('fs_hz = 5000.0\nspeed_rpm = 1500.0\ntorque_nm = 20.0\npair = "spur-gds"\n'
                                      'sensor = 0\n')
    assert main(["compare", str(p), "--no-attribution"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and p.name in err[0]


def _matlab73(path, struct: dict):
    """A MAT v7.3 file holding one struct ``meas`` as MATLAB writes it: each field a dataset with its
    MATLAB_class; ``struct`` maps field -> (array as MATLAB holds it, class, empty)."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        g = f.create_group("meas")
        g.attrs["MATLAB_class"] = np.bytes_("struct")
        for k, (v, cls, empty) in struct.items():
            ds = g.create_dataset(k, data=np.asarray(v).T)       # MATLAB stores column-major
            ds.attrs["MATLAB_class"] = np.bytes_(cls)
            if empty:
                ds.attrs["MATLAB_empty"] = np.uint8(1)
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(116) + b"\0" * 8 + b"\x00\x02IM")


def test_a_matlab_v73_struct_with_text_empty_and_logical_fields_reads_its_numeric_fields_only(tmp_path):
    """meas.acc, meas.fs with meas.unit = 'm/s^2' (char: uint16 code units), meas.comment = [] (stored as its
    dimensions [0 0] with MATLAB_empty), meas.valid = true(1, n) (logical, uint8): refused before as "1-D arrays
    of equal length {'acc': 5000, 'unit': 5}" or read with valid as a channel; now acc is the one channel, as
    from the same struct saved as v5."""
    unit = np.array([[ord(c) for c in "m/s^2"]], dtype=np.uint16)
    _matlab73(tmp_path / "r.mat", {"acc": (TONE[None, :], "double", False), "fs": (np.array([[FS]]), "double", False),
                                   "unit": (unit, "char", False),
                                   "comment": (np.array([0, 0], dtype=np.uint64), "double", True),
                                   "valid": (np.ones((1, N), dtype=np.uint8), "logical", False)})
    m = load_measurement(tmp_path / "r.mat", _side())
    assert (tuple(m.channels), m.sensor, m.fs_hz) == (("acc",), "acc", FS)
    np.testing.assert_array_equal(m.signal, TONE)


def test_the_rate_an_npz_or_mat_file_states_is_read_as_text_too_and_disagreeing_entries_are_refused(tmp_path):
    """fs saved as text ("12800") was ignored (refused as no rate); fs = 5000 beside sample_rate = 10000 read the
    first silently; two structs' fs gave "give fs_hz in the sidecar" without saying why. Now: the text is read;
    agreeing entries give the rate; disagreeing ones are refused naming each, unless the sidecar's fs_hz is one of
    them."""
    from scipy.io import savemat

    np.savez(tmp_path / "text.npz", acc=TONE, fs=np.array("5000"))
    assert load_measurement(tmp_path / "text.npz", _side()).fs_hz == FS
    np.savez(tmp_path / "word.npz", acc=TONE, fs=np.array("fast"))
    with pytest.raises(InputError, match=r"word.npz:fs: got 'fast'; allowed: a sampling rate in Hz"):
        load_measurement(tmp_path / "word.npz", _side())
    np.savez(tmp_path / "two.npz", acc=TONE, fs=FS, sample_rate=2 * FS)
    with pytest.raises(InputError, match=r"two.npz: sampling rate: got 'fs = 5000, sample_rate = 10000'; "
                                         r"allowed: one rate: these entries of the file disagree.*fs_hz"):
        load_measurement(tmp_path / "two.npz", _side())
    assert load_measurement(tmp_path / "two.npz", _side(fs_hz=2 * FS)).fs_hz == 2 * FS
    with pytest.raises(InputError, match=r"its 7000 Hz is none of them"):
        load_measurement(tmp_path / "two.npz", _side(fs_hz=7000.0))
    savemat(tmp_path / "same.mat", {"run1": {"acc": TONE, "fs": FS}, "run2": {"acc": -TONE, "fs": FS}})
    m = load_measurement(tmp_path / "same.mat", _side(sensor="run1.acc"))
    assert m.fs_hz == FS
    np.testing.assert_array_equal(m.signal, TONE)
    savemat(tmp_path / "differ.mat", {"run1": {"acc": TONE, "fs": FS}, "run2": {"acc": -TONE, "fs": 2 * FS}})
    with pytest.raises(InputError, match=r"sampling rate: got 'run1.fs = 5000, run2.fs = 10000'"):
        load_measurement(tmp_path / "differ.mat", _side(sensor="run1.acc"))
