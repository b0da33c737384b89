"""C3D reader (via the maintained ``c3d`` package): markers, units, events -> key points.

Missing markers are exact zeros or NaN in C3D files and become NaN; the residual column is not
trusted (several writers store -1 for every valid sample). Units come from POINT:UNITS. Events
come from the EVENT group (Vicon "Foot Strike"/"Foot Off" with "Left"/"Right" contexts, Motion
Analysis "LHS"/"RTO"... labels); their TIMES are absolute (minutes, seconds) from the start of
capture, so the first frame's time ``(first_frame - 1) / rate`` is subtracted.
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gaitwatch.mocap.common import MocapFormatError, parse_event_label, sort_events
from gaitwatch.mocap.mapping import MarkerMapOptions, markers_to_trajectory
from gaitwatch.trajectory import Trajectory

log = logging.getLogger(__name__)

UNIT_SCALE = {"mm": 0.001, "cm": 0.01, "m": 1.0, "dm": 0.1, "in": 0.0254, "inch": 0.0254}


@dataclass
class C3DMarkers:
    """Raw marker data of a C3D file.

    Attributes
    ----------
    labels : list of str
        Point labels as stored (stripped), one per column of ``xyz``.
    xyz : ndarray, shape (T, N, 3)
        Metres, laboratory frame, NaN where missing.
    rate : float
        Point frame rate (Hz).
    first_frame : int
        Number of the first frame in the capture (1-based), from TRIAL:ACTUAL_START_FIELD when
        present, else the header.
    events : list of dict
        Gait events, ``time_s`` relative to the first frame of the points.
    """

    labels: list[str]
    xyz: np.ndarray
    rate: float
    first_frame: int
    events: list[dict] = field(default_factory=list)

    def markers(self) -> dict[str, np.ndarray]:
        """Label -> (T, 3); a repeated label keeps its column with the most frames present."""
        out: dict[str, np.ndarray] = {}
        for i, lab in enumerate(self.labels):
            xyz = self.xyz[:, i]
            if lab in out and np.isfinite(out[lab]).all(-1).sum() >= np.isfinite(xyz).all(-1).sum():
                continue
            out[lab] = xyz
        return out


def _string_array(reader, key: str) -> list[str]:
    p = reader.get(key)
    if p is None:
        return []
    try:
        arr = p.string_array
    except Exception:  # noqa: BLE001 - c3d raises assorted errors for odd shapes
        try:
            return [p.string_value.strip()]
        except Exception:  # noqa: BLE001
            return []
    return [str(s).strip() for s in np.ravel(arr)]


def _first_frame(reader) -> int:
    p = reader.get("TRIAL:ACTUAL_START_FIELD")
    if p is not None:
        try:
            words = np.asarray(p.int16_array).astype(np.int64).ravel() & 0xFFFF
            if words.size >= 2:
                return int(words[0] + 65536 * words[1])
            if words.size == 1:
                return int(words[0])
        except Exception:  # noqa: BLE001
            pass
    return int(reader.header.first_frame)


def read_c3d_events(reader, rate: float, first_frame: int, n_frames: int) -> list[dict]:
    """Gait events of an open ``c3d.Reader``, times relative to the first frame of the points.

    Events outside the recording (before its first frame or after its last) are dropped, as
    are events that are not heel strikes / toe offs of a side (e.g. "General" force-plate marks).
    """
    if reader.get("EVENT:TIMES") is None:
        return []
    try:
        times = np.asarray(reader.get("EVENT:TIMES").float_array, dtype=float)
    except Exception as exc:  # noqa: BLE001
        raise MocapFormatError(f"EVENT:TIMES cannot be read ({exc})") from None
    # The c3d package returns the (2, n) parameter as an (n, 2) array: minutes, seconds.
    if times.ndim == 1:
        times = times.reshape(-1, 2)
    elif times.shape[-1] != 2 and times.shape[0] == 2:
        times = times.T
    labels = _string_array(reader, "EVENT:LABELS")
    contexts = _string_array(reader, "EVENT:CONTEXTS")
    used = reader.get("EVENT:USED")
    n = len(times)
    if used is not None:
        with contextlib.suppress(Exception):
            n = min(n, int(used.int16_value))
    offset = (first_frame - 1) / rate
    duration = (n_frames - 1) / rate
    out = []
    for i in range(n):
        lab = labels[i] if i < len(labels) else ""
        ctx = contexts[i] if i < len(contexts) else ""
        parsed = parse_event_label(lab, ctx)
        if parsed is None:
            continue
        t = float(times[i, 0]) * 60.0 + float(times[i, 1]) - offset
        if -0.5 / rate <= t <= duration + 0.5 / rate:
            out.append({"side": parsed[0], "type": parsed[1], "time_s": max(t, 0.0)})
    return sort_events(out)


def read_c3d_markers(path: str | Path) -> C3DMarkers:
    """Read the 3D points, units and events of a C3D file.

    Raises
    ------
    MocapFormatError
        For a file the ``c3d`` package cannot parse, or without points.
    FileNotFoundError
    """
    import c3d

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    with path.open("rb") as fh, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            reader = c3d.Reader(fh)
            frames = [pts[:, :3].copy() for _, pts, _ in reader.read_frames(copy=False)]
        except Exception as exc:  # noqa: BLE001 - the package raises assorted errors
            raise MocapFormatError(f"{path}: not a readable C3D file ({exc})") from None
        if not frames or frames[0].shape[0] == 0:
            raise MocapFormatError(f"{path}: POINT: the file has no 3D points")
        xyz = np.asarray(frames, dtype=float)
        n_pts = xyz.shape[1]
        labels = [str(s).strip() for s in reader.point_labels][:n_pts]
        labels += [""] * (n_pts - len(labels))
        p = reader.get("POINT:UNITS")
        units = p.string_value.strip(" \x00").lower() if p is not None else "mm"
        if units not in UNIT_SCALE:
            log.warning("%s: POINT:UNITS %r unknown, assuming mm", path, units)
        scale = UNIT_SCALE.get(units, 0.001)
        rate = float(reader.point_rate)
        if not rate > 0:
            raise MocapFormatError(f"{path}: POINT:RATE is {rate}, not a frame rate")
        first = _first_frame(reader)
        try:
            events = read_c3d_events(reader, rate, first, xyz.shape[0])
        except MocapFormatError as exc:
            raise MocapFormatError(f"{path}: {exc}") from None
    missing = np.all(xyz == 0.0, axis=-1) | ~np.isfinite(xyz).all(axis=-1)
    xyz[missing] = np.nan
    return C3DMarkers(labels=labels, xyz=xyz * scale, rate=rate, first_frame=first, events=events)


def load_c3d(
    path: str | Path,
    *,
    align_walking_to_x: bool = False,
    vertical: tuple[int, int] | None = None,
    options: MarkerMapOptions | None = None,
) -> Trajectory:
    """A C3D recording as a :class:`Trajectory` of the 19 key points (z up, floor at 0).

    Parameters
    ----------
    path : str or Path
    align_walking_to_x : bool
        Rotate about z so that the subject walks along +x.
    vertical : (axis, sign), optional
        Force the laboratory up axis (0, 1, 2 and +-1) instead of detecting it.
    options : MarkerMapOptions, optional
        Geometric constants of the mapping.

    Returns
    -------
    Trajectory
        ``events`` holds the file's heel strikes and toe offs (seconds from the first frame).
    """
    m = read_c3d_markers(path)
    T = m.xyz.shape[0]
    return markers_to_trajectory(
        m.markers(),
        np.arange(T) / m.rate,
        fps=m.rate,
        source=str(path),
        events=m.events,
        vertical=vertical,
        align_walking=align_walking_to_x,
        options=options,
    )
