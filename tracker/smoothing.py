"""Fixed-lag smoothing of the tracked key points (an output stage after ``Tracker.process``).

Each frame's estimate carries the filter's own noise: the particle chosen at one frame and the
next differ by more than the body moved. A centred local polynomial fit over a short window
(Savitzky-Golay, in time) removes most of it and keeps the motion of walking: with a window
of 0.45 s and a quadratic the benchmark's key-point error fell 5.5 % and the knee flexion RMSE
2.7 deg (docs/tracker.md, "Output smoothing"). The ankles, heels and toes are fitted with a
quartic (``feet_order``): a foot stops at heel strike and starts at toe off, the instants the
gait events are read from, and a quadratic over the window rounds those off.

:class:`KeypointSmoother` works as a stream: :meth:`~KeypointSmoother.push` takes one frame at a
time and returns the frames that are final, each ``half`` frames later (the window's half
width); :meth:`~KeypointSmoother.flush` returns the rest at the end (or when tracking stops on an
error, so nothing is lost). Memory stays at one window. Frames come out in the order they went
in.

Segments: only frames of one continuous track are fitted together. A frame without a pose, a
(re)initialised track, or a gap in time of more than ``max_gap_s`` ends a segment; a frame near
a segment's end is fitted on the frames of its segment that are in its window (a lower order
when there are few), a segment of one frame is left as it is.

Depth through one camera (``eye``, the camera's centre, given only when one camera sees the
person): a single view fixes where the body is across the image far better than how far it is
from the camera, and the filter's depth jitters from frame to frame. The distance of the key
points' centroid from the camera, along the horizontal line of sight, is fitted over a longer
window (``depth_window``, ``depth_order``) and each frame's key points move together along that
line onto the fit (after their own fit): the limbs keep their motion relative to the body.

Balance through one camera (``balance``, with the depth stage): one view cannot see how far
the pelvis stands to the side of the feet along its line of sight either, and the filter's
estimate errs there (one oblique camera: the hips' centre 1-85 mm further to the side of the
feet's centre than the truth's, per recording). A standing or walking body keeps its pelvis
over its feet. The pelvis's sideways offset from the feet's centre (across the pelvis,
horizontal) is averaged over the depth window's frames, and the part of it that lies along the
line of sight is taken back by the share ``balance``: the hips and everything above them move
along the line of sight, the knees half as far (their angle stays), the feet not at all.
Frames whose feet may be hidden (``legs_seen`` False) count as no offset in the mean, so the
step fades in and out with the feet's evidence.

Only the key points are smoothed; the pose vector and weight stay the tracker's own.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gaitwatch.conventions import KEYPOINTS, side_index
from tracker.config import SmoothingConfig

#: The key points fitted with ``feet_order``: both ankles, heels and toes.
FEET = [side_index(s, p) for s in ("left", "right") for p in ("ankle", "heel", "toe")]

#: The key points the balance step moves along the line of sight with the pelvis (the hips and
#: every point above them); the knees move half as far, the feet (:data:`FEET`) stay.
UPPER = [KEYPOINTS.index(n) for n in ("head", "neck", "sacrum")] + [
    side_index(s, p) for s in ("left", "right") for p in ("shoulder", "elbow", "wrist", "hip")
]
KNEES = [side_index(s, "knee") for s in ("left", "right")]
_HIPS = (side_index("left", "hip"), side_index("right", "hip"))

#: Statuses that start a new segment (the pose jumps).
RESTART_STATUSES = frozenset({"initialised", "reinitialised"})


@dataclass
class SmoothedFrame:
    """One frame through the smoother: ``joints`` is None for a frame without a pose;
    ``item`` is the caller's own payload, returned untouched."""

    time_s: float
    joints: np.ndarray | None
    item: Any = None
    restart: bool = False
    raw: np.ndarray | None = field(default=None, repr=False)
    #: The raw key points' centroid's horizontal distance from the depth stage's eye.
    distance: float = field(default=float("nan"), repr=False)
    #: The raw pelvis's sideways offset (2,) from the feet's centre, horizontal (balance step).
    sideways: np.ndarray | None = field(default=None, repr=False)


def sideways_offset(joints: np.ndarray) -> np.ndarray | None:
    """The horizontal offset (2,) of the hips' centre from the feet's centre (the mean of both
    ankles, heels and toes), its component across the pelvis (along the line from the right
    hip to the left); None for other than 19 key points, or hips one above the other."""
    if joints.shape[0] != len(KEYPOINTS):
        return None
    across = joints[_HIPS[0], :2] - joints[_HIPS[1], :2]
    n = float(np.linalg.norm(across))
    if not n > 1e-6:
        return None
    across /= n
    offset = 0.5 * (joints[_HIPS[0], :2] + joints[_HIPS[1], :2]) - joints[FEET, :2].mean(axis=0)
    out = float(offset @ across) * across
    return out if np.isfinite(out).all() else None


