"""MCAP pose logs: what ``gaitwatch track`` writes, and the reader that gives the poses back.

A pose log is one MCAP file (https://mcap.dev; the ``mcap`` package, zstd-compressed chunks,
fully indexed) with JSON-encoded messages on these channels (format in ``docs/pose-log.md``):

``/gaitwatch/pose`` (schema ``gaitwatch.Pose``)
    One message per frame with a pose: the 19 key points (world frame, metres), the 31 DOF values
    (``tracker.dof`` order and units), the best weight and the filter used.
``/gaitwatch/status`` (schema ``gaitwatch.Status``)
    Frames without a pose (nobody in view ...) with the reason, and free-text notes on frames.
``/skeleton`` (schema ``foxglove.SceneUpdate``)
    The skeleton for Foxglove's 3D panel: joints as spheres, bones as a line list.
``/tf`` (schema ``foxglove.FrameTransforms``) and ``/camera/<name>/calibration``
    (``foxglove.CameraCalibration``): the camera poses and intrinsics, at the start and once per
    second of log time so that Foxglove shows them after a seek.

and one MCAP metadata record ``gaitwatch`` with the camera files, body height, filter name and
settings, frame rate and software version (written first, so a file cut short keeps it).

``log_time`` of every message is ``start_time_ns + time_s`` in nanoseconds since the Unix epoch.

Crash safety: the writer is a context manager whose ``__exit__`` finalises the file (summary and
index) also when the ``with`` body raises. The writer closes a compressed chunk and flushes it to
the operating system every ``flush_every`` frames or ``flush_interval_s`` seconds, whichever comes
first, so a process killed outright loses at most that much. :func:`read_poselog` reads a file
without summary (or cut at any byte) by a sequential scan up to the last whole record and sets
:attr:`PoseLog.truncated`.
"""

from __future__ import annotations

import datetime as _dt
import io
import json
import logging
import math
import mmap
import os
import struct
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Final

import numpy as np
import yaml
import zstandard
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Footer, Message, Metadata
from mcap.stream_reader import ReadDataStream, breakup_chunk
from mcap.writer import CompressionType, IndexType, Writer
from scipy.spatial.transform import Rotation

import gaitwatch
from gaitwatch.conventions import BONE_INDICES, KEYPOINTS, N_KEYPOINTS
from gaitwatch.errors import InputError
from gaitwatch.trajectory import Trajectory
from tracker.camera import Camera, CameraFileError, parse_camera
from tracker.dof import DOF_NAMES, N_DOF

log = logging.getLogger(__name__)

FORMAT_VERSION: Final[int] = 1
MCAP_PROFILE: Final[str] = ""  # no ROS profile: plain JSON messages
METADATA_NAME: Final[str] = "gaitwatch"
END_METADATA_NAME: Final[str] = "gaitwatch.end"

TOPIC_POSE: Final[str] = "/gaitwatch/pose"
TOPIC_STATUS: Final[str] = "/gaitwatch/status"
TOPIC_SKELETON: Final[str] = "/skeleton"
TOPIC_TF: Final[str] = "/tf"
WORLD_FRAME: Final[str] = "world"
SKELETON_ENTITY_ID: Final[str] = "skeleton"

SCHEMA_POSE: Final[str] = "gaitwatch.Pose"
SCHEMA_STATUS: Final[str] = "gaitwatch.Status"
SCHEMA_SCENE_UPDATE: Final[str] = "foxglove.SceneUpdate"
SCHEMA_FRAME_TRANSFORMS: Final[str] = "foxglove.FrameTransforms"
SCHEMA_CAMERA_CALIBRATION: Final[str] = "foxglove.CameraCalibration"

_MAGIC: Final[bytes] = bytes([137, 77, 67, 65, 80, 48, 13, 10])  # "\x89MCAP0\r\n"
_NS: Final[int] = 1_000_000_000


def calibration_topic(camera_name: str) -> str:
    """Topic of a camera's ``foxglove.CameraCalibration`` messages."""
    return f"/camera/{camera_name}/calibration"


class PoseLogError(InputError):
    """A pose log that cannot be read; the message names the file."""


# ---------------------------------------------------------------------------------------------
# JSON schemas (jsonschema encoding). The Foxglove ones follow the field names of Foxglove's
# published schemas (foxglove-sdk/schemas/jsonschema); Foxglove recognises them by name.
# ---------------------------------------------------------------------------------------------
_NUM: Final[dict] = {"type": "number"}
# Foxglove's JSON-schema parser accepts one "type" per field (no ["number", "null"] unions), so
# values that may be unknown are declared as numbers and written as null when unknown.
_NUM_OR_NULL: Final[dict] = {"type": "number", "description": "null when unknown"}
_TIME: Final[dict] = {
    "type": "object",
    "title": "time",
    "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999},
    },
}
_DURATION: Final[dict] = {
    "type": "object",
    "title": "duration",
    "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer", "minimum": 0}},
}
_VECTOR3: Final[dict] = {
    "title": "foxglove.Vector3",
    "type": "object",
    "properties": {"x": _NUM, "y": _NUM, "z": _NUM},
    "required": ["x", "y", "z"],
}
_POINT3: Final[dict] = {**_VECTOR3, "title": "foxglove.Point3"}
_QUATERNION: Final[dict] = {
    "title": "foxglove.Quaternion",
    "type": "object",
    "properties": {"x": _NUM, "y": _NUM, "z": _NUM, "w": _NUM},
    "required": ["x", "y", "z", "w"],
}
_POSE: Final[dict] = {
    "title": "foxglove.Pose",
    "type": "object",
    "properties": {"position": _VECTOR3, "orientation": _QUATERNION},
    "required": ["position", "orientation"],
}
_COLOR: Final[dict] = {
    "title": "foxglove.Color",
    "type": "object",
    "properties": {"r": _NUM, "g": _NUM, "b": _NUM, "a": _NUM},
    "required": ["r", "g", "b", "a"],
}
_SPHERE: Final[dict] = {
    "title": "foxglove.SpherePrimitive",
    "type": "object",
    "properties": {"pose": _POSE, "size": _VECTOR3, "color": _COLOR},
    "required": ["pose", "size", "color"],
}
_LINE: Final[dict] = {
    "title": "foxglove.LinePrimitive",
    "type": "object",
    "properties": {
        "type": {
            "title": "foxglove.LineType",
            "oneOf": [
                {"title": "LINE_STRIP", "const": 0},
                {"title": "LINE_LOOP", "const": 1},
                {"title": "LINE_LIST", "const": 2},
            ],
        },
        "pose": _POSE,
        "thickness": _NUM,
        "scale_invariant": {"type": "boolean"},
        "points": {"type": "array", "items": _POINT3},
        "color": _COLOR,
        "colors": {"type": "array", "items": _COLOR},
        "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}},
    },
    "required": [
        "type",
        "pose",
        "thickness",
        "scale_invariant",
        "points",
        "color",
        "colors",
        "indices",
    ],
}
# Primitive arrays the skeleton leaves empty. Foxglove needs "properties" on every object schema.
_ANY_OBJECTS: Final[dict] = {"type": "array", "items": {"type": "object", "properties": {}}}

