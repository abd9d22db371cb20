"""The ``gearpit`` command line: one subcommand per pipeline stage.

Each subcommand lives in its own module under ``gearpit.commands`` exposing
``register(subparsers)``, which adds its parser and sets ``func`` (taking the
parsed namespace, returning an exit code). Bad input anywhere raises a
:class:`gearpit.errors.GearpitError`; this entry point turns it into one line on
stderr and exit code 2, with no traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from gearpit import __version__
from gearpit.errors import GearpitError

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
        return int(args.func(args) or 0)
    except GearpitError as exc:
        print(f"gearpit {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
