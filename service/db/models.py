"""The database schema: SQLAlchemy 2.0 declarative models with typed ``Mapped[...]`` columns.

Every schema change is an Alembic migration in ``migrations/versions`` (the test suite checks
that the migrations and these models agree). Only portable SQL types are used, so any
SQLAlchemy URL works; SQLite specifics live in the connect hook of ``service.db.session``.

Times are stored as UTC (:class:`UTCDateTime` returns timezone-aware datetimes). Measurements
carry ``resident_id`` directly so that per-resident queries and erasure need no joins.
"""

from __future__ import annotations

import datetime as dt
import enum
from typing import Any

from sqlalchemy import (
    JSON,
    Boolean,
    Column,
    Date,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    String,
    Table,
    Text,
)
from sqlalchemy.engine import Dialect
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship
from sqlalchemy.types import TypeDecorator

from gaitwatch.conventions import GAIT_JSON_FIELDS

# Stable constraint names, so migrations can drop and alter them on every backend.
NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


def utcnow() -> dt.datetime:
    """The current time, timezone-aware UTC."""
    return dt.datetime.now(dt.UTC)


class UTCDateTime(TypeDecorator[dt.datetime]):
    """A datetime stored as naive UTC and read back timezone-aware (UTC).

    Naive datetimes given to it are refused: every time in gaitwatch is absolute.
    """

    impl = DateTime
    cache_ok = True

    def process_bind_param(self, value: dt.datetime | None, dialect: Dialect) -> Any:
        if value is None:
            return None
        if value.tzinfo is None:
            raise ValueError("naive datetime given to a UTC column; attach a timezone")
        return value.astimezone(dt.UTC).replace(tzinfo=None)

    def process_result_value(self, value: Any, dialect: Dialect) -> dt.datetime | None:
        if value is None:
            return None
        if isinstance(value, str):  # pragma: no cover - drivers without native datetimes
            value = dt.datetime.fromisoformat(value)
        return value.replace(tzinfo=dt.UTC) if value.tzinfo is None else value.astimezone(dt.UTC)


class Base(DeclarativeBase):
    """Declarative base with the naming convention above."""

    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map = {dt.datetime: UTCDateTime(), dict[str, Any]: JSON()}


class Role(enum.StrEnum):
    """What an API key may do."""

    admin = "admin"
    caregiver = "caregiver"


class AlertState(enum.StrEnum):
    """Alert life cycle: open -> acknowledged -> resolved (open -> resolved is allowed too)."""

    open = "open"
    acknowledged = "acknowledged"
    resolved = "resolved"


# The numeric gait parameters stored as columns of a bout (CONVENTIONS), in order.
BOUT_METRICS: tuple[str, ...] = GAIT_JSON_FIELDS
# Further metrics aggregated per day: timed-up-and-go durations from transfers.
TUG_METRIC = "tug_time_s"
AGGREGATE_METRICS: tuple[str, ...] = (*BOUT_METRICS, TUG_METRIC)


class Resident(Base):
    """A person monitored at home; ``display_name`` may be a pseudonym."""

    __tablename__ = "residents"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    display_name: Mapped[str] = mapped_column(String(200))
    height_m: Mapped[float | None] = mapped_column(Float)
    timezone: Mapped[str] = mapped_column(String(64), default="UTC")
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    updated_at: Mapped[dt.datetime] = mapped_column(default=utcnow, onupdate=utcnow)

    cameras: Mapped[list[Camera]] = relationship(back_populates="resident")


class Camera(Base):
    """A camera in a resident's home. Status is derived from ``last_seen_at``."""

    __tablename__ = "cameras"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    resident_id: Mapped[int | None] = mapped_column(
        ForeignKey("residents.id", ondelete="SET NULL"), index=True
    )
    location: Mapped[str | None] = mapped_column(String(200))
    enabled: Mapped[bool] = mapped_column(Boolean, default=True)
    last_seen_at: Mapped[dt.datetime | None] = mapped_column()
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    resident: Mapped[Resident | None] = relationship(back_populates="cameras")


recording_cameras = Table(
    "recording_cameras",
    Base.metadata,
    Column("recording_id", ForeignKey("recordings.id", ondelete="CASCADE"), primary_key=True),
    Column("camera_id", ForeignKey("cameras.id", ondelete="CASCADE"), primary_key=True),
)


