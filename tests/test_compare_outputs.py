"""Output paths of ``gearpit compare`` (and of every command through :mod:`gearpit.atomic`), the model lock, the
ledger's validation and the messages of ``--add`` / ``--candidates``.

Reference: the auditor's reproductions (bad --json/--report paths, symbolic links, FIFOs, two runs at once, a
ledger edited by hand, a fit taken from another recording). Comparisons here are short (1 s, no attribution).
"""
from __future__ import annotations

import json
import os

import numpy as np
import pytest

from gearpit.atomic import atomic_path, atomic_set, check_output_path
from gearpit.errors import InputError


# ---------------------------------------------------------------------- gearpit.atomic
def test_atomic_path_writes_through_a_symlink(tmp_path):
    """A link stays a link; the file it points to gets the new content (written beside it, then renamed)."""
    target = tmp_path / "sub" / "target.json"
    target.parent.mkdir()
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    with atomic_path(link) as tmp:
        assert tmp.parent == target.parent
        tmp.write_text("new")
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new"
    assert sorted(p.name for p in target.parent.iterdir()) == ["target.json"]


def test_atomic_set_writes_through_a_symlink(tmp_path):
    target = tmp_path / "t.csv"
    target.write_text("old")
    (tmp_path / "l.csv").symlink_to(target)
    with atomic_set([tmp_path / "l.csv"]) as staged:
        for p in staged.values():
            p.write_text("new")
    assert (tmp_path / "l.csv").is_symlink() and target.read_text() == "new"


def test_atomic_path_refuses_a_fifo_and_a_directory(tmp_path):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="not a regular file"):
        with atomic_path(fifo) as tmp:
            tmp.write_text("x")
    assert fifo.is_fifo()
    (tmp_path / "d").mkdir()
    with pytest.raises(InputError, match="a directory"):
        with atomic_path(tmp_path / "d") as tmp:
            tmp.write_text("x")
    assert (tmp_path / "d").is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "pipe.json"]


def test_a_device_is_refused_before_writing():
    """Checked without writing (the old code, run as root, replaced the device with a plain file)."""
    from gearpit.atomic import write_target

    with pytest.raises(InputError, match="/dev/null.*not a regular file"):
        write_target("/dev/null")


def test_check_output_path(tmp_path):
    (tmp_path / "f.toml").write_text("")
    with pytest.raises(InputError, match=r"--json.*f\.toml is a file"):
        check_output_path(tmp_path / "f.toml" / "o.json", "--json")
    with pytest.raises(InputError, match=r"--report.*a directory"):
        check_output_path(tmp_path, "--report")
    with pytest.raises(InputError, match=r"--json.*input or ledger"):
        check_output_path(tmp_path / "f.toml", "--json", inputs=[tmp_path / "f.toml"])
    assert check_output_path(tmp_path / "new" / "o.json", "--json") == tmp_path / "new" / "o.json"
    assert not (tmp_path / "new").exists()


# ---------------------------------------------------------------------- gearpit compare: outputs checked first
@pytest.fixture(scope="module")
def rig_files(tmp_path_factory):
    """A 1 s simulated rig (compare.synthetic) as rig.csv + rig.toml; each test copies it."""
    from compare.synthetic import rig_measurement
    from compare.workflow import write_rig_files

    d = tmp_path_factory.mktemp("rig_src")
    write_rig_files(rig_measurement(({"name": "pitch_error", "grade": 8.0},), duration_s=1.0), d)
    return d


@pytest.fixture
def rig(rig_files, tmp_path):
    import shutil

    for name in ("rig.csv", "rig.toml"):
        shutil.copy(rig_files / name, tmp_path / name)
    return tmp_path


def _compare(rig, *args):
    from gearpit.cli import main

    return main(["compare", str(rig / "rig.csv"), "--no-attribution", "--no-calibrate", *map(str, args)])


def _state(rig):
    """Every file's bytes, but the model's lock file (left in place by design: compare.model_lock)."""
    return {p.name: p.read_bytes() for p in sorted(rig.iterdir()) if p.is_file() and p.suffix != ".lock"}


