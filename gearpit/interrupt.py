"""Stopping a command: SIGINT (Ctrl-C) and SIGTERM become one exception that unwinds cleanly.

By default Python turns SIGINT into :class:`KeyboardInterrupt` but dies at once
on SIGTERM, so ``finally`` blocks (removing a temporary file, stopping pool
workers) never run. :func:`signals_raise` makes both signals raise
:class:`Interrupted` (a :class:`KeyboardInterrupt`, so code written for Ctrl-C
handles both), and the command line turns it into one line on stderr and the
shell's exit code ``128 + signal`` (130 for SIGINT, 143 for SIGTERM).

Only the command line installs the handlers; the library never does.

References
----------
Python documentation, ``signal`` module (handlers run in the main thread and
may raise); Bash manual, "Exit Status" (128 + n for a fatal signal n);
Linux ``prctl(2)``, ``PR_SET_PDEATHSIG``.
"""
from __future__ import annotations

import signal
from contextlib import contextmanager
from typing import Iterator

#: the signals that stop a command cleanly
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived; ``signum`` is the signal, :attr:`exit_code` what the shell expects."""

    def __init__(self, signum: int = signal.SIGINT):
        self.signum = int(signum)
        super().__init__(signal.Signals(self.signum).name)

    @property
    def exit_code(self) -> int:
        """``128 + signum``: 130 for SIGINT, 143 for SIGTERM."""
        return 128 + self.signum


def exit_code(exc: KeyboardInterrupt) -> int:
    """The exit code for a stop: :attr:`Interrupted.exit_code`, 130 for a plain :class:`KeyboardInterrupt`."""
    return exc.exit_code if isinstance(exc, Interrupted) else 128 + signal.SIGINT


def _raise(signum, frame):
    raise Interrupted(signum)


@contextmanager
def signals_raise() -> Iterator[None]:
    """Within the block, SIGINT and SIGTERM raise :class:`Interrupted`; the old handlers come back after.

    A signal that was ignored when the block started (``nohup``, a background
    job's SIGINT) stays ignored.
    """
    old = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    for s, handler in old.items():
        if handler is not signal.SIG_IGN:
            signal.signal(s, _raise)
    try:
        yield
    finally:
        for s, handler in old.items():
            if handler is not None:
                signal.signal(s, handler)


def reset_in_worker() -> None:
    """In a pool worker: ignore SIGINT and take SIGTERM's default (die), and on Linux die with the parent.

    Ctrl-C reaches every process of the terminal's group; the parent alone
    decides what happens (it stops the workers). A forked worker inherits the
    parent's raising handlers, which would print a traceback per worker.
    ``PR_SET_PDEATHSIG`` makes the kernel send SIGKILL to a worker whose parent
    died without stopping it (SIGKILL cannot be caught), so no worker is left
    blocked on a pipe nobody reads.
    """
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform == "linux":
        import ctypes
        import os

        pr_set_pdeathsig = 1
        try:
            ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)
        except (OSError, AttributeError):  # no libc prctl: the parent's own stop still ends the workers
            return
        if os.getppid() == 1:  # the parent died before prctl took effect
            os._exit(1)
