"""``gaitwatch gait (POSES.mcap | JOINTS.csv [--fps F]) [--json OUT.json] [--source S]``: gait
analysis.

Prints a table (bouts, summary, transfers, falls, fall risk with reasons) and with ``--json``
writes the CONVENTIONS object ``{"bouts": [...], "events": [...], "summary": {...}}`` plus the
extra keys of :class:`gait.result.GaitReport` (``null`` for unknown values). Bad input ends with
a one-line error and exit code 2; an existing ``--json`` file is replaced only on success.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import tempfile
from pathlib import Path

from pydantic import ValidationError

from gait.analysis import GaitConfig, analyse
from gait.filtering import GaitInputError
from gait.result import GaitReport
from gaitwatch.conventions import GAIT_JSON_FIELDS
from gaitwatch.errors import InputError
from gaitwatch.trajectory import Trajectory, read_joints_csv

log = logging.getLogger(__name__)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "gait",
        help="gait parameters, balance, transfers, falls and fall risk of a recording",
        description=(
            "Analyse the joint trajectories of a pose log (POSES.mcap from 'gaitwatch track') or "
            "a JOINTS.csv: walking bouts, gait events, spatiotemporal parameters, knee/hip "
            "angles, margin of stability, transfers, falls and a fall-risk level with reasons."
        ),
    )
    p.add_argument("input", metavar="POSES.mcap|JOINTS.csv", type=Path, help="recording to read")
    p.add_argument(
        "--fps", type=float, default=None, help="frame rate of a JOINTS.csv (default: from times)"
    )
    p.add_argument("--json", metavar="OUT.json", type=Path, default=None, help="write JSON here")
    p.add_argument(
        "--long-lie-s",
        type=float,
        default=60.0,
        help="time on the floor after a fall that counts as a long lie (s, default 60)",
    )
    p.add_argument(
        "--treadmill-speed",
        type=float,
        default=0.0,
        metavar="M_S",
        help="belt speed for a treadmill recording (m/s; default 0 = overground)",
    )
    p.add_argument(
        "--source",
        choices=("video", "markers"),
        default="video",
        help="where the key points come from: 'video' (tracked, the default; a pose log always "
        "is) or 'markers' (a laboratory JOINTS.csv). Sets the gait events' calibration "
        "(docs/gait.md, 'Gait events')",
    )
    p.set_defaults(func=run)


def load_input(path: Path, fps: float | None) -> Trajectory:
    """Read POSES.mcap (through ``service.poselog``) or JOINTS.csv."""
    if fps is not None and not (math.isfinite(fps) and fps > 0):
        raise InputError(f"--fps must be a positive number, not {fps}")
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a folder, expected POSES.mcap or JOINTS.csv")
    suffix = path.suffix.lower()
    if suffix == ".mcap":
        from service.poselog import read_poselog  # lazy: only MCAP input needs it

        plog = read_poselog(path)
        traj = plog.trajectory
        if plog.truncated:
            log.warning("%s was cut short; analysing it up to its last whole message", path)
        if fps is not None:
            traj.fps = fps
        return traj
    if suffix == ".csv":
        return read_joints_csv(path, fps=fps)
    raise InputError(f"{path}: unknown input type {suffix or '(none)'}, expected .mcap or .csv")


def _fmt(v: float | None, nd: int = 2) -> str:
    return "-" if v is None else f"{v:.{nd}f}"


_COLUMNS = (
    ("speed m/s", "walking_speed_m_s", 2),
    ("cadence", "cadence_steps_min", 1),
    ("stride m", "stride_length_m", 2),
    ("step m", "step_length_m", 2),
    ("width m", "step_width_m", 2),
    ("stride s", "stride_time_s", 2),
    ("stance%", "stance_pct", 1),
    ("swing%", "swing_pct", 1),
    ("DS%", "double_support_pct", 1),
    ("CV%", "stride_time_cv_pct", 1),
)
assert {c[1] for c in _COLUMNS} == set(GAIT_JSON_FIELDS)


def format_report(rep: GaitReport) -> str:
    """The readable terminal table."""
    lines = []
    s = rep.summary
    lines.append(
        f"{rep.source or 'recording'}: {s.duration_s:.1f} s at {_fmt(s.fps, 1)} Hz, "
        f"{len(rep.events)} gait events, {s.n_bouts} walking bout(s), "
        f"{s.walking_time_s:.1f} s walking"
    )
    head = f"{'':10s} {'start s':>7s} {'end s':>7s} {'strides':>7s} " + " ".join(
        f"{c[0]:>9s}" for c in _COLUMNS
    )
    lines.append(head)
    rows = [(f"bout {i + 1}", b.start_s, b.end_s, b) for i, b in enumerate(rep.bouts)]
    for name, a, b, p in rows + [("summary", None, None, s)]:
        lines.append(
            f"{name:10s} {_fmt(a):>7s} {_fmt(b):>7s} {p.n_strides:7d} "
            + " ".join(f"{_fmt(getattr(p, c[1]), c[2]):>9s}" for c in _COLUMNS)
        )
    k, bal = s.kinematics, s.balance
    lines.append(
        f"knee: peak swing flexion {_fmt(k.knee_peak_swing_flexion_deg, 1)} deg, min stance "
        f"{_fmt(k.knee_min_stance_flexion_deg, 1)} deg, ROM {_fmt(k.knee_rom_deg, 1)} deg; hip ROM "
        f"{_fmt(k.hip_rom_deg, 1)} deg; trunk sway ML {_fmt(k.trunk_sway_ml_deg, 1)} / AP "
        f"{_fmt(k.trunk_sway_ap_deg, 1)} deg"
    )
    lines.append(
        f"margin of stability: ML mean {_fmt(bal.mos_ml_mean_m, 3)} m (min "
        f"{_fmt(bal.mos_ml_min_m, 3)}), AP mean {_fmt(bal.mos_ap_mean_m, 3)} m over "
        f"{bal.n_steps} steps"
    )
    if rep.activities:
        lines.append(
            "activities: "
            + ", ".join(f"{a.type} {a.start_s:.1f}-{a.end_s:.1f} s" for a in rep.activities)
        )
    for t in rep.transfers:
        lines.append(
            f"transfer: {t.type.replace('_', '-')} {t.start_s:.2f}-{t.end_s:.2f} s "
            f"({t.duration_s:.2f} s)"
        )
    for t in rep.tug:
        lines.append(
            f"TUG-like sequence: {t.duration_s:.1f} s ({t.start_s:.1f}-{t.end_s:.1f} s, walked "
            f"{_fmt(t.walk_distance_m, 1)} m{', with turn' if t.includes_turn else ''})"
        )
    for f in rep.falls:
        lines.append(
            f"FALL at {f.impact_s:.1f} s (descent {f.peak_descent_speed_m_s:.1f} m/s), on the "
            f"floor {f.on_floor_s:.0f} s{', LONG LIE' if f.long_lie else ''}"
            f"{', got up' if f.got_up else ''}"
        )
    lines.append(f"fall risk: {rep.risk.level.upper()}")
    for r in rep.risk.reasons:
        lines.append(f"  - {r.message} [{r.source}]")
    if not rep.risk.reasons:
        ev = ", ".join(rep.risk.evaluated) or "none"
        lines.append(f"  no indicator above its threshold (evaluated: {ev})")
    return "\n".join(lines)


def _write_json(rep: GaitReport, out: Path) -> None:
    directory = out.parent if str(out.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(f"{out}: folder {directory} does not exist")
    if out.is_dir():
        raise InputError(f"{out}: --json names a folder, not a file")
    fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(rep.to_json_dict(), fh, indent=2, allow_nan=False)
            fh.write("\n")
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


_OPTIONS = {"long_lie_s": "--long-lie-s", "treadmill_speed_m_s": "--treadmill-speed"}


def run(args: argparse.Namespace) -> int:
    if args.json is not None and args.json.exists() and args.json.resolve() == args.input.resolve():
        raise InputError(f"{args.json}: --json would overwrite the input it reads")
    if args.source == "markers" and args.input.suffix.lower() == ".mcap":
        raise InputError(
            f"{args.input}: a pose log holds tracked key points; --source markers is for a "
            "laboratory JOINTS.csv"
        )
    traj = load_input(args.input, args.fps)
    if len(traj) < 2:
        raise GaitInputError(f"{args.input}: fewer than two frames with a pose; nothing to analyse")
    try:
        cfg = GaitConfig(
            long_lie_s=args.long_lie_s,
            treadmill_speed_m_s=args.treadmill_speed,
            source=args.source,
        )
    except ValidationError as err:
        first = err.errors()[0]
        field = str(first["loc"][0]) if first.get("loc") else ""
        option = _OPTIONS.get(field, field)
        raise InputError(f"{option}: {first['msg'].lower()}, not {first.get('input')}") from None
    rep = analyse(traj, cfg)
    print(format_report(rep))
    if args.json is not None:
        _write_json(rep, args.json)
        print(f"wrote {args.json}")
    return 0
