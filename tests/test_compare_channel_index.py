"""Which channel a sidecar's ``sensor``/``tacho`` selects: a 0-based index counts the file's channels in the order
the file holds them (compare.formats, compare.array_files, compare.measurement).

Source of truth: the README's table of measurement files and the sidecar key ``sensor`` ("channel name or 0-based
column index"); each test writes its own small file with one tone among other channels and checks that the tone is
the channel read (exactly: the samples are compared, no tolerance beyond float storage).
"""
from __future__ import annotations

import numpy as np
import pytest

from compare.measurement import Sidecar, load_measurement
from gearpit.errors import InputError

FS = 5000.0
N = 5000   # 1 s: at 1500 rpm the spur-gds wheel turns 7.25 times


def _tone_and_others(k, seed=0):
    """``k`` channels of noise and a 725 Hz tone."""
    rng = np.random.default_rng(seed)
    tone = np.sin(2 * np.pi * 725.0 * np.arange(N) / FS)
    return tone, [0.1 * rng.standard_normal(N) for _ in range(k)]


def _side(**extra):
    return Sidecar.from_dict({"speed_rpm": 1500.0, "torque_nm": 20.0, "pair": "spur-gds", **extra})


def _mat73(path, items, *, track_order=False, fields=None):
    """A MAT v7.3 file (HDF5 after a 512-byte MATLAB header); ``items`` top-level vectors or one struct (a dict);
    ``fields``: the struct's MATLAB_fields attribute (the order MATLAB keeps its fields in)."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512, track_order=track_order) as f:
        for k, v in items.items():
            if isinstance(v, dict):
                g = f.create_group(k)
                g.attrs["MATLAB_class"] = np.bytes_("struct")
                if fields is not None:
                    g.attrs.create("MATLAB_fields", [np.array(list(n), dtype="S1") for n in fields],
                                   dtype=h5py.vlen_dtype(np.dtype("S1")))
                for kk, vv in v.items():
                    g.create_dataset(kk, data=np.asarray(vv)[None, :])
            else:
                f.create_dataset(k, data=np.asarray(v)[None, :])
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(116) + b"\0" * 8 + b"\x00\x02IM")


def test_an_npz_index_counts_its_arrays_in_the_order_written(tmp_path):
    """np.savez(vib=..., aux=...) with sensor = 0 reads vib (it read aux: the keys were sorted)."""
    tone, (other,) = _tone_and_others(1)
    np.savez(tmp_path / "r.npz", vib=tone, aux=other, fs_hz=FS)
    m = load_measurement(tmp_path / "r.npz", _side(sensor=0, tacho=1))
    assert (m.sensor, m.tacho, tuple(m.channels)) == ("vib", "aux", ("vib", "aux"))
    np.testing.assert_array_equal(m.signal, tone)


def test_a_mat_v5_index_counts_its_variables_in_the_order_written(tmp_path):
    """Channel_1 .. Channel_11 with sensor = 1 reads Channel_2 (it read Channel_10, sorted as text)."""
    from scipy.io import savemat

    tone, others = _tone_and_others(10)
    chans = {f"Channel_{k}": (tone if k == 2 else others.pop()) for k in range(1, 12)}
    savemat(tmp_path / "r.mat", {**chans, "fs": FS})
    m = load_measurement(tmp_path / "r.mat", _side(sensor=1))
    assert m.sensor == "Channel_2"
    np.testing.assert_array_equal(m.signal, tone)


def test_a_mat_v73_index_follows_the_stored_order_and_is_refused_where_none_is_stored(tmp_path):
    """HDF5 lists members by name unless the file tracks their creation order: with the order tracked, or a
    struct's MATLAB_fields, an index counts in the file's order; with neither, an index is refused and asks for a
    name (a name still reads)."""
    tone, (other,) = _tone_and_others(1)
    _mat73(tmp_path / "tracked.mat", {"vib": tone, "aux": other, "fs": np.array([FS])}, track_order=True)
    assert load_measurement(tmp_path / "tracked.mat", _side(sensor=0)).sensor == "vib"
    _mat73(tmp_path / "fields.mat", {"meas": {"vib": tone, "aux": other, "fs": np.array([FS])}},
           fields=["vib", "aux", "fs"])
    m = load_measurement(tmp_path / "fields.mat", _side(sensor=0))
    assert m.sensor == "vib"
    np.testing.assert_array_equal(m.signal, tone)
    _mat73(tmp_path / "plain.mat", {"vib": tone, "aux": other, "fs": np.array([FS])})
    with pytest.raises(InputError, match=r"sensor: got 0; allowed: a channel name \(this MAT v7.3 .* does not "
                                         r"store the order of its variables.*one of aux, vib"):
        load_measurement(tmp_path / "plain.mat", _side(sensor=0))
    np.testing.assert_array_equal(load_measurement(tmp_path / "plain.mat", _side(sensor="vib")).signal, tone)


def _csv_time_acc_noise(path, header="time_s,acc,noise"):
    tone, (noise,) = _tone_and_others(1)
    t = np.arange(N) / FS
    np.savetxt(path, np.column_stack([t, tone, noise]), delimiter=",", header=header, comments="", fmt="%.10g")
    return tone, noise


def test_a_csv_index_counts_the_columns_as_written_and_the_time_column_is_no_channel(tmp_path):
    """Header time_s,acc,noise: sensor = 1 is acc and tacho = 2 noise (they read noise and nothing: the index was
    counted after the time column was taken out); sensor = 0, the time column, is refused naming it."""
    f = tmp_path / "r.csv"
    tone, noise = _csv_time_acc_noise(f)
    m = load_measurement(f, _side(sensor=1, tacho=2))
    assert (m.sensor, m.tacho, m.fs_hz) == ("acc", "noise", pytest.approx(FS))
    np.testing.assert_allclose(m.signal, tone, rtol=1e-9)
    with pytest.raises(InputError, match=r"sensor: got 0; allowed: a data column: column 0 \(time_s\) is the time "
                                         r"column.*1 \(acc\), 2 \(noise\)"):
        load_measurement(f, _side(sensor=0))
    with pytest.raises(InputError, match=r"sensor: got 3; allowed: a column index in \[0, 2\]"):
        load_measurement(f, _side(sensor=3))


def test_a_headerless_csv_whose_sidecar_names_its_time_column_counts_it_too(tmp_path):
    """channels = ["t", "acc", "noise"] for a file without names: sensor = 1 is acc, as written."""
    f = tmp_path / "r.txt"
    tone, _ = _csv_time_acc_noise(f, header="")
    f.write_text(f.read_text().lstrip("\n"))
    m = load_measurement(f, _side(channels=["t", "acc", "noise"], sensor=1))
    assert (m.sensor, tuple(m.channels)) == ("acc", ("acc", "noise"))
    np.testing.assert_allclose(m.signal, tone, rtol=1e-9)


def test_a_classifier_reads_the_same_channel_for_an_index(tmp_path):
    """gearpit predict/evaluate read measurement files through models.measurement_files: sensor = 1 of
    time_s,acc,noise is the tone there too (correlation with the tone > 0.99, with noise < 0.1)."""
    from models.measurement_files import load_measurement_groups

    f = tmp_path / "r.csv"
    tone, noise = _csv_time_acc_noise(f)
    (tmp_path / "r.toml").write_text('speed_rpm = 1500.0\ntorque_nm = 20.0\npair = "spur-gds"\nsensor = 1\n')
    groups = load_measurement_groups([f], refine_speed=False)
    x = groups.sets[0].signals[0].astype(float)
    n = x.size
    assert abs(np.corrcoef(x, tone[:n])[0, 1]) > 0.99 and abs(np.corrcoef(x, noise[:n])[0, 1]) < 0.1


def test_two_columns_of_one_name_are_refused_naming_them(tmp_path):
    """Header time_s,acc [g],acc [g]: the second column had replaced the first under the one name, read by name
    or by index alike; refused naming the name and its columns (as written), whatever selects the sensor; the
    sidecar's channels name them apart."""
    f = tmp_path / "r.csv"
    tone, noise = _csv_time_acc_noise(f, header="time_s,acc [g],acc [g]")
    for ref in ("acc [g]", 1, 2):
        with pytest.raises(InputError, match=r"r.csv: column names: got \"'acc \[g\]' \(columns 1, 2\)\""):
            load_measurement(f, _side(sensor=ref))
    m = load_measurement(f, _side(channels=["acc_a", "acc_b"], sensor=1))
    assert (m.sensor, tuple(m.channels)) == ("acc_a", ("acc_a", "acc_b"))
    np.testing.assert_allclose(m.signal, tone, rtol=1e-9)