SCENE_UPDATE_SCHEMA: Final[dict] = {
    "title": SCHEMA_SCENE_UPDATE,
    "description": "An update to the entities displayed in a 3D scene",
    "type": "object",
    "properties": {
        "deletions": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntityDeletion",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "type": {
                        "title": "foxglove.SceneEntityDeletionType",
                        "oneOf": [
                            {"title": "MATCHING_ID", "const": 0},
                            {"title": "ALL", "const": 1},
                        ],
                    },
                    "id": {"type": "string"},
                },
                "required": ["timestamp", "type", "id"],
            },
        },
        "entities": {
            "type": "array",
            "items": {
                "title": "foxglove.SceneEntity",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": _DURATION,
                    "frame_locked": {"type": "boolean"},
                    "metadata": {
                        "type": "array",
                        "items": {
                            "title": "foxglove.KeyValuePair",
                            "type": "object",
                            "properties": {
                                "key": {"type": "string"},
                                "value": {"type": "string"},
                            },
                        },
                    },
                    "arrows": _ANY_OBJECTS,
                    "cubes": _ANY_OBJECTS,
                    "spheres": {"type": "array", "items": _SPHERE},
                    "cylinders": _ANY_OBJECTS,
                    "lines": {"type": "array", "items": _LINE},
                    "triangles": _ANY_OBJECTS,
                    "texts": _ANY_OBJECTS,
                    "models": _ANY_OBJECTS,
                },
                "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked"],
            },
        },
    },
    "required": ["deletions", "entities"],
}

FRAME_TRANSFORMS_SCHEMA: Final[dict] = {
    "title": SCHEMA_FRAME_TRANSFORMS,
    "description": "An array of FrameTransform messages",
    "type": "object",
    "properties": {
        "transforms": {
            "type": "array",
            "items": {
                "title": "foxglove.FrameTransform",
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "parent_frame_id": {"type": "string"},
                    "child_frame_id": {"type": "string"},
                    "translation": _VECTOR3,
                    "rotation": _QUATERNION,
                },
                "required": [
                    "timestamp",
                    "parent_frame_id",
                    "child_frame_id",
                    "translation",
                    "rotation",
                ],
            },
        }
    },
    "required": ["transforms"],
}

CAMERA_CALIBRATION_SCHEMA: Final[dict] = {
    "title": SCHEMA_CAMERA_CALIBRATION,
    "description": "Camera calibration parameters",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "width": {"type": "integer", "minimum": 0},
        "height": {"type": "integer", "minimum": 0},
        "distortion_model": {"type": "string"},
        "D": {"type": "array", "items": _NUM},
        "K": {"type": "array", "items": _NUM, "minItems": 9, "maxItems": 9},
        "R": {"type": "array", "items": _NUM, "minItems": 9, "maxItems": 9},
        "P": {"type": "array", "items": _NUM, "minItems": 12, "maxItems": 12},
    },
    "required": [
        "timestamp",
        "frame_id",
        "width",
        "height",
        "distortion_model",
        "D",
        "K",
        "R",
        "P",
    ],
}

POSE_SCHEMA: Final[dict] = {
    "title": SCHEMA_POSE,
    "description": (
        "The estimated pose of one frame: 19 key points in the world frame (metres, z up; "
        "null where unknown), the 31 pose DOFs (tracker.dof order: metres and radians), the "
        "best particle weight and the filter that produced it."
    ),
    "type": "object",
    "properties": {
        "frame": {"type": "integer", "description": "Frame number in the source video"},
        "time_s": {**_NUM, "description": "Seconds from the first frame of the recording"},
        "joints": {
            "type": "object",
            "description": "Key point name -> [x, y, z] in metres, world frame",
            "properties": {
                name: {"type": "array", "items": _NUM_OR_NULL, "minItems": 3, "maxItems": 3}
                for name in KEYPOINTS
            },
            "required": list(KEYPOINTS),
        },
        "dofs": {
            "type": "array",
            "items": _NUM_OR_NULL,
            "minItems": N_DOF,
            "maxItems": N_DOF,
            "description": "The 31 DOF values in tracker.dof.DOF_NAMES order",
        },
        "weight": {**_NUM_OR_NULL, "description": "Weight (likelihood) of the estimate"},
        "filter": {"type": "string", "description": "ipf, apf, condensation ..."},
        "leg_length": {
            "type": "number",
            "description": "Relative leg length of the body model the dofs refer to "
            "(tracker.body.BodyModel leg_length); 1.0 when absent",
        },
    },
    "required": ["frame", "time_s", "joints", "dofs", "weight", "filter"],
}

