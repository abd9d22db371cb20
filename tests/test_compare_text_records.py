"""Measurement files as loggers, spreadsheets and MATLAB write them (compare.text_records, compare.formats,
compare.array_files): each file is written here from known samples, read back, and compared with them value for
value; the rate must be the one the file states."""
from __future__ import annotations

import numpy as np
import pytest

from compare.formats import read_record
from gearpit.errors import InputError

FS = 8000.0


def _signal(n=400):
    t = np.arange(n) / FS
    rng = np.random.default_rng(3)
    return t, np.round(np.sin(2 * np.pi * 310.0 * t) + 0.1 * rng.standard_normal(n), 6), np.round(
        rng.standard_normal(n), 6)


def _rows(cols, sep, fmt="{:.6f}", comma=False):
    out = []
    for row in zip(*cols):
        cells = [fmt.format(v) for v in row]
        out.append(sep.join(c.replace(".", ",") if comma else c for c in cells))
    return out


def test_a_spreadsheet_export_with_a_byte_order_mark_keeps_its_time_column(tmp_path):
    """Excel's "CSV UTF-8" starts with a byte-order mark; before, the first header read '\\ufefftime_s', so the
    time column became a channel and the rate was lost."""
    t, a, b = _signal()
    p = tmp_path / "bom.csv"
    p.write_text("\ufefftime_s,acc,tacho\n" + "\n".join(_rows((t, a, b), ",", "{:.8f}")) + "\n", encoding="utf-8")
    rec = read_record(p)
    assert rec.names == ("acc", "tacho")
    assert rec.fs_hz == pytest.approx(FS, rel=1e-9)
    np.testing.assert_allclose(rec.data, np.column_stack([a, b]), atol=1e-12)


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_a_decimal_comma_export_is_read_as_decimal_points(tmp_path, sep):
    """German/French locale exports: '0,125;-3,5' (and tab- or space-separated); the comma is the decimal mark
    whenever it is not the delimiter."""
    t, a, b = _signal()
    p = tmp_path / "de.csv"
    p.write_text(sep.join(["time_ms", "Beschl", "Tacho"]) + "\n"
                 + "\n".join(_rows((t * 1e3, a, b), sep, "{:.6f}", comma=True)) + "\n")
    rec = read_record(p)
    assert rec.names == ("Beschl", "Tacho") and rec.fs_hz == pytest.approx(FS, rel=1e-6)
    np.testing.assert_allclose(rec.data, np.column_stack([a, b]), atol=1e-12)


def test_a_loggers_comment_preamble_and_comment_lines_among_the_rows_are_skipped(tmp_path):
    t, a, b = _signal()
    rows = _rows((a, b), ",")
    rows.insert(100, "# channel 2 re-ranged")
    p = tmp_path / "logger.csv"
    p.write_text("% rig 3, 2026-12-04\n# fs = 8000 Hz\n// units: m/s^2, V\nacc,tacho\n" + "\n".join(rows) + "\n")
    rec = read_record(p)
    assert rec.names == ("acc", "tacho") and rec.data.shape == (400, 2)
    np.testing.assert_allclose(rec.data, np.column_stack([a, b]), atol=1e-12)


@pytest.mark.parametrize("name,scale", [("time_ms", 1e3), ("Time [ms]", 1e3), ("t (us)", 1e6), ("time/s", 1.0),
                                        ("Time", 1.0)])
def test_a_time_column_in_its_named_unit_gives_the_rate_in_hz(tmp_path, name, scale):
    """A time column whose name carries its unit is converted to seconds at the file boundary: 'time_ms' read
    as seconds would give 8 MHz."""
    t, a, _ = _signal()
    p = tmp_path / "t.csv"
    p.write_text(f"{name},acc\n" + "\n".join(_rows((t * scale, a), ",", "{:.9g}")) + "\n")
    rec = read_record(p)
    assert rec.names == ("acc",)
    assert rec.fs_hz == pytest.approx(FS, rel=1e-6)


def test_a_unit_row_under_the_header_is_refused_with_its_line(tmp_path):
    """Not guessed at: a second header row of units is named in the error (line 2)."""
    t, a, _ = _signal()
    p = tmp_path / "units.csv"
    p.write_text("time,acc\ns,m/s^2\n" + "\n".join(_rows((t, a), ",")) + "\n")
    with pytest.raises(InputError, match="line 2"):
        read_record(p)


