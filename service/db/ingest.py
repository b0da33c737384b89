"""Ingest one analysed recording: the gait result of ``gait.analysis`` plus the recording info.

The gait result is the CONVENTIONS ``gait --json`` object (``{"bouts", "events", "summary"}``
plus extra keys such as ``transfers``, ``falls``, ``balance``, ``risk``). It is validated here
with this module's own pydantic models, so the store does not depend on ``gait/``'s classes:
every bout and the summary must carry the CONVENTIONS fields (null allowed: NaN in the analysis);
further numeric metrics are kept in the ``extra`` JSON of the row.

Ingest is idempotent: a recording is identified by the SHA-256 of its pose log, and ingesting
the same hash again changes nothing (:attr:`IngestResult.created` is False).
"""

from __future__ import annotations

import datetime as dt
import logging
import math
import re
from dataclasses import dataclass, field
from typing import Annotated, Any
from zoneinfo import ZoneInfo

from pydantic import (
    AliasChoices,
    AwareDatetime,
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    create_model,
    field_validator,
    model_validator,
)
from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from gaitwatch.conventions import GAIT_JSON_FIELDS
from gaitwatch.errors import InputError
from service.config import AlertRules
from service.db import aggregates, audit, baselines, rules
from service.db.models import (
    Aggregate,
    Alert,
    AlertState,
    Baseline,
    Bout,
    Camera,
    Fall,
    Recording,
    Resident,
    Transfer,
)

log = logging.getLogger(__name__)

MAX_ITEMS = 10_000
MAX_DURATION_S = 7 * 24 * 3600.0
_KIND_RE = re.compile(r"^[a-z][a-z0-9_]{0,39}$")


class IngestError(InputError):
    """A gait result or recording description that cannot be stored."""


def _finite_or_none(v: Any) -> Any:
    """NaN/inf metric values mean 'not measurable': store them as null."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def clean_json(obj: Any, depth: int = 0) -> Any:
    """``obj`` made storable as JSON: NaN/inf -> None, keys as strings, bounded depth."""
    if depth > 8:
        raise ValueError("nested too deeply (more than 8 levels)")
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k)[:100]: clean_json(v, depth + 1) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [clean_json(v, depth + 1) for v in obj]
    if obj is None or isinstance(obj, str | int | bool):
        return obj
    raise ValueError(f"value of type {type(obj).__name__} cannot be stored")


MetricValue = Annotated[float | None, Field(allow_inf_nan=True)]


class _Extras(BaseModel):
    """Common base: extra keys allowed and kept (cleaned for JSON)."""

    model_config = ConfigDict(extra="allow", populate_by_name=True)

    def extras(self) -> dict[str, Any]:
        """The extra (non-declared) keys, JSON-clean."""
        return clean_json(dict(self.model_extra or {}))

    @model_validator(mode="after")
    def _extras_storable(self) -> _Extras:
        try:
            clean_json(dict(self.model_extra or {}))
        except ValueError as err:
            raise ValueError(f"extra fields: {err}") from None
        return self


def _metric_fields() -> dict[str, Any]:
    return {
        name: (
            MetricValue,
            Field(..., description=f"CONVENTIONS gait field `{name}` (null when not measurable)"),
        )
        for name in GAIT_JSON_FIELDS
    }


MetricsIn = create_model(  # type: ignore[call-overload]
    "MetricsIn",
    __base__=_Extras,
    __doc__="Gait parameters: every CONVENTIONS field required (null allowed); extras kept.",
    **_metric_fields(),
)


class _MetricsValidators(MetricsIn):  # type: ignore[misc, valid-type]
    @field_validator(*GAIT_JSON_FIELDS, mode="before")
    @classmethod
    def _nan_to_none(cls, v: Any) -> Any:
        return _finite_or_none(v)


class SummaryIn(_MetricsValidators):
    """The recording's summary parameters."""


