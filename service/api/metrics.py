"""Prometheus metrics in the text exposition format, without extra dependencies.

Counts and latencies of requests per method, route template and status, and ingest counts.
Process-local: each server process exposes its own figures.
"""

from __future__ import annotations

import bisect
import threading
import time
from collections import defaultdict
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

BUCKETS = (0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0)


def _esc(v: str) -> str:
    return v.replace("\\", "\\\\").replace("\n", "\\n").replace('"', '\\"')


class Registry:
    """Thread-safe counters and histograms rendered as Prometheus text."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.requests: dict[tuple[str, str, str], int] = defaultdict(int)
        self.latency: dict[tuple[str, str], list[int]] = {}
        self.latency_sum: dict[tuple[str, str], float] = defaultdict(float)
        self.latency_count: dict[tuple[str, str], int] = defaultdict(int)
        self.ingest: dict[str, int] = defaultdict(int)

    def observe_request(self, method: str, route: str, status: int, seconds: float) -> None:
        with self._lock:
            self.requests[(method, route, str(status))] += 1
            key = (method, route)
            hist = self.latency.setdefault(key, [0] * (len(BUCKETS) + 1))
            hist[bisect.bisect_left(BUCKETS, seconds)] += 1
            self.latency_sum[key] += seconds
            self.latency_count[key] += 1

    def count_ingest(self, outcome: str, n: int = 1) -> None:
        with self._lock:
            self.ingest[outcome] += n

    def render(self, gauges: dict[str, tuple[str, float]] | None = None) -> str:
        """Prometheus text format (version 0.0.4)."""
        out: list[str] = []
        with self._lock:
            out.append("# HELP gaitwatch_http_requests_total HTTP requests answered.")
            out.append("# TYPE gaitwatch_http_requests_total counter")
            for (m, r, s), n in sorted(self.requests.items()):
                out.append(
                    f'gaitwatch_http_requests_total{{method="{m}",route="{_esc(r)}",'
                    f'status="{s}"}} {n}'
                )
            out.append("# HELP gaitwatch_http_request_duration_seconds Request latency.")
            out.append("# TYPE gaitwatch_http_request_duration_seconds histogram")
            for (m, r), hist in sorted(self.latency.items()):
                lab = f'method="{m}",route="{_esc(r)}"'
                cum = 0
                for b, c in zip((*BUCKETS, float("inf")), hist, strict=True):
                    cum += c
                    le = "+Inf" if b == float("inf") else repr(b)
                    out.append(
                        f'gaitwatch_http_request_duration_seconds_bucket{{{lab},le="{le}"}} {cum}'
                    )
                out.append(
                    f"gaitwatch_http_request_duration_seconds_sum{{{lab}}} "
                    f"{self.latency_sum[(m, r)]:.6f}"
                )
                out.append(
                    f"gaitwatch_http_request_duration_seconds_count{{{lab}}} "
                    f"{self.latency_count[(m, r)]}"
                )
            out.append("# HELP gaitwatch_ingest_total Recordings ingested through this process.")
            out.append("# TYPE gaitwatch_ingest_total counter")
            for outcome in ("created", "duplicate", "rejected"):
                out.append(f'gaitwatch_ingest_total{{outcome="{outcome}"}} {self.ingest[outcome]}')
        for name, (help_, value) in (gauges or {}).items():
            out.append(f"# HELP {name} {help_}")
            out.append(f"# TYPE {name} gauge")
            out.append(f"{name} {value:g}")
        return "\n".join(out) + "\n"


class MetricsMiddleware:
    """Pure ASGI middleware timing every HTTP request by its route template."""

    def __init__(self, app: ASGIApp, registry: Registry) -> None:
        self.app = app
        self.registry = registry

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        t0 = time.perf_counter()
        status = 500

        async def _send(msg: Message) -> None:
            nonlocal status
            if msg["type"] == "http.response.start":
                status = int(msg["status"])
            await send(msg)

        try:
            await self.app(scope, receive, _send)
        finally:
            route: Any = scope.get("route")
            path = getattr(route, "path", None) or "unmatched"
            self.registry.observe_request(
                scope.get("method", "?"), path, status, time.perf_counter() - t0
            )
