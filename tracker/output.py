"""The key points ``gaitwatch track`` writes, for a whole footage at once: each frame's leg
labels (:mod:`tracker.leglabels`), then the smoothing (:mod:`tracker.smoothing`). The benchmark
and ``gaitwatch simulate --advise`` score these; ``gaitwatch track`` runs the same two stages as
streams."""

from __future__ import annotations

import numpy as np

from tracker.config import TrackerConfig
from tracker.leglabels import relabel_legs
from tracker.smoothing import smooth_keypoints


def written_keypoints(
    times: np.ndarray,
    joints: np.ndarray,
    config: TrackerConfig,
    fps: float,
    restarts: np.ndarray | None = None,
    frames: np.ndarray | None = None,
    eye: np.ndarray | None = None,
    *,
    keypoint_cue: bool | None = None,
    legs_seen: np.ndarray | None = None,
) -> np.ndarray:
    """``joints`` (T, 19, 3) of the frames with a pose at ``times`` (T,) -> the written (T, 19,
    3), with ``config.leg_labels`` and ``config.smoothing``; ``restarts``, ``frames`` and
    ``eye`` (the camera's centre when one camera sees the person,
    :func:`tracker.smoothing.single_camera_eye`) as in
    :func:`tracker.smoothing.smooth_keypoints`. ``keypoint_cue``: whether the 2D key-point cue
    had detections to score (the tracker's detector ran, or key points were given), which
    decides one camera's leg labels (:func:`tracker.leglabels.chooses_labels`); None: as
    ``config.keypoints`` says (on, with a detector). ``legs_seen`` (T,): the frames'
    :attr:`tracker.pipeline.FrameResult.legs_seen` (None: all True), for the smoothing's
    balance step."""
    if keypoint_cue is None:
        keypoint_cue = config.keypoints.enabled and config.keypoints.detector != "none"
    labelled, _ = relabel_legs(
        times,
        joints,
        config.leg_labels,
        fps,
        restarts,
        frames,
        single_camera=eye is not None,
        keypoint_cue=keypoint_cue,
    )
    return smooth_keypoints(
        times, labelled, config.smoothing, fps, restarts, frames, eye, legs_seen=legs_seen
    )
