"""The FastAPI application: ``create_app(settings)``.

The app refuses to start on a database whose schema is not at the packaged head revision
(:class:`service.db.migrate.SchemaOutOfDateError`), unless ``settings.auto_upgrade`` is set, in
which case it upgrades first (after a backup copy of a SQLite file).
"""

from __future__ import annotations

import gc
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from gaitwatch import __version__
from service.api import errors
from service.api.metrics import MetricsMiddleware, Registry
from service.api.routes import (
    alerts,
    apikeys,
    cameras,
    measurements,
    recordings,
    residents,
    system,
    trends,
)
from service.config import Settings, load_settings
from service.db.audit import AuditBuffer
from service.db.migrate import require_current_schema, schema_status, upgrade
from service.db.session import make_engine, make_sessionmaker

log = logging.getLogger(__name__)

_gc_frozen = False


def freeze_startup_objects() -> None:
    """Move every object alive now to the garbage collector's permanent generation (once).

    A server process holds ~120 000 long-lived objects after start-up (modules, SQLAlchemy
    and pydantic machinery, the routes). CPython's generation-2 collection walks all of them,
    a 40-210 ms pause (the slower figure on a loaded machine) during which every request of
    that worker waits: those pauses were the API's p99 tail (docs/api.md, "Latency tail").
    Frozen objects are skipped by the collector (still freed by reference counting), so the
    later full collections only walk what the requests allocate.
    """
    global _gc_frozen
    if not _gc_frozen:
        gc.collect()
        gc.freeze()
        _gc_frozen = True


DESCRIPTION = """
Caregivers' API of **gaitwatch**: residents, their gait trends against their personal baseline,
walking bouts, transfers, falls, alerts and cameras.

Every endpoint except `/healthz` needs an API key (`Authorization: Bearer gw_...` or
`X-API-Key: gw_...`), created with `gaitwatch apikey create`. Admin keys see every resident;
a caregiver key sees only its assigned residents (any other resident answers 404).

Errors always have the body `{"error": {"status", "code", "message", "details"}}`.
Lists are paged with `limit` (at most 500 by default) and `offset`, and report `total`.
"""

TAGS = [
    {"name": "residents", "description": "The people monitored; deleting one erases their data."},
    {"name": "trends", "description": "A metric over time against the personal baseline."},
    {"name": "measurements", "description": "Walking bouts, transfers, falls."},
    {"name": "alerts", "description": "Raised on ingest; open -> acknowledged -> resolved."},
    {"name": "cameras", "description": "Cameras of the homes and whether they are online."},
    {"name": "recordings", "description": "Analysed recordings (ingest and list)."},
    {"name": "api keys", "description": "Admin only."},
    {"name": "system", "description": "Health and Prometheus metrics."},
]


def create_app(settings: Settings | None = None, *, check_schema: bool = True) -> FastAPI:
    """Build the API for ``settings`` (default: from the environment).

    Parameters
    ----------
    settings : Settings, optional
    check_schema : bool
        Verify the schema revision (and upgrade it when ``settings.auto_upgrade``).

    Raises
    ------
    SchemaOutOfDateError
        The schema is not current and ``auto_upgrade`` is off.
    """
    settings = settings or load_settings()
    url = settings.db_url
    if check_schema and settings.auto_upgrade:
        settings.backup_dir.mkdir(parents=True, exist_ok=True)
        copy = upgrade(url, backup_dir=settings.backup_dir)
        if copy is not None:
            log.info("schema upgraded; previous database copied to %s", copy)
    engine = make_engine(
        url, pool_size=settings.db_pool_size, busy_timeout_ms=settings.sqlite_busy_timeout_ms
    )
    if check_schema:
        try:
            require_current_schema(engine)
        except Exception:
            engine.dispose()
            raise
        log.info("database schema at %s", schema_status(engine).current)

    sessions = make_sessionmaker(engine)
    audit_buffer = AuditBuffer(sessions)
    # API keys are checked on the event loop (no thread hop) through their own small pool:
    # each check takes a connection and returns it at once, so it never waits for the main
    # pool, whose connections are released on the event loop.
    auth_engine = make_engine(url, pool_size=2, busy_timeout_ms=settings.sqlite_busy_timeout_ms)

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        freeze_startup_objects()
        yield
        audit_buffer.close()  # write the queued read-audit entries
        auth_engine.dispose()

    public = settings.public_docs
    app = FastAPI(
        lifespan=lifespan,
        title="gaitwatch",
        version=__version__,
        description=DESCRIPTION,
        openapi_tags=TAGS,
        # Nobody without a key reads anything but /healthz: the schema is served by
        # system.openapi_document behind a key unless the documentation is made public.
        openapi_url="/openapi.json" if public else None,
        docs_url="/docs" if public else None,
        redoc_url="/redoc" if public else None,
    )
    app.state.settings = settings
    app.state.engine = engine
    app.state.sessionmaker = sessions
    app.state.auth_sessionmaker = make_sessionmaker(auth_engine)
    app.state.audit = audit_buffer
    app.state.metrics = Registry()
    errors.install(app)
    for module in (system, residents, trends, measurements, recordings, alerts, cameras, apikeys):
        app.include_router(module.router)
    app.add_middleware(MetricsMiddleware, registry=app.state.metrics)
    return app
