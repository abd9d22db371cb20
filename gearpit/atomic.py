"""Write files whole or not at all: write to a temporary name, then rename.

:func:`atomic_path` does one file; :func:`atomic_set` a set of files that
belong together (a run's CSV, NPZ, JSON and PNG), renamed into place only
once every one of them is written. A temporary is removed when its block
fails or is stopped (Ctrl-C, or SIGTERM under the command line, which turns it
into an exception: :mod:`gearpit.interrupt`); a process killed outright
(SIGKILL) leaves it, and :func:`remove_leftovers` clears it on the next run.
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

#: what a temporary of ``name`` is called: ``.name.XXXXXXXX.part.suffix`` (a set: ``.stem.outputs.XXXXXXXX.part``)
_PART = ".part"


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception (Ctrl-C included) the temporary file is removed and ``path`` is untouched.
    """
    target = Path(path)
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
    targets = [Path(t) for t in targets]
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
