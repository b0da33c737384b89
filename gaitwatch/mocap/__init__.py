"""Readers of laboratory motion capture mapped to the 19 key points (world frame, z up).

``load_mocap(path, **kw)`` dispatches by extension: ``.c3d`` (:func:`load_c3d`), ``.trc``
(:func:`load_trc`), ``.bvh`` (:func:`load_bvh`). ``read_mot`` reads OpenSim ``.mot`` tables and
``load_trc_with_grf`` adds force-plate contact events to a TRC recording.
"""

from __future__ import annotations

from pathlib import Path

from gaitwatch.mocap.bvh import forward_kinematics, load_bvh, parse_bvh, read_bvh
from gaitwatch.mocap.c3d import load_c3d, read_c3d_markers
from gaitwatch.mocap.common import MocapFormatError, align_walking_to_x
from gaitwatch.mocap.mapping import MarkerMapOptions, markers_to_trajectory
from gaitwatch.mocap.mot import (
    grf_contact_events,
    load_trc_with_grf,
    read_mot,
    read_mot_table,
)
from gaitwatch.mocap.trc import load_trc, read_trc
from gaitwatch.trajectory import Trajectory

__all__ = [
    "MarkerMapOptions",
    "MocapFormatError",
    "align_walking_to_x",
    "forward_kinematics",
    "grf_contact_events",
    "load_bvh",
    "load_c3d",
    "load_mocap",
    "load_trc",
    "load_trc_with_grf",
    "markers_to_trajectory",
    "parse_bvh",
    "read_bvh",
    "read_c3d_markers",
    "read_mot",
    "read_mot_table",
    "read_trc",
]


def load_mocap(path: str | Path, **kw) -> Trajectory:
    """Read a motion-capture file into a :class:`Trajectory` of the 19 key points.

    Parameters
    ----------
    path : str or Path
        ``.c3d``, ``.trc`` or ``.bvh``.
    **kw
        Passed to the format's loader (e.g. ``align_walking_to_x=True``).

    Raises
    ------
    MocapFormatError
        For an unknown extension or a file that cannot be used.
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".c3d":
        return load_c3d(path, **kw)
    if ext == ".trc":
        return load_trc(path, **kw)
    if ext == ".bvh":
        return load_bvh(path, **kw)
    raise MocapFormatError(
        f"{path}: unknown motion-capture format {ext!r} (expected .c3d, .trc or .bvh)"
    )
