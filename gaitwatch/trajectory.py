"""Joint trajectories: the container every part exchanges, and the ``JOINTS.csv`` format.

A :class:`Trajectory` is a sequence of frames, each with the 19 key points of
``gaitwatch.conventions`` in the world frame (metres, z up). Frames where nobody was tracked are
simply absent: ``frames`` and ``times`` say which frames are present, and frame numbers need not be
contiguous. A key point that is unknown in a present frame is NaN.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitwatch.conventions import JOINTS_CSV_COLUMNS, KEYPOINTS, KP, N_KEYPOINTS
from gaitwatch.errors import InputError


class TrajectoryFormatError(InputError):
    """A joint-trajectory file that cannot be read; the message names the file and the place."""


@dataclass
class Trajectory:
    """Key-point positions over time.

    Attributes
    ----------
    positions : ndarray, shape (T, 19, 3), float64
        Metres, world frame, CONVENTIONS key-point order. NaN where unknown.
    times : ndarray, shape (T,), float64
        Seconds from the first frame of the recording (``time_s``), strictly increasing.
    frames : ndarray, shape (T,), int64
        Frame numbers in the source recording (may have gaps where nobody was tracked).
    fps : float or None
        Nominal frame rate, when known.
    source : str
        Where the data came from (a path or a description), for messages.
    events : list of dict
        Laboratory gait events when the source carries them:
        ``{"side": "left"|"right", "type": "heel_strike"|"toe_off", "time_s": float}``.
    stature_m : float or None
        The subject's standing height when the source knows it (a synthesised walk); None:
        estimate it from the key points when needed.
    """

    positions: np.ndarray
    times: np.ndarray
    frames: np.ndarray | None = None
    fps: float | None = None
    source: str = ""
    events: list[dict] = field(default_factory=list)
    stature_m: float | None = None

    def __post_init__(self) -> None:
        self.positions = np.asarray(self.positions, dtype=np.float64)
        self.times = np.asarray(self.times, dtype=np.float64)
        if self.positions.ndim != 3 or self.positions.shape[1:] != (N_KEYPOINTS, 3):
            raise ValueError(
                f"positions must have shape (T, {N_KEYPOINTS}, 3), not {self.positions.shape}"
            )
        if self.times.shape != (self.positions.shape[0],):
            raise ValueError(
                f"times must have shape ({self.positions.shape[0]},), not {self.times.shape}"
            )
        if self.times.size > 1 and not np.all(np.diff(self.times) > 0):
            raise ValueError("times must be strictly increasing")
        if self.frames is None:
            if self.fps:
                self.frames = np.rint((self.times - self.times[:1].sum()) * self.fps).astype(
                    np.int64
                )
            else:
                self.frames = np.arange(self.positions.shape[0], dtype=np.int64)
        self.frames = np.asarray(self.frames, dtype=np.int64)
        if self.frames.shape != self.times.shape:
            raise ValueError("frames and times must have the same length")

    def __len__(self) -> int:
        return int(self.positions.shape[0])

    def joint(self, name: str) -> np.ndarray:
        """Positions of one key point, shape (T, 3)."""
        return self.positions[:, KP[name]]

    @property
    def duration_s(self) -> float:
        return float(self.times[-1] - self.times[0]) if len(self) else 0.0

    def with_positions(self, positions: np.ndarray) -> Trajectory:
        """A copy with other positions (same shape), the same frames, times, fps and events."""
        return Trajectory(
            positions=positions,
            times=self.times.copy(),
            frames=self.frames.copy(),
            fps=self.fps,
            source=self.source,
            events=list(self.events),
            stature_m=self.stature_m,
        )

    def estimated_fps(self) -> float:
        """The nominal fps if known, else the median frame rate from the time stamps."""
        if self.fps:
            return float(self.fps)
        if len(self) < 2:
            raise ValueError("cannot estimate a frame rate from fewer than two frames")
        return float(1.0 / np.median(np.diff(self.times)))


def resample(traj: Trajectory, fps: float, max_frames: int | None = None) -> Trajectory:
    """Interpolate key points linearly to ``fps`` frames per second.

    The result starts at the first sample (``time_s`` = 0, frame 0) and ends at or before the
    last; events are shifted to the new time origin and kept when inside the clip. A NaN key
    point makes its neighbouring resampled values NaN.
    """
    if not fps > 0:
        raise ValueError(f"fps must be positive, not {fps}")
    if len(traj) < 2:
        raise ValueError(f"{traj.source or 'trajectory'}: resampling needs at least two frames")
    t0 = traj.times[0]
    n = int(math.floor((traj.times[-1] - t0) * fps + 1e-9)) + 1
    if max_frames is not None:
        n = min(n, int(max_frames))
    tn = np.arange(n) / fps
    src_t = traj.times - t0
    flat = traj.positions.reshape(len(traj), -1)
    idx = np.clip(np.searchsorted(src_t, tn, side="right") - 1, 0, len(traj) - 2)
    w = ((tn - src_t[idx]) / (src_t[idx + 1] - src_t[idx]))[:, None]
    out = (1 - w) * flat[idx] + w * flat[idx + 1]
    events = [
        {**e, "time_s": float(e["time_s"] - t0)}
        for e in traj.events
        if 0 <= e["time_s"] - t0 <= tn[-1] + 1e-9
    ]
    return Trajectory(
        positions=out.reshape(n, N_KEYPOINTS, 3),
        times=tn,
        frames=np.arange(n, dtype=np.int64),
        fps=float(fps),
        source=traj.source,
        events=events,
        stature_m=traj.stature_m,
    )


def write_joints_csv(traj: Trajectory, path: str | Path) -> None:
    """Write ``JOINTS.csv``: ``frame,time_s,joint,x,y,z``, one row per frame and key point.

    Key points that are NaN in a frame are written as empty fields so the row count stays 19 per
    frame.
    """
    path = Path(path)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(JOINTS_CSV_COLUMNS)
        for f, t, pts in zip(traj.frames, traj.times, traj.positions, strict=True):
            for j, name in enumerate(KEYPOINTS):
                x, y, z = pts[j]
                w.writerow(
                    [int(f), f"{t:.6f}", name]
                    + ["" if math.isnan(v) else f"{v:.6f}" for v in (x, y, z)]
                )


def read_joints_csv(path: str | Path, fps: float | None = None) -> Trajectory:
    """Read a ``JOINTS.csv`` (CONVENTIONS format) into a :class:`Trajectory`.

    Raises :class:`TrajectoryFormatError` naming the file, line and field for a malformed file,
    and :class:`FileNotFoundError` for a missing one. Key points missing from a frame are NaN.
    ``fps`` overrides the frame rate estimated from the time stamps.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    rows: dict[int, tuple[float, np.ndarray]] = {}
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise TrajectoryFormatError(
                f"{path}: empty file, expected a header {','.join(JOINTS_CSV_COLUMNS)}"
            )
        header = [h.strip() for h in header]
        missing = [c for c in JOINTS_CSV_COLUMNS if c not in header]
        if missing:
            raise TrajectoryFormatError(f"{path}: header lacks column(s) {', '.join(missing)}")
        col = {c: header.index(c) for c in JOINTS_CSV_COLUMNS}
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) < len(header):
                raise TrajectoryFormatError(
                    f"{path}:{lineno}: expected {len(header)} fields, got {len(row)}"
                )
            try:
                frame = int(row[col["frame"]])
            except ValueError:
                raise TrajectoryFormatError(
                    f"{path}:{lineno}: frame {row[col['frame']]!r} is not an integer"
                ) from None
            try:
                t = float(row[col["time_s"]])
            except ValueError:
                raise TrajectoryFormatError(
                    f"{path}:{lineno}: time_s {row[col['time_s']]!r} is not a number"
                ) from None
            name = row[col["joint"]].strip()
            if name not in KP:
                raise TrajectoryFormatError(f"{path}:{lineno}: unknown joint {name!r}")
            xyz = []
            for c in ("x", "y", "z"):
                v = row[col[c]].strip()
                try:
                    xyz.append(float(v) if v else math.nan)
                except ValueError:
                    raise TrajectoryFormatError(
                        f"{path}:{lineno}: {c} {v!r} is not a number"
                    ) from None
            if frame not in rows:
                rows[frame] = (t, np.full((N_KEYPOINTS, 3), np.nan))
            elif not math.isclose(rows[frame][0], t, abs_tol=1e-6):
                raise TrajectoryFormatError(
                    f"{path}:{lineno}: frame {frame} has two different times "
                    f"({rows[frame][0]} and {t})"
                )
            rows[frame][1][KP[name]] = xyz
    if not rows:
        raise TrajectoryFormatError(f"{path}: no frames")
    frames = np.array(sorted(rows), dtype=np.int64)
    times = np.array([rows[f][0] for f in frames])
    if np.any(np.diff(times) <= 0):
        raise TrajectoryFormatError(f"{path}: time_s does not increase with frame")
    positions = np.stack([rows[f][1] for f in frames])
    traj = Trajectory(positions=positions, times=times, frames=frames, fps=fps, source=str(path))
    if traj.fps is None and len(traj) >= 2:
        # Frame numbers and times together give the rate even when frames are missing.
        df = np.diff(frames)
        dt = np.diff(times)
        traj.fps = float(np.median(df / dt))
    return traj
