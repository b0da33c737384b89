"""Which leg is which: a fixed-lag decision over the key points written by ``gaitwatch track``
(an output stage after ``Tracker.process``, before the smoothing of :mod:`tracker.smoothing`).

A silhouette does not tell the left leg from the right, and the tracker now and then follows
a leg with the other leg's label for a few frames, most often after the legs have crossed.
In the key points this shows as a jump: the leg labelled left is suddenly where the right one
was, and back. Real feet do not jump: the stance foot stands still, the swing foot moves
smoothly. So each frame's labelling, as estimated or with the legs' key points exchanged
(knees, ankles, heels and toes), is chosen by a Viterbi search that minimises the summed
squared second difference in time of those eight points (the acceleration times the frame
interval squared), plus ``swap_cost`` (m^2) per exchanged frame, which keeps the tracker's
labels where motion does not decide (a segment in which every frame is exchanged moves as
smoothly as one in which none is).

:class:`LegRelabeller` works as a stream, like the smoother: :meth:`~LegRelabeller.push` takes one
frame and returns the frames whose labelling is decided, ``lag`` frames later (the best path
ending at the newest frame, read back); :meth:`~LegRelabeller.flush` decides the rest. Segments
are those of the smoother: a frame without a pose, a (re)initialised track, or a gap of more
than ``max_gap_s`` ends one, and each segment is decided on its own.

With one camera and the 2D key-point cue the tracker's own labels stand by default
(:func:`chooses_labels`, ``config.single_camera``): there the detections inform each frame's
legs, and one camera's noisy depth makes the smoothest labelling the worse choice (measured).

Only the key points change; the pose vector (DOFs) and the weight stay the tracker's own. On an
exchanged frame the written key points of the legs are therefore not the forward kinematics of
the written DOFs with the legs exchanged (that would mirror the legs about the pelvis).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from gaitwatch.conventions import L_ANKLE, L_HEEL, L_KNEE, L_TOE, R_ANKLE, R_HEEL, R_KNEE, R_TOE
from tracker.config import LegLabelConfig
from tracker.smoothing import segment_starts
from tracker.triangulation import side_distances

#: The key points exchanged with the other leg's, and scored (knee, ankle, heel, toe).
LEFT_POINTS: tuple[int, ...] = (L_KNEE, L_ANKLE, L_HEEL, L_TOE)
RIGHT_POINTS: tuple[int, ...] = (R_KNEE, R_ANKLE, R_HEEL, R_TOE)
_LEFT = list(LEFT_POINTS)
_RIGHT = list(RIGHT_POINTS)


def exchange_legs(joints: np.ndarray) -> np.ndarray:
    """A copy of ``joints`` (..., 19, 3) with the legs' key points exchanged (hips excepted)."""
    out = np.array(joints, dtype=np.float64, copy=True)
    out[..., _LEFT, :] = joints[..., _RIGHT, :]
    out[..., _RIGHT, :] = joints[..., _LEFT, :]
    return out


def labels_differ(joints: np.ndarray, other: np.ndarray) -> bool:
    """True when ``joints``' legs (knees, ankles, heels, toes; (19, 3)) lie nearer ``other``'s
    with the two legs' key points exchanged than as they are: the two poses label the legs the
    other way round."""
    a = np.asarray(joints, dtype=np.float64)
    b = np.asarray(other, dtype=np.float64)
    legs = _LEFT + _RIGHT
    same = np.linalg.norm(a[legs] - b[legs], axis=1).mean()
    swapped = np.linalg.norm(exchange_legs(a)[legs] - b[legs], axis=1).mean()
    return bool(swapped < same)


def label_vote(joints: np.ndarray, points: Sequence[np.ndarray | None] | None, cameras) -> int:
    """Which labelling of ``joints``' legs (19, 3) this frame's detections favour: +1 when
    their projections lie nearer the detected points with the legs exchanged than as they are,
    -1 when farther, 0 when no camera has a detected point on both legs or it is a tie
    (``points``: per camera None or the detected (19, 2) pixels, NaN where none;
    :attr:`tracker.keypoints2d.KeypointCue.points`). The distances
    (:func:`tracker.triangulation.side_distances`, over the knee, ankle, heel and toe pairs
    seen on both legs) are summed over the cameras."""
    if points is None:
        return 0
    j = np.asarray(joints, dtype=np.float64)
    keep = exchanged = 0.0
    seen = False
    for cam, uv in zip(cameras, points, strict=True):
        if uv is None:
            continue
        dist = side_distances(
            cam, np.asarray(uv, dtype=np.float64), j, _LEFT, _RIGHT, common_only=True
        )
        if dist is None:
            continue
        seen = True
        keep += dist[0]
        exchanged += dist[1]
    if not seen or exchanged == keep:
        return 0
    return 1 if exchanged < keep else -1