class BoutIn(_MetricsValidators):
    """One walking bout: its time span (seconds from the first frame) and parameters."""

    start_s: float = Field(
        ..., ge=0, validation_alias=AliasChoices("start_s", "start_time_s", "t_start_s", "start")
    )
    end_s: float = Field(
        ..., ge=0, validation_alias=AliasChoices("end_s", "end_time_s", "t_end_s", "end")
    )

    @model_validator(mode="after")
    def _ordered(self) -> BoutIn:
        if self.end_s < self.start_s:
            raise ValueError(f"bout ends ({self.end_s}) before it starts ({self.start_s})")
        return self


class EventIn(BaseModel):
    """A gait event (CONVENTIONS): only counted, not stored row by row."""

    model_config = ConfigDict(extra="allow")

    side: str | None = None
    type: str = Field(..., max_length=40)
    time_s: float = Field(..., ge=0)


class TransferIn(_Extras):
    """A sit-to-stand, stand-to-sit or timed-up-and-go sequence."""

    kind: str = Field(..., validation_alias=AliasChoices("kind", "type"), max_length=40)
    start_s: float = Field(
        ..., ge=0, validation_alias=AliasChoices("start_s", "time_s", "start_time_s", "t_start_s")
    )
    end_s: float | None = Field(None, ge=0, validation_alias=AliasChoices("end_s", "end_time_s"))
    duration_s: MetricValue = Field(None, ge=0)
    tug_time_s: MetricValue = Field(
        None, ge=0, validation_alias=AliasChoices("tug_time_s", "tug_s", "tug_duration_s")
    )

    @field_validator("duration_s", "tug_time_s", mode="before")
    @classmethod
    def _nan_to_none(cls, v: Any) -> Any:
        return _finite_or_none(v)

    @field_validator("kind")
    @classmethod
    def _kind(cls, v: str) -> str:
        v = v.strip().lower().replace("-", "_").replace(" ", "_")
        if not _KIND_RE.match(v):
            raise ValueError("kind must be lower-case letters, digits and underscores")
        return v

    @model_validator(mode="after")
    def _duration(self) -> TransferIn:
        if self.duration_s is None and self.end_s is not None:
            if self.end_s < self.start_s:
                raise ValueError("transfer ends before it starts")
            self.duration_s = self.end_s - self.start_s
        if self.tug_time_s is None and self.kind in ("tug", "timed_up_and_go"):
            self.tug_time_s = self.duration_s
        return self


class FallIn(_Extras):
    """A detected fall; ``lie_duration_s`` is the time spent on the floor when known."""

    start_s: float = Field(
        ..., ge=0, validation_alias=AliasChoices("start_s", "time_s", "start_time_s", "t_s")
    )
    duration_s: MetricValue = Field(None, ge=0)
    lie_duration_s: MetricValue = Field(
        None,
        ge=0,
        validation_alias=AliasChoices(
            "lie_duration_s", "long_lie_s", "time_on_floor_s", "on_floor_s"
        ),
    )
    long_lie: bool = False

    @field_validator("duration_s", "lie_duration_s", mode="before")
    @classmethod
    def _nan_to_none(cls, v: Any) -> Any:
        return _finite_or_none(v)


def _unwrap_list(v: Any) -> Any:
    """Accept ``{"events": [...]}`` / ``{"items": [...]}`` for a list (nested result style)."""
    if isinstance(v, dict):
        for key in ("events", "items", "detected", "list"):
            if isinstance(v.get(key), list):
                return v[key]
        if not v:
            return []
    return v


class TugIn(_Extras):
    """A timed-up-and-go-like sequence (``gait.result.TUG``): stored as a ``tug`` transfer."""

    start_s: float = Field(..., ge=0, validation_alias=AliasChoices("start_s", "time_s"))
    end_s: float | None = Field(None, ge=0)
    duration_s: MetricValue = Field(None, ge=0)

    @field_validator("duration_s", mode="before")
    @classmethod
    def _nan_to_none(cls, v: Any) -> Any:
        return _finite_or_none(v)

    def as_transfer(self) -> TransferIn:
        d = self.duration_s
        if d is None and self.end_s is not None:
            d = self.end_s - self.start_s
        return TransferIn.model_validate(
            {
                **self.extras(),
                "kind": "tug",
                "start_s": self.start_s,
                "end_s": self.end_s,
                "duration_s": d,
                "tug_time_s": d,
            }
        )


