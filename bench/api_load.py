"""Load benchmark of the trends endpoint: requests/s and p50/p99 latency on loopback.

Builds (or reuses, with ``--db``) a SQLite database of ``--residents`` residents with ``--days``
of daily recordings, bouts and aggregates, starts ``gaitwatch serve`` in a subprocess on a free
port of 127.0.0.1, and drives ``GET /residents/{id}/trends`` with ``--clients`` concurrent
clients (httpx AsyncClient, one connection each) until ``--requests`` requests or
``--seconds`` have passed. The request mix is what a dashboard asks: the last 90 days by day
(60 %), the last year by week (25 %), two years by month (15 %), random resident and metric.

Target (issue 6): p99 under 50 ms at 50 concurrent clients with SQLite on the 2-core machine.
Client and server share the machine, so the figures include the client's own CPU use; the
client's event-loop lag is printed so its own stalls are not taken for the server's. In the
think-time scenario each client starts after its own think time (not all at the same instant);
``--show-slow MS`` lists when the slow requests started (docs/api.md, "Latency tail").

Usage::

    python bench/api_load.py                     # 100 residents x 730 days, 50 clients
    python bench/api_load.py --db /tmp/gw-bench.sqlite3 --clients 10 --requests 2000
"""

from __future__ import annotations

import argparse
import asyncio
import datetime as dt
import gc
import os
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import httpx
import numpy as np

from gaitwatch.conventions import GAIT_JSON_FIELDS
from service.api.security import create_api_key
from service.db.migrate import upgrade
from service.db.models import Resident
from service.db.session import make_engine, make_sessionmaker
from service.db.synthetic import populate


def build_db(path: Path, residents: int, days: int, bouts_per_day: int, seed: int) -> str:
    """Create the database unless ``path`` already holds the residents; return an admin key."""
    url = f"sqlite:///{path}"
    upgrade(url)
    engine = make_engine(url, pool_size=2)
    try:
        sm = make_sessionmaker(engine)
        with sm() as s:
            have = s.query(Resident).count()
        if have < residents:
            t0 = time.perf_counter()
            with sm() as s:
                populate(
                    s,
                    np.random.default_rng(seed),
                    n_residents=residents - have,
                    days=days,
                    bouts_per_day=bouts_per_day,
                )
            print(
                f"built {residents - have} residents x {days} days in "
                f"{time.perf_counter() - t0:.0f} s",
                file=sys.stderr,
            )
        with sm() as s:
            _, token = create_api_key(s, name="bench", role="admin")
            s.commit()
        return token
    finally:
        engine.dispose()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_server(url: str, port: int, workers: int) -> subprocess.Popen[bytes]:
    env = {**os.environ, "GAITWATCH_DATABASE_URL": url}
    cmd = [sys.executable, "-m", "service.cli", "-q", "serve", "--host", "127.0.0.1"]
    cmd += ["--port", str(port), "--log-level", "warning", "--workers", str(workers)]
    proc = subprocess.Popen(cmd, env=env)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise SystemExit(f"server exited with code {proc.returncode}")
        try:
            if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code == 200:
                return proc
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    proc.terminate()
    raise SystemExit("server did not become healthy within 60 s")