@pytest.mark.parametrize("flag, where, allowed", [
    ("--report", "report_dir", "a directory"),
    ("--json", "report_dir", "a directory"),
    ("--json", "rig.toml/o.json", "rig.toml is a file"),
    ("--json", "rig.csv", "input or ledger"),
    ("--report", "rig.toml", "input or ledger"),
    ("--json", "rig.model.toml", "input or ledger"),
    ("--json", "rig.model.ledger.jsonl", "input or ledger"),
])
def test_bad_output_path_is_refused_before_any_work(rig, capsys, flag, where, allowed):
    """One stderr line naming the flag, the path and why; exit 2; the model, the ledger and every file as they
    were (before: an IsADirectoryError traceback after the model and the ledger had been written)."""
    (rig / "report_dir").mkdir()
    before = _state(rig)
    assert _compare(rig, "--add", "pitch_error:grade=8", flag, rig / where) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and flag in err[0] and where.split("/")[0] in err[0] and allowed in err[0]
    assert _state(rig) == before and not (rig / "rig.model.toml").exists()


def test_same_path_for_json_and_report_is_refused(rig, capsys):
    assert _compare(rig, "--json", rig / "o.out", "--report", rig / "o.out") == 2
    assert "--report" in capsys.readouterr().err and not (rig / "o.out").exists()


def test_model_and_ledger_are_written_after_the_outputs(rig, monkeypatch):
    """A failure while writing the JSON leaves the model and the ledger as they were."""
    import compare.workflow as wf

    def fail(doc, path):
        raise OSError("disk full")

    monkeypatch.setattr(wf, "write_json", fail)
    with pytest.raises(OSError, match="disk full"):
        wf.run(rig / "rig.csv", add=["pitch_error:grade=8"], attribution=False, calibrate=False,
               json_path=rig / "o.json")
    assert not (rig / "rig.model.toml").exists() and not (rig / "rig.model.ledger.jsonl").exists()


# ---------------------------------------------------------------------- one comparison at a time per model
def _hold_lock(model_path):
    import fcntl

    from compare.model_lock import lock_path

    fh = open(lock_path(model_path), "a+")
    fcntl.flock(fh, fcntl.LOCK_EX)
    return fh


def test_a_second_run_waits_and_reads_the_ledger_after_the_first(rig, capsys):
    """While another run holds the model's lock and appends its row, this run waits (says so on stderr), then
    reads the ledger and the model as the other left them: its row is run 2 and both effects are in the model
    (before: both rows "run": 1 and one --add lost)."""
    import threading

    from compare.ledger import read_ledger
    from compare.model import ComparisonModel
    from compare.workflow import run
    from datagen.effects import EffectSpec

    model = rig / "rig.model.toml"
    holder = _hold_lock(model)

    def other_run():       # what the first comparison writes while it holds the lock
        import time

        time.sleep(0.5)
        ComparisonModel().with_effect(EffectSpec.from_dict({"name": "eccentricity_pinion"}).build()).save(model)
        (rig / "rig.model.ledger.jsonl").write_text(json.dumps({"run": 1, "model": "x", "error_db": {"total": 1.0},
                                                                 "candidates": []}) + "\n")
        holder.close()

    t = threading.Thread(target=other_run)
    t.start()
    out = run(rig / "rig.csv", add=["pitch_error:grade=8"], attribution=False, calibrate=False)
    t.join()
    assert "waiting for rig.model.toml.lock" in capsys.readouterr().err
    assert [r["run"] for r in read_ledger(rig / "rig.model.ledger.jsonl")] == [1, 2]
    assert ComparisonModel.load(model).effect_names == ("eccentricity_pinion", "pitch_error")
    assert out.ledger[-1]["run"] == 2


def test_a_run_gives_up_after_the_lock_wait(rig, monkeypatch, capsys):
    import compare.model_lock as ml

    monkeypatch.setattr(ml, "LOCK_WAIT_S", 0.3)
    holder = _hold_lock(rig / "rig.model.toml")
    try:
        assert _compare(rig, "--add", "pitch_error:grade=8") == 2
    finally:
        holder.close()
    err = capsys.readouterr().err.strip().splitlines()
    assert "--model" in err[-1] and "rig.model.toml.lock" in err[-1] and "0.3 s" in err[-1]
    assert not (rig / "rig.model.toml").exists() and not (rig / "rig.model.ledger.jsonl").exists()


