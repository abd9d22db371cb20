"""Write files whole or not at all: write to a temporary name, then rename.

:func:`atomic_path` does one file; :func:`atomic_set` a set of files that
belong together (a run's CSV, NPZ, JSON and PNG), renamed into place only
once every one of them is written. A temporary is removed when its block
fails or is stopped (Ctrl-C, or SIGTERM under the command line, which turns it
into an exception: :mod:`gearpit.interrupt`); a process killed outright
(SIGKILL) leaves it, and :func:`remove_leftovers` clears it on the next run.

A target that is a symbolic link is written through: the temporary goes
beside the file the link points to and is renamed onto that file, so the link
stays a link. A target that exists and is not a regular file (a directory, a
FIFO, a device such as ``/dev/full``) is refused with :class:`InputError`
rather than replaced; :func:`check_output_path` makes the same checks up front,
before a command does its work.
"""
from __future__ import annotations

import glob
import os
import shutil
import signal
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

from gearpit.errors import InputError

#: what a temporary of ``name`` is called: ``.name.XXXXXXXX.part.suffix`` (a set: ``.stem.outputs.XXXXXXXX.part``)
_PART = ".part"


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception (Ctrl-C included) the temporary file is removed and ``path`` is untouched. A symbolic link
    is written through (its target file is replaced); a target that is not a regular file is refused
    (module docstring).
    """
    target = write_target(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=_PART + target.suffix, dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        if tmp_path.exists():  # mkstemp makes 0600 files; give the usual umask-based mode
            _usual_mode(tmp_path)
        os.replace(tmp_path, target)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


@contextmanager
def atomic_set(targets: Iterable[str | Path], *, stale: Iterable[str | Path] = ()) -> Iterator[dict[Path, Path]]:
    """Write files that belong together: yield ``{target: temporary path}``; on success remove ``stale`` and
    rename every temporary onto its target.

    The temporaries are in one hidden folder beside the first target
    (``.STEM.outputs.XXXXXXXX.part``). Until the block ends the old files are
    untouched; on any exception (Ctrl-C included) the folder is removed and
    nothing changes. ``stale`` are earlier outputs this run does not rewrite
    (a PNG of the same name when no PNG is drawn now): they are removed just
    before the renames, so the folder never holds a new file beside an old
    one. The removals and renames run with SIGINT and SIGTERM blocked where
    the platform allows.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_set([d / "a.txt", d / "b.txt"]) as tmp:
    ...     for target, path in tmp.items():
    ...         _ = path.write_text(target.name)
    >>> sorted(p.name for p in d.iterdir())
    ['a.txt', 'b.txt']
    """
    targets = [write_target(t) for t in targets]
    stale = [Path(s) for s in stale]
    first = targets[0]
    first.parent.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix=f".{first.stem}.outputs.", suffix=_PART, dir=first.parent))
    try:
        staged = {t: folder / t.name for t in targets}
        yield staged
        with _stop_signals_held():
            for s in stale:
                s.unlink(missing_ok=True)
            for target, tmp in staged.items():
                _usual_mode(tmp)
                os.replace(tmp, target)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def write_target(path: str | Path, field: str = "output path") -> Path:
    """The file a write to ``path`` replaces: ``path`` itself, or the file a symbolic link there points to
    (resolved, a dangling link included). Raises :class:`InputError` (naming ``field``) when that exists and is
    not a regular file."""
    p = Path(path)
    if p.is_symlink():
        p = Path(os.path.realpath(p))
    if p.exists() and not p.is_file():
        kind = "a directory" if p.is_dir() else "not a regular file (a FIFO, socket or device)"
        raise InputError(field, str(path), f"a regular file or a new name (this path is {kind})")
    return p


def check_output_path(path: str | Path, field: str, *, inputs: Iterable[str | Path] = ()) -> Path:
    """Check before any work that a command can write ``path``: not an existing directory or other non-regular
    file (a symbolic link counts as what it points to), a parent folder that is one or can be created (no file
    in its way), and none of the run's own ``inputs``. Raises :class:`InputError` naming ``field`` and the path;
    returns the file that will be written. Creates nothing.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> check_output_path(d, "--json")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gearpit.errors.InputError: --json: got '...'; allowed: a regular file or a new name (this path is a directory)
    """
    target = write_target(path, field)
    for parent in [target.parent, *target.parent.parents]:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(field, str(path), f"a path whose folder can be created ({parent} is a file)")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise InputError(field, str(path), f"a path in a writable folder ({parent} is not writable)")
            break
    for inp in inputs:
        if inp is not None and os.path.realpath(inp) == os.path.realpath(target):
            raise InputError(field, str(path), f"a file other than the run's own input or ledger {inp}")
    return target


def remove_leftovers(targets: Iterable[str | Path]) -> list[Path]:
    """Remove the temporaries a killed run (SIGKILL, power loss) left for ``targets``; return what was removed.

    Matches the names :func:`atomic_path` and :func:`atomic_set` give, for
    these targets only (another run writing other names into the same folder
    keeps its temporaries).
    """
    removed = []
    for target in (Path(t) for t in targets):
        d = target.parent
        patterns = [f".{glob.escape(target.name)}.*{_PART}{glob.escape(target.suffix)}",
                    f".{glob.escape(target.stem)}.outputs.*{_PART}"]
        for pattern in patterns:
            for p in d.glob(pattern):
                if p.is_dir():
                    shutil.rmtree(p, ignore_errors=True)
                else:
                    p.unlink(missing_ok=True)
                removed.append(p)
    return removed


def _usual_mode(path: Path) -> None:
    """mkstemp makes 0600 files: give the usual umask-based mode."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


@contextmanager
def _stop_signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back for a few renames (their handler runs right after), where the platform can."""
    held = {signal.SIGINT, signal.SIGTERM}
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    except (AttributeError, OSError, ValueError):
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