def window_frames(window_s: float, fps: float) -> int:
    """Odd number of frames in a window of ``window_s`` seconds at ``fps`` (at least 1)."""
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, not {fps}")
    n = int(round(window_s * fps))
    return max(1, n if n % 2 == 1 else n + 1)


def local_fit(times: np.ndarray, values: np.ndarray, at: float, order: int) -> np.ndarray:
    """Least-squares polynomial in time (order at most ``len(times) - 1``) evaluated at ``at``.

    ``times`` (n,), ``values`` (n, ...) -> (...). Times are centred on ``at`` for conditioning.
    """
    n = len(times)
    return np.tensordot(fit_weights(times, at, order), values.reshape(n, -1), axes=1).reshape(
        values.shape[1:]
    )


def fit_weights(times: np.ndarray, at: float, order: int) -> np.ndarray:
    """(n,) weights ``w`` with ``w @ values`` = :func:`local_fit` ``(times, values, at, order)``:
    the fit is linear in the values, and ``w`` is the first row of the pseudo-inverse of the
    Vandermonde matrix (order at most ``n - 1``; the mean when that is 0)."""
    n = len(times)
    deg = min(order, n - 1)
    if deg <= 0:
        return np.full(n, 1.0 / n)
    t = np.asarray(times, dtype=np.float64) - at
    scale = float(np.abs(t).max()) or 1.0  # times centred on ``at`` and scaled: conditioning
    # Column 0 of the Vandermonde matrix is the polynomial's value at ``at``.
    return np.linalg.pinv(np.vander(t / scale, deg + 1, increasing=True))[0]


