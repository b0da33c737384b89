"""``gaitwatch demo``: run the whole pipeline on an embedded default, no server needed."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="run the pipeline end to end on built-in data")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    print("gaitwatch demo: the pipeline is not assembled yet; nothing to run.")
    return 0
