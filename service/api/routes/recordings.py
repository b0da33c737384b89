"""``/residents/{id}/recordings``: ingest an analysed recording, list the stored ones."""

from __future__ import annotations

import datetime as dt
from typing import Any

from fastapi import APIRouter, Request, Response, status
from pydantic import BaseModel, Field
from sqlalchemy import func, select
from sqlalchemy.orm import selectinload

from service.api.deps import (
    AdminDep,
    PageDep,
    PrincipalDep,
    ResidentId,
    SessionDep,
    SettingsDep,
    visible_resident,
)
from service.api.errors import ApiError, not_found, responses
from service.api.schemas import IngestIn, IngestOut, PageOut
from service.db.baselines import BaselineRule
from service.db.ingest import IngestError, ingest
from service.db.models import Recording, Resident

router = APIRouter(tags=["recordings"])


class RecordingOut(BaseModel):
    id: int
    sha256: str
    started_at: dt.datetime
    ended_at: dt.datetime
    duration_s: float
    ingested_at: dt.datetime
    camera_names: list[str] = Field(default_factory=list)
    summary: dict[str, Any] = Field(default_factory=dict)


@router.post(
    "/residents/{resident_id}/recordings",
    response_model=IngestOut,
    status_code=status.HTTP_201_CREATED,
    responses={
        200: {"description": "Already stored (same hash): nothing changed."},
        **responses(401, 403, 404, 422),
    },
)
def ingest_recording(
    resident_id: ResidentId,
    body: IngestIn,
    session: SessionDep,
    principal: AdminDep,
    settings: SettingsDep,
    request: Request,
    response: Response,
):
    """Store a recording's gait analysis (admin keys only; the pipeline's key).

    ``recording`` is the recording description (cameras, pose-log path and SHA-256, absolute
    start, duration); ``result`` the CONVENTIONS ``gait --json`` object. The same SHA-256 twice
    changes nothing (answer 200 instead of 201). Pose-log paths must lie inside the service's
    pose-log folder.
    """
    if session.get(Resident, resident_id) is None:
        raise not_found(f"resident {resident_id}")
    info = dict(body.recording)
    if "resident_id" in info and info["resident_id"] != resident_id:
        raise ApiError(422, "body.recording.resident_id: differs from the resident in the path")
    info["resident_id"] = resident_id
    path = info.get("pose_log_path")
    if isinstance(path, str):
        root = settings.poselog_dir.resolve()
        full = (root / path).resolve()
        if not full.is_relative_to(root):
            raise ApiError(422, "body.recording.pose_log_path: must lie inside the pose-log folder")
        info["pose_log_path"] = str(full)
    metrics = request.app.state.metrics
    try:
        out = ingest(
            session,
            info,
            body.result,
            actor=principal.actor,
            alert_rules=settings.rules,
            baseline_rule=BaselineRule(
                settings.baseline_window_days,
                settings.baseline_gap_days,
                settings.baseline_min_days,
            ),
        )
    except IngestError as err:
        metrics.count_ingest("rejected")
        raise ApiError(422, str(err)) from None
    metrics.count_ingest("created" if out.created else "duplicate")
    if not out.created:
        response.status_code = status.HTTP_200_OK
    return out.__dict__


@router.get(
    "/residents/{resident_id}/recordings",
    response_model=PageOut[RecordingOut],
    responses=responses(401, 404, 422),
)
def list_recordings(
    resident_id: ResidentId,
    session: SessionDep,
    principal: PrincipalDep,
    page: PageDep,
    request: Request,
):
    """Stored recordings of the resident, newest first."""
    visible_resident(session, principal, resident_id)
    q = select(Recording).where(Recording.resident_id == resident_id)
    total = session.scalar(select(func.count()).select_from(q.subquery()))
    recs = session.scalars(
        q.options(selectinload(Recording.cameras))
        .order_by(Recording.started_at.desc())
        .limit(page.limit)
        .offset(page.offset)
    ).all()
    items = [
        {
            "id": r.id,
            "sha256": r.sha256,
            "started_at": r.started_at,
            "ended_at": r.ended_at,
            "duration_s": r.duration_s,
            "ingested_at": r.ingested_at,
            "camera_names": [c.name for c in r.cameras],
            "summary": r.summary,
        }
        for r in recs
    ]
    request.app.state.audit.add(
        actor=principal.actor,
        action="read",
        target=request.url.path,
        resident_id=resident_id,
    )
    return {"items": items, "total": total, "limit": page.limit, "offset": page.offset}