class KeypointSmoother:
    """Centred local polynomial smoothing of key points over a stream of frames.

    Parameters
    ----------
    window : int
        Frames in the window (odd; 1 = no smoothing, frames pass straight through).
    order : int
        Polynomial order (0-4).
    max_gap_s : float
        A larger time step between two frames ends the segment.
    feet_order : int, optional
        Polynomial order (0-4) for the ankles, heels and toes of 19-point frames (:data:`FEET`);
        None: ``order``.
    eye : array (3,), optional
        The one camera's centre (world, metres): the frames' distance from it along the
        horizontal line of sight is fitted over ``depth_window`` frames (odd) with
        ``depth_order`` (see the module docstring). None, or a window of 1: no depth stage.
    balance : float
        With the depth stage: the share of the pelvis's sideways offset from the feet
        (averaged over the depth window), its component along the line of sight, taken back
        (module docstring; 19-point frames). 0: off.
    """

    def __init__(
        self,
        window: int,
        order: int = 2,
        max_gap_s: float = 0.5,
        feet_order: int | None = None,
        *,
        eye: np.ndarray | None = None,
        depth_window: int = 1,
        depth_order: int = 1,
        balance: float = 0.0,
    ) -> None:
        for name, value in (("window", window), ("depth_window", depth_window)):
            if value < 1 or value % 2 == 0:
                raise ValueError(f"{name} must be an odd number of frames >= 1, not {value}")
        orders = (("order", order), ("feet_order", feet_order), ("depth_order", depth_order))
        for name, value in orders:
            if value is not None and not 0 <= value <= 4:
                raise ValueError(f"{name} must be 0 to 4, not {value}")
        self.window = int(window)
        self.half = self.window // 2
        self.order = int(order)
        self.feet_order = self.order if feet_order is None else int(feet_order)
        self.max_gap_s = float(max_gap_s)
        self.eye = None
        if eye is not None and depth_window > 1:
            self.eye = np.asarray(eye, dtype=np.float64).reshape(3)
            if not np.isfinite(self.eye).all():
                raise ValueError(f"eye must be a finite point, not {eye}")
        self.depth_half = int(depth_window) // 2 if self.eye is not None else 0
        self.depth_order = int(depth_order)
        if not 0 <= balance <= 2:
            raise ValueError(f"balance must be 0 to 2, not {balance}")
        self.balance = float(balance) if self.depth_half > 0 else 0.0
        #: Frames a frame waits for (the longer of the two half windows).
        self.lag = max(self.half, self.depth_half)
        #: Frames not yet returned (oldest first); the segment's earlier frames kept for fits.
        self._pending: deque[SmoothedFrame] = deque()
        self._history: deque[SmoothedFrame] = deque(maxlen=self.lag)
        self._weights: dict[tuple, np.ndarray] = {}

    @classmethod
    def from_config(
        cls, config: SmoothingConfig, fps: float, eye: np.ndarray | None = None
    ) -> KeypointSmoother:
        """The smoother of ``config`` at frame rate ``fps`` (window 1 when disabled); ``eye``
        the camera's centre when one camera sees the person (:func:`single_camera_eye`)."""
        on = config.enabled
        window = window_frames(config.window_s, fps) if on else 1
        depth = window_frames(config.depth_window_s, fps) if on and config.depth_window_s else 1
        return cls(
            window,
            config.order,
            config.max_gap_s,
            config.feet_order,
            eye=eye,
            depth_window=depth,
            depth_order=config.depth_order,
            balance=config.balance,
        )

    # -- stream -----------------------------------------------------------------------------
    def push(
        self,
        time_s: float,
        joints: np.ndarray | None,
        item: Any = None,
        *,
        restart: bool = False,
        legs_seen: bool = True,
    ) -> list[SmoothedFrame]:
        """Add one frame; returns the frames that are now final (oldest first).

        ``joints`` (K, 3) or None for a frame without a pose; ``restart`` marks a frame that
        starts a new track (a segment boundary before it); ``legs_seen`` False: the frame's
        feet are the model's guess, and its offset counts as none in the balance step's mean
        (:attr:`tracker.pipeline.FrameResult.legs_seen`).
        """
        j = None if joints is None else np.array(joints, dtype=np.float64)
        frame = SmoothedFrame(float(time_s), j, item, bool(restart), raw=j)
        if j is not None and self.eye is not None:
            frame.distance = float(np.hypot(*(j[:, :2].mean(axis=0) - self.eye[:2])))
            if self.balance > 0 and legs_seen:
                frame.sideways = sideways_offset(j)
        out: list[SmoothedFrame] = []
        if self._pending and self._breaks(self._pending[-1], frame):
            out += self._drain()
        elif not self._pending and self._history and self._breaks(self._history[-1], frame):
            self._history.clear()
        self._pending.append(frame)
        if frame.joints is None:  # ends the segment: it and everything before are final
            out += self._drain()
            return out
        while self._ready():
            out.append(self._emit())
        return out

    def flush(self) -> list[SmoothedFrame]:
        """Every frame not yet returned (the end of the footage, or tracking stopped)."""
        return self._drain()

    # -- internals --------------------------------------------------------------------------
    def _breaks(self, prev: SmoothedFrame, frame: SmoothedFrame) -> bool:
        return (
            prev.joints is None
            or frame.joints is None
            or frame.restart
            or frame.time_s - prev.time_s > self.max_gap_s
        )

    def _ready(self) -> bool:
        # the oldest pending frame has its whole windows (half a window of later frames)
        return len(self._pending) > self.lag

    def _emit(self) -> SmoothedFrame:
        frame = self._pending[0]
        if frame.joints is not None and self.lag > 0:
            history = list(self._history)
            after = []
            for f in list(self._pending)[1 : self.lag + 1]:
                if f.raw is None or f.restart:
                    break
                after.append(f)
            if self.half > 0:
                seg = [*history[max(0, len(history) - self.half) :], frame, *after[: self.half]]
                if len(seg) > 1:
                    t = np.array([f.time_s for f in seg])
                    v = np.stack([f.raw for f in seg])
                    frame.joints = self._fit(t, v, frame.time_s, self.order)
                    if self.feet_order != self.order and v.shape[1] == len(KEYPOINTS):
                        frame.joints[FEET] = self._fit(t, v[:, FEET], frame.time_s, self.feet_order)
            if self.depth_half > 0:
                seg = [
                    *history[max(0, len(history) - self.depth_half) :],
                    frame,
                    *after[: self.depth_half],
                ]
                if len(seg) > 1:
                    frame.joints = self._depth_fit(seg, frame)
                    if self.balance > 0:
                        frame.joints = self._balance_fit(seg, frame)
        self._pending.popleft()
        if frame.joints is None:
            self._history.clear()
        else:
            self._history.append(frame)
        return frame

    def _depth_fit(self, seg: list[SmoothedFrame], frame: SmoothedFrame) -> np.ndarray:
        """``frame``'s key points moved along the horizontal line of sight from :attr:`eye`
        so that their centroid's distance is the fit over ``seg`` of the raw centroids'."""
        assert self.eye is not None and frame.joints is not None
        eye = self.eye[:2]
        t = np.array([f.time_s for f in seg])
        dist = np.array([f.distance for f in seg])
        target = float(self._fit(t, dist, frame.time_s, self.depth_order))
        offset = frame.joints[:, :2].mean(axis=0) - eye
        now = float(np.linalg.norm(offset))
        if not (now > 1e-6 and np.isfinite(target)):
            return frame.joints
        out = frame.joints.copy()
        out[:, :2] += (target - now) * offset / now
        return out

    def _balance_fit(self, seg: list[SmoothedFrame], frame: SmoothedFrame) -> np.ndarray:
        """``frame``'s hips and the points above them moved along the horizontal line of sight
        from :attr:`eye` by ``-balance`` times the component along it of the pelvis's
        sideways offset averaged over ``seg``, the frames whose feet were not seen counting as
        no offset (the knees by half of it)."""
        assert self.eye is not None and frame.joints is not None
        seen = [f.sideways for f in seg if f.sideways is not None]
        if not seen or frame.joints.shape[0] != len(KEYPOINTS):
            return frame.joints
        # A mean, not a fit in time (the frames seen may all lie on one side of this one),
        # over the whole window with the unseen frames counting as no offset: the step fades
        # in and out with the feet's evidence instead of jumping (the sacrum's path gives the
        # gait events).
        offset = np.sum(seen, axis=0) / len(seg)
        sight = 0.5 * (frame.joints[_HIPS[0], :2] + frame.joints[_HIPS[1], :2]) - self.eye[:2]
        n = float(np.linalg.norm(sight))
        if not (n > 1e-6 and np.isfinite(offset).all()):
            return frame.joints
        sight /= n
        step = -self.balance * float(offset @ sight) * sight
        out = frame.joints.copy()
        out[UPPER, :2] += step
        out[KNEES, :2] += 0.5 * step
        return out

    def _fit(self, t: np.ndarray, v: np.ndarray, at: float, order: int) -> np.ndarray:
        """:func:`local_fit` with the weights cached per (order, frame times relative to
        ``at``, microseconds): inside a track at a steady frame rate they repeat."""
        key = (order, tuple(np.round((t - at) * 1e6).astype(np.int64).tolist()))
        w = self._weights.get(key)
        if w is None:
            if len(self._weights) >= 256:
                self._weights.clear()
            w = self._weights[key] = fit_weights(t, at, order)
        return np.tensordot(w, v, axes=1)

    def _drain(self) -> list[SmoothedFrame]:
        out = []
        while self._pending:
            out.append(self._emit())
        if out and out[-1].joints is not None:
            self._history.clear()  # the segment is over
        return out


