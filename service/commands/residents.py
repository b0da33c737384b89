"""``gaitwatch resident add|list|erase`` and ``gaitwatch ingest``: data from the command line."""

from __future__ import annotations

import argparse
import datetime as dt
import json
from pathlib import Path

from gaitwatch.errors import InputError
from service.commands._dbcommon import add_db_option, cli_actor, open_session, settings_from

# Database modules are imported inside the commands, so `gaitwatch --help` stays fast.


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("resident", help="add, list or erase residents")
    rsub = p.add_subparsers(dest="resident_command", metavar="ACTION", required=True)
    a = rsub.add_parser("add", help="add a resident and print its id")
    add_db_option(a)
    a.add_argument("name", help="name or pseudonym")
    a.add_argument("--height", type=float, metavar="METRES")
    a.add_argument("--timezone", default="UTC", help="IANA zone of the home (default UTC)")
    a.set_defaults(func=run_add)
    ls = rsub.add_parser("list", help="list residents")
    add_db_option(ls)
    ls.set_defaults(func=run_list)
    er = rsub.add_parser("erase", help="erase a resident, their measurements and pose logs")
    add_db_option(er)
    er.add_argument("id", type=int)
    er.add_argument("--yes", action="store_true", help="do it (required)")
    er.set_defaults(func=run_erase)

    ing = sub.add_parser("ingest", help="store a `gait --json` result for a resident")
    add_db_option(ing)
    ing.add_argument("result", type=Path, metavar="RESULT.json")
    ing.add_argument("--resident", type=int, required=True, metavar="ID")
    ing.add_argument(
        "--poselog",
        type=Path,
        required=True,
        metavar="POSES.mcap",
        help="the pose log the result came from (hashed; identifies the recording)",
    )
    ing.add_argument(
        "--start",
        required=True,
        metavar="ISO",
        help="absolute start time with zone, e.g. 2026-03-02T07:00:00+01:00",
    )
    ing.add_argument("--duration", type=float, required=True, metavar="S")
    ing.add_argument("--camera", action="append", default=[], metavar="NAME")
    ing.set_defaults(func=run_ingest)


def run_add(args: argparse.Namespace) -> int:
    from pydantic import ValidationError

    from service.api.schemas import ResidentCreate
    from service.db import audit
    from service.db.models import Resident

    try:
        body = ResidentCreate(display_name=args.name, height_m=args.height, timezone=args.timezone)
    except ValidationError as err:
        e = err.errors()[0]
        raise InputError(f"resident: {'.'.join(map(str, e['loc']))}: {e['msg']}") from None
    with open_session(settings_from(args)) as session:
        r = Resident(**body.model_dump())
        session.add(r)
        session.flush()
        audit.record(
            session, actor=cli_actor(), action="create", target=f"resident:{r.id}", resident_id=r.id
        )
        session.commit()
        print(r.id)
    return 0


def run_list(args: argparse.Namespace) -> int:
    from sqlalchemy import select

    from service.db import audit
    from service.db.models import Resident

    with open_session(settings_from(args)) as session:
        for r in session.scalars(select(Resident).order_by(Resident.id)):
            h = f"{r.height_m:.2f} m" if r.height_m else "-"
            print(f"{r.id:>5}  {h:>7}  {r.timezone:<20}  {r.display_name}")
        audit.record(session, actor=cli_actor(), action="list", target="residents")
        session.commit()
    return 0


def run_erase(args: argparse.Namespace) -> int:
    from service.db.erasure import erase_resident

    if not args.yes:
        raise InputError(f"erasing resident {args.id} cannot be undone: add --yes")
    with open_session(settings_from(args)) as session:
        rep = erase_resident(session, args.id, actor=cli_actor())
    print(f"resident {args.id} erased: " + ", ".join(f"{k} {v}" for k, v in rep.rows.items()))
    print(
        f"pose logs deleted {len(rep.files_deleted)}, missing {len(rep.files_missing)}, "
        f"kept (content changed) {len(rep.files_kept)}"
    )
    return 0


def run_ingest(args: argparse.Namespace) -> int:
    from service.db.baselines import BaselineRule
    from service.db.erasure import file_sha256
    from service.db.ingest import ingest

    try:
        result = json.loads(args.result.read_text(encoding="utf-8"))
    except json.JSONDecodeError as err:
        raise InputError(f"{args.result}: not JSON ({err})") from None
    try:
        start = dt.datetime.fromisoformat(args.start)
    except ValueError:
        raise InputError(f"--start: {args.start!r} is not an ISO date-time") from None
    if start.tzinfo is None:
        raise InputError("--start: give a time zone (e.g. Z or +01:00)")
    settings = settings_from(args)
    info = {
        "resident_id": args.resident,
        "cameras": args.camera,
        "pose_log_path": str(args.poselog.resolve()),
        "sha256": file_sha256(args.poselog),
        "started_at": start,
        "duration_s": args.duration,
    }
    with open_session(settings) as session:
        out = ingest(
            session,
            info,
            result,
            actor=cli_actor(),
            alert_rules=settings.rules,
            baseline_rule=BaselineRule(
                settings.baseline_window_days,
                settings.baseline_gap_days,
                settings.baseline_min_days,
            ),
        )
    if not out.created:
        print(f"recording already stored (id {out.recording_id}): nothing changed")
    else:
        print(
            f"recording {out.recording_id}: {out.bouts} bouts, {out.transfers} transfers, "
            f"{out.falls} falls, {len(out.alert_ids)} alerts raised"
        )
    return 0
