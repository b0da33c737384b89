"""``gaitwatch demo``: the whole pipeline on an embedded default, with no server to install.

1. ``simulate``: a procedural walk (built in, no data files needed) rendered as camera footage of a
   person in a room, with its ground truth ``JOINTS.csv``;
2. ``track``: Interval Particle Filtering on that footage -> ``poses.mcap``;
3. ``export``: the tracked joints as ``JOINTS.csv``, scored against the ground truth;
4. ``gait``: gait parameters, balance and fall risk -> ``gait.json``;
5. the store: an SQLite database in the output folder, migrated, with a demo resident and the
   result ingested (what the REST API then serves; ``gaitwatch serve --db ...`` starts it).

Every step is the real sub-command, called as a user would call it.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as dt
import io
import json
import shutil
import time
from pathlib import Path

from gaitwatch.errors import InputError


class DemoError(InputError):
    """The demo cannot run with these options."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="run the pipeline end to end on built-in data",
        description="Simulate a walk seen by cameras, track it with IPF, analyse the gait and "
        "store the result in an SQLite database, all in --out.",
    )
    p.add_argument(
        "--out", default="gaitwatch-demo", help="output folder (default ./gaitwatch-demo)"
    )
    p.add_argument("--cameras", type=int, choices=(1, 2, 3), default=2, help="cameras (2)")
    p.add_argument("--frames", type=int, default=80, help="frames at 20 fps to track (80)")
    p.add_argument("--filter", choices=("ipf", "apf", "condensation"), default="ipf")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--force", action="store_true", help="replace an earlier demo in --out")
    p.set_defaults(func=run)


def _step(n: int, title: str) -> None:
    print(f"\n[{n}/5] {title}", flush=True)


def _call(argv: list[str]) -> None:
    from service.cli import main

    rc = main(argv)
    if rc != 0:
        raise DemoError(f"'gaitwatch {' '.join(argv)}' failed with exit code {rc}")


def run(args: argparse.Namespace) -> int:
    if args.frames < 40:
        raise DemoError("--frames must be at least 40 (two strides at 20 fps)")
    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        if not args.force:
            raise DemoError(f"{out} is not empty; use --force to replace the earlier demo")
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    scene = out / "scene"
    views = ",".join(["oblique", "side", "frontal"][: args.cameras])
    height = 1.68
    t0 = time.perf_counter()

    _step(1, f"simulate: a {height} m person walking, seen by {args.cameras} camera(s)")
    _call(
        [
            "-q", "simulate", f"walk:speed=1.1,height={height},distance=5",
            "--out", str(scene), "--views", views, "--fps", "20",
            "--max-frames", str(args.frames), "--seed", str(args.seed), "--shape", "heavy",
        ]
    )  # fmt: skip
    cams = sorted(scene.glob("cam*.yaml"))
    print(f"      wrote {scene}/ (videos, camera files, backgrounds, JOINTS.csv)")

    _step(2, f"track: {args.filter} on the footage")
    poses = out / "poses.mcap"
    argv = ["-q", "track"]
    argv += [str(c.with_suffix(".mp4")) for c in cams]
    for c in cams:
        argv += ["--camera", str(c)]
    for c in cams:
        argv += ["--background", str(c.with_name(c.stem + "-background.png"))]
    argv += ["--height", str(height), "--filter", args.filter, "--seed", str(args.seed)]
    argv += ["--out", str(poses)]
    t_track = time.perf_counter()
    _call(argv)
    t_track = time.perf_counter() - t_track
    print(f"      wrote {poses} in {t_track:.1f} s")

    _step(3, "export and score against the ground truth")
    joints = out / "JOINTS.csv"
    _call(["-q", "export", str(poses), "--csv", str(joints)])
    _print_accuracy(scene / "JOINTS.csv", joints)

    _step(4, "gait: parameters, balance, fall risk")
    gait_json = out / "gait.json"
    _call(["gait", str(joints), "--json", str(gait_json)])

    _step(5, "store: SQLite database, resident, ingest")
    db_url = f"sqlite:///{(out / 'gaitwatch.sqlite3').resolve()}"
    _call(["-q", "db", "upgrade", "--db", db_url])
    resident_id = _add_resident(db_url, height)
    start = dt.datetime.now(dt.UTC).replace(microsecond=0).isoformat()
    duration = json.loads(gait_json.read_text()).get("duration_s") or args.frames / 20
    _call(
        [
            "-q", "ingest", str(gait_json), "--db", db_url, "--resident", str(resident_id),
            "--poselog", str(poses), "--start", start, "--duration", f"{float(duration):.3f}",
        ]
    )  # fmt: skip
    print(f"      stored for resident {resident_id} in {db_url}")
    print(
        f"\nDone in {time.perf_counter() - t0:.0f} s. Serve it with:\n"
        f"  gaitwatch serve --db {db_url}\n"
        f"  (create a key first: gaitwatch apikey create --role admin --db {db_url})"
    )
    return 0


def _add_resident(db_url: str, height: float) -> int:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        _call(["-q", "resident", "add", "Demo resident", "--height", str(height), "--db", db_url])
    return int(buf.getvalue().split()[-1])


def _print_accuracy(truth_csv: Path, est_csv: Path) -> None:
    from gaitwatch.evaluation import evaluate
    from gaitwatch.trajectory import read_joints_csv

    m = evaluate(read_joints_csv(truth_csv), read_joints_csv(est_csv))
    print(
        f"      mean joint error {m.mpjpe_mm:.0f} mm (lower limbs {m.lower_limb_mm:.0f} mm), "
        f"hip / knee flexion RMSE {m.hip_flexion_rmse_deg:.1f} / "
        f"{m.knee_flexion_rmse_deg:.1f} deg, frames lost {m.frames_lost}/{m.n_truth_frames}"
    )