def single_camera_eye(cameras) -> np.ndarray | None:
    """The centre (3,) of the one camera in ``cameras`` (each with a ``center``), or None
    with two or more: then the cameras fix the depth and the depth stage stays off."""
    cams = list(cameras)
    return np.asarray(cams[0].center, dtype=np.float64) if len(cams) == 1 else None


def segment_starts(
    n: int, restarts: np.ndarray | None = None, frames: np.ndarray | None = None
) -> np.ndarray:
    """(n,) bool: the frames that start a segment in the whole-footage forms, ``restarts`` (a
    track starts) or a frame number that does not follow the previous one's."""
    flags = np.zeros(n, dtype=bool) if restarts is None else np.asarray(restarts, bool)
    if frames is not None:
        f = np.asarray(frames)
        flags = flags | np.concatenate([[True], np.diff(f) != 1])[:n]
    return flags


def smooth_keypoints(
    times: np.ndarray,
    joints: np.ndarray,
    config: SmoothingConfig,
    fps: float,
    restarts: np.ndarray | None = None,
    frames: np.ndarray | None = None,
    eye: np.ndarray | None = None,
    legs_seen: np.ndarray | None = None,
) -> np.ndarray:
    """The whole-footage form: ``joints`` (T, K, 3) of frames with a pose at ``times`` (T,),
    ``restarts`` (T,) True where a track starts; ``frames`` (T,) their frame numbers, a frame
    that does not follow the previous one (a frame without a pose between them) also starts a
    segment; ``eye`` as in :class:`KeypointSmoother`; ``legs_seen`` (T,) as in
    :meth:`KeypointSmoother.push` (None: all True). Returns the smoothed (T, K, 3)."""
    sm = KeypointSmoother.from_config(config, fps, eye)
    seen = np.ones(len(times), dtype=bool) if legs_seen is None else np.asarray(legs_seen, bool)
    if seen.shape != (len(times),):
        raise ValueError(f"legs_seen has shape {seen.shape}, expected ({len(times)},)")
    starts = segment_starts(len(times), restarts, frames)
    out: list[np.ndarray] = []
    for t, j, r, ls in zip(times, joints, starts, seen, strict=True):
        out += [f.joints for f in sm.push(float(t), j, restart=bool(r), legs_seen=bool(ls))]
    out += [f.joints for f in sm.flush()]
    return np.stack(out) if out else np.zeros_like(np.asarray(joints, dtype=np.float64))