def test_a_matlab_struct_is_flattened_and_its_fs_found(tmp_path):
    """save('rec.mat', 'data') with data.acc, data.tacho, data.fs; and two runs with the same field names, which
    keep their dotted paths."""
    import scipy.io as sio

    _, a, b = _signal()
    p = tmp_path / "struct.mat"
    sio.savemat(p, {"data": {"acc": a, "tacho": b, "fs": FS}})
    rec = read_record(p)
    assert rec.names == ("acc", "tacho") and rec.fs_hz == FS
    np.testing.assert_array_equal(rec.data, np.column_stack([a, b]))
    p2 = tmp_path / "runs.mat"
    sio.savemat(p2, {"run1": {"acc": a}, "run2": {"acc": b}, "Fs": FS})
    rec = read_record(p2)
    assert rec.names == ("run1.acc", "run2.acc") and rec.fs_hz == FS
    np.testing.assert_array_equal(rec.data, np.column_stack([a, b]))
    assert read_record(p2, variable="run2.acc").data[:, 0].tolist() == b.tolist()


def test_a_time_vector_in_a_mat_file_gives_the_rate_and_is_no_channel_and_must_agree_with_fs(tmp_path):
    import h5py
    import scipy.io as sio

    t, a, b = _signal()
    p = tmp_path / "v5.mat"
    sio.savemat(p, {"acc": a, "tacho": b, "t": t})
    rec = read_record(p)
    assert rec.names == ("acc", "tacho") and rec.fs_hz == pytest.approx(FS, rel=1e-9)
    p73 = tmp_path / "v73.mat"     # MATLAB -v7.3: HDF5, a struct is a group, arrays stored column-major
    with h5py.File(p73, "w") as f:
        g = f.create_group("rec")
        g.create_dataset("acc", data=a[None, :])
        g.create_dataset("time_ms", data=1e3 * t[None, :])
    rec = read_record(p73)
    assert rec.names == ("acc",) and rec.fs_hz == pytest.approx(FS, rel=1e-9)
    np.testing.assert_array_equal(rec.data[:, 0], a)
    bad = tmp_path / "bad.mat"
    sio.savemat(bad, {"acc": a, "t": t, "fs": 2 * FS})
    with pytest.raises(InputError, match="within 1 %"):
        read_record(bad)


def test_a_file_without_names_whose_sidecar_names_its_time_column_gets_its_rate_from_it(tmp_path):
    """A headerless TSV (time, acceleration, tacho) with ``channels = ["time_ms", "acc", "tacho"]`` in its
    sidecar: the rate comes from the named time column (in ms), which is no channel; the record is the file's."""
    import json

    from compare.measurement import load_measurement

    n = 4000
    t = np.arange(n) / FS
    a = np.round(np.sin(2 * np.pi * 310.0 * t), 6)
    b = np.round(np.cos(2 * np.pi * 17.0 * t), 6)
    p = tmp_path / "rig.tsv"
    p.write_text("\n".join(_rows((1e3 * t, a, b), "\t", "{:.6f}")) + "\n")
    (tmp_path / "rig.json").write_text(json.dumps({"pair": "spur-gds", "speed_rpm": 1000.0, "torque_nm": 50.0,
                                                    "sensor": "acc", "channels": ["time_ms", "acc", "tacho"]}))
    m = load_measurement(p)
    assert m.fs_hz == pytest.approx(FS, rel=1e-6) and set(m.channels) == {"acc", "tacho"}
    np.testing.assert_array_equal(m.signal, a)


@pytest.mark.parametrize("name,scale,decimals,sep", [("time_s", 1.0, 7, ","), ("time_s", 1.0, 5, ","),
                                                     ("time_ms", 1e3, 3, ";")])
def test_a_time_column_rounded_to_its_printed_decimals_gives_the_true_rate(tmp_path, name, scale, decimals, sep):
    """12.8 kHz times written to 7 decimals (steps of 78 and 79 us) read 12804.1 Hz as 1 / median step, and to 5
    decimals (10 us) or in ms to 3 decimals (decimal comma) they were refused as non-uniform; the rate is now the
    least-squares step, the check allows the written resolution, and the rate comes back as 12800 Hz."""
    n, fs = 6400, 12800.0
    t = np.arange(n) / fs * scale
    a = np.round(np.sin(2 * np.pi * 333.0 * t / scale), 4)
    lines = [f"{name}{sep}acc"] + [f"{tv:.{decimals}f}{sep}{av:.4f}".replace(".", "," if sep == ";" else ".")
                                   for tv, av in zip(t, a)]
    p = tmp_path / "t.csv"
    p.write_text("\n".join(lines) + "\n")
    rec = read_record(p)
    assert rec.fs_hz == pytest.approx(fs, rel=1e-9)
    np.testing.assert_allclose(rec.data[:, 0], a)


