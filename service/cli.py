"""The ``gaitwatch`` command line (contract in ``shared/CONVENTIONS.md``).

Sub-commands live in ``service/commands/<name>.py``; each module's ``register(subparsers)``
adds its parser. Bad input ends with a one-line ``gaitwatch: error: ...`` on stderr and a
non-zero exit code; CLI output goes to stdout, diagnostics through ``logging`` to stderr.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from gaitwatch import __version__
from gaitwatch.errors import InputError

log = logging.getLogger("gaitwatch")

# Order is the order of ``gaitwatch --help``.
COMMAND_MODULES: tuple[str, ...] = (
    "service.commands.demo",
    "service.commands.track",
    "service.commands.export",
    "service.commands.gait",
    "service.commands.camera",
    "service.commands.residents",
    "service.commands.apikey",
    "service.commands.db",
    "service.commands.serve",
    "service.commands.simulate",
)

EXIT_BAD_INPUT = 2
EXIT_FAILURE = 1


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gaitwatch",
        description="Markerless 3D gait and fall-risk monitoring (Interval Particle Filtering).",
    )
    parser.add_argument("--version", action="version", version=f"gaitwatch {__version__}")
    parser.add_argument(
        "-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)"
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def _setup_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else logging.INFO if verbose == 0 else logging.DEBUG
    logging.basicConfig(
        level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr, force=True
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    _setup_logging(args.verbose, args.quiet)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_BAD_INPUT
    try:
        return int(args.func(args) or 0)
    except (InputError, FileNotFoundError, IsADirectoryError, PermissionError) as err:
        msg = str(err).replace("\n", " ")
        print(f"gaitwatch: error: {msg}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("gaitwatch: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
