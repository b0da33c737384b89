"""``gaitwatch apikey create|list|revoke``: API keys (stored hashed, shown once)."""

from __future__ import annotations

import argparse

from service.commands._dbcommon import add_db_option, cli_actor, open_session, settings_from


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("apikey", help="create, list and revoke API keys")
    asub = p.add_subparsers(dest="apikey_command", metavar="ACTION", required=True)
    c = asub.add_parser("create", help="create a key and print it (shown only this once)")
    add_db_option(c)
    c.add_argument("--role", required=True, choices=["admin", "caregiver"])
    c.add_argument(
        "--resident",
        type=int,
        action="append",
        default=[],
        metavar="ID",
        help="resident a caregiver key may see (repeat for several)",
    )
    c.add_argument("--name", default=None, help="label, e.g. who holds the key")
    c.set_defaults(func=run_create)
    ls = asub.add_parser("list", help="list keys (never the keys themselves)")
    add_db_option(ls)
    ls.set_defaults(func=run_list)
    rv = asub.add_parser("revoke", help="revoke a key by id")
    add_db_option(rv)
    rv.add_argument("id", type=int)
    rv.set_defaults(func=run_revoke)


def run_create(args: argparse.Namespace) -> int:
    from service.api.security import create_api_key
    from service.db import audit

    with open_session(settings_from(args)) as session:
        name = args.name or f"{args.role} key"
        key, token = create_api_key(session, name=name, role=args.role, resident_ids=args.resident)
        audit.record(
            session,
            actor=cli_actor(),
            action="apikey_create",
            target=f"api_key:{key.id}",
            detail=f"role={key.role} residents={sorted(args.resident)}",
        )
        session.commit()
        print(token)
        print(
            f"key id {key.id} ({key.role}); store it now: it cannot be shown again",
            flush=True,
        )
    return 0


def run_list(args: argparse.Namespace) -> int:
    from sqlalchemy import select
    from sqlalchemy.orm import selectinload

    from service.db.models import ApiKey

    with open_session(settings_from(args)) as session:
        keys = session.scalars(
            select(ApiKey).options(selectinload(ApiKey.residents)).order_by(ApiKey.id)
        ).all()
        print(f"{'id':>4}  {'role':<9}  {'prefix':<8}  {'state':<7}  residents  name")
        for k in keys:
            state = "revoked" if k.revoked_at else "active"
            res = ",".join(str(r.id) for r in k.residents) or ("all" if k.role == "admin" else "-")
            print(f"{k.id:>4}  {k.role:<9}  {k.prefix:<8}  {state:<7}  {res:<9}  {k.name}")
    return 0


def run_revoke(args: argparse.Namespace) -> int:
    from service.api.security import revoke_api_key
    from service.db import audit

    with open_session(settings_from(args)) as session:
        key = revoke_api_key(session, args.id)
        audit.record(session, actor=cli_actor(), action="apikey_revoke", target=f"api_key:{key.id}")
        session.commit()
        print(f"key {key.id} revoked")
    return 0
