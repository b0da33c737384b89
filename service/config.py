"""Service configuration: one pydantic-settings model, read from ``GAITWATCH_*`` variables.

Every field can be set by an environment variable with the prefix ``GAITWATCH_`` (e.g.
``GAITWATCH_DATABASE_URL``, ``GAITWATCH_PORT``, ``GAITWATCH_AUTO_UPGRADE=1``) or by a ``.env``
file in the working directory. Unknown ``GAITWATCH_`` variables in a ``.env`` file are refused.
Command-line options (``gaitwatch serve --port ...``) override the environment.
"""

from __future__ import annotations

from pathlib import Path

from platformdirs import user_data_dir
from pydantic import Field, ValidationError, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from gaitwatch.errors import InputError

ENV_PREFIX = "GAITWATCH_"


class ConfigError(InputError):
    """A setting that cannot be used (the message names the variable)."""


def default_data_dir() -> Path:
    """The per-user data folder (``~/.local/share/gaitwatch`` on Linux)."""
    return Path(user_data_dir("gaitwatch", appauthor=False))


class AlertRules(BaseSettings):
    """Thresholds of the alert rules (``service.db.rules``), all overridable from the environment.

    Environment names are ``GAITWATCH_RULES_<FIELD>``, e.g. ``GAITWATCH_RULES_SLOW_SPEED_M_S``.
    """

    model_config = SettingsConfigDict(env_prefix=ENV_PREFIX + "RULES_", extra="forbid")

    slow_speed_m_s: float = Field(
        0.8,
        gt=0,
        title="Slow walking speed",
        description="Alert when a recording's walking speed is below this (m/s). "
        "0.8 m/s: Studenski et al. 2011, JAMA 305(1) (gait speed and survival).",
    )
    baseline_drop_pct: float = Field(
        15.0,
        gt=0,
        lt=100,
        title="Drop below baseline",
        description="Alert when the day's median walking speed is more than this many per cent "
        "below the resident's personal baseline.",
    )
    tug_slow_s: float = Field(
        13.5,
        gt=0,
        title="Slow TUG",
        description="Alert when a timed-up-and-go is at least this long (s). "
        "Shumway-Cook et al. 2000, Phys Ther 80(9).",
    )
    long_lie_s: float = Field(
        60.0,
        gt=0,
        title="Long lie",
        description="A fall whose time on the floor is at least this long (s) is a long lie.",
    )


class Settings(BaseSettings):
    """Everything the service reads from its environment.

    The database defaults to a SQLite file ``gaitwatch.sqlite3`` in ``data_dir``.
    """

    model_config = SettingsConfigDict(
        env_prefix=ENV_PREFIX, env_file=".env", extra="forbid", env_nested_delimiter="__"
    )

    data_dir: Path = Field(
        default_factory=default_data_dir,
        title="Data folder",
        description="Folder of the default SQLite database, pose logs and backups.",
    )
    database_url: str | None = Field(
        None,
        title="Database URL",
        description="Any SQLAlchemy URL, e.g. sqlite:////data/gaitwatch.sqlite3 or "
        "postgresql+psycopg://user:pw@host/gaitwatch. Default: a SQLite file in data_dir.",
        examples=["sqlite:////var/lib/gaitwatch/gaitwatch.sqlite3"],
    )
    host: str = Field("127.0.0.1", title="Host", description="Address the API listens on.")
    port: int = Field(8000, ge=1, le=65535, title="Port", description="TCP port of the API.")
    public_docs: bool = Field(
        False,
        title="Public API documentation",
        description="Serve the OpenAPI document and the interactive /docs page without a key. "
        "Off by default: only /healthz is open, and /openapi.json needs a valid key.",
    )
    auto_upgrade: bool = Field(
        False,
        title="Upgrade schema on start",
        description="Upgrade an out-of-date database schema when the service starts (after a "
        "backup copy of a SQLite file) instead of refusing to start.",
    )
    db_pool_size: int = Field(
        20, ge=1, le=200, title="Connection pool size", description="Connections kept open."
    )
    sqlite_busy_timeout_ms: int = Field(
        10_000, ge=0, title="SQLite busy timeout", description="How long a writer waits (ms)."
    )
    max_page_size: int = Field(
        500, ge=1, le=10_000, title="Largest page", description="Upper bound of `limit`."
    )
    camera_offline_after_s: float = Field(
        600.0,
        gt=0,
        title="Camera offline after",
        description="A camera not heard from for this long (s) is reported offline.",
    )
    baseline_window_days: int = Field(
        56, ge=7, le=730, title="Baseline window", description="Days of daily medians used."
    )
    baseline_gap_days: int = Field(
        7,
        ge=0,
        le=365,
        title="Baseline gap",
        description="The most recent days left out of the baseline, so a decline shows.",
    )
    baseline_min_days: int = Field(
        7, ge=1, title="Baseline minimum", description="Days with data needed for a baseline."
    )
    rules: AlertRules = Field(default_factory=AlertRules, title="Alert rule thresholds")

    @field_validator("database_url")
    @classmethod
    def _non_empty(cls, v: str | None) -> str | None:
        if v is not None and not v.strip():
            return None
        return v

    @property
    def db_url(self) -> str:
        """The database URL in effect (the default SQLite file when none is configured)."""
        if self.database_url:
            return self.database_url
        return f"sqlite:///{(self.data_dir / 'gaitwatch.sqlite3').resolve()}"

    @property
    def poselog_dir(self) -> Path:
        """Folder where pose logs uploaded through the API are kept."""
        return self.data_dir / "poselogs"

    @property
    def backup_dir(self) -> Path:
        """Folder of the automatic copies made before a schema upgrade."""
        return self.data_dir / "backups"


def load_settings(**overrides: object) -> Settings:
    """Read the settings from the environment, applying explicit ``overrides`` on top.

    Raises
    ------
    ConfigError
        A variable has a value that cannot be used; the message names it.
    """
    clean = {k: v for k, v in overrides.items() if v is not None}
    try:
        return Settings(**clean)  # type: ignore[arg-type]
    except ValidationError as err:
        first = err.errors()[0]
        loc = ".".join(str(p) for p in first["loc"]) or "?"
        raise ConfigError(
            f"setting {ENV_PREFIX}{loc.upper()}: {first['msg']} (got {first.get('input')!r})"
        ) from None