STATUS_SCHEMA: Final[dict] = {
    "title": SCHEMA_STATUS,
    "description": (
        "A frame without a pose (no_pose true: nobody in view, silhouette too small, ...) or a "
        "note about a frame (no_pose false: e.g. several people, following one)."
    ),
    "type": "object",
    "properties": {
        "frame": {"type": "integer"},
        "time_s": _NUM,
        "reason": {"type": "string"},
        "no_pose": {"type": "boolean"},
    },
    "required": ["frame", "time_s", "reason", "no_pose"],
}


# ---------------------------------------------------------------------------------------------
# Message construction
# ---------------------------------------------------------------------------------------------
def _json(obj: Any) -> bytes:
    return json.dumps(obj, allow_nan=False, separators=(",", ":")).encode()


def _json_default(obj: Any) -> Any:
    """Make settings JSON-serialisable: numpy values, pydantic models, paths."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if hasattr(obj, "model_dump"):
        return obj.model_dump(mode="json")
    if isinstance(obj, (set, frozenset, tuple)):
        return list(obj)
    return str(obj)


def _finite_or_none(a: np.ndarray) -> list:
    """A float array as nested lists with NaN/inf as None (JSON null)."""
    a = np.asarray(a, dtype=np.float64)
    return np.where(np.isfinite(a), a, None).tolist()


def _stamp(log_time_ns: int) -> dict[str, int]:
    sec, nsec = divmod(int(log_time_ns), _NS)
    return {"sec": sec, "nsec": nsec}


_IDENTITY_POSE: Final[dict] = {
    "position": {"x": 0.0, "y": 0.0, "z": 0.0},
    "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
}
_COLOR_LEFT: Final[dict] = {"r": 0.2, "g": 0.5, "b": 1.0, "a": 1.0}
_COLOR_RIGHT: Final[dict] = {"r": 1.0, "g": 0.3, "b": 0.2, "a": 1.0}
_COLOR_CENTRE: Final[dict] = {"r": 0.95, "g": 0.95, "b": 0.95, "a": 1.0}
_COLOR_BONE: Final[dict] = {"r": 0.9, "g": 0.8, "b": 0.3, "a": 1.0}
_JOINT_COLORS: Final[tuple[dict, ...]] = tuple(
    _COLOR_LEFT
    if n.startswith("left_")
    else _COLOR_RIGHT
    if n.startswith("right_")
    else _COLOR_CENTRE
    for n in KEYPOINTS
)
JOINT_SPHERE_DIAMETER_M: Final[float] = 0.05
BONE_THICKNESS_M: Final[float] = 0.02


def _xyz(p: Sequence[float]) -> dict[str, float]:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _compact(obj: Any) -> str:
    return json.dumps(obj, separators=(",", ":"))


# The skeleton message is formatted from templates: it is written every frame and a generic JSON
# encoder of its ~600 numbers costs four times as much. Positions are given to 0.1 mm.
_SPHERE_TEMPLATES: Final[tuple[str, ...]] = tuple(
    '{"pose":{"position":{"x":%.4f,"y":%.4f,"z":%.4f},'
    '"orientation":{"x":0.0,"y":0.0,"z":0.0,"w":1.0}},'
    f'"size":{_compact({k: JOINT_SPHERE_DIAMETER_M for k in "xyz"})},'
    f'"color":{_compact(color)}}}'
    for color in _JOINT_COLORS
)
_POINT_TEMPLATE: Final[str] = '{"x":%.4f,"y":%.4f,"z":%.4f}'
_SKELETON_HEAD: Final[str] = (
    '{"deletions":[],"entities":[{"timestamp":{"sec":%d,"nsec":%d},'
    f'"frame_id":"{WORLD_FRAME}","id":"{SKELETON_ENTITY_ID}",'
    '"lifetime":{"sec":0,"nsec":0},"frame_locked":false,"metadata":[],"arrows":[],"cubes":[],'
    '"spheres":['
)
_SKELETON_MIDDLE: Final[str] = (
    '],"cylinders":[],"lines":[{"type":2,'  # LINE_LIST: each pair of points is one bone
    f'"pose":{_compact(_IDENTITY_POSE)},"thickness":{BONE_THICKNESS_M!r},'
    '"scale_invariant":false,"points":['
)
_SKELETON_TAIL: Final[str] = (
    f'],"color":{_compact(_COLOR_BONE)},"colors":[],"indices":[]}}],'
    '"triangles":[],"texts":[],"models":[]}]}'
)


def skeleton_scene_update(joints: np.ndarray, log_time_ns: int) -> bytes:
    """A JSON ``foxglove.SceneUpdate`` drawing the skeleton: joints as spheres, bones as lines.

    One entity ``skeleton`` in frame ``world``: a sphere per key point (left side blue, right
    red, midline white) and one ``LINE_LIST`` primitive with a pair of points per bone of
    ``gaitwatch.conventions.BONES``. It replaces the previous skeleton (same entity id).

    Parameters
    ----------
    joints : ndarray, shape (19, 3)
        Key points in the world frame, metres. Joints with a non-finite coordinate, and bones
        touching them, are left out. Written to 0.1 mm.
    log_time_ns : int
        Entity timestamp, nanoseconds since the Unix epoch.

    Returns
    -------
    bytes
        The message, UTF-8 JSON.
    """
    ok = np.all(np.isfinite(joints), axis=1).tolist()
    p = np.asarray(joints, dtype=np.float64).tolist()
    spheres = ",".join([_SPHERE_TEMPLATES[j] % tuple(p[j]) for j in range(N_KEYPOINTS) if ok[j]])
    points = ",".join(
        [
            _POINT_TEMPLATE % tuple(p[a]) + "," + _POINT_TEMPLATE % tuple(p[b])
            for a, b in BONE_INDICES
            if ok[a] and ok[b]
        ]
    )
    sec, nsec = divmod(int(log_time_ns), _NS)
    text = _SKELETON_HEAD % (sec, nsec) + spheres + _SKELETON_MIDDLE + points + _SKELETON_TAIL
    return text.encode()


def skeleton_deletion(log_time_ns: int) -> dict:
    """A ``foxglove.SceneUpdate`` removing the skeleton (a frame without a pose)."""
    return {
        "deletions": [{"timestamp": _stamp(log_time_ns), "type": 0, "id": SKELETON_ENTITY_ID}],
        "entities": [],
    }


def camera_frame_id(camera: Camera) -> str:
    """The Foxglove frame id of a camera: its name (``world`` is reserved for the world)."""
    return camera.name if camera.name != WORLD_FRAME else f"camera_{camera.name}"


def camera_transforms(cameras: Sequence[Camera], log_time_ns: int) -> dict:
    """A ``foxglove.FrameTransforms``: each camera's pose in the world (camera -> world).

    The camera file holds world -> camera ``R, t``; the camera frame's origin in the world is
    ``-R^T t`` and its orientation ``R^T`` (OpenCV axes: x right, y down, z forward).
    """
    stamp = _stamp(log_time_ns)
    transforms = []
    for cam in cameras:
        q = Rotation.from_matrix(cam.R.T).as_quat()  # x, y, z, w
        transforms.append(
            {
                "timestamp": stamp,
                "parent_frame_id": WORLD_FRAME,
                "child_frame_id": camera_frame_id(cam),
                "translation": _xyz(cam.center),
                "rotation": {
                    "x": float(q[0]),
                    "y": float(q[1]),
                    "z": float(q[2]),
                    "w": float(q[3]),
                },
            }
        )
    return {"transforms": transforms}


def camera_calibration(camera: Camera, log_time_ns: int) -> dict:
    """A ``foxglove.CameraCalibration`` for one camera (lets Foxglove draw its frustum)."""
    d = camera.dist.tolist()
    model = "rational_polynomial" if len(d) > 5 else "plumb_bob"
    if len(d) < 5 and model == "plumb_bob":
        d = d + [0.0] * (5 - len(d))
    P = np.zeros((3, 4))
    P[:, :3] = camera.K
    return {
        "timestamp": _stamp(log_time_ns),
        "frame_id": camera_frame_id(camera),
        "width": int(camera.width),
        "height": int(camera.height),
        "distortion_model": model,
        "D": [float(v) for v in d],
        "K": camera.K.ravel().tolist(),
        "R": np.eye(3).ravel().tolist(),
        "P": P.ravel().tolist(),
    }


def camera_yaml(camera: Camera) -> str:
    """The camera file (CONVENTIONS format) as YAML text."""
    return yaml.safe_dump(camera.to_dict(), sort_keys=False, default_flow_style=None)


# ---------------------------------------------------------------------------------------------
# Writer
# ---------------------------------------------------------------------------------------------
class PoseLogWriter:
    """Stream poses of a tracking run into an MCAP pose log.

    Use it as a context manager: ``__exit__`` finalises the file (summary and index) whether the
    ``with`` body ends normally or raises, and records how it ended in the ``gaitwatch.end``
    metadata. Memory does not grow with the number of frames beyond MCAP's chunk index (under
    1 kB per chunk; a chunk is closed every ``flush_every`` frames or ``flush_interval_s``
    seconds).

    Parameters
    ----------
    path : str or Path
        Output file; overwritten.
    cameras : list of Camera
        The calibrated cameras of the run (stored in the metadata and drawn in Foxglove).
    body_height_m : float
        Body height used to scale the body model, metres.
    filter_name : str
        Default filter name of the frames (``ipf``, ``apf``, ``condensation``).
    settings : dict
        Filter and tracker settings (JSON-serialisable; numpy values and pydantic models are
        converted).
    software_version : str
        Defaults to ``gaitwatch.__version__``.
    start_time_ns : int, optional
        Capture time of ``time_s = 0`` in nanoseconds since the Unix epoch; now if not given.
    fps : float, optional
        Nominal frame rate of the footage; the reader gives it as ``Trajectory.fps``.
    flush_every : int
        Close the compressed chunk and flush it to the operating system every this many frames
        (pose or no-pose), bounding what a killed process loses.
    flush_interval_s : float or None
        Also flush when this many seconds of wall-clock time have passed since the last flush
        (None: by frame count only, which makes the chunk layout reproducible).
    chunk_size : int
        Upper bound of a chunk's uncompressed size in bytes.

    Examples
    --------
    >>> with PoseLogWriter("poses.mcap", cameras=cams, body_height_m=1.7, filter_name="ipf",
    ...                    settings={}, fps=20) as log:               # doctest: +SKIP
    ...     log.write_frame(0, 0.0, joints, dofs, weight=0.8)
    ...     log.write_no_pose(1, 0.05, "no silhouette")
    """

    def __init__(
        self,
        path: str | Path,
        *,
        cameras: Sequence[Camera],
        body_height_m: float,
        filter_name: str,
        settings: dict,
        software_version: str = gaitwatch.__version__,
        start_time_ns: int | None = None,
        fps: float | None = None,
        flush_every: int = 100,
        flush_interval_s: float | None = 2.0,
        chunk_size: int = 1024 * 1024,
    ) -> None:
        if flush_every < 1:
            raise ValueError(f"flush_every must be >= 1, not {flush_every}")
        if fps is not None and not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be positive, not {fps}")
        self.path = Path(path)
        self.cameras = list(cameras)
        self.filter_name = str(filter_name)
        self.fps = None if fps is None else float(fps)
        self.start_time_ns = time.time_ns() if start_time_ns is None else int(start_time_ns)
        if self.start_time_ns < 0:
            raise ValueError(f"start_time_ns must be >= 0, not {start_time_ns}")
        self.flush_every = int(flush_every)
        self.flush_interval_s = None if flush_interval_s is None else float(flush_interval_s)
        self._last_flush = time.monotonic()
        self.n_pose = 0
        self.n_no_pose = 0
        self._last_frame: int | None = None
        self._last_time: float | None = None
        self._since_flush = 0
        self._next_tf_ns = self.start_time_ns + _NS
        self._closed = False

        meta = {
            "format_version": str(FORMAT_VERSION),
            "software_version": str(software_version),
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            "start_time_ns": str(self.start_time_ns),
            "fps": "" if self.fps is None else repr(self.fps),
            "body_height_m": repr(float(body_height_m)),
            "filter": self.filter_name,
            "settings": json.dumps(settings, default=_json_default, sort_keys=True),
            "keypoints": json.dumps(list(KEYPOINTS)),
            "dof_names": json.dumps(list(DOF_NAMES)),
            "camera_count": str(len(self.cameras)),
        }
        for i, cam in enumerate(self.cameras):
            meta[f"camera/{i}"] = camera_yaml(cam)

        self._fh = self.path.open("wb")
        try:
            self._writer = Writer(
                self._fh,
                chunk_size=int(chunk_size),
                compression=CompressionType.ZSTD,
                index_types=IndexType.ALL,
            )
            self._writer.start(profile=MCAP_PROFILE, library=f"gaitwatch/{software_version}")
            self._writer.add_metadata(METADATA_NAME, meta)
            w = self._writer
            ids = {
                name: w.register_schema(name, "jsonschema", _json(schema))
                for name, schema in (
                    (SCHEMA_POSE, POSE_SCHEMA),
                    (SCHEMA_STATUS, STATUS_SCHEMA),
                    (SCHEMA_SCENE_UPDATE, SCENE_UPDATE_SCHEMA),
                    (SCHEMA_FRAME_TRANSFORMS, FRAME_TRANSFORMS_SCHEMA),
                    (SCHEMA_CAMERA_CALIBRATION, CAMERA_CALIBRATION_SCHEMA),
                )
            }
            self._ch_pose = w.register_channel(TOPIC_POSE, "json", ids[SCHEMA_POSE])
            self._ch_status = w.register_channel(TOPIC_STATUS, "json", ids[SCHEMA_STATUS])
            self._ch_skeleton = w.register_channel(TOPIC_SKELETON, "json", ids[SCHEMA_SCENE_UPDATE])
            self._ch_tf = w.register_channel(TOPIC_TF, "json", ids[SCHEMA_FRAME_TRANSFORMS])
            self._ch_calib = [
                w.register_channel(
                    calibration_topic(camera_frame_id(c)), "json", ids[SCHEMA_CAMERA_CALIBRATION]
                )
                for c in self.cameras
            ]
            self._write_cameras(self.start_time_ns)
            self._fh.flush()
        except BaseException:
            self._fh.close()
            raise

    # -- context manager ----------------------------------------------------------------------
    def __enter__(self) -> PoseLogWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc is None:
            self.close()
        else:
            self.close(error=f"{exc_type.__name__}: {exc}" if exc_type else str(exc))

    # -- writing ------------------------------------------------------------------------------
    def _log_time(self, frame_index: int, time_s: float) -> int:
        if self._closed:
            raise ValueError(f"{self.path}: pose log is closed")
        if not math.isfinite(time_s):
            raise ValueError(f"frame {frame_index}: time_s must be finite, not {time_s}")
        if self._last_frame is not None and frame_index <= self._last_frame:
            raise ValueError(
                f"frame {frame_index} is not after the previous frame {self._last_frame}"
            )
        if self._last_time is not None and time_s <= self._last_time:
            raise ValueError(
                f"frame {frame_index}: time_s {time_s} is not after the previous {self._last_time}"
            )
        log_time = self.start_time_ns + round(time_s * _NS)
        if log_time < 0:
            raise ValueError(f"frame {frame_index}: time_s {time_s} lies before the Unix epoch")
        return log_time

    def _add(self, channel: int, log_time: int, payload: dict | bytes, seq: int) -> None:
        self._writer.add_message(
            channel_id=channel,
            log_time=log_time,
            publish_time=log_time,
            data=payload if isinstance(payload, bytes) else _json(payload),
            sequence=seq,
        )

    def _write_cameras(self, log_time: int) -> None:
        if not self.cameras:
            return
        self._add(self._ch_tf, log_time, camera_transforms(self.cameras, log_time), 0)
        for ch, cam in zip(self._ch_calib, self.cameras, strict=True):
            self._add(ch, log_time, camera_calibration(cam, log_time), 0)

    def _after_frame(self, frame_index: int, time_s: float, log_time: int) -> None:
        self._last_frame = frame_index
        self._last_time = time_s
        if log_time >= self._next_tf_ns:
            # Repeat the camera poses once per second of log time so Foxglove shows them after
            # a seek (the first ones are written at start).
            self._write_cameras(log_time)
            self._next_tf_ns = log_time + _NS
        self._since_flush += 1
        if self._since_flush >= self.flush_every or (
            self.flush_interval_s is not None
            and time.monotonic() - self._last_flush >= self.flush_interval_s
        ):
            self.flush()

    def write_frame(
        self,
        frame_index: int,
        time_s: float,
        joints: np.ndarray,
        dofs: np.ndarray,
        weight: float,
        filter_name: str | None = None,
        leg_length: float | None = None,
    ) -> None:
        """Log the pose of one frame.

        Parameters
        ----------
        frame_index : int
            Frame number in the source video; strictly increasing over the log.
        time_s : float
            Seconds from the first frame of the recording; strictly increasing.
        joints : ndarray, shape (19, 3)
            Key points, world frame, metres (CONVENTIONS order). NaN where unknown.
        dofs : ndarray, shape (31,)
            Pose vector in ``tracker.dof`` order (metres, radians).
        weight : float
            Weight (likelihood) of the estimate.
        filter_name : str, optional
            Filter that produced the pose; the writer's ``filter_name`` if not given.
        leg_length : float, optional
            Relative leg length of the body model ``dofs`` refer to (``BodyModel.leg_length``,
            0.8-1.2); not written when not given (readers take 1.0).
        """
        frame_index = int(frame_index)
        time_s = float(time_s)
        joints = np.asarray(joints, dtype=np.float64)
        dofs = np.asarray(dofs, dtype=np.float64)
        if joints.shape != (N_KEYPOINTS, 3):
            raise ValueError(f"joints must have shape ({N_KEYPOINTS}, 3), not {joints.shape}")
        if dofs.shape != (N_DOF,):
            raise ValueError(f"dofs must have shape ({N_DOF},), not {dofs.shape}")
        if leg_length is not None and not (math.isfinite(leg_length) and 0.5 <= leg_length <= 2):
            raise ValueError(f"leg_length must be finite and between 0.5 and 2, not {leg_length}")
        log_time = self._log_time(frame_index, time_s)
        w = float(weight)
        pose = {
            "frame": frame_index,
            "time_s": time_s,
            "joints": dict(zip(KEYPOINTS, _finite_or_none(joints), strict=True)),
            "dofs": _finite_or_none(dofs),
            "weight": w if math.isfinite(w) else None,
            "filter": self.filter_name if filter_name is None else str(filter_name),
        }
        if leg_length is not None:
            pose["leg_length"] = float(leg_length)
        self._add(self._ch_pose, log_time, pose, frame_index)
        self._add(self._ch_skeleton, log_time, skeleton_scene_update(joints, log_time), frame_index)
        self.n_pose += 1
        self._after_frame(frame_index, time_s, log_time)

    def write_no_pose(self, frame_index: int, time_s: float, reason: str) -> None:
        """Log a frame that has no pose (nobody in view, silhouette too small ...).

        The skeleton is removed from the Foxglove scene at this time.
        """
        frame_index = int(frame_index)
        time_s = float(time_s)
        log_time = self._log_time(frame_index, time_s)
        status = {"frame": frame_index, "time_s": time_s, "reason": str(reason), "no_pose": True}
        self._add(self._ch_status, log_time, status, frame_index)
        self._add(self._ch_skeleton, log_time, skeleton_deletion(log_time), frame_index)
        self.n_no_pose += 1
        self._after_frame(frame_index, time_s, log_time)

    def write_note(self, frame_index: int, time_s: float, text: str) -> None:
        """Log a note about a frame that may also have a pose (e.g. "2 people, following one").

        Notes do not take part in the frame ordering checks; their ``time_s`` must be finite.
        """
        if self._closed:
            raise ValueError(f"{self.path}: pose log is closed")
        time_s = float(time_s)
        if not math.isfinite(time_s):
            raise ValueError(f"note on frame {frame_index}: time_s must be finite")
        log_time = max(0, self.start_time_ns + round(time_s * _NS))
        status = {
            "frame": int(frame_index),
            "time_s": time_s,
            "reason": str(text),
            "no_pose": False,
        }
        self._add(self._ch_status, log_time, status, int(frame_index))

    def flush(self) -> None:
        """Close the current chunk and hand everything written so far to the operating system."""
        if self._closed:
            return
        if hasattr(self._writer, "flush"):  # mcap >= 1.5
            self._writer.flush()
        self._fh.flush()
        self._since_flush = 0
        self._last_flush = time.monotonic()

    def close(self, error: str | None = None) -> None:
        """Finalise the file: end record, summary, index and footer. Idempotent.

        Parameters
        ----------
        error : str, optional
            Why tracking stopped, when it stopped on an error (recorded in ``gaitwatch.end``).
        """
        if self._closed:
            return
        self._closed = True
        try:
            end = {
                "status": "error" if error else "complete",
                "frames_with_pose": str(self.n_pose),
                "frames_without_pose": str(self.n_no_pose),
            }
            if error:
                end["error"] = error
            self._writer.add_metadata(END_METADATA_NAME, end)
            self._writer.finish()
        finally:
            self._fh.close()
        log.debug(
            "pose log %s closed: %d poses, %d without", self.path, self.n_pose, self.n_no_pose
        )

    @property
    def closed(self) -> bool:
        return self._closed


# ---------------------------------------------------------------------------------------------
# Reader
# ---------------------------------------------------------------------------------------------
@dataclass
class PoseLog:
    """The content of a pose log.

    Attributes
    ----------
    trajectory : Trajectory
        Frames with a pose only (frame numbers may have gaps); ``fps`` from the metadata.
    dofs : ndarray, shape (T, 31)
        Pose vectors of those frames (``tracker.dof`` order; metres and radians).
    weights : ndarray, shape (T,)
        Weight of each estimate.
    filters : list of str
        Filter that produced each pose.
    leg_lengths : ndarray, shape (T,)
        Relative leg length of the body model each pose's ``dofs`` refer to (1.0 where the log
        does not say).
    no_pose : list of (int, float, str)
        Frames without a pose: frame, time_s, reason.
    cameras : list of Camera
        The cameras of the run, from the metadata (empty if absent).
    metadata : dict
        ``body_height_m``, ``filter``, ``settings``, ``software_version``, ``created``, ``fps``,
        ``start_time_ns``, ``format_version`` and, when the file was finalised, ``end``.
    truncated : bool
        True when the file was cut short and was read up to the last whole record.
    notes : list of (int, float, str)
        Notes written with :meth:`PoseLogWriter.write_note`: frame, time_s, text.
    """

    trajectory: Trajectory
    dofs: np.ndarray
    weights: np.ndarray
    filters: list[str]
    no_pose: list[tuple[int, float, str]]
    cameras: list[Camera]
    metadata: dict
    truncated: bool
    notes: list[tuple[int, float, str]] = field(default_factory=list)
    leg_lengths: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.trajectory)


_GAITWATCH_TOPICS: Final[tuple[str, ...]] = (TOPIC_POSE, TOPIC_STATUS)


class _Collector:
    """Decodes gaitwatch messages as they are read (no raw payloads are kept)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.metadata: dict[str, dict[str, str]] = {}
        self.topics: set[str] = set()
        self.truncated = False
        self.frames: list[int] = []
        self.times: list[float] = []
        self.positions: list[np.ndarray] = []
        self.dofs: list[np.ndarray] = []
        self.weights: list[float] = []
        self.filters: list[str | None] = []
        self.leg_lengths: list[float] = []
        self.no_pose: list[tuple[int, float, str]] = []
        self.notes: list[tuple[int, float, str]] = []

    def message(self, topic: str, payload: bytes) -> None:
        try:
            msg = json.loads(payload)
            if topic == TOPIC_POSE:
                joints = msg["joints"]
                if isinstance(joints, dict):
                    joints = [joints[name] for name in KEYPOINTS]
                pos = _as_float_array(joints, (N_KEYPOINTS, 3))
                dofs = _as_float_array(msg["dofs"], (N_DOF,))
                self.frames.append(int(msg["frame"]))
                self.times.append(float(msg["time_s"]))
                self.positions.append(pos)
                self.dofs.append(dofs)
                self.weights.append(np.nan if msg["weight"] is None else float(msg["weight"]))
                f = msg.get("filter")
                self.filters.append(None if f is None else str(f))
                legs = msg.get("leg_length")
                self.leg_lengths.append(1.0 if legs is None else float(legs))
            else:
                entry = (int(msg["frame"]), float(msg["time_s"]), str(msg["reason"]))
                (self.no_pose if msg.get("no_pose", True) else self.notes).append(entry)
        except (ValueError, KeyError, TypeError, AttributeError) as err:
            raise PoseLogError(f"{self.path}: malformed message on {topic} ({err})") from None


