"""Output piped into a reader that stops early (``gearpit ... | head``): the command ends quietly."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from datagen import dataset
from datagen.sweep import sweep_from_dict

from test_dataset_config import BASE, REPO  # tests/ is on sys.path (conftest.py)


@pytest.mark.parametrize("command", ["stiffness --json", "dataset info"])
def test_closed_pipe_ends_quietly(tmp_path, command):
    """The reader's end is closed before the command writes (what ``| head -c 80`` does to a longer output):
    no traceback and no "Exception ignored" on stderr, exit code 1, the command's files written (the old code
    printed a BrokenPipeError traceback from ``print`` or at the interpreter's last flush, exit 120).

    Source: Python documentation, ``signal`` module, "Note on SIGPIPE"; exact.
    """
    if command == "dataset info":  # a dataset that has not started: its metadata alone
        dataset.open_for_writing(tmp_path / "ds", sweep_from_dict(BASE))
        args = ["dataset", "info", str(tmp_path / "ds")]
    else:
        args = ["stiffness", "--json", "--grid", "20x60", "--positions-per-cycle", "8", "--out", str(tmp_path / "st")]
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        proc = subprocess.run([sys.executable, "-m", "gearpit.cli", *args], cwd=REPO, stdout=write_end,
                              stderr=subprocess.PIPE, text=True, timeout=60)
    finally:
        os.close(write_end)
    assert proc.stderr == ""
    assert proc.returncode == 1
    assert command != "stiffness --json" or (tmp_path / "st" / "summary.json").exists()
