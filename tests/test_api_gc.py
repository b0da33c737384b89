"""The API server keeps its start-up objects out of full garbage collections (issue 6)."""

from __future__ import annotations

import gc
import weakref

from service.api.app import freeze_startup_objects
from tests.service_helpers import *  # noqa: F403  (fixtures)
from tests.service_helpers import World


class _Node:
    def __init__(self) -> None:
        self.me = self  # a reference cycle: only the cycle collector frees it


def test_app_start_freezes_startup_objects_once(shared_world: World) -> None:
    # The app's lifespan has run (TestClient entered): modules, SQLAlchemy, pydantic and
    # FastAPI objects, far more than 10 000, sit in the permanent generation.
    assert gc.get_freeze_count() > 10_000
    assert shared_world.client.get("/healthz").status_code == 200
    # Once per process: a later app start freezes nothing new, so garbage made after start-up
    # (by requests) is still collected.
    node = _Node()
    ref = weakref.ref(node)
    del node
    freeze_startup_objects()
    gc.collect()
    assert ref() is None
