"""One comparison at a time per model file: an exclusive lock on ``<model>.lock``.

A comparison reads the model and its ledger, works, then rewrites the model
(``--add``, ``--refit``) and appends a ledger row numbered after the rows it
read. Two runs on the same model at once would each read the same state: the
last model write drops the other run's effect and both rows get the same run
number. :func:`model_lock` holds ``fcntl.flock`` (Linux, macOS) on a lock file
beside the model from before the model is read until the ledger row is
written, so concurrent runs take turns; a run that has waited
:data:`LOCK_WAIT_S` is refused with :class:`gearpit.errors.InputError`. The
lock file is left in place (removing it would race with a waiting run); the
kernel releases the lock when the holder exits, killed or not.
"""
from __future__ import annotations

import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from gearpit.errors import InputError

#: how long a comparison waits for another one on the same model before it gives up (s)
LOCK_WAIT_S = 600.0
_POLL_S = 0.1


def lock_path(model_path: str | Path) -> Path:
    """``<model>.lock`` beside the model file."""
    p = Path(model_path)
    return p.with_name(p.name + ".lock")


@contextmanager
def model_lock(model_path: str | Path, wait_s: float | None = None) -> Iterator[Path]:
    """Hold the model's lock for the block (module docstring); says on stderr when it has to wait."""
    import fcntl

    path = lock_path(model_path)
    path.parent.mkdir(parents=True, exist_ok=True)
    wait_s = LOCK_WAIT_S if wait_s is None else wait_s
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        t0 = time.monotonic()
        told = False
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                holder = os.pread(fd, 64, 0).decode("ascii", "replace").strip() or "?"
                if time.monotonic() - t0 >= wait_s:
                    raise InputError("--model", str(model_path), f"a model no other comparison is using (another "
                                     f"run, pid {holder}, has held {path.name} for more than {wait_s:g} s; "
                                     "wait for it or compare with another --model)") from None
                if not told:
                    print(f"gearpit compare: waiting for {path.name}: another comparison (pid {holder}) is using "
                          f"this model (up to {wait_s:g} s)", file=sys.stderr, flush=True)
                    told = True
                time.sleep(_POLL_S)
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield path
    finally:
        os.close(fd)     # releases the lock