# ---------------------------------------------------------------------- the ledger, validated when read
_ROW = {"run": 1, "time_utc": "2026-01-01T00:00:00Z", "measurement": "rig.csv", "measurement_sha256": None,
        "model": "baseline", "effects": [], "speed_rpm": 1000.0, "gain_db": 12.0,
        "error_db": {"order": 7.7, "total": 9.3}, "raw_error_db": {"total": 9.4}, "noise_error_db": {"total": 0.5},
        "claimed": None, "candidates": [{"effect": "pitch_error", "params": {"grade": 8.0}, "reduction": 0.9,
                                         "error_db": 0.8, "nuisance": None}], "calibration": None}


@pytest.mark.parametrize("line, field, allowed", [
    ('{"error_db": 5.0}', "run", "an integer"),
    (json.dumps({**_ROW, "error_db": 5.0}), "error_db", "an object"),
    ("{}", "run", "an integer"),
    ("[1, 2, 3]", "row", "a JSON object"),
    (json.dumps({**_ROW, "error_db": {"total": "9.3"}}), "error_db.total", "a finite number or null"),
    (json.dumps({**_ROW, "error_db": {"total": float("nan")}}), "error_db.total", "a finite number or null"),
    (json.dumps({**_ROW, "error_db": {"order": 1.0}}), "error_db.total", "missing"),
    (json.dumps({**_ROW, "candidates": [{"effect": "pitch_error", "params": "grade=8"}]}), "candidates[0].params",
     "an object"),
    (json.dumps({**_ROW, "candidates": ["pitch_error"]}), "candidates[0]", "an object"),
], ids=["no_run", "error_not_object", "empty", "array", "str_total", "nan_total", "no_total", "str_params",
        "str_candidate"])
def test_a_bad_ledger_row_names_file_line_and_field(tmp_path, line, field, allowed):
    from compare.ledger import read_ledger

    led = tmp_path / "m.ledger.jsonl"
    led.write_text(json.dumps(_ROW) + "\n" + line + "\n")
    with pytest.raises(InputError) as exc:
        read_ledger(led)
    msg = str(exc.value)
    assert f"{led}: line 2: {field}:" in msg and allowed in msg and "\n" not in msg


def test_a_bad_ledger_stops_the_run_before_any_work(rig, capsys):
    """Exit 2, one line; no row added, the model not written (before: a traceback after the row was added)."""
    led = rig / "rig.model.ledger.jsonl"
    led.write_text(json.dumps({**_ROW, "error_db": {"total": "9.3"}}) + "\n")
    before = _state(rig)
    assert _compare(rig, "--add", "pitch_error", "--json", rig / "o.json") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line 1: error_db.total" in err[0]
    assert _state(rig) == before


def test_the_ledger_writer_writes_null_not_nan(tmp_path):
    from compare.ledger import append_row, history_table, read_ledger

    led = tmp_path / "l.jsonl"
    append_row(led, {**_ROW, "error_db": {"order": float("nan"), "total": np.float64(np.inf)},
                     "gain_db": np.float64("nan")})
    text = led.read_text()
    assert "NaN" not in text and "Infinity" not in text
    row = read_ledger(led)[0]
    assert row["error_db"] == {"order": None, "total": None} and row["gain_db"] is None
    assert history_table([row]).splitlines()[1].split()[:3] == ["1", "-", "-"]


def test_null_errors_in_the_ledger_reach_the_json_and_report(rig):
    """A row with null errors (a NaN written by the old code, now null) does not break a later --json / --report
    run: the document validates against the schema (before: "Out of range float values are not JSON
    compliant" on every later run)."""
    jsonschema = pytest.importorskip("jsonschema")
    from compare.schema import SCHEMA
    from compare.workflow import run

    (rig / "rig.model.ledger.jsonl").write_text(json.dumps({**_ROW, "error_db": {"order": None, "total": None}})
                                                 + "\n")
    run(rig / "rig.csv", attribution=False, calibrate=False, json_path=rig / "o.json", report=rig / "o.html")
    doc = json.loads((rig / "o.json").read_text())
    jsonschema.validate(doc, SCHEMA)
    assert [r["error_db"]["total"] is None for r in doc["ledger"]] == [True, False]