class Recording(Base):
    """One analysed pose log: its file, content hash and time span. Unique per hash."""

    __tablename__ = "recordings"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    resident_id: Mapped[int] = mapped_column(
        ForeignKey("residents.id", ondelete="CASCADE"), index=True
    )
    sha256: Mapped[str] = mapped_column(String(64), unique=True)
    pose_log_path: Mapped[str | None] = mapped_column(Text)
    started_at: Mapped[dt.datetime] = mapped_column()
    ended_at: Mapped[dt.datetime] = mapped_column()
    duration_s: Mapped[float] = mapped_column(Float)
    summary: Mapped[dict[str, Any]] = mapped_column(default=dict)
    ingested_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    cameras: Mapped[list[Camera]] = relationship(secondary=recording_cameras)


class Bout(Base):
    """A walking bout with its gait parameters (CONVENTIONS fields as columns, extras in JSON)."""

    __tablename__ = "bouts"
    __table_args__ = (Index("ix_bouts_resident_start", "resident_id", "started_at"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    recording_id: Mapped[int] = mapped_column(
        ForeignKey("recordings.id", ondelete="CASCADE"), index=True
    )
    resident_id: Mapped[int] = mapped_column(ForeignKey("residents.id", ondelete="CASCADE"))
    day: Mapped[dt.date] = mapped_column(Date)
    started_at: Mapped[dt.datetime] = mapped_column()
    ended_at: Mapped[dt.datetime] = mapped_column()
    start_s: Mapped[float] = mapped_column(Float)
    end_s: Mapped[float] = mapped_column(Float)
    walking_speed_m_s: Mapped[float | None] = mapped_column(Float)
    cadence_steps_min: Mapped[float | None] = mapped_column(Float)
    stride_length_m: Mapped[float | None] = mapped_column(Float)
    step_length_m: Mapped[float | None] = mapped_column(Float)
    step_width_m: Mapped[float | None] = mapped_column(Float)
    stride_time_s: Mapped[float | None] = mapped_column(Float)
    stance_pct: Mapped[float | None] = mapped_column(Float)
    swing_pct: Mapped[float | None] = mapped_column(Float)
    double_support_pct: Mapped[float | None] = mapped_column(Float)
    stride_time_cv_pct: Mapped[float | None] = mapped_column(Float)
    extra: Mapped[dict[str, Any]] = mapped_column(default=dict)


class Transfer(Base):
    """A sit-to-stand, stand-to-sit or timed-up-and-go sequence."""

    __tablename__ = "transfers"
    __table_args__ = (Index("ix_transfers_resident_start", "resident_id", "started_at"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    recording_id: Mapped[int] = mapped_column(
        ForeignKey("recordings.id", ondelete="CASCADE"), index=True
    )
    resident_id: Mapped[int] = mapped_column(ForeignKey("residents.id", ondelete="CASCADE"))
    day: Mapped[dt.date] = mapped_column(Date)
    kind: Mapped[str] = mapped_column(String(40))
    started_at: Mapped[dt.datetime] = mapped_column()
    start_s: Mapped[float] = mapped_column(Float)
    duration_s: Mapped[float | None] = mapped_column(Float)
    tug_time_s: Mapped[float | None] = mapped_column(Float)
    extra: Mapped[dict[str, Any]] = mapped_column(default=dict)


class Fall(Base):
    """A detected fall, with the time spent on the floor when known."""

    __tablename__ = "falls"
    __table_args__ = (Index("ix_falls_resident_start", "resident_id", "started_at"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    recording_id: Mapped[int] = mapped_column(
        ForeignKey("recordings.id", ondelete="CASCADE"), index=True
    )
    resident_id: Mapped[int] = mapped_column(ForeignKey("residents.id", ondelete="CASCADE"))
    started_at: Mapped[dt.datetime] = mapped_column()
    start_s: Mapped[float] = mapped_column(Float)
    duration_s: Mapped[float | None] = mapped_column(Float)
    lie_duration_s: Mapped[float | None] = mapped_column(Float)
    long_lie: Mapped[bool] = mapped_column(Boolean, default=False)
    extra: Mapped[dict[str, Any]] = mapped_column(default=dict)


class Aggregate(Base):
    """Per resident, metric and period (local day, ISO week, month): median, quartiles, count.

    ``period`` is ``day``, ``week`` (``start`` a Monday) or ``month`` (``start`` the 1st). The
    week and month rows pool the underlying values (exact quantiles), so trends of any bucket
    read a handful of rows.
    """

    __tablename__ = "aggregates"

    resident_id: Mapped[int] = mapped_column(
        ForeignKey("residents.id", ondelete="CASCADE"), primary_key=True
    )
    metric: Mapped[str] = mapped_column(String(64), primary_key=True)
    period: Mapped[str] = mapped_column(String(8), primary_key=True)
    start: Mapped[dt.date] = mapped_column(Date, primary_key=True)
    median: Mapped[float] = mapped_column(Float)
    q1: Mapped[float] = mapped_column(Float)
    q3: Mapped[float] = mapped_column(Float)
    count: Mapped[int] = mapped_column(Integer)


PERIODS: tuple[str, ...] = ("day", "week", "month")


class Baseline(Base):
    """A resident's current personal baseline of one metric (median of daily medians)."""

    __tablename__ = "baselines"

    resident_id: Mapped[int] = mapped_column(
        ForeignKey("residents.id", ondelete="CASCADE"), primary_key=True
    )
    metric: Mapped[str] = mapped_column(String(64), primary_key=True)
    value: Mapped[float] = mapped_column(Float)
    q1: Mapped[float] = mapped_column(Float)
    q3: Mapped[float] = mapped_column(Float)
    n_days: Mapped[int] = mapped_column(Integer)
    window_start: Mapped[dt.date] = mapped_column(Date)
    window_end: Mapped[dt.date] = mapped_column(Date)
    computed_at: Mapped[dt.datetime] = mapped_column(default=utcnow)


class Alert(Base):
    """Something a caregiver should look at; raised by ``service.db.rules`` on ingest."""

    __tablename__ = "alerts"
    __table_args__ = (Index("ix_alerts_resident_state", "resident_id", "state"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    resident_id: Mapped[int] = mapped_column(ForeignKey("residents.id", ondelete="CASCADE"))
    recording_id: Mapped[int | None] = mapped_column(
        ForeignKey("recordings.id", ondelete="SET NULL")
    )
    kind: Mapped[str] = mapped_column(String(40))
    severity: Mapped[str] = mapped_column(String(16))
    message: Mapped[str] = mapped_column(Text)
    state: Mapped[str] = mapped_column(String(16), default=AlertState.open.value, index=True)
    raised_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    occurred_at: Mapped[dt.datetime | None] = mapped_column()
    acknowledged_by: Mapped[str | None] = mapped_column(String(120))
    acknowledged_at: Mapped[dt.datetime | None] = mapped_column()
    acknowledge_note: Mapped[str | None] = mapped_column(Text)
    resolved_by: Mapped[str | None] = mapped_column(String(120))
    resolved_at: Mapped[dt.datetime | None] = mapped_column()
    resolve_note: Mapped[str | None] = mapped_column(Text)


api_key_residents = Table(
    "api_key_residents",
    Base.metadata,
    Column("api_key_id", ForeignKey("api_keys.id", ondelete="CASCADE"), primary_key=True),
    Column("resident_id", ForeignKey("residents.id", ondelete="CASCADE"), primary_key=True),
)


class ApiKey(Base):
    """An API key: only its prefix (for lookup) and the SHA-256 of the whole key are kept."""

    __tablename__ = "api_keys"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    prefix: Mapped[str] = mapped_column(String(16), unique=True)
    key_hash: Mapped[str] = mapped_column(String(64))
    name: Mapped[str] = mapped_column(String(120))
    role: Mapped[str] = mapped_column(String(16))
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    revoked_at: Mapped[dt.datetime | None] = mapped_column()

    residents: Mapped[list[Resident]] = relationship(secondary=api_key_residents)


class AuditEntry(Base):
    """Who read or changed which resident's data, and when.

    ``resident_id`` is deliberately not a foreign key: entries outlive an erased resident.
    """

    __tablename__ = "audit_log"
    __table_args__ = (Index("ix_audit_log_resident_at", "resident_id", "at"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    actor: Mapped[str] = mapped_column(String(120))
    action: Mapped[str] = mapped_column(String(40))
    resident_id: Mapped[int | None] = mapped_column(Integer)
    target: Mapped[str] = mapped_column(String(300))
    detail: Mapped[str | None] = mapped_column(Text)
