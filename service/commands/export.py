"""``gaitwatch export POSES.mcap --csv JOINTS.csv``: a pose log's joint positions as JOINTS.csv.

Frames without a pose have no rows (CONVENTIONS). A log cut short by a crash is exported up to
its last whole message, with a warning in the summary line.
"""

from __future__ import annotations

import argparse
import logging
import os
import tempfile
from pathlib import Path

from gaitwatch.errors import InputError
from gaitwatch.trajectory import Trajectory, write_joints_csv
from service.poselog import read_poselog

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export",
        help="export a pose log (MCAP) to JOINTS.csv",
        description=(
            "Write the joint positions of a pose log written by 'gaitwatch track' as JOINTS.csv "
            "(frame,time_s,joint,x,y,z; metres, world frame). Frames without a pose have no rows."
        ),
    )
    p.add_argument("poses", metavar="POSES.mcap", type=Path, help="pose log to read")
    p.add_argument(
        "--csv", metavar="JOINTS.csv", type=Path, required=True, help="CSV file to write"
    )
    p.set_defaults(func=run)


def _write_atomically(traj: Trajectory, out: Path) -> None:
    """Write the CSV beside ``out``, then move it into place: a failure leaves ``out`` intact."""
    directory = out.parent if str(out.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(f"{out}: folder {directory} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".tmp", dir=directory)
    os.close(fd)
    try:
        write_joints_csv(traj, tmp)
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def run(args: argparse.Namespace) -> int:
    src: Path = args.poses
    out: Path = args.csv
    if out.exists() and src.exists() and out.resolve() == src.resolve():
        raise InputError(f"{out}: --csv would overwrite the pose log it reads")
    if out.is_dir():
        raise InputError(f"{out}: --csv names a folder, not a file")
    plog = read_poselog(src)
    traj = plog.trajectory
    if len(traj) == 0:
        cut = " (the file was cut short)" if plog.truncated else ""
        raise InputError(
            f"{src}: no frame with a pose{cut} ({len(plog.no_pose)} without); nothing to export"
        )
    _write_atomically(traj, out)
    line = (
        f"exported {len(traj)} frames with a pose (frames {traj.frames[0]}-{traj.frames[-1]}, "
        f"{traj.times[0]:.2f}-{traj.times[-1]:.2f} s; {len(plog.no_pose)} without a pose) "
        f"to {out}"
    )
    if plog.truncated:
        line += f"; warning: {src} was cut short, read up to its last whole message"
    print(line)
    return 0
