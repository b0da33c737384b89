"""Shared fixtures. Tests needing ../shared/data skip with a clear reason when it is absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("GAITWATCH_SHARED_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The folder of real recordings beside the checkout (``../shared/data``)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(
            f"shared recordings not found at {SHARED_DATA} "
            "(set GAITWATCH_SHARED_DATA or place shared/ beside the checkout)"
        )
    return SHARED_DATA


@pytest.fixture(scope="module")
def body():
    """The tracker's body model of a 1.72 m person (modules may define their own)."""
    from tracker.body import BodyModel

    return BodyModel(1.72)


@pytest.fixture(scope="module")
def limits():
    """The walking joint limits as (low, high) arrays (radians, metres)."""
    from tracker.dof import JointLimits

    return JointLimits.profile("walking").arrays()


def shared_file(shared_data: Path, rel: str) -> Path:
    p = shared_data / rel
    if not p.is_file():
        pytest.skip(f"shared file {rel} not found under {shared_data}")
    return p


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Skip ``sqlite_only`` tests when the storage tests run on PostgreSQL (see
    ``tests/service_helpers.py``)."""
    if not os.environ.get("GAITWATCH_TEST_POSTGRES_URL"):
        return
    skip = pytest.mark.skip(reason="SQLite-only feature; the storage tests run on PostgreSQL")
    for item in items:
        if "sqlite_only" in item.keywords:
            item.add_marker(skip)
