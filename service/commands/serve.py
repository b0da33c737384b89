"""``gaitwatch serve``: run the REST API with uvicorn (settings from ``GAITWATCH_*``)."""

from __future__ import annotations

import argparse
import logging
import os

from service.commands._dbcommon import add_db_option

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="run the caregivers' REST API")
    p.add_argument("--host", help="listen address (default: $GAITWATCH_HOST or 127.0.0.1)")
    p.add_argument("--port", type=int, help="TCP port (default: $GAITWATCH_PORT or 8000)")
    add_db_option(p)
    p.add_argument(
        "--upgrade",
        action="store_true",
        default=None,
        help="upgrade an out-of-date schema first (after a backup copy) instead of refusing",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=1,
        help="server processes (default 1; SQLite copes with a few)",
    )
    p.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import uvicorn

    from service.api.app import create_app
    from service.config import ENV_PREFIX, load_settings

    settings = load_settings(
        host=args.host, port=args.port, database_url=args.db, auto_upgrade=args.upgrade
    )
    app = create_app(settings)  # refuses an out-of-date schema with a clear error
    log.info("serving on http://%s:%d", settings.host, settings.port)
    common = dict(
        host=settings.host,
        port=settings.port,
        log_level=args.log_level,
        access_log=False,
        proxy_headers=False,
        # Dashboards poll every few seconds: keep their connections instead of closing them
        # after uvicorn's default 5 s (a client reusing a just-closed connection gets an error).
        timeout_keep_alive=75,
    )
    if args.workers <= 1:
        uvicorn.run(app, **common)
        return 0
    # Several processes: each builds its app from the environment; the schema is current now.
    app.state.engine.dispose()
    os.environ[ENV_PREFIX + "DATABASE_URL"] = settings.db_url
    os.environ[ENV_PREFIX + "AUTO_UPGRADE"] = "0"
    uvicorn.run("service.api.app:create_app", factory=True, workers=args.workers, **common)
    return 0
