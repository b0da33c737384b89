"""Files of a 2D pose detector's key points, one per camera, for the tracker's key-point cue.

``gaitwatch track --keypoints FILE`` (one per camera, ``none`` for a camera without) gives the
tracker each frame's detected 2D key points (:mod:`tracker.keypoints2d`). Two formats:

* **CSV** (``.csv``): a header ``frame`` then, for each of the 19 CONVENTIONS key points in
  order, ``<name>_u,<name>_v,<name>_conf`` (e.g. ``head_u,head_v,head_conf,neck_u,...``); one
  row per frame with a detection, ``frame`` the 0-based index of the frame in the camera's
  video (as the pose log numbers them); ``u, v`` in pixels of the camera file's image size,
  ``conf`` in [0, 1]; an empty cell (or ``nan``) for a point the detector does not give.
* **NumPy** (``.npy``): a float array ``(T, 19, 3)``, row t the frame of index t, ``(u, v,
  conf)`` per key point, NaN where there is none (``bench/keypoints_mediapipe.py`` writes it).

A frame without a row (or whose row is all NaN) has no detection: the cue does not score it.
Bad files raise :class:`KeypointFileError` naming the file, the line and what is wrong.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from gaitwatch.conventions import KEYPOINTS, N_KEYPOINTS
from gaitwatch.errors import InputError

#: The CSV header.
COLUMNS: tuple[str, ...] = ("frame",) + tuple(
    f"{name}_{part}" for name in KEYPOINTS for part in ("u", "v", "conf")
)


class KeypointFileError(InputError):
    """A 2D key-point file that cannot be used."""


class KeypointFile:
    """The detected key points of one camera by frame index.

    Attributes
    ----------
    path : Path
    frames : dict[int, np.ndarray]
        Frame index -> ``(19, 3)`` float64 ``(u, v, conf)``, NaN where missing.
    """

    def __init__(self, path: Path, frames: dict[int, np.ndarray]) -> None:
        self.path = path
        self.frames = frames

    def get(self, frame_index: int) -> np.ndarray | None:
        """The key points of a frame, or None when the detector found nobody there."""
        return self.frames.get(int(frame_index))

    def __len__(self) -> int:
        return len(self.frames)


def _check(path: Path, where: str, points: np.ndarray) -> np.ndarray | None:
    """A frame's ``(19, 3)`` points checked: None when it holds no point."""
    if np.isinf(points).any():
        raise KeypointFileError(f"{path}: {where}: infinite value")
    uv_ok = np.isfinite(points[:, :2]).all(axis=1)
    if not uv_ok.any():
        return None
    if (np.isnan(points[:, 0]) != np.isnan(points[:, 1])).any():
        raise KeypointFileError(f"{path}: {where}: a point with u but no v (or v but no u)")
    conf = points[uv_ok, 2]
    if not np.isfinite(conf).all() or (conf < 0).any() or (conf > 1).any():
        raise KeypointFileError(f"{path}: {where}: conf must be within 0 and 1 for every point")
    return points


def _read_csv(path: Path) -> dict[int, np.ndarray]:
    out: dict[int, np.ndarray] = {}
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None:
            raise KeypointFileError(f"{path}: empty file (no header)")
        if tuple(h.strip() for h in header) != COLUMNS:
            raise KeypointFileError(
                f"{path}: the header must be frame, then <name>_u,<name>_v,<name>_conf for the "
                f"19 key points in CONVENTIONS order ({', '.join(COLUMNS[:4])}, ...)"
            )
        for line, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != len(COLUMNS):
                raise KeypointFileError(
                    f"{path}: line {line}: {len(row)} values, expected {len(COLUMNS)}"
                )
            try:
                frame = int(row[0])
                values = [float(c) if c.strip() else math.nan for c in row[1:]]
            except ValueError:
                raise KeypointFileError(f"{path}: line {line}: not a number") from None
            if frame < 0:
                raise KeypointFileError(f"{path}: line {line}: frame must be >= 0, not {frame}")
            if frame in out:
                raise KeypointFileError(f"{path}: line {line}: frame {frame} given twice")
            pts = _check(path, f"line {line}", np.array(values).reshape(N_KEYPOINTS, 3))
            if pts is not None:
                out[frame] = pts
    return out


def _read_npy(path: Path) -> dict[int, np.ndarray]:
    try:
        arr = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise KeypointFileError(f"{path}: not a NumPy array file ({err})") from None
    if arr.ndim != 3 or arr.shape[1:] != (N_KEYPOINTS, 3) or arr.dtype.kind not in "fiu":
        raise KeypointFileError(
            f"{path}: expected numbers of shape (frames, {N_KEYPOINTS}, 3), got {arr.dtype} "
            f"{arr.shape}"
        )
    out: dict[int, np.ndarray] = {}
    for t, pts in enumerate(np.asarray(arr, dtype=np.float64)):
        checked = _check(path, f"frame {t}", pts)
        if checked is not None:
            out[t] = checked
    return out


def read_keypoints(path: str | Path) -> KeypointFile:
    """Read one camera's key-point file (``.csv`` or ``.npy``, module docstring)."""
    p = Path(path)
    if not p.is_file():
        raise KeypointFileError(f"{p}: no such file")
    suffix = p.suffix.lower()
    if suffix == ".csv":
        frames = _read_csv(p)
    elif suffix == ".npy":
        frames = _read_npy(p)
    else:
        raise KeypointFileError(f"{p}: a key-point file must be .csv or .npy")
    return KeypointFile(p, frames)


__all__ = ["COLUMNS", "KeypointFile", "KeypointFileError", "read_keypoints"]
