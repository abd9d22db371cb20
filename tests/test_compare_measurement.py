"""Measurement loading: every file layout, the sidecar, and the refusals (compare.formats, compare.array_files,
compare.sidecar, compare.measurement).

Source of truth: the layouts and the sidecar documented in compare/formats.py, compare/array_files.py,
compare/sidecar.py and compare/measurement.py (and, for the public datasets,
../shared/data/spectraquest_gfd/README.md); each test writes its own small file.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from compare.measurement import Sidecar, load_measurement, read_sidecar
from gearpit.errors import InputError

FS = 5000.0
N = 5000  # 1 s: at 1500 rpm the spur-gds wheel turns 7.25 times


def _signal(n=N, channels=2, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    x = np.sin(2 * np.pi * 725.0 * t)[:, None] + 0.1 * rng.standard_normal((n, channels))
    return t, x


def _sidecar(tmp_path, name="m.toml", **extra):
    d = {"speed_rpm": 1500.0, "torque_nm": 20.0, "pair": "spur-gds", **extra}
    p = tmp_path / name
    if name.endswith(".json"):
        p.write_text(json.dumps(d))
    else:
        lines = []
        for k, v in d.items():
            lines.append(f"{k} = {json.dumps(v)}")
        p.write_text("\n".join(lines) + "\n")
    return p


def test_csv_with_time_column_gives_fs_and_channels(tmp_path):
    """A header with time_s: fs = 1/dt exactly (5000 Hz), time column dropped, sensor by name."""
    t, x = _signal()
    f = tmp_path / "rec.csv"
    np.savetxt(f, np.column_stack([t, x]), delimiter=",", header="time_s,acc_x,acc_y", comments="", fmt="%.10g")
    m = load_measurement(f, _sidecar(tmp_path, sensor="acc_y"))
    assert m.fs_hz == pytest.approx(FS, rel=1e-9)
    assert set(m.channels) == {"acc_x", "acc_y"}
    np.testing.assert_allclose(m.signal, x[:, 1], rtol=1e-9)


def test_headerless_csv_needs_fs_and_names_columns(tmp_path):
    """No header, no time: names from the sidecar's channels, fs from fs_hz; sensor by index."""
    _, x = _signal()
    f = tmp_path / "rec.txt"
    np.savetxt(f, x, fmt="%.8g")  # whitespace separated
    m = load_measurement(f, _sidecar(tmp_path, fs_hz=FS, channels=["a", "b"], sensor=1))
    assert m.sensor == "b" and m.fs_hz == FS
    with pytest.raises(InputError, match="fs_hz"):
        load_measurement(f, _sidecar(tmp_path, name="nofs.toml", sensor=0))


