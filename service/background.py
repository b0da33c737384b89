"""The empty scene of each camera estimated from recorded footage (``gaitwatch track`` without
``--background``).

One extra pass over the footage before tracking: every frame is decoded, frames spread evenly
over it are kept (:class:`tracker.background.FrameSampler`, within a memory budget per camera)
and their per-pixel median is the empty scene (:func:`tracker.background.median_background`),
one per lighting state when a light was switched during the footage
(:class:`tracker.background.LightingStates`). With the 2D pose detector, the person is then
found in each sample (:func:`tracker.background.people_in_samples`) and left out of the
median, which is taken again: someone who stays in one part of the view for most of the
footage no longer stays in its empty scene. The tracker then subtracts it as it would a given
``--background`` image, switching states with the light
(:class:`tracker.background.LightingSwitch`).

A problem in the footage (a frame that cannot be decoded, videos of different lengths) ends the
pass where it is found, with a warning, and the median is taken over the frames read so far:
the tracking pass then stops at the same place with its own error, after tracking every frame
before it.
"""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Sequence
from pathlib import Path

from service.video import VideoError, open_videos
from tracker.background import (
    DEFAULT_MAX_BYTES,
    DEFAULT_SAMPLES,
    FrameSampler,
    LightingStates,
    people_in_samples,
)
from tracker.camera import Camera

log = logging.getLogger(__name__)

#: Above this share of unsure pixels the estimate is reported as doubtful.
UNSURE_WARNING = 0.02
#: Above this share the estimate is not used (None: the tracker learns that camera's
#: background as the footage goes, with MOG2): the light changed during the footage.
UNSURE_LIMIT = 0.3


def footage_backgrounds(
    paths: Sequence[str | Path],
    cameras: Sequence[Camera],
    *,
    max_frames: int | None = None,
    min_span_s: float = 60.0,
    samples: int = DEFAULT_SAMPLES,
    max_bytes: int = DEFAULT_MAX_BYTES,
    tolerance: float = 30.0,
    unsure_limit: float = UNSURE_LIMIT,
    progress: bool = False,
    detector=None,
    segmentation=None,
) -> list[LightingStates | None]:
    """Per camera, the empty scene estimated from its footage under each of its lighting states
    (:class:`tracker.background.LightingStates`: uint8 BGR images of the frames' size), or None
    where more than ``unsure_limit`` of a state's pixels are unsure.

    A lamp switched on or off during the footage splits the samples into two states by their
    brightness, each with its own median (:class:`tracker.background.LightingSwitch` picks a
    frame's). Where a state is still mostly unsure (a light that changed gradually and a lot,
    a scene that changed), the tracker learns that camera's background as the footage goes
    (MOG2), as it did before it estimated it.

    Parameters
    ----------
    paths, cameras
        One video file or frame folder per camera, and its camera, as for ``gaitwatch track``.
    max_frames : int, optional
        The frames to be tracked: the estimate reads the first ``max_frames`` frames, or
        ``min_span_s`` seconds of footage if that is more (someone who stands still in a short
        excerpt would stay in its median). None reads the whole footage.
    min_span_s : float
        See ``max_frames``.
    samples, max_bytes
        :class:`~tracker.background.FrameSampler`'s capacity and memory budget per camera.
    tolerance : float
        Grey levels within which a frame agrees with the estimate (the segmentation threshold).
    unsure_limit : float
        See above.
    progress : bool
        Show a progress bar on stderr.
    detector : tracker.detector2d.PoseDetector, optional
        Finds the person in each sample, to leave them out of the median
        (:func:`sampled_states`); None takes the plain median.
    segmentation : tracker.segmentation.SegmentationConfig, optional
        The tracker's segmentation settings, to find the person's box in each sample.

    Raises
    ------
    VideoError
        A video that cannot be opened, or whose first frame cannot be decoded.
    """
    import sys

    from tqdm import tqdm

    videos = open_videos(paths, cameras, on_length_mismatch="stop")
    limit = max_frames
    if limit is not None:
        fps = videos.sources[0].fps or cameras[0].fps or 25.0
        limit = max(limit, math.ceil(min_span_s * fps))
    total = videos.frame_count
    if limit is not None:
        total = min(total, limit) if total else limit
    samplers = [FrameSampler(samples, max_bytes) for _ in paths]
    with (
        videos,
        tqdm(
            total=total,
            unit="frame",
            desc="background",
            file=sys.stderr,
            disable=not progress,
            dynamic_ncols=True,
        ) as bar,
    ):
        try:
            for _, _, frames in itertools.islice(videos, limit):
                for sampler, frame in zip(samplers, frames, strict=True):
                    sampler.offer(frame)
                bar.update(1)
        except VideoError as err:
            log.warning(
                "reading the footage for its background stopped after %d frame(s): %s",
                videos.frames_read,
                err,
            )
    return [
        sampled_states(
            s,
            Path(p).name,
            tolerance=tolerance,
            unsure_limit=unsure_limit,
            detector=detector,
            segmentation=segmentation,
        )
        for p, s in zip(paths, samplers, strict=True)
    ]


def sampled_states(
    sampler: FrameSampler,
    name: str,
    *,
    tolerance: float = 30.0,
    unsure_limit: float = UNSURE_LIMIT,
    detector=None,
    segmentation=None,
) -> LightingStates | None:
    """One camera's empty scene from the frames ``sampler`` kept (logged under ``name``):
    its :class:`~tracker.background.LightingStates`, or None where a state is unsure on more
    than ``unsure_limit`` of its pixels (the tracker then learns that camera's background).

    With a ``detector`` (:class:`tracker.detector2d.PoseDetector`), the person found in each
    sample against the plain median (:func:`tracker.background.people_in_samples`, with the
    ``segmentation`` settings) is left out of a second median. A detector that cannot run
    leaves the plain median, with a warning."""
    from tracker.detector2d import DetectorUnavailableError

    frames = sampler.frames
    est = LightingStates(frames, tolerance=tolerance)
    masked = 0
    if detector is not None:
        try:
            masks = people_in_samples(
                frames, [est.states[k].image for k in est.sample_states], detector, segmentation
            )
        except DetectorUnavailableError as err:
            log.warning("%s: the person is not left out of the empty scene: %s", name, err)
        else:
            masked = sum(m is not None for m in masks)
            if masked:
                est = LightingStates(frames, tolerance=tolerance, masks=masks)
    log.info(
        "%s: empty scene estimated from %d of %d frame(s) (every %d-th), %d lighting "
        "state(s), the person left out of %d; %.1f %% of the pixels unsure, %.1f %% filled in",
        name,
        est.overall.n_samples,
        sampler.offered,
        sampler.stride,
        len(est.states),
        masked,
        100 * est.unsure_fraction,
        100 * est.filled_fraction,
    )
    if est.unsure_fraction > unsure_limit:
        log.warning(
            "%s: %.0f %% of the estimated empty scene is unsure (the light changed during "
            "the footage?): learning the background as the footage goes instead (mog2); an "
            "image of the empty scene (--background) is better",
            name,
            100 * est.unsure_fraction,
        )
        return None
    if est.unsure_fraction > UNSURE_WARNING:
        log.warning(
            "%s: %.0f %% of the estimated empty scene is unsure (someone or something "
            "stayed in one place for much of the footage, or the light changed); an image "
            "of the empty scene (--background) is better",
            name,
            100 * est.unsure_fraction,
        )
    return est