_READ_ERRORS: Final = (McapError, struct.error, ValueError, EOFError, zstandard.ZstdError)


def _read_indexed(fh: Any, out: _Collector) -> bool:
    """Read through the summary and index; False when the file has no usable summary.

    Only raises :class:`PoseLogError` (malformed gaitwatch messages); MCAP-level problems make
    it return False so that the caller scans the file sequentially instead.
    """
    try:
        reader = make_reader(fh, validate_crcs=True)
        summary = reader.get_summary()
        if summary is None or not summary.chunk_indexes:
            return False
        topics = {c.topic for c in summary.channels.values()}
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        messages = reader.iter_messages(topics=list(_GAITWATCH_TOPICS), log_time_order=False)
        for _schema, channel, message in messages:
            out.message(channel.topic, message.data)
    except PoseLogError:
        raise
    except (*_READ_ERRORS, OSError) as err:
        log.debug("indexed read of %s failed (%s); scanning sequentially", out.path, err)
        return False
    out.topics = topics
    out.metadata = metadata
    return True


def _iter_records(buf: memoryview) -> Iterator[tuple[int, memoryview]]:
    """Top-level records (opcode, body) after the magic; stops before a record that is cut."""
    pos = len(_MAGIC)
    n = len(buf)
    while pos + 9 <= n:
        opcode = buf[pos]
        (length,) = struct.unpack_from("<Q", buf, pos + 1)
        end = pos + 9 + length
        if end > n:
            return
        yield opcode, buf[pos + 9 : end]
        pos = end


