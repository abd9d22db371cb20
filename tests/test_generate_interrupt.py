"""`gearpit generate` stopped by SIGTERM or Ctrl-C: no worker outlives it, one line says what is kept, resume works."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from datagen import dataset
from datagen.generate import generate
from datagen.sweep import sweep_from_dict

from test_dataset_config import REPO, base  # tests/ is on sys.path (conftest.py)
from test_dataset_generate import _to_toml, digest

#: 18 samples in 9 shards of 2: a 2-worker run lasts ~1 s after its first shard, long enough to be stopped
DOC = base(sweep__shard_size=2)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The sweep generated uninterrupted, in this process."""
    out = tmp_path_factory.mktemp("ref") / "ds"
    generate(sweep_from_dict(DOC), out, progress=False)
    return out


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (psutil if installed, else the parent links in /proc)."""
    try:
        import psutil
    except ImportError:
        parent = {}
        for d in os.listdir("/proc"):
            try:
                with open(f"/proc/{d}/stat") as fh:
                    parent[int(d)] = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (ValueError, OSError):
                continue
        found, frontier = [], [pid]
        while frontier:
            kids = [c for c, p in parent.items() if p in frontier]
            found += kids
            frontier = kids
        return found
    try:
        return [p.pid for p in psutil.Process(pid).children(recursive=True)]
    except psutil.NoSuchProcess:
        return []


def _running(pid: int) -> bool:
    """``pid`` exists and is not a zombie waiting to be reaped."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc")
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_stopped_run_leaves_no_worker_says_what_is_kept_and_resumes(reference, tmp_path, signum):
    """SIGTERM to the command, or SIGINT to its process group (Ctrl-C), once its first shard is written: the
    2 workers end with it (the old code left both blocked on a pipe, ~230 MB each, or printed a traceback per
    process), stderr holds one line with the number of shards kept, the exit code is 128 + signal, and the
    same command again completes to the bytes of the uninterrupted run.

    Source: Bash manual "Exit Status" (128 + n); resume: exact (sha256).
    """
    toml = tmp_path / "sweep.toml"
    toml.write_text(_to_toml(DOC))
    out = tmp_path / "ds"
    proc = subprocess.Popen([sys.executable, "-m", "gearpit.cli", "generate", str(toml), "--out", str(out),
                             "--workers", "2", "--quiet"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    workers = []
    try:
        deadline = time.monotonic() + 60
        while not (out.exists() and dataset.finished_shards(out)):
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline
            time.sleep(0.005)
        workers = _descendants(proc.pid)
        assert len(workers) >= 2, "the pool runs 2 workers"
        if signum == signal.SIGINT:  # Ctrl-C reaches the whole foreground group
            os.killpg(proc.pid, signum)
        else:
            os.kill(proc.pid, signum)
        _, err = proc.communicate(timeout=20)
        deadline = time.monotonic() + 3
        while any(map(_running, workers)) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(map(_running, workers)), f"workers outlived the command: {workers}"
    finally:
        for pid in filter(_running, workers):  # on the old code: do not leave them behind
            os.kill(pid, signal.SIGKILL)
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    kept = len(dataset.finished_shards(out))
    assert 1 <= kept < 9
    assert proc.returncode == 128 + signum
    assert err.splitlines() == [f"gearpit generate: interrupted: {kept} of 9 shards written; "
                                "rerun the same command to resume"]
    report = generate(sweep_from_dict(DOC), out, progress=False)
    assert report.skipped == kept and report.computed == 9 - kept
    assert digest(out) == digest(reference)
