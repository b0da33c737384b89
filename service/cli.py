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

# Top-level command -> (module that registers it, one-line help). Order is that of
# ``gaitwatch --help``. Only the module of the command being run is imported, so every call
# (and ``--help``) starts fast; the others appear in the help as their one-line summary.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("service.commands.demo", "run the pipeline end to end on built-in data"),
    "simulate": ("service.commands.simulate", "render footage of a recorded motion; camera advice"),
    "track": ("service.commands.track", "track a person in video into a 3D pose log (MCAP)"),
    "export": ("service.commands.export", "export a pose log's joints to JOINTS.csv"),
    "gait": ("service.commands.gait", "gait parameters, balance, transfers, falls and risk"),
    "camera": ("service.commands.camera", "camera file tools (check a calibration)"),
    "resident": ("service.commands.residents", "add, list or erase residents"),
    "ingest": ("service.commands.residents", "store a `gait --json` result for a resident"),
    "apikey": ("service.commands.apikey", "create, list and revoke API keys"),
    "db": ("service.commands.db", "database schema and backups"),
    "serve": ("service.commands.serve", "run the caregivers' REST API"),
}

EXIT_BAD_INPUT = 2
EXIT_FAILURE = 1


def _requested_command(argv: Sequence[str]) -> str | None:
    """The first positional argument: the sub-command (top-level options take no values)."""
    for arg in argv:
        if arg == "--":
            return None
        if not arg.startswith("-"):
            return arg
    return None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser; only ``command``'s own parser is built in full."""
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
    if command in COMMANDS:
        importlib.import_module(COMMANDS[command][0]).register(sub)
    for name, (_module, summary) in COMMANDS.items():
        if name not in sub.choices:  # listed in --help; parsed fully only when it is run
            sub.add_parser(name, help=summary)
    return parser


def _setup_logging(verbose: int, quiet: bool) -> None:
    level = logging.WARNING if quiet else logging.INFO if verbose == 0 else logging.DEBUG
    logging.basicConfig(
        level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr, force=True
    )
    # Libraries' own chatter (migration plugins, numba) only with -vv.
    for noisy in ("alembic", "numba", "httpx"):
        logging.getLogger(noisy).setLevel(logging.DEBUG if verbose >= 2 else logging.WARNING)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    command = _requested_command(argv)
    parser = build_parser(command)
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