def _read_sequential(buf: memoryview, out: _Collector) -> None:
    """Scan the file record by record without the index, up to the last whole record."""
    out.truncated = True
    channels: dict[int, str] = {}

    def take(rec: Any) -> None:
        if isinstance(rec, Channel):
            channels[rec.id] = rec.topic
            out.topics.add(rec.topic)
        elif isinstance(rec, Message):
            topic = channels.get(rec.channel_id)
            if topic in _GAITWATCH_TOPICS:
                out.message(topic, rec.data)

    for opcode, body in _iter_records(buf):
        stream = ReadDataStream(io.BytesIO(body))
        try:
            if opcode == Opcode.CHUNK:
                # Decode the whole chunk first so that a damaged chunk adds nothing.
                records = breakup_chunk(Chunk.read(stream), validate_crc=True)
                for rec in records:
                    take(rec)
            elif opcode == Opcode.CHANNEL:
                take(Channel.read(stream))
            elif opcode == Opcode.MESSAGE:
                take(Message.read(stream, len(body)))
            elif opcode == Opcode.METADATA:
                m = Metadata.read(stream)
                out.metadata[m.name] = dict(m.metadata)
            elif opcode == Opcode.FOOTER:
                Footer.read(stream)
                out.truncated = bytes(buf[-len(_MAGIC) :]) != _MAGIC
                break
        except _READ_ERRORS as err:
            log.debug("%s: stopping at a damaged record (opcode %d): %s", out.path, opcode, err)
            break