def test_npy_npz_wav_mat_round_trip(tmp_path):
    """The same 2-channel record read back from NPY, NPZ (fs inside), WAV (int16, fs in header), MAT v5 and v7.3."""
    _, x = _signal()
    np.save(tmp_path / "a.npy", x)
    np.savez(tmp_path / "a.npz", left=x[:, 0], right=x[:, 1], fs_hz=FS)
    from scipy.io import savemat, wavfile

    wavfile.write(tmp_path / "a.wav", int(FS), (x / 4 * 32767).astype(np.int16))
    savemat(tmp_path / "a.mat", {"data": x, "fs": FS})
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "b.mat", "w", userblock_size=512) as f:  # v7.3: HDF5 after a 512-byte header,
        f["data"] = x.T                                                # column-major (transposed) arrays
        f["fs"] = np.array([[FS]])
    with open(tmp_path / "b.mat", "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(116) + b"\0" * 8 + b"\x00\x02IM")
    side = _sidecar(tmp_path, fs_hz=FS, sensor=0)
    for name, side_ in (("a.npy", side), ("a.npz", _sidecar(tmp_path, "z.toml", sensor="left")),
                        ("a.wav", _sidecar(tmp_path, "w.json", sensor=0)), ("a.mat", _sidecar(tmp_path, "m5.toml", sensor=0)),
                        ("b.mat", _sidecar(tmp_path, "m7.toml", sensor=0))):
        m = load_measurement(tmp_path / name, side_)
        assert m.fs_hz == pytest.approx(FS), name
        tol = 1e-3 if name.endswith(".wav") else 1e-12
        np.testing.assert_allclose(m.signal / (0.25 if name.endswith(".wav") else 1.0), x[:, 0], atol=tol, err_msg=name)


def test_public_layouts_mcc5_phm_seu(tmp_path):
    """MCC5-THU (header, 12.8 kHz, speed/torque from the name), PHM 2023 (V<rpm>_<torque>N_<run>.txt, 20480 Hz,
    tacho column), SEU (free-text header lines, 8 columns, fs from the sidecar)."""
    rng = np.random.default_rng(1)
    d = rng.standard_normal((13000, 8))
    mc = tmp_path / "gear_pitting_H_speed_circulation_20Nm-1500rpm.csv"
    np.savetxt(mc, d, delimiter=",", header=",".join(["speed", "torque", "motor_vibration_x", "motor_vibration_y",
                                                      "motor_vibration_z", "gearbox_vibration_x", "gearbox_vibration_y",
                                                      "gearbox_vibration_z"]), comments="")
    m = load_measurement(mc, Sidecar.from_dict({"pair": "spur-gds", "tacho": 2}))
    assert (m.fs_hz, m.speed_rpm, m.torque_nm, m.sensor, m.fault) == (12800.0, 1500.0, 20.0, "gearbox_vibration_x",
                                                                       "gear_pitting_H")
    ph = tmp_path / "V1500_20N_2.txt"
    np.savetxt(ph, rng.standard_normal((21000, 4)), fmt="%.6f")
    m = load_measurement(ph, Sidecar.from_dict({"pair": "spur-gds"}))
    assert (m.fs_hz, m.speed_rpm, m.torque_nm, m.tacho, m.sensor) == (20480.0, 1500.0, 20.0, "tacho", "acc_1")
    se = tmp_path / "Surface_25_0.csv"
    head = "\n".join(f"description line {i}\tfree text" for i in range(16))
    body = "\n".join("\t".join(f"{v:.5f}" for v in row) + "\t" for row in rng.standard_normal((6000, 8)))
    se.write_text(head + "\n" + body + "\n")
    m = load_measurement(se, Sidecar.from_dict({"pair": "spur-gds", "fs_hz": 5120.0, "torque_nm": 1.0}))
    assert (m.speed_rpm, m.sensor, m.fault, m.n_samples) == (1500.0, "parallel_x", "surface", 6000)


@pytest.mark.parametrize("case, field", [
    ("nan", "channel acc"), ("short", "measurement length"), ("columns", "channels"), ("row", "line"),
    ("unknown_key", "speed_rmp"), ("no_fs", "fs_hz"), ("sensor", "sensor"), ("constant", "channel acc"),
])
def test_bad_files_are_refused_naming_the_field(tmp_path, case, field):
    """NaN, too short (< two wheel revolutions), wrong column count, ragged rows, typo keys, missing fs, unknown
    sensor, constant signal: each raises InputError whose message names the field."""
    t, x = _signal(channels=1)
    x = x[:, 0]
    side = {"fs_hz": FS, "channels": ["acc"], "sensor": "acc"}
    if case == "nan":
        x = x.copy()
        x[1234] = np.nan
    elif case == "short":
        x = x[:1000]  # 0.2 s < 2 wheel revolutions (0.276 s at 1500 rpm)
    elif case == "columns":
        side["channels"] = ["acc", "extra"]
    elif case == "unknown_key":
        side["speed_rmp"] = 1.0
    elif case == "no_fs":
        del side["fs_hz"]
    elif case == "sensor":
        side["sensor"] = "acc_z"
    elif case == "constant":
        x = np.ones_like(x)
    f = tmp_path / "bad.csv"
    np.savetxt(f, x, fmt="%.8g")
    if case == "row":
        f.write_text(f.read_text() + "1.0,2.0\n")
    with pytest.raises(InputError) as exc:
        load_measurement(f, _sidecar(tmp_path, **side))
    assert field in str(exc.value)


def test_sidecar_json_and_toml_agree(tmp_path):
    """The same keys in JSON and TOML give the same sidecar; a pair table works like a preset name."""
    a = read_sidecar(_sidecar(tmp_path, "s.toml", fs_hz=FS, sensor="x", tacho="k", tacho_pulses_per_rev=2))
    b = read_sidecar(_sidecar(tmp_path, "s.json", fs_hz=FS, sensor="x", tacho="k", tacho_pulses_per_rev=2))
    assert a.to_dict() == b.to_dict()
    c = Sidecar.from_dict({"pair": {"preset": "spur-gds", "pinion": {"teeth": 31, "face_width_mm": 20.0}},
                           "speed_rpm": 1000.0})
    assert c.pair.pinion.teeth == 31 and c.pair.wheel.teeth == 100


def test_real_spectraquest_file_loads(tmp_path):
    """The shared real-data CSV (header a1..a4, 88832 rows, fs undocumented) loads with a sidecar that gives an
    assumed fs; the channel RMS (mean removed) matches the data README's 5.946 for h30hz0.csv a1 (to 0.001)."""
    from pathlib import Path

    f = Path(__file__).resolve().parents[2] / "shared" / "data" / "spectraquest_gfd" / "h30hz0.csv"
    if not f.exists():
        pytest.skip("shared data not present")
    m = load_measurement(f, Sidecar.from_dict({"pair": "spur-gds", "fs_hz": 20000.0, "speed_rpm": 1800.0,
                                               "torque_nm": 1.0, "sensor": "a1"}))
    assert set(m.channels) == {"a1", "a2", "a3", "a4"} and m.n_samples == 88832
    assert float(np.std(m.signal)) == pytest.approx(5.946, abs=1e-3)


def test_a_mesh_frequency_above_nyquist_names_fs_and_where_it_came_from(tmp_path):
    """A record at 1 kHz whose sidecar puts the mesh at 29 x 1000 / 60 = 483 Hz (above 0.45 fs) was refused as
    a wrong speed_rpm alone; the message now names fs and its source (here the NPZ's own rate) beside speed_rpm."""
    from compare.speed import refine_speed

    rng = np.random.default_rng(6)
    p = tmp_path / "slow.npz"
    np.savez(p, acc=rng.standard_normal(4000), fs=1000.0)
    _sidecar(tmp_path, "slow.toml", sensor="acc", speed_rpm=1000.0)
    m = load_measurement(p)
    with pytest.raises(InputError, match="fs_hz / speed_rpm") as exc:
        refine_speed(m)
    msg = str(exc.value)
    assert "fs 1000 Hz from slow.npz's own rate" in msg and "check speed_rpm" in msg


@pytest.mark.parametrize("name", ["m.json", "m.toml"])
def test_a_sidecar_with_a_byte_order_mark_or_a_json_null_is_read(tmp_path, name):
    """Windows Notepad writes a byte-order mark: a JSON or TOML sidecar with one was refused (a CSV with one was
    read); a JSON ``"tacho": null`` was refused as not a channel. The mark is skipped, a null is a key left out."""
    t, x = _signal()
    p = tmp_path / "m.csv"
    p.write_text("time_s,acc,b\n" + "\n".join(f"{a:.6f},{b:.6f},{c:.6f}" for a, (b, c) in zip(t, x)) + "\n")
    if name.endswith(".json"):
        text = json.dumps({"speed_rpm": 1500.0, "torque_nm": 20.0, "pair": "spur-gds", "sensor": "acc",
                           "tacho": None, "fault": None})
    else:
        text = 'speed_rpm = 1500.0\ntorque_nm = 20.0\npair = "spur-gds"\nsensor = "acc"\n'
    (tmp_path / name).write_bytes(("\ufeff" + text).encode("utf-8"))
    m = load_measurement(p)
    assert m.sensor == "acc" and m.tacho is None and m.fs_hz == pytest.approx(FS)
    assert read_sidecar(tmp_path / name).tacho is None


@pytest.mark.parametrize("name", ["m.toml", "m.json"])
def test_a_sidecar_given_as_the_measurement_is_named_a_sidecar(tmp_path, name):
    """``gearpit predict model r0.toml`` said "r0.toml: ... a sidecar beside it (r0.toml or r0.json)"; it now says
    that the file is a sidecar, not a measurement, and names the data file beside it; no template is written."""
    from compare.measurement import find_sidecar

    t, x = _signal()
    np.savez(tmp_path / "m.npz", acc=x[:, 0], fs_hz=FS)
    side = _sidecar(tmp_path, name, sensor="acc")
    for call in (find_sidecar, load_measurement):
        with pytest.raises(InputError, match=f"{name} is a sidecar .*not a measurement.*m.npz beside it"):
            call(side)
    assert not list(tmp_path.glob("*.template"))