class GaitResultIn(_Extras):
    """The ``gait --json`` object (CONVENTIONS) with optional transfers, TUGs and falls.

    ``tug`` entries (``gait.result.GaitReport.tug``) are stored as transfers of kind ``tug``.
    """

    bouts: list[BoutIn] = Field(default_factory=list, max_length=MAX_ITEMS)
    events: list[EventIn] = Field(default_factory=list, max_length=20 * MAX_ITEMS)
    summary: SummaryIn
    transfers: list[TransferIn] = Field(default_factory=list, max_length=MAX_ITEMS)
    tug: list[TugIn] = Field(default_factory=list, max_length=MAX_ITEMS)
    falls: list[FallIn] = Field(default_factory=list, max_length=MAX_ITEMS)

    @field_validator("transfers", "falls", "tug", mode="before")
    @classmethod
    def _lists(cls, v: Any) -> Any:
        return [] if v is None else _unwrap_list(v)

    @model_validator(mode="after")
    def _tugs_are_transfers(self) -> GaitResultIn:
        self.transfers = [*self.transfers, *(t.as_transfer() for t in self.tug)]
        self.tug = []
        return self


class RecordingInfo(BaseModel):
    """What is known about the recording besides its analysis."""

    model_config = ConfigDict(extra="forbid")

    resident_id: int = Field(..., ge=1, le=2**62)
    cameras: list[Annotated[str, Field(min_length=1, max_length=200)]] = Field(
        default_factory=list, max_length=32, description="Camera names (the camera YAML `name`)."
    )
    pose_log_path: str | None = Field(None, max_length=4096, description="The pose log (MCAP).")
    sha256: str = Field(..., description="SHA-256 of the pose log, 64 hex digits.")
    started_at: AwareDatetime = Field(..., description="Absolute start time (with timezone).")
    duration_s: float = Field(..., gt=0, le=MAX_DURATION_S)

    @field_validator("sha256")
    @classmethod
    def _hex(cls, v: str) -> str:
        v = v.strip().lower()
        if not re.fullmatch(r"[0-9a-f]{64}", v):
            raise ValueError("sha256 must be 64 hexadecimal digits")
        return v

    @field_validator("pose_log_path")
    @classmethod
    def _path(cls, v: str | None) -> str | None:
        if v is not None and ("\x00" in v or not v.strip()):
            raise ValueError("pose_log_path must be a non-empty path without NUL characters")
        return v


