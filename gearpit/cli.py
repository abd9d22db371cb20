"""The ``gearpit`` command line: one subcommand per pipeline stage.

Each subcommand lives in its own module under ``gearpit.commands`` exposing
``register(subparsers)``, which adds its parser and sets ``func`` (taking the
parsed namespace, returning an exit code). Bad input anywhere raises a
:class:`gearpit.errors.GearpitError`; this entry point turns it into one line on
stderr and exit code 2, with no traceback.

Stopped by Ctrl-C (SIGINT) or SIGTERM, a command unwinds (its temporaries
removed, its workers stopped), prints one ``interrupted`` line on stderr and
exits ``128 + signal`` (130, 143; :mod:`gearpit.interrupt`). Output piped into
a reader that closes early (``| head``) ends the command quietly, as the Python
documentation's "Note on SIGPIPE" in the ``signal`` module describes.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys

from gearpit import __version__
from gearpit.errors import GearpitError
from gearpit.interrupt import exit_code, signals_raise

#: subcommand modules, in the order of the pipeline
COMMAND_MODULES = [
    "gearpit.commands.demo",
    "gearpit.commands.stiffness",
    "gearpit.commands.simulate",
    "gearpit.commands.generate",
    "gearpit.commands.dataset",
    "gearpit.commands.rank_features",
    "gearpit.commands.train",
    "gearpit.commands.evaluate",
    "gearpit.commands.predict",
    "gearpit.commands.compare",
]


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse default is also 2)
        self.exit(2, f"gearpit: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="gearpit", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"gearpit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with signals_raise():
            code = int(args.func(args) or 0)
            sys.stdout.flush()  # inside the try: a closed pipe shows here, not at exit
        return code
    except GearpitError as exc:
        print(f"gearpit {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader (``| head``) has gone: send what is still buffered to devnull, so that the interpreter's
        # own flush at exit does not fail again (Python docs, signal module, "Note on SIGPIPE")
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except KeyboardInterrupt as exc:  # SIGINT or SIGTERM (gearpit.interrupt.Interrupted)
        note = getattr(exc, "note", "")
        print(f"gearpit {args.command}: interrupted{': ' + note if note else ''}", file=sys.stderr)
        return exit_code(exc)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