def _as_float_array(values: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Nested lists with None for unknown values -> float array of ``shape`` (NaN for None)."""
    a = np.array(values, dtype=object)
    if a.shape != shape:
        raise ValueError(f"expected shape {shape}, got {a.shape}")
    a[np.equal(a, None)] = np.nan
    return a.astype(np.float64)


def _parse_metadata(path: Path, raw: dict[str, str]) -> tuple[dict, list[Camera]]:
    meta: dict[str, Any] = {}
    try:
        if "format_version" in raw:
            meta["format_version"] = int(raw["format_version"])
        if "body_height_m" in raw:
            meta["body_height_m"] = float(raw["body_height_m"])
        meta["fps"] = float(raw["fps"]) if raw.get("fps") else None
        if "start_time_ns" in raw:
            meta["start_time_ns"] = int(raw["start_time_ns"])
        for key in ("filter", "software_version", "created"):
            if key in raw:
                meta[key] = raw[key]
        for key in ("settings", "keypoints", "dof_names"):
            if key in raw:
                meta[key] = json.loads(raw[key])
        count = int(raw.get("camera_count", "0"))
    except ValueError as err:
        raise PoseLogError(f"{path}: metadata '{METADATA_NAME}' is malformed ({err})") from None
    if "keypoints" in meta and tuple(meta["keypoints"]) != KEYPOINTS:
        raise PoseLogError(f"{path}: metadata keypoints differ from the 19 CONVENTIONS key points")
    if "dof_names" in meta and tuple(meta["dof_names"]) != DOF_NAMES:
        raise PoseLogError(f"{path}: metadata dof_names differ from tracker.dof.DOF_NAMES")
    cameras = []
    for i in range(count):
        key = f"camera/{i}"
        if key not in raw:
            raise PoseLogError(f"{path}: metadata '{METADATA_NAME}' lacks {key}")
        try:
            cameras.append(parse_camera(yaml.safe_load(raw[key]), f"{path}: metadata {key}"))
        except yaml.YAMLError as err:
            raise PoseLogError(f"{path}: metadata {key} is not valid YAML ({err})") from None
        except CameraFileError as err:
            raise PoseLogError(str(err)) from None
    return meta, cameras


def read_poselog(path: str | Path) -> PoseLog:
    """Read a pose log written by :class:`PoseLogWriter`.

    The file's index is used when it has one; a file without summary (cut short by a crash, or
    damaged) is scanned sequentially up to the last whole record, and ``truncated`` is set.

    Raises
    ------
    PoseLogError
        The file is missing, is not MCAP, or holds no gaitwatch pose log; the message names it.
    """
    path = Path(path)
    out = _Collector(path)
    try:
        fh = path.open("rb")
    except FileNotFoundError:
        raise PoseLogError(f"{path}: no such file") from None
    except (IsADirectoryError, PermissionError) as err:
        raise PoseLogError(f"{path}: cannot read ({err.__class__.__name__})") from None
    with fh:
        size = os.fstat(fh.fileno()).st_size
        head = fh.read(len(_MAGIC))
        if head != _MAGIC:
            if head and _MAGIC.startswith(head):
                raise PoseLogError(f"{path}: MCAP file cut short before its header")
            raise PoseLogError(f"{path}: not an MCAP file (no MCAP magic at the start)")
        fh.seek(-len(_MAGIC), os.SEEK_END)
        complete = size > 2 * len(_MAGIC) and fh.read(len(_MAGIC)) == _MAGIC
        fh.seek(0)
        if not (complete and _read_indexed(fh, out)):
            out = _Collector(path)  # discard anything from a failed indexed read
            with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
                view = memoryview(mm)
                try:
                    _read_sequential(view, out)
                finally:
                    view.release()
            if out.truncated:
                log.warning("%s: file was cut short; read up to the last whole record", path)

    raw_meta = out.metadata.get(METADATA_NAME)
    if raw_meta is None and not (out.topics & set(_GAITWATCH_TOPICS)):
        if out.truncated:
            raise PoseLogError(
                f"{path}: MCAP file cut short before any gaitwatch content "
                f"('{METADATA_NAME}' metadata or {TOPIC_POSE} channel); nothing to read"
            )
        raise PoseLogError(
            f"{path}: MCAP file without gaitwatch pose channels ({TOPIC_POSE}, {TOPIC_STATUS}) "
            f"or '{METADATA_NAME}' metadata; not a gaitwatch pose log"
        )
    meta, cameras = _parse_metadata(path, raw_meta or {})
    if END_METADATA_NAME in out.metadata:
        meta["end"] = dict(out.metadata[END_METADATA_NAME])

    T = len(out.frames)
    frames = np.asarray(out.frames, dtype=np.int64)
    order = np.argsort(frames, kind="stable")
    positions = np.stack(out.positions)[order] if T else np.empty((0, N_KEYPOINTS, 3))
    dofs = np.stack(out.dofs)[order] if T else np.empty((0, N_DOF))
    default_filter = str(meta.get("filter", ""))
    filters = [out.filters[i] or default_filter for i in order]
    try:
        traj = Trajectory(
            positions=positions,
            times=np.asarray(out.times, dtype=np.float64)[order],
            frames=frames[order],
            fps=meta.get("fps"),
            source=str(path),
        )
    except ValueError as err:
        raise PoseLogError(f"{path}: {err}") from None
    if traj.fps is None and T >= 2:
        traj.fps = float(np.median(np.diff(traj.frames) / np.diff(traj.times)))
    return PoseLog(
        trajectory=traj,
        dofs=dofs,
        weights=np.asarray(out.weights, dtype=np.float64)[order],
        filters=filters,
        no_pose=sorted(out.no_pose),
        cameras=cameras,
        metadata=meta,
        truncated=out.truncated,
        notes=sorted(out.notes),
        leg_lengths=np.asarray(out.leg_lengths, dtype=np.float64)[order],
    )
