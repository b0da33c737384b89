"""``gaitwatch db upgrade|current|backup OUT``: schema migrations and consistent backups."""

from __future__ import annotations

import argparse
from pathlib import Path

from service.commands._dbcommon import add_db_option, settings_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("db", help="database schema and backups")
    dsub = p.add_subparsers(dest="db_command", metavar="ACTION", required=True)
    up = dsub.add_parser(
        "upgrade", help="create or upgrade the schema (copies a SQLite file first)"
    )
    add_db_option(up)
    up.add_argument("--revision", default="head", help="target revision (default: head)")
    up.set_defaults(func=run_upgrade)
    cur = dsub.add_parser("current", help="print the schema revision and whether it is current")
    add_db_option(cur)
    cur.set_defaults(func=run_current)
    bk = dsub.add_parser("backup", help="consistent copy of the SQLite database (while it runs)")
    add_db_option(bk)
    bk.add_argument("out", type=Path, metavar="OUT", help="file to write (must not exist)")
    bk.add_argument("--force", action="store_true", help="overwrite OUT")
    bk.set_defaults(func=run_backup)


def run_upgrade(args: argparse.Namespace) -> int:
    from service.db.migrate import schema_status, upgrade
    from service.db.session import make_engine

    settings = settings_from(args)
    url = settings.db_url
    copy = upgrade(url, backup_dir=settings.backup_dir, revision=args.revision)
    engine = make_engine(url, pool_size=1)
    try:
        st = schema_status(engine)
    finally:
        engine.dispose()
    if copy is not None:
        print(f"backup: {copy}")
    print(f"schema at revision {st.current} (head {st.head})")
    return 0


def run_current(args: argparse.Namespace) -> int:
    from service.db.migrate import schema_status
    from service.db.session import make_engine

    settings = settings_from(args)
    engine = make_engine(settings.db_url, pool_size=1)
    try:
        st = schema_status(engine)
    finally:
        engine.dispose()
    state = "up to date" if st.up_to_date else "OUT OF DATE: run `gaitwatch db upgrade`"
    print(f"{settings.db_url}: revision {st.current or '(empty)'}; head {st.head}; {state}")
    return 0 if st.up_to_date else 1


def run_backup(args: argparse.Namespace) -> int:
    from service.db.backup import backup_database

    settings = settings_from(args)
    out = backup_database(settings.db_url, args.out, overwrite=args.force)
    print(f"backup written to {out}")
    return 0