@dataclass
class LabelledFrame:
    """One frame through the relabeller: ``joints`` (19, 3), with the legs exchanged when
    ``exchanged``, or None for a frame without a pose; ``item`` is the caller's payload."""

    time_s: float
    joints: np.ndarray | None
    item: Any = None
    restart: bool = False
    exchanged: bool = False


class LegRelabeller:
    """Fixed-lag choice of each frame's leg labelling over a stream of frames (module docstring).

    Parameters
    ----------
    lag : int
        Frames after which a frame's labelling is decided (0: at once, from the past only).
    swap_cost : float
        Cost (m^2) of each exchanged frame.
    max_gap_s : float
        A longer step between two frames ends the segment.
    enabled : bool
        False: every frame passes through at once, as it is.
    """

    def __init__(
        self, lag: int, swap_cost: float, max_gap_s: float = 0.5, *, enabled: bool = True
    ) -> None:
        if lag < 0:
            raise ValueError(f"lag must be >= 0 frames, not {lag}")
        if not (np.isfinite(swap_cost) and swap_cost >= 0):
            raise ValueError(f"swap_cost must be >= 0, not {swap_cost}")
        self.lag = int(lag)
        self.swap_cost = float(swap_cost)
        self.max_gap_s = float(max_gap_s)
        self.enabled = bool(enabled)
        self._reset()

    @classmethod
    def from_config(
        cls,
        config: LegLabelConfig,
        fps: float,
        *,
        single_camera: bool = False,
        keypoint_cue: bool = False,
    ) -> LegRelabeller:
        """The relabeller of ``config`` at frame rate ``fps``; ``single_camera`` and
        ``keypoint_cue`` as in :func:`chooses_labels`."""
        if not (np.isfinite(fps) and fps > 0):
            raise ValueError(f"fps must be positive, not {fps}")
        return cls(
            int(round(config.lag_s * fps)),
            config.swap_cost_m2,
            config.max_gap_s,
            enabled=chooses_labels(config, single_camera=single_camera, keypoint_cue=keypoint_cue),
        )

    # -- stream -----------------------------------------------------------------------------
    def push(
        self, time_s: float, joints: np.ndarray | None, item: Any = None, *, restart: bool = False
    ) -> list[LabelledFrame]:
        """Add one frame; returns the frames now decided (oldest first).

        ``joints`` (19, 3) or None for a frame without a pose; ``restart`` marks a frame that
        starts a new track (a segment boundary before it).
        """
        j = None if joints is None else np.array(joints, dtype=np.float64)
        frame = LabelledFrame(float(time_s), j, item, bool(restart))
        if not self.enabled:
            return [frame]
        out: list[LabelledFrame] = []
        if self._frames and (
            j is None or frame.restart or frame.time_s - self._frames[-1].time_s > self.max_gap_s
        ):
            out += self.flush()
        if j is None:
            return [*out, frame]
        self._add(frame)
        if len(self._frames) > self.lag:
            out.append(self._decide_oldest())
        return out

    def flush(self) -> list[LabelledFrame]:
        """Decide every frame held (the end of a segment or of the footage)."""
        out: list[LabelledFrame] = []
        if self._frames:
            labels = self._best_path()[-len(self._frames) :]
            for frame, lab in zip(self._frames, labels, strict=True):
                out.append(self._apply(frame, bool(lab)))
        self._reset()
        return out

    # -- internals --------------------------------------------------------------------------
    def _reset(self) -> None:
        #: Frames not yet decided, oldest first.
        self._frames: deque[LabelledFrame] = deque()
        #: The segment's last two frames' leg points, as estimated and exchanged: (2, 8, 3).
        self._prev: list[np.ndarray] = []
        #: Path cost of each state (label of the frame before, label of this frame) (2, 2).
        self._cost: np.ndarray | None = None
        #: Per frame from the segment's third on: the best label two frames back for each
        #: state (2, 2); the segment's frames before the oldest held one are not needed.
        self._back: deque[np.ndarray] = deque()

    def _add(self, frame: LabelledFrame) -> None:
        assert frame.joints is not None
        legs = frame.joints[_LEFT + _RIGHT]
        x = np.stack([legs, np.concatenate([legs[4:], legs[:4]])])  # (2 labels, 8, 3)
        c = self.swap_cost
        labels = np.arange(2)
        if len(self._prev) == 1:  # the segment's second frame
            self._cost = c * (labels[:, None] + labels[None, :])
        elif len(self._prev) == 2:
            p2, p1 = self._prev
            assert self._cost is not None
            # acc[a, b, c]: squared second difference with labels a (t-2), b (t-1), c (t)
            d = x[None, None, :] - 2.0 * p1[None, :, None] + p2[:, None, None]
            acc = np.einsum("abcpk,abcpk->abc", d, d)
            total = self._cost[:, :, None] + acc + c * labels[None, None, :]
            back = np.argmin(total, axis=0)  # (b, c): the best a
            self._cost = np.take_along_axis(total, back[None], axis=0)[0]
            self._back.append(back)
        self._prev = [*self._prev[-1:], x]
        self._frames.append(frame)

    def _best_path(self) -> list[int]:
        """Labels of the segment's frames along the best path ending at the newest frame (at
        least those of the held frames)."""
        if self._cost is None:  # one frame in the segment
            return [0]
        b, c = (int(v) for v in np.unravel_index(np.argmin(self._cost), (2, 2)))
        labels = [c, b]
        for back in reversed(self._back):
            a = int(back[b, c])
            labels.append(a)
            b, c = a, b
        return labels[::-1]

    def _decide_oldest(self) -> LabelledFrame:
        labels = self._best_path()
        frame = self._frames.popleft()
        lab = labels[len(labels) - len(self._frames) - 1]
        # back-pointers older than the held frames are not read again
        while len(self._back) > len(self._frames) + 1:
            self._back.popleft()
        return self._apply(frame, bool(lab))

    @staticmethod
    def _apply(frame: LabelledFrame, exchange: bool) -> LabelledFrame:
        if exchange:  # held frames all have joints
            assert frame.joints is not None
            frame.joints = exchange_legs(frame.joints)
            frame.exchanged = True
        return frame