def _fmt_validation(err: ValidationError, what: str) -> str:
    first = err.errors()[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(top level)"
    more = f" (and {err.error_count() - 1} more problems)" if err.error_count() > 1 else ""
    return f"{what}: field {loc}: {first['msg']}{more}"


def parse_result(data: Any, source: str = "gait result") -> GaitResultIn:
    """Validate a gait-result dict (or an object with ``model_dump``) into :class:`GaitResultIn`.

    Raises
    ------
    IngestError
        Naming ``source`` and the first bad field.
    """
    if hasattr(data, "model_dump"):
        data = data.model_dump(mode="python")
    try:
        return GaitResultIn.model_validate(data)
    except ValidationError as err:
        raise IngestError(_fmt_validation(err, source)) from None


def parse_info(data: Any, source: str = "recording info") -> RecordingInfo:
    """Validate the recording description. Raises :class:`IngestError`."""
    if isinstance(data, RecordingInfo):
        return data
    try:
        return RecordingInfo.model_validate(data)
    except ValidationError as err:
        raise IngestError(_fmt_validation(err, source)) from None


@dataclass
class IngestResult:
    """What an ingest did."""

    recording_id: int
    created: bool
    bouts: int = 0
    transfers: int = 0
    falls: int = 0
    alert_ids: list[int] = field(default_factory=list)


def ingest(
    session: Session,
    info: RecordingInfo | dict[str, Any],
    result: GaitResultIn | dict[str, Any] | Any,
    *,
    actor: str = "system",
    alert_rules: AlertRules | None = None,
    baseline_rule: baselines.BaselineRule | None = None,
) -> IngestResult:
    """Store one analysed recording, update aggregates and baselines, raise alerts; commit.

    Parameters
    ----------
    session : Session
        A session with no pending work; this function commits (or rolls back on error).
    info : RecordingInfo or dict
        Resident, cameras, pose-log path and hash, absolute start, duration.
    result : GaitResultIn, dict or GaitReport
        The gait analysis (CONVENTIONS ``gait --json`` object).
    actor : str
        Who ingests, for the audit log.
    alert_rules, baseline_rule
        Thresholds (defaults from :class:`service.config.AlertRules` / ``BaselineRule``).

    Returns
    -------
    IngestResult
        ``created`` False when the recording (same hash) was already stored: nothing changed.

    Raises
    ------
    IngestError
        Invalid input, unknown resident, times outside the recording.
    """
    info = parse_info(info)
    res = result if isinstance(result, GaitResultIn) else parse_result(result)
    alert_rules = alert_rules or AlertRules()
    baseline_rule = baseline_rule or baselines.BaselineRule()

    existing = session.scalar(select(Recording.id).where(Recording.sha256 == info.sha256))
    if existing is not None:
        log.info("recording %s already stored (id %d): nothing to do", info.sha256[:12], existing)
        return IngestResult(recording_id=existing, created=False)
    resident = session.get(Resident, info.resident_id)
    if resident is None:
        raise IngestError(f"recording info: field resident_id: no resident {info.resident_id}")
    _check_times(info, res)
    try:
        out = _store(session, resident, info, res, actor, alert_rules, baseline_rule)
        session.commit()
    except IntegrityError:
        # Another process stored the same hash in the meantime: that one wins.
        session.rollback()
        existing = session.scalar(select(Recording.id).where(Recording.sha256 == info.sha256))
        if existing is None:
            raise
        return IngestResult(recording_id=existing, created=False)
    except Exception:
        session.rollback()
        raise
    return out


def _check_times(info: RecordingInfo, res: GaitResultIn) -> None:
    limit = info.duration_s + 1.0
    for name, items in (("bouts", res.bouts), ("transfers", res.transfers), ("falls", res.falls)):
        for i, it in enumerate(items):
            end = getattr(it, "end_s", None) or it.start_s
            if it.start_s > limit or end > limit:
                raise IngestError(
                    f"gait result: field {name}.{i}: time {max(it.start_s, end):g} s is after the "
                    f"end of the recording ({info.duration_s:g} s)"
                )


def _store(
    session: Session,
    resident: Resident,
    info: RecordingInfo,
    res: GaitResultIn,
    actor: str,
    alert_rules: AlertRules,
    baseline_rule: baselines.BaselineRule,
) -> IngestResult:
    try:
        tz = ZoneInfo(resident.timezone)
    except Exception:  # invalid zone stored: fall back to UTC rather than lose the data
        tz = ZoneInfo("UTC")
    t0 = info.started_at.astimezone(dt.UTC)
    ended = t0 + dt.timedelta(seconds=info.duration_s)

    def at(s: float) -> dt.datetime:
        return t0 + dt.timedelta(seconds=s)

    def day(t: dt.datetime) -> dt.date:
        return t.astimezone(tz).date()

    cams = _cameras(session, resident, info.cameras, ended)
    summary = res.summary.model_dump(include=set(GAIT_JSON_FIELDS))
    summary.update(res.summary.extras())
    rec = Recording(
        resident_id=resident.id,
        sha256=info.sha256,
        pose_log_path=info.pose_log_path,
        started_at=t0,
        ended_at=ended,
        duration_s=info.duration_s,
        summary={
            "summary": summary,
            "n_events": len(res.events),
            "extra": res.extras(),
        },
        cameras=cams,
    )
    session.add(rec)
    session.flush()
    days: set[dt.date] = set()
    for b in res.bouts:
        s = at(b.start_s)
        days.add(day(s))
        session.add(
            Bout(
                recording_id=rec.id,
                resident_id=resident.id,
                day=day(s),
                started_at=s,
                ended_at=at(b.end_s),
                start_s=b.start_s,
                end_s=b.end_s,
                extra=b.extras(),
                **{m: getattr(b, m) for m in GAIT_JSON_FIELDS},
            )
        )
    tugs: list[tuple[dt.datetime, float]] = []
    for t in res.transfers:
        s = at(t.start_s)
        days.add(day(s))
        session.add(
            Transfer(
                recording_id=rec.id,
                resident_id=resident.id,
                day=day(s),
                kind=t.kind,
                started_at=s,
                start_s=t.start_s,
                duration_s=t.duration_s,
                tug_time_s=t.tug_time_s,
                extra=t.extras(),
            )
        )
        if t.tug_time_s is not None:
            tugs.append((s, t.tug_time_s))
    falls: list[rules.FallFact] = []
    for f in res.falls:
        s = at(f.start_s)
        long_lie = f.long_lie or (
            f.lie_duration_s is not None and f.lie_duration_s >= alert_rules.long_lie_s
        )
        session.add(
            Fall(
                recording_id=rec.id,
                resident_id=resident.id,
                started_at=s,
                start_s=f.start_s,
                duration_s=f.duration_s,
                lie_duration_s=f.lie_duration_s,
                long_lie=long_lie,
                extra=f.extras(),
            )
        )
        falls.append(rules.FallFact(s, f.lie_duration_s, long_lie))
    session.flush()
    aggregates.recompute_days(session, resident.id, days)
    session.flush()
    stored = baselines.update_baselines(session, resident.id, baseline_rule)
    session.flush()

    rec_day = day(t0)
    day_median = session.scalar(
        select(Aggregate.median).where(
            Aggregate.resident_id == resident.id,
            Aggregate.metric == "walking_speed_m_s",
            Aggregate.period == "day",
            Aggregate.start == rec_day,
        )
    )
    base: Baseline | None = stored.get("walking_speed_m_s")
    # The baseline must not include the day it is compared with.
    base_value = base.value if base is not None and base.window_end < rec_day else None
    drafts = rules.evaluate(
        rules.RuleInput(
            recording_speed_m_s=res.summary.walking_speed_m_s if res.bouts else None,
            day=rec_day,
            day_median_speed_m_s=day_median,
            baseline_speed_m_s=base_value,
            falls=falls,
            tug_times_s=tugs,
            recording_start=t0,
        ),
        alert_rules,
    )
    alerts = _raise_alerts(session, resident.id, rec.id, drafts)
    audit.record(
        session,
        actor=actor,
        action="ingest",
        target=f"recording:{rec.id}",
        resident_id=resident.id,
        detail=f"{len(res.bouts)} bouts, {len(res.transfers)} transfers, {len(res.falls)} falls",
    )
    session.flush()
    return IngestResult(
        recording_id=rec.id,
        created=True,
        bouts=len(res.bouts),
        transfers=len(res.transfers),
        falls=len(res.falls),
        alert_ids=[a.id for a in alerts],
    )


def _cameras(
    session: Session, resident: Resident, names: list[str], seen: dt.datetime
) -> list[Camera]:
    cams: list[Camera] = []
    for name in dict.fromkeys(names):
        cam = session.scalar(select(Camera).where(Camera.name == name))
        if cam is None:
            cam = Camera(name=name, resident_id=resident.id)
            session.add(cam)
        elif cam.resident_id is None:
            cam.resident_id = resident.id
        if cam.last_seen_at is None or cam.last_seen_at < seen:
            cam.last_seen_at = seen
        cams.append(cam)
    return cams


def _raise_alerts(
    session: Session, resident_id: int, recording_id: int, drafts: list[rules.AlertDraft]
) -> list[Alert]:
    out: list[Alert] = []
    for d in drafts:
        if d.unique_open:
            n_open = session.scalar(
                select(func.count(Alert.id)).where(
                    Alert.resident_id == resident_id,
                    Alert.kind == d.kind,
                    Alert.state != AlertState.resolved.value,
                )
            )
            if n_open:
                continue
        a = Alert(
            resident_id=resident_id,
            recording_id=recording_id,
            kind=d.kind,
            severity=d.severity,
            message=d.message,
            occurred_at=d.occurred_at,
            state=AlertState.open.value,
        )
        session.add(a)
        out.append(a)
    session.flush()
    return out