# ---------------------------------------------------------------------- --add EFFECT: whose fit
def _ledger_with_fit(rig, measurement="rig.csv", sha=None, model="baseline"):
    from compare.ledger import file_sha256

    rows = [{**_ROW, "measurement": str(rig / measurement),
             "measurement_sha256": sha if sha is not None else file_sha256(rig / "rig.csv"), "model": model},
            {**_ROW, "run": 2, "measurement": str(rig / "rig.csv"), "candidates": []}]
    (rig / "rig.model.ledger.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))


def test_add_names_the_run_and_measurement_of_the_fit(rig):
    """The fit of run 1 on this measurement and model: named by run, no warning (before: "the last
    comparison", though run 2 fitted nothing)."""
    from compare.workflow import run

    _ledger_with_fit(rig)
    out = run(rig / "rig.csv", add=["pitch_error"], attribution=False, calibrate=False)
    msg = [m for m in out.messages if m.startswith("added pitch_error")]
    assert msg == [f"added pitch_error with the parameters fitted by run 1 of the ledger (on {rig / 'rig.csv'}, "
                   "model baseline): {'grade': 8.0}"]
    assert not [m for m in out.messages if m.startswith("warning")]


def test_add_warns_when_the_fit_is_from_another_measurement_or_model(rig):
    from compare.workflow import run

    _ledger_with_fit(rig, measurement="pitted.csv", sha="0" * 64, model="tip_relief(x=1)")
    out = run(rig / "rig.csv", add=["pitch_error"], attribution=False, calibrate=False)
    warn = [m for m in out.messages if m.startswith("warning")]
    assert len(warn) == 2
    assert "run 1" in warn[0] and "another measurement" in warn[0] and "pitted.csv" in warn[0]
    assert "run 1" in warn[1] and "another model (tip_relief(x=1))" in warn[1] and "(baseline)" in warn[1]


# ---------------------------------------------------------------------- --candidates, --add, description, sidecar
def test_candidates_that_are_never_tried_are_named_and_a_typo_is_a_candidates_error():
    from compare.model import ComparisonModel
    from compare.workflow import candidate_notes

    model = ComparisonModel.from_dict({"effects": [{"name": "pitch_error", "grade": 6.0}]})
    notes = candidate_notes(model, ["noise", "pitch_error", "tip_relief"])
    assert len(notes) == 2 and "noise: not tried" in notes[0] and "pitch_error: not tried" in notes[1]
    with pytest.raises(InputError) as err:
        candidate_notes(model, ["tip_releif"])
    assert err.value.field == "--candidates" and "tip_relief" in err.value.allowed


def test_add_twice_says_it_replaces_and_add_noise_is_refused():
    from compare.model import ComparisonModel
    from compare.workflow import extend_model

    msgs: list[str] = []
    model = extend_model(ComparisonModel.from_dict({}), ["pitch_error:grade=8", "pitch_error:grade=7"], [], msgs)
    assert [e.to_dict()["grade"] for e in model.effects] == [7.0]
    assert any("given again: this one replaces" in m for m in msgs)
    with pytest.raises(InputError) as err:
        extend_model(model, ["noise:snr_db=20"], [], [])
    assert err.value.field == "--add" and "noise floor" in err.value.allowed


def test_the_models_description_reaches_ledger_cli_table_json_and_report(rig):
    """The model file's free-text description ("shown in the ledger") was shown nowhere; HTML in it is escaped."""
    from compare.ledger import history_table, ledger_path, read_ledger
    from compare.workflow import run

    csv = rig / "rig.csv"
    model = csv.parent / "described.model.toml"
    model.write_text('description = "<b>rig A</b>, first guess"\n')
    out = run(csv, model_path=model, attribution=False, json_path=csv.parent / "d.json",
              report=csv.parent / "d.html", calibrate=False)
    rows = read_ledger(ledger_path(model))
    assert rows[-1]["description"] == "<b>rig A</b>, first guess"
    assert "[<b>rig A</b>, first guess]" in history_table(rows)
    doc = json.loads((csv.parent / "d.json").read_text())
    assert doc["model"]["user_description"] == "<b>rig A</b>, first guess"
    html = (csv.parent / "d.html").read_text()
    assert "&lt;b&gt;rig A&lt;/b&gt;" in html and "<b>rig A</b>" not in html
    assert any(m.startswith("sidecar: ") and m.endswith(".toml") for m in out.messages)
