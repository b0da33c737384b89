"""Request and response bodies of the API (pydantic), with OpenAPI examples.

Request bodies forbid unknown fields, so a typo is a 422 instead of being silently ignored.
"""

from __future__ import annotations

import datetime as dt
from typing import Annotated, Any, Generic, Literal, TypeVar
from zoneinfo import ZoneInfo, available_timezones

from pydantic import BaseModel, ConfigDict, Field, field_validator

from gaitwatch.conventions import GAIT_JSON_FIELDS
from service.db.models import AGGREGATE_METRICS

T = TypeVar("T")

Metric = Literal[AGGREGATE_METRICS]  # type: ignore[valid-type]
Bucket = Literal["day", "week", "month"]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", str_strip_whitespace=True)


class Out(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class PageOut(Out, Generic[T]):
    """One page of a list, with the total number of items matching the filters."""

    items: list[T]
    total: int = Field(..., examples=[128])
    limit: int = Field(..., examples=[50])
    offset: int = Field(..., examples=[0])


Name = Annotated[str, Field(min_length=1, max_length=200)]


def _check_tz(v: str | None) -> str | None:
    if v is None:
        return v
    if v not in available_timezones() and v != "UTC":
        raise ValueError(f"unknown IANA time zone {v[:64]!r}")
    ZoneInfo(v)
    return v


class ResidentCreate(Strict):
    """A new resident. Use a pseudonym if the home prefers."""

    display_name: Name = Field(..., examples=["Resident A"])
    height_m: float | None = Field(None, gt=0.5, lt=2.6, examples=[1.68])
    timezone: str = Field("UTC", max_length=64, examples=["Europe/Paris"])

    _tz = field_validator("timezone")(_check_tz)

    model_config = ConfigDict(
        extra="forbid",
        str_strip_whitespace=True,
        json_schema_extra={
            "examples": [{"display_name": "Resident A", "height_m": 1.68, "timezone": "UTC"}]
        },
    )


class ResidentUpdate(Strict):
    """Fields to change; absent fields stay as they are."""

    display_name: Name | None = Field(None, examples=["Resident B"])
    height_m: float | None = Field(None, gt=0.5, lt=2.6, examples=[1.7])
    timezone: str | None = Field(None, max_length=64, examples=["Europe/Berlin"])

    _tz = field_validator("timezone")(_check_tz)


class CameraBrief(Out):
    id: int
    name: str


class ResidentOut(Out):
    id: int = Field(..., examples=[1])
    display_name: str = Field(..., examples=["Resident A"])
    height_m: float | None = Field(None, examples=[1.68])
    timezone: str = Field(..., examples=["UTC"])
    created_at: dt.datetime
    updated_at: dt.datetime
    cameras: list[CameraBrief] = Field(default_factory=list)


class ErasureOut(BaseModel):
    """What deleting a resident erased."""

    resident_id: int
    rows: dict[str, int] = Field(..., examples=[{"bouts": 120, "recordings": 12}])
    files_deleted: int
    files_missing: int
    files_kept: int = Field(
        ..., description="Pose logs not deleted because their content no longer matches."
    )


class BaselineOut(Out):
    """The resident's current personal baseline of the metric."""

    value: float = Field(..., examples=[1.12])
    q1: float
    q3: float
    n_days: int = Field(..., examples=[42])
    window_start: dt.date
    window_end: dt.date


class TrendPoint(BaseModel):
    """One bucket of a trend."""

    start: dt.date = Field(..., examples=["2026-03-02"])
    end: dt.date = Field(..., description="Last day of the bucket (inclusive).")
    median: float = Field(..., examples=[1.08])
    q1: float = Field(..., examples=[1.01])
    q3: float = Field(..., examples=[1.15])
    count: int = Field(..., description="Values (bouts, or TUGs) in the bucket.", examples=[9])
    baseline: float | None = Field(
        None, description="Personal baseline in effect at the start of the bucket.", examples=[1.12]
    )
    change: float | None = Field(None, description="median - baseline.", examples=[-0.04])
    change_pct: float | None = Field(
        None, description="100 * (median - baseline) / baseline.", examples=[-3.6]
    )


class TrendOut(BaseModel):
    resident_id: int
    metric: str = Field(..., examples=["walking_speed_m_s"])
    unit: str = Field(..., examples=["m/s"])
    bucket: str = Field(..., examples=["week"])
    from_: dt.date = Field(..., alias="from")
    to: dt.date
    baseline: BaselineOut | None = None
    points: list[TrendPoint]

    model_config = ConfigDict(populate_by_name=True)


class BoutOut(Out):
    id: int
    recording_id: int
    started_at: dt.datetime
    ended_at: dt.datetime
    day: dt.date
    walking_speed_m_s: float | None = Field(None, examples=[1.05])
    cadence_steps_min: float | None = None
    stride_length_m: float | None = None
    step_length_m: float | None = None
    step_width_m: float | None = None
    stride_time_s: float | None = None
    stance_pct: float | None = None
    swing_pct: float | None = None
    double_support_pct: float | None = None
    stride_time_cv_pct: float | None = None
    extra: dict[str, Any] = Field(default_factory=dict)


assert all(f in BoutOut.model_fields for f in GAIT_JSON_FIELDS)


class TransferOut(Out):
    id: int
    recording_id: int
    kind: str = Field(..., examples=["sit_to_stand"])
    started_at: dt.datetime
    duration_s: float | None = Field(None, examples=[2.4])
    tug_time_s: float | None = None
    extra: dict[str, Any] = Field(default_factory=dict)


class FallOut(Out):
    id: int
    recording_id: int
    started_at: dt.datetime
    duration_s: float | None = None
    lie_duration_s: float | None = Field(None, examples=[95.0])
    long_lie: bool
    extra: dict[str, Any] = Field(default_factory=dict)


AlertStateName = Literal["open", "acknowledged", "resolved"]


class AlertOut(Out):
    id: int = Field(..., examples=[3])
    resident_id: int
    recording_id: int | None = None
    kind: str = Field(..., examples=["fall"])
    severity: str = Field(..., examples=["high"])
    message: str = Field(..., examples=["fall detected at 2026-03-02T07:14:03+00:00"])
    state: AlertStateName
    raised_at: dt.datetime
    occurred_at: dt.datetime | None = None
    acknowledged_by: str | None = None
    acknowledged_at: dt.datetime | None = None
    acknowledge_note: str | None = None
    resolved_by: str | None = None
    resolved_at: dt.datetime | None = None
    resolve_note: str | None = None


class AlertAction(Strict):
    """A note for acknowledging or resolving an alert."""

    note: str | None = Field(None, max_length=2000, examples=["Called the resident; all well."])


CameraStatus = Literal["online", "offline", "unknown", "disabled"]


class CameraOut(Out):
    id: int
    name: str = Field(..., examples=["living-room"])
    resident_id: int | None = None
    location: str | None = Field(None, examples=["living room, north wall"])
    enabled: bool
    last_seen_at: dt.datetime | None = None
    status: CameraStatus = Field(
        ...,
        description="online: heard from recently; offline: not for a while; unknown: never.",
    )


class CameraCreate(Strict):
    name: Name = Field(..., examples=["living-room"])
    resident_id: int | None = Field(None, ge=1, le=2**62)
    location: str | None = Field(None, max_length=200)
    enabled: bool = True


class CameraUpdate(Strict):
    resident_id: int | None = Field(None, ge=1, le=2**62)
    location: str | None = Field(None, max_length=200)
    enabled: bool | None = None


class ApiKeyCreate(Strict):
    name: Name = Field(..., examples=["night shift tablet"])
    role: Literal["admin", "caregiver"] = Field(..., examples=["caregiver"])
    resident_ids: list[Annotated[int, Field(ge=1, le=2**62)]] = Field(
        default_factory=list, max_length=1000, examples=[[1, 2]]
    )


class ApiKeyOut(Out):
    id: int
    name: str
    role: str
    prefix: str
    created_at: dt.datetime
    revoked_at: dt.datetime | None = None
    resident_ids: list[int] = Field(default_factory=list)


class ApiKeyCreated(ApiKeyOut):
    key: str = Field(..., description="The key itself. Shown once; only its hash is kept.")


class IngestIn(Strict):
    """A recording's description and its gait analysis (the ``gait --json`` object)."""

    recording: dict[str, Any] = Field(
        ...,
        examples=[
            {
                "cameras": ["living-room"],
                "pose_log_path": "poses/2026-03-02T07-00.mcap",
                "sha256": "9f" * 32,
                "started_at": "2026-03-02T07:00:00Z",
                "duration_s": 600,
            }
        ],
    )
    result: dict[str, Any] = Field(..., description="CONVENTIONS `gait --json` object.")


class IngestOut(BaseModel):
    recording_id: int
    created: bool = Field(..., description="False: this recording (hash) was already stored.")
    bouts: int
    transfers: int
    falls: int
    alert_ids: list[int]


class HealthOut(BaseModel):
    status: Literal["ok", "unavailable"]
    database: Literal["ok", "unreachable"]
    schema_revision: str | None = None