def server_cpu_s(pid: int) -> float:
    """CPU seconds (user + system) used so far by process ``pid`` and its children (Linux)."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0.0
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(stat.parent.name) == pid or int(fields[1]) == pid:
            total += (int(fields[11]) + int(fields[12])) / tick
    return total


def make_paths(rng: np.random.Generator, ids: list[int], n: int, today: dt.date) -> list[str]:
    paths = []
    for _ in range(n):
        rid = int(rng.choice(ids))
        metric = GAIT_JSON_FIELDS[int(rng.integers(len(GAIT_JSON_FIELDS)))]
        u = rng.random()
        bucket, span = ("day", 89) if u < 0.6 else ("week", 364) if u < 0.85 else ("month", 729)
        start = today - dt.timedelta(days=span)
        paths.append(
            f"/residents/{rid}/trends?metric={metric}&bucket={bucket}&from={start}&to={today}"
        )
    return paths


@dataclass
class Run:
    """One measured run: latency (s) and start (s from the run's start) of each request."""

    latency: list[float]
    started: list[float]
    errors: int
    wall: float
    loop_lag: list[float]


async def drive(
    base: str,
    token: str,
    paths: list[str],
    clients: int,
    seconds: float,
    think_s: float = 0.0,
    rng: np.random.Generator | None = None,
) -> Run:
    """Run the requests with ``clients`` workers; latencies, start times, errors, wall time.

    Each client waits an exponentially distributed think time of mean ``think_s`` after each
    answer (0: closed loop, as fast as the server answers).
    """
    rng = rng or np.random.default_rng(0)
    queue: asyncio.Queue[str] = asyncio.Queue()
    for p in paths:
        queue.put_nowait(p)
    lat: list[float] = []
    started: list[float] = []
    lags: list[float] = []
    errors = 0
    deadline = time.perf_counter() + seconds
    headers = {"Authorization": f"Bearer {token}"}
    limits = httpx.Limits(max_connections=clients, max_keepalive_connections=clients)

    async def worker(client: httpx.AsyncClient) -> None:
        nonlocal errors
        if think_s > 0:
            # Caregivers do not all click at the same instant: start each client after its
            # own think time. (Starting all 50 at once queued 50 requests on 2 workers, a
            # 250 ms burst that alone was 1.7 % of 3000 requests, i.e. the whole p99.)
            await asyncio.sleep(float(rng.exponential(think_s)))
        while time.perf_counter() < deadline:
            try:
                path = queue.get_nowait()
            except asyncio.QueueEmpty:
                return
            t0 = time.perf_counter()
            try:
                r = await client.get(path, headers=headers)
                ok = r.status_code == 200 and r.json()["points"] is not None
                if not ok:
                    print(f"error {r.status_code}: {r.text[:200]}", file=sys.stderr)
            except httpx.HTTPError as err:
                ok = False
                print(f"error {type(err).__name__}: {err}", file=sys.stderr)
            lat.append(time.perf_counter() - t0)
            started.append(t0)
            errors += not ok
            if think_s > 0:
                await asyncio.sleep(float(rng.exponential(think_s)))

    async def lag_monitor() -> None:
        # The load generator's own stalls (its GC, its CPU share) show up as event-loop lag.
        while True:
            t = time.perf_counter()
            await asyncio.sleep(0.005)
            lags.append(time.perf_counter() - t - 0.005)

    async with httpx.AsyncClient(base_url=base, limits=limits, timeout=30) as client:
        monitor = asyncio.create_task(lag_monitor())
        t0 = time.perf_counter()
        await asyncio.gather(*(worker(client) for _ in range(clients)))
        wall = time.perf_counter() - t0
        monitor.cancel()
    return Run(lat, [t - t0 for t in started], errors, wall, lags)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--residents", type=int, default=100)
    ap.add_argument("--days", type=int, default=730)
    ap.add_argument("--bouts-per-day", type=int, default=4)
    ap.add_argument("--clients", type=int, default=50)
    ap.add_argument("--requests", type=int, default=3000, help="measured requests (max)")
    ap.add_argument("--warmup", type=int, default=300)
    ap.add_argument("--seconds", type=float, default=60.0, help="time limit of the measurement")
    ap.add_argument("--workers", type=int, default=2, help="server processes")
    ap.add_argument(
        "--think",
        type=float,
        default=1.0,
        help="mean think time (s) of each client between requests in the caregiver scenario",
    )
    ap.add_argument("--db", type=Path, help="database file to build or reuse (default: temp)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--show-slow",
        type=float,
        default=0.0,
        metavar="MS",
        help="list the start time (s into the run) of every request slower than MS",
    )
    args = ap.parse_args(argv)

    tmp = None
    if args.db is None:
        tmp = tempfile.TemporaryDirectory(prefix="gw-bench-")
        args.db = Path(tmp.name) / "bench.sqlite3"
    token = build_db(args.db, args.residents, args.days, args.bouts_per_day, args.seed)
    url = f"sqlite:///{args.db}"
    load_before = " ".join(f"{x:.1f}" for x in os.getloadavg())
    port = free_port()
    proc = start_server(url, port, args.workers)
    try:
        rng = np.random.default_rng(args.seed)
        ids = list(range(1, args.residents + 1))
        today = dt.datetime.now(dt.UTC).date()
        base = f"http://127.0.0.1:{port}"
        asyncio.run(drive(base, token, make_paths(rng, ids, args.warmup, today), 10, 60, 0.0, rng))
        # The load generator's own full GC pauses would be counted as server latency.
        gc.collect()
        gc.freeze()
        results = {}
        cpu: dict[str, float] = {}
        for name, think in (("caregivers", args.think), ("saturation", 0.0)):
            paths = make_paths(rng, ids, args.requests, today)
            cpu0 = server_cpu_s(proc.pid)
            results[name] = asyncio.run(
                drive(base, token, paths, args.clients, args.seconds, think, rng)
            )
            cpu[name] = server_cpu_s(proc.pid) - cpu0
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
        if tmp is not None:
            tmp.cleanup()
    print(f"load average before: {load_before}")
    print(
        f"trends endpoint, {args.residents} residents x {args.days} days, SQLite, "
        f"{args.clients} concurrent clients, {args.workers} server worker(s), "
        f"{os.cpu_count()} CPUs shared with the load generator"
    )
    for name, run in results.items():
        lat, errors, wall = run.latency, run.errors, run.wall
        ms = np.array(lat) * 1000
        how = (
            f"each client thinks {args.think:g} s (mean) between requests"
            if name == "caregivers"
            else "closed loop, no think time"
        )
        print(f"[{name}] {how}")
        print(f"  server CPU per request: {1000 * cpu[name] / max(len(lat), 1):.1f} ms")
        print(f"  requests: {len(lat)} in {wall:.1f} s ({len(lat) / wall:.0f}/s), errors: {errors}")
        print(
            f"  latency ms: p50 {np.percentile(ms, 50):.1f}  p90 {np.percentile(ms, 90):.1f}  "
            f"p99 {np.percentile(ms, 99):.1f}  p99.9 {np.percentile(ms, 99.9):.1f}  "
            f"max {ms.max():.1f}  "
            f"(target p99 < 50 ms: {'met' if np.percentile(ms, 99) < 50 else 'NOT met'})"
        )
        lag = np.array(run.loop_lag or [0.0]) * 1000
        print(
            f"  load generator loop lag ms: p99 {np.percentile(lag, 99):.1f}  max {lag.max():.1f}"
        )
        if args.show_slow > 0:
            slow = [(t, x) for t, x in zip(run.started, ms, strict=True) if x > args.show_slow]
            print(f"  requests slower than {args.show_slow:g} ms: {len(slow)} (first 40 listed)")
            for t, x in slow[:40]:
                print(f"    at {t:7.3f} s: {x:.0f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