def test_a_jitter_beyond_the_written_resolution_is_refused_and_fs_hz_suggested(tmp_path):
    """Rounding to the printed digits is allowed, a 0.3 % jitter at 7 decimals is not; the message says to give
    fs_hz in the sidecar, and a sidecar that gives it is then used in place of the column."""
    from compare.measurement import Sidecar, load_measurement

    fs = 12800.0
    t = np.round(np.arange(6400) / fs, 7)
    rng = np.random.default_rng(1)
    a = np.round(rng.standard_normal(6400), 4)
    tt = t + np.round(rng.normal(0.0, 2.5e-7, t.size), 7)
    p = tmp_path / "jitter.csv"
    p.write_text("time_s,acc\n" + "\n".join(f"{x:.7f},{y:.4f}" for x, y in zip(tt, a)) + "\n")
    with pytest.raises(InputError, match="non-uniform") as exc:
        read_record(p)
    assert "give fs_hz in the sidecar" in str(exc.value)
    m = load_measurement(p, Sidecar.from_dict({"pair": "spur-gds", "speed_rpm": 1000.0, "torque_nm": 40.0,
                                               "fs_hz": fs, "sensor": "acc"}))
    assert m.fs_hz == fs and m.channels.keys() == {"acc"}


@pytest.mark.parametrize("missing,name,scale", [(1, "time_s", 1.0), (100, "time_s", 1.0), (100, "time_ms", 1e3)])
def test_a_gap_in_the_time_column_is_refused_naming_its_time_and_size_even_with_fs_hz(tmp_path, missing, name,
                                                                                       scale):
    """Missing samples are a phase jump, not clock jitter: before, a sidecar giving fs_hz had the column dropped and
    the two parts spliced without a word (the audit's gap_fs.csv, 100 samples missing). Now refused with or without
    fs_hz, naming where the gap starts and how many samples are missing; a jitter with fs_hz stays accepted (above)."""
    from compare.measurement import Sidecar, load_measurement

    fs = 12800.0
    keep = np.r_[0:3000, 3000 + missing:6400]
    t = np.round(np.arange(6400) / fs * scale, 7)[keep]
    a = np.round(np.random.default_rng(2).standard_normal(6400), 4)[keep]
    p = tmp_path / "gap.csv"
    p.write_text(f"{name},acc\n" + "\n".join(f"{x:.7f},{y:.4f}" for x, y in zip(t, a)) + "\n")
    side = {"pair": "spur-gds", "speed_rpm": 1000.0, "torque_nm": 40.0, "sensor": "acc"}
    for sidecar in (side, {**side, "fs_hz": fs}):
        with pytest.raises(InputError, match="gap") as exc:
            load_measurement(p, Sidecar.from_dict(sidecar))
        msg = str(exc.value)
        assert f"about {missing} missing sample" in msg and "step 2999 -> 3000" in msg
        assert "0.2342969" in msg or "(0.234296875 s)" in msg      # where it starts: 2999 / fs


@pytest.mark.parametrize("name", ["Zeit_ms", "Zeit [ms]", "Temps (ms)", "clock/ms"])
def test_the_sidecars_time_column_gets_its_unit_from_any_name(tmp_path, name):
    """A unit was read only from names beginning with time/t: ``time_column = "Zeit_ms"`` was read as seconds,
    fs 12.8 Hz for 12.8 kHz (the audit's time_ms_sc.csv). The column the sidecar names gets its unit from the end
    of any name."""
    fs = 12800.0
    t = np.arange(3200) / fs * 1e3
    a = np.round(np.sin(2 * np.pi * 333.0 * t / 1e3), 4)
    p = tmp_path / "t.csv"
    p.write_text(f'"{name}",acc\n' + "\n".join(f"{tv:.6f},{av:.4f}" for tv, av in zip(t, a)) + "\n")
    rec = read_record(p, time_column=name)
    assert rec.fs_hz == pytest.approx(fs, rel=1e-9) and rec.names == ("acc",)