def chooses_labels(config: LegLabelConfig, *, single_camera: bool, keypoint_cue: bool) -> bool:
    """Whether the labels are chosen by smooth motion (``config.enabled``): always with two
    cameras or more; with one camera (``single_camera``) as ``config.single_camera`` says,
    ``"auto"`` only when the 2D key-point cue has no detections to score (``keypoint_cue``
    False: the cue is off, or neither its detector nor given key points feed it).

    Why: with one camera the depth of each leg point is noisy, and where the cue's detections
    inform each frame's legs the tracker's own labels were measured better than the smoothest
    labelling (session 37: lower limbs -6.8 +- 2.9 mm over 48 one-camera runs without the
    relabelling); without the cue smooth motion helps one camera too (session 18: -6.5 mm)."""
    if not config.enabled:
        return False
    if not single_camera or config.single_camera == "on":
        return True
    return config.single_camera == "auto" and not keypoint_cue


def relabel_legs(
    times: np.ndarray,
    joints: np.ndarray,
    config: LegLabelConfig,
    fps: float,
    restarts: np.ndarray | None = None,
    frames: np.ndarray | None = None,
    *,
    single_camera: bool = False,
    keypoint_cue: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The whole-footage form: ``joints`` (T, 19, 3) of frames with a pose at ``times`` (T,),
    ``restarts`` and ``frames`` as in :func:`tracker.smoothing.smooth_keypoints`,
    ``single_camera`` and ``keypoint_cue`` as in :func:`chooses_labels`. Returns the
    relabelled joints (T, 19, 3) and which frames were exchanged (T,) bool."""
    rl = LegRelabeller.from_config(
        config, fps, single_camera=single_camera, keypoint_cue=keypoint_cue
    )
    out: list[LabelledFrame] = []
    for t, j, r in zip(times, joints, segment_starts(len(times), restarts, frames), strict=True):
        out += rl.push(float(t), j, restart=bool(r))
    out += rl.flush()
    if not out:
        return np.zeros_like(np.asarray(joints, dtype=np.float64)), np.zeros(0, dtype=bool)
    return np.stack([f.joints for f in out]), np.array([f.exchanged for f in out])
