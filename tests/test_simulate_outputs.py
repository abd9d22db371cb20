"""``gearpit simulate`` into a folder that holds an earlier run: the outputs are one run's, whole or not at all."""
from __future__ import annotations

import os
import signal

from datagen.simulate import Signals
from gearpit.cli import main

from test_dynamics_simulate import CASE_TOML  # tests/ is on sys.path (conftest.py)


def _listing(folder):
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def test_run_without_png_removes_the_old_png_and_a_killed_runs_temporaries(tmp_path, capsys):
    """An earlier --png run and a killed run's temporaries (a half CSV, a staging folder) are in --out: the run
    without --png leaves exactly its CSV, NPZ and JSON (the old PNG showed another run), and another case's
    temporary stays (it may be writing)."""
    case = tmp_path / "case.toml"
    case.write_text(CASE_TOML)
    out = tmp_path / "out"
    assert main(["simulate", str(case), "--out", str(out), "--png"]) == 0
    (out / ".case.csv.2u635bx9.part.csv").write_bytes(b"time_s,half")      # SIGKILL during the old CSV write
    (out / ".case.outputs.abcd1234.part").mkdir()                           # ... during a set's write
    (out / ".case.outputs.abcd1234.part" / "case.npz").write_bytes(b"half")
    (out / ".other.csv.zz.part.csv").write_bytes(b"another run")
    assert main(["simulate", str(case), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".other.csv.zz.part.csv", "case.csv", "case.json", "case.npz"]
    assert Signals.load_npz(out / "case.npz").metadata["case"]["seed"] == 3


def test_stopped_run_leaves_the_earlier_files_as_they_were(tmp_path, monkeypatch, capsys):
    """SIGTERM arrives after the new CSV is written (the old code left a new CSV/NPZ/JSON beside the old PNG, and
    a hidden ``.case.png.*.part.png``): exit 143, every earlier file byte for byte as it was, no temporary."""
    case = tmp_path / "case.toml"
    case.write_text(CASE_TOML)
    out = tmp_path / "out"
    assert main(["simulate", str(case), "--out", str(out), "--png"]) == 0
    before = _listing(out)
    case.write_text(CASE_TOML.replace("speed_rpm = 1500.0", "speed_rpm = 900.0"))
    save_npz = Signals.save_npz

    def save_npz_then_sigterm(self, path):
        save_npz(self, path)
        os.kill(os.getpid(), signal.SIGTERM)  # the handler gearpit.cli installs turns it into an exception

    monkeypatch.setattr(Signals, "save_npz", save_npz_then_sigterm)
    capsys.readouterr()
    assert main(["simulate", str(case), "--out", str(out), "--png"]) == 143
    assert capsys.readouterr().err.strip() == "gearpit simulate: interrupted"
    assert _listing(out) == before