def test_a_time_column_of_ms_read_as_seconds_is_refused_naming_the_column_and_its_reading(tmp_path):
    """A logger's ``Time`` column in ms (no unit in the name) gave fs 12.8 Hz, and the error came later about
    speed_rpm ("a mesh frequency below 0.45 fs (5.76 Hz)"); a sample-index column gave 1 Hz. Now refused where the
    rate is read, naming the column, the unit it was read in and the remedy (MIN_FS_HZ: 100 Hz); with fs_hz in the
    sidecar the column is only dropped, as a jittering one is."""
    from compare.measurement import Sidecar, load_measurement

    fs = 12800.0
    t = np.arange(6400) / fs
    a = np.round(np.random.default_rng(4).standard_normal(6400), 4)
    side = {"pair": "spur-gds", "speed_rpm": 1000.0, "torque_nm": 40.0, "sensor": "acc"}
    for col, rate in ((1e3 * t, "12.8"), (np.arange(6400.0), "1")):
        p = tmp_path / "logger.csv"
        p.write_text("Time,acc\n" + "\n".join(f"{tv:.6f},{av:.4f}" for tv, av in zip(col, a)) + "\n")
        with pytest.raises(InputError, match="column Time") as exc:
            load_measurement(p, Sidecar.from_dict(side))
        msg = str(exc.value)
        assert f"fs {rate} Hz from this time column read as seconds" in msg
        assert "name it time_ms" in msg and "fs_hz" in msg
        m = load_measurement(p, Sidecar.from_dict({**side, "fs_hz": fs}))
        assert m.fs_hz == fs and set(m.channels) == {"acc"}


def test_a_rate_in_khz_is_refused_naming_where_fs_came_from(tmp_path):
    """An NPZ/MAT ``fs`` stored in kHz (12.8) was taken as 12.8 Hz, and so was a sidecar's fs_hz = 12.8; the
    message now names the rate's source."""
    from compare.measurement import Sidecar, load_measurement

    a = np.random.default_rng(5).standard_normal(6400)
    side = {"pair": "spur-gds", "speed_rpm": 1000.0, "torque_nm": 40.0, "sensor": "acc"}
    p = tmp_path / "rig.npz"
    np.savez(p, acc=a, fs=12.8)
    with pytest.raises(InputError, match=r"fs_hz: got .12\.8 Hz from rig\.npz's own rate \(its scalar"):
        load_measurement(p, Sidecar.from_dict(side))
    np.savez(p, acc=a)
    with pytest.raises(InputError, match=r"12\.8 Hz from the sidecar's fs_hz"):
        load_measurement(p, Sidecar.from_dict({**side, "fs_hz": 12.8}))


@pytest.mark.parametrize("fmt,sep,comma", [("{:.6E}", ",", False), ("{:.6E}", ";", True), ("{:.6e}", "\t", False)])
def test_a_time_column_in_e_notation_is_read_to_its_significant_digits(tmp_path, fmt, sep, comma):
    """``%.6E`` (7 significant digits; a decimal point or comma) holds 0.9999219 to 1e-7 and 7.8125e-5 to 1e-11:
    the resolution was taken as the decimals that write every value (1e-9 here), and a 1 s column at 12.8 kHz was
    refused as non-uniform (the audit's sci6.csv, semi_comma_sci.csv). Each value now gets its own last digit's
    step; a 100-sample gap is still refused."""
    fs = 12800.0
    t = np.arange(12800) / fs
    a = np.round(np.sin(2 * np.pi * 333.0 * t), 4)
    p = tmp_path / "sci.csv"
    p.write_text(f"time_s{sep}acc\n" + "\n".join(_rows((t, a), sep, fmt, comma)) + "\n")
    rec = read_record(p)
    assert rec.fs_hz == pytest.approx(fs, rel=1e-9)
    np.testing.assert_allclose(rec.data[:, 0], a, atol=1e-9)
    keep = np.r_[0:6000, 6100:12800]
    p.write_text(f"time_s{sep}acc\n" + "\n".join(_rows((t[keep], a[keep]), sep, fmt, comma)) + "\n")
    with pytest.raises(InputError, match="about 100 missing samples"):
        read_record(p)


