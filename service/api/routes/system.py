"""``/healthz`` (no key needed), ``/metrics`` (Prometheus, admin keys) and the OpenAPI document
(any key, unless the settings make the documentation public)."""

from __future__ import annotations

import logging

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse, PlainTextResponse
from sqlalchemy import func, select, text

from service.api.deps import AdminDep, PrincipalDep, SessionDep
from service.api.errors import responses
from service.api.schemas import HealthOut
from service.db.migrate import current_revision
from service.db.models import Alert, AlertState, Recording, Resident

log = logging.getLogger(__name__)
router = APIRouter(tags=["system"])


@router.get("/healthz", response_model=HealthOut, responses={503: {"model": HealthOut}})
def healthz(request: Request):
    """Liveness and database reachability. No API key needed; no resident data."""
    engine = request.app.state.engine
    try:
        with engine.connect() as conn:
            conn.execute(text("SELECT 1"))
        rev = current_revision(engine)
    except Exception as err:  # any driver error means unreachable
        log.warning("health check: database unreachable: %s", err)
        return JSONResponse(
            {"status": "unavailable", "database": "unreachable", "schema_revision": None},
            status_code=503,
        )
    return {"status": "ok", "database": "ok", "schema_revision": rev}


@router.get(
    "/metrics",
    response_class=PlainTextResponse,
    responses={200: {"content": {"text/plain": {}}}, **responses(401, 403)},
)
def metrics(request: Request, session: SessionDep, principal: AdminDep):
    """Prometheus text format: requests, latencies, ingest counts, stored totals."""
    gauges = {
        "gaitwatch_residents": (
            "Residents stored.",
            session.scalar(select(func.count(Resident.id))),
        ),
        "gaitwatch_recordings": (
            "Recordings stored.",
            session.scalar(select(func.count(Recording.id))),
        ),
        "gaitwatch_alerts_open": (
            "Alerts not yet resolved.",
            session.scalar(
                select(func.count(Alert.id)).where(Alert.state != AlertState.resolved.value)
            ),
        ),
    }
    body = request.app.state.metrics.render({k: (h, float(v or 0)) for k, (h, v) in gauges.items()})
    return PlainTextResponse(body, media_type="text/plain; version=0.0.4; charset=utf-8")


@router.get("/openapi.json", include_in_schema=False)
def openapi_document(request: Request, principal: PrincipalDep) -> JSONResponse:
    """The OpenAPI schema for key holders (the public route exists only with ``public_docs``)."""
    return JSONResponse(request.app.openapi())
