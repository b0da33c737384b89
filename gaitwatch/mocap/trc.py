"""TRC reader (OpenSim / Motion Analysis marker files): tab-separated marker trajectories.

Layout: line 1 ``PathFileType ...``; line 2 the header keys (DataRate, CameraRate, NumFrames,
NumMarkers, Units, ...); line 3 their values; line 4 ``Frame#  Time  <marker>  <blank>  <blank>
...``; line 5 ``X1 Y1 Z1 ...``; then the data (an optional blank line first). Empty fields are
missing samples. OpenSim files are y up; the vertical is detected anyway.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gaitwatch.mocap.common import MocapFormatError
from gaitwatch.mocap.mapping import MarkerMapOptions, markers_to_trajectory
from gaitwatch.trajectory import Trajectory

log = logging.getLogger(__name__)

UNIT_SCALE = {"mm": 0.001, "cm": 0.01, "m": 1.0, "in": 0.0254}


@dataclass
class TRCMarkers:
    """Raw content of a TRC file.

    Attributes
    ----------
    labels : list of str
    xyz : ndarray, shape (T, N, 3)
        Metres, laboratory frame, NaN where missing.
    times : ndarray, shape (T,)
        The file's Time column (seconds; need not start at 0).
    frames : ndarray, shape (T,)
        The Frame# column.
    rate : float
        DataRate (Hz).
    units : str
    """

    labels: list[str]
    xyz: np.ndarray
    times: np.ndarray
    frames: np.ndarray
    rate: float
    units: str

    def markers(self) -> dict[str, np.ndarray]:
        return {lab: self.xyz[:, i] for i, lab in enumerate(self.labels)}


def _float(s: str) -> float:
    s = s.strip()
    return float(s) if s else float("nan")


def read_trc(path: str | Path) -> TRCMarkers:
    """Read a TRC file.

    Raises
    ------
    MocapFormatError
        Naming the file, line and field for a malformed file.
    FileNotFoundError
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    lines = path.read_text(errors="replace").splitlines()
    if len(lines) < 6:
        raise MocapFormatError(f"{path}: too short for a TRC file ({len(lines)} lines)")
    keys = lines[1].split("\t")
    vals = lines[2].split("\t")
    keys = [k.strip() for k in keys if k.strip()]
    vals = [v.strip() for v in vals if v.strip()]
    head = dict(zip(keys, vals, strict=False))
    try:
        rate = float(head["DataRate"])
    except (KeyError, ValueError):
        raise MocapFormatError(f"{path}:3: DataRate missing or not a number") from None
    if not rate > 0:
        raise MocapFormatError(f"{path}:3: DataRate {rate} is not a frame rate")
    units = head.get("Units", "mm").strip().lower()
    if units not in UNIT_SCALE:
        raise MocapFormatError(f"{path}:3: Units {units!r} unknown (expected mm, cm or m)")
    names_row = lines[3].split("\t")
    if len(names_row) < 3 or names_row[0].strip() != "Frame#":
        raise MocapFormatError(f"{path}:4: expected 'Frame#<TAB>Time<TAB>marker names'")
    labels = [n.strip() for n in names_row[2:] if n.strip()]
    n = len(labels)
    rows = []
    for lineno, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        f = line.split("\t")
        if len(f) < 2:
            raise MocapFormatError(f"{path}:{lineno}: expected Frame# and Time fields")
        f = f + [""] * (2 + 3 * n - len(f))
        try:
            rows.append([_float(v) for v in f[: 2 + 3 * n]])
        except ValueError:
            raise MocapFormatError(f"{path}:{lineno}: a field is not a number") from None
    if not rows:
        raise MocapFormatError(f"{path}: no data rows")
    a = np.asarray(rows, dtype=float)
    xyz = a[:, 2:].reshape(len(a), n, 3) * UNIT_SCALE[units]
    xyz[np.all(xyz == 0.0, axis=-1)] = np.nan
    return TRCMarkers(
        labels=labels,
        xyz=xyz,
        times=a[:, 1],
        frames=a[:, 0].astype(np.int64),
        rate=rate,
        units=units,
    )


def load_trc(
    path: str | Path,
    *,
    align_walking_to_x: bool = False,
    vertical: tuple[int, int] | None = None,
    options: MarkerMapOptions | None = None,
    events: list[dict] | None = None,
    grf: str | Path | None = None,
    grf_threshold_n: float = 20.0,
) -> Trajectory:
    """A TRC recording as a :class:`Trajectory` of the 19 key points (z up, floor at 0).

    Times are ``(frame - first frame) / DataRate`` (the Time column is often rounded), so they
    start at 0. ``events`` (times relative to the first frame) are attached as given; with
    ``grf`` (an OpenSim ground-reaction ``.mot``) the foot-contact events are derived from it
    instead (see :func:`gaitwatch.mocap.mot.load_trc_with_grf`).
    """
    if grf is not None:
        from gaitwatch.mocap.mot import load_trc_with_grf

        return load_trc_with_grf(
            path,
            grf,
            grf_threshold_n,
            align_walking_to_x=align_walking_to_x,
            vertical=vertical,
            options=options,
        )
    m = read_trc(path)
    frames = m.frames - m.frames[0]
    if np.any(np.diff(frames) <= 0):
        raise MocapFormatError(f"{path}: Frame# does not increase")
    return markers_to_trajectory(
        m.markers(),
        frames / m.rate,
        fps=m.rate,
        source=str(path),
        events=events,
        vertical=vertical,
        align_walking=align_walking_to_x,
        options=options,
    )