@pytest.mark.parametrize("sep,comma", [(",", False), (";", True), (",", True)])
def test_quoted_numbers_are_read(tmp_path, sep, comma):
    """Every cell quoted (``"0.125"``; French Excel: ``"0,125"`` beside a comma delimiter) was refused as "numbers
    only"."""
    t, a, b = _signal()
    p = tmp_path / "q.csv"
    rows = [sep.join(f'"{c}"' for c in r.split("|")) for r in _rows((t, a, b), "|", "{:.8f}", comma)]
    p.write_text(sep.join(['"time_s"', '"acc"', '"tacho"']) + "\n" + "\n".join(rows) + "\n")
    rec = read_record(p)
    assert rec.names == ("acc", "tacho") and rec.fs_hz == pytest.approx(FS, rel=1e-9)
    np.testing.assert_allclose(rec.data, np.column_stack([a, b]), atol=1e-12)


def test_a_pandas_index_column_is_dropped_and_an_unnamed_counter_named_in_the_message(tmp_path):
    """pandas' ``to_csv`` writes its index under an empty header cell: the header had one name fewer than the data
    and was refused by count. It is now dropped; a counter column under a header that does not name it at all is
    named in the message."""
    import pandas as pd

    t, a, b = _signal()
    p = tmp_path / "pd.csv"
    pd.DataFrame({"time_s": t, "acc": a, "tacho": b}).to_csv(p)
    rec = read_record(p)
    assert rec.names == ("acc", "tacho") and rec.fs_hz == pytest.approx(FS, rel=1e-9)
    np.testing.assert_allclose(rec.data, np.column_stack([a, b]), atol=1e-12)
    p.write_text("time_s,acc,tacho\n" + "\n".join(f"{i}," + r for i, r in enumerate(_rows((t, a, b), ","))) + "\n")
    with pytest.raises(InputError, match="an index column without a name"):
        read_record(p)


@pytest.mark.parametrize("encoding,name", [("cp1252", "cp1252"), ("utf-16", "UTF-16"), ("utf-16-le", "UTF-16")])
def test_a_windows_or_utf16_export_is_decoded_and_its_encoding_named(tmp_path, encoding, name):
    """A cp1252 header (``Beschl. [m/s²]``) was decoded to U+FFFD and a sidecar naming the channel was refused
    with a garbled list; Excel's "Unicode text" (UTF-16) gave "got '\\x00'". Both are read; errors name the
    encoding used."""
    t, a, b = _signal()
    p = tmp_path / "win.txt"
    body = "\r\n".join(_rows((t, a, b), "\t", "{:.8f}"))
    p.write_bytes(("time_s\tBeschl. [m/s²]\ttemp [°C]\r\n" + body + "\r\n").encode(encoding))
    rec = read_record(p)
    assert rec.names == ("Beschl. [m/s²]", "temp [°C]") and rec.fs_hz == pytest.approx(FS, rel=1e-9)
    np.testing.assert_allclose(rec.data, np.column_stack([a, b]), atol=1e-12)
    p.write_bytes(("time_s\tBeschl. [m/s²]\ttemp [°C]\r\n" + body + "\r\nabc\t1\t2\r\n").encode(encoding))
    with pytest.raises(InputError, match=f"read as {name}: not UTF-8"):
        read_record(p)


def test_an_empty_last_cell_is_an_empty_cell_not_a_short_row(tmp_path):
    """``0.1,0.2,`` under a three-name header was refused as a row of 2 columns; it is an empty cell, read as NaN
    like one in the middle (refused only in a channel that is read, and the message says so)."""
    from compare.measurement import Sidecar, load_measurement

    fs = 12800.0
    t = np.arange(6400) / fs
    rng = np.random.default_rng(7)
    a, b = np.round(rng.standard_normal(6400), 4), np.round(rng.standard_normal(6400), 4)
    rows = _rows((t, a, b), ",", "{:.8f}")
    rows[500] = rows[500].rsplit(",", 1)[0] + ","
    p = tmp_path / "e.csv"
    p.write_text("time_s,acc,y\n" + "\n".join(rows) + "\n")
    side = {"pair": "spur-gds", "speed_rpm": 1000.0, "torque_nm": 40.0}
    m = load_measurement(p, Sidecar.from_dict({**side, "sensor": "acc"}))
    np.testing.assert_array_equal(m.signal, a)
    with pytest.raises(InputError, match=r"channel y: .*first at index \[500\].*empty cell"):
        load_measurement(p, Sidecar.from_dict({**side, "sensor": "y"}))
