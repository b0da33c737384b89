"""Several independent tracks of one footage, their key points averaged (config ``ensemble``).

Through one camera a track goes astray in ways the silhouettes cannot refuse: a leg half a
cycle behind, the knees bent where the truth's are straight, the body a little nearer the
camera. Two tracks of the same footage with other random draws go astray in other frames and
other ways, so the mean of their key points errs less than either (docs/tracker.md, "Several
tracks averaged"). :class:`EnsembleTracker` runs ``ensemble.tracks`` whole
:class:`~tracker.pipeline.Tracker` instances on the same silhouettes (one segmentation per
frame), each with its own generator spawned from the caller's and ``1 / tracks`` of the filter's
likelihood evaluations (:func:`member_config`), and returns per frame one
:class:`~tracker.pipeline.FrameResult` whose ``joints`` are the tracks' mean:

* each track's legs (hip, knee, ankle, heel, toe) and arms (shoulder, elbow, wrist) are first
  put on the side of the first posed track's nearer to them (a track's left and right are
  labels; the output's leg labels, :mod:`tracker.leglabels`, then choose the averaged track's);
* ``pose``, ``leg_length`` and the blob choice are the first posed track's, so ``pose`` no
  longer gives ``joints`` by forward kinematics (the pose log keeps both); ``weight`` is the
  tracks' mean, ``evaluations`` their sum;
* a frame is (re)initialised only when every posed track is (one track's re-initialisation
  moves the mean by a fraction of its jump); notes carry their track's number;
* revisions (the backward pass, ``config.revise``) of any track re-average those frames, and
  :attr:`EnsembleTracker.pending_from` is the oldest frame any track may still revise.

:func:`make_tracker` builds a plain :class:`~tracker.pipeline.Tracker` for one track, with the
caller's generator, so ``tracks = 1`` is the single tracker exactly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from gaitwatch.conventions import side_index
from tracker.config import EnsembleConfig, TrackerConfig
from tracker.pipeline import Detection, FrameResult, Tracker
from tracker.segmentation import Segmentation

#: Key-point pairs exchanged together when a track's side is matched to the reference's.
LEG_PAIRS = tuple(
    (side_index("left", p), side_index("right", p)) for p in ("hip", "knee", "ankle", "heel", "toe")
)
ARM_PAIRS = tuple(
    (side_index("left", p), side_index("right", p)) for p in ("shoulder", "elbow", "wrist")
)

#: Statuses of a frame that starts a track.
_STARTS = ("initialised", "reinitialised")


def member_config(config: TrackerConfig) -> TrackerConfig:
    """The configuration of one of ``config.ensemble.tracks`` tracks: the IPF's ``kept`` and
    the baselines' ``evaluations`` (when set) divided by the number of tracks (rounded, at least
    1), no ensemble of its own."""
    k = config.ensemble.tracks
    if k > 1:
        config = config.divided_budget(k)
    return config.model_copy(update={"ensemble": EnsembleConfig(tracks=1)})


def make_tracker(
    cameras: Sequence,
    config: TrackerConfig | None = None,
    *,
    rng: np.random.Generator,
    **kwargs,
) -> Tracker | EnsembleTracker:
    """A :class:`~tracker.pipeline.Tracker` (``config.ensemble.tracks`` = 1) or an
    :class:`EnsembleTracker`; ``kwargs`` as :class:`~tracker.pipeline.Tracker` takes them."""
    config = config or TrackerConfig()
    if config.ensemble.tracks == 1:
        return Tracker(cameras, config, rng=rng, **kwargs)
    return EnsembleTracker(cameras, config, rng=rng, **kwargs)


def match_sides(joints: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``joints`` (19, 3) with its legs and its arms each exchanged between the sides when the
    exchange brings them nearer to ``reference``'s (19, 3) (mean distance of the group's key
    points)."""
    out = joints.copy()
    for pairs in (LEG_PAIRS, ARM_PAIRS):
        left = [a for a, _ in pairs]
        right = [b for _, b in pairs]
        keep = np.linalg.norm(joints[left + right] - reference[left + right], axis=1).mean()
        swap = np.linalg.norm(joints[right + left] - reference[left + right], axis=1).mean()
        if swap < keep:
            out[left], out[right] = joints[right], joints[left]
    return out


def combine(results: Sequence[FrameResult]) -> FrameResult:
    """One frame's result from the tracks' results of that frame (see the module's docs)."""
    k = len(results)
    first = results[0]
    notes = [
        n if k == 1 else f"track {i + 1}/{k}: {n}" for i, r in enumerate(results) for n in r.notes
    ]
    evaluations = int(sum(r.evaluations for r in results))
    posed = [r for r in results if r.has_pose]
    if not posed:
        return FrameResult(
            first.frame_index,
            first.time_s,
            None,
            None,
            0.0,
            first.status,
            reason=first.reason,
            notes=notes,
            evaluations=evaluations,
        )
    ref = posed[0]
    joints = np.mean([ref.joints] + [match_sides(r.joints, ref.joints) for r in posed[1:]], axis=0)
    status = ref.status if all(r.status in _STARTS for r in posed) else "tracked"
    return FrameResult(
        ref.frame_index,
        ref.time_s,
        ref.pose,
        joints,
        float(np.mean([r.weight for r in posed])),
        status,
        notes=notes,
        evaluations=evaluations,
        leg_length=ref.leg_length,
    )


class EnsembleTracker:
    """``config.ensemble.tracks`` trackers on the same silhouettes, their key points averaged.

    Takes the arguments of :class:`~tracker.pipeline.Tracker` (but ``body`` and
    ``likelihood``: each track builds its own) and offers what its callers use:
    :meth:`process`, :meth:`process_segmentations`, :meth:`segment`, :attr:`pending_from`,
    :attr:`filter_name`, :attr:`evaluations_per_step`, :meth:`set_occluders`; ``config`` is
    the whole configuration, ``tracks`` the trackers (``tracks[0].likelihood`` holds the
    current frame's silhouettes).
    """

    def __init__(
        self,
        cameras: Sequence,
        config: TrackerConfig | None = None,
        *,
        rng: np.random.Generator,
        height_m: float = 1.70,
        backgrounds: Sequence[np.ndarray | None] | None = None,
        occluders: Sequence[np.ndarray | None] | None = None,
    ) -> None:
        self.config = config or TrackerConfig()
        sub = member_config(self.config)
        self.tracks = [
            Tracker(
                cameras,
                sub,
                rng=r,
                height_m=height_m,
                backgrounds=backgrounds,
                occluders=occluders,
            )
            for r in rng.spawn(self.config.ensemble.tracks)
        ]
        #: Each track's latest result per frame still open to revision.
        self._open: dict[int, list[FrameResult]] = {}

    @property
    def filter_name(self) -> str:
        return self.tracks[0].filter_name

    @property
    def cameras(self) -> list:
        return self.tracks[0].cameras

    @property
    def lik_cameras(self) -> list:
        return self.tracks[0].lik_cameras

    @property
    def likelihood(self):
        """The first track's likelihood (its silhouettes are the current frame's)."""
        return self.tracks[0].likelihood

    @property
    def detects_keypoints(self) -> bool:
        """Whether the built-in 2D pose detector runs (the first track's, for all tracks)."""
        return self.tracks[0].detects_keypoints

    @property
    def evaluations_per_step(self) -> int:
        """The filters' likelihood evaluations per frame, all tracks together."""
        return int(sum(t.evaluations_per_step for t in self.tracks))

    @property
    def pending_from(self) -> int | None:
        """The oldest frame whose result a later frame may still revise (any track), or None."""
        pending = [p for p in (t.pending_from for t in self.tracks) if p is not None]
        return min(pending) if pending else None

    def set_background(self, camera: int, image: np.ndarray) -> None:
        """As :meth:`tracker.pipeline.Tracker.set_background` (the shared segmenters)."""
        self.tracks[0].set_background(camera, image)

    def segment(self, frames: Sequence[np.ndarray]) -> list[Segmentation]:
        """One segmentation per camera, shared by every track (the first track's segmenters)."""
        return self.tracks[0].segment(frames)

    def set_occluders(self, occluders: Sequence[np.ndarray | None] | None) -> None:
        for t in self.tracks:
            t.set_occluders(occluders)

    def detect_ahead(self, frames: Sequence[np.ndarray], segs: Sequence[Segmentation]) -> Detection:
        """As :meth:`tracker.pipeline.Tracker.detect_ahead`: the detector the tracks share
        (never None: the ensemble detects before any track chooses its blobs)."""
        first = self.tracks[0]
        Detection.check_step(frames, segs, len(first.cameras))
        if first.detector is None or all(s.empty for s in segs):
            return Detection(tuple(segs), ran=False)
        return Detection.found(segs, first.detect_keypoints(frames, segs), first.detector)

    def process(
        self,
        frame_index: int,
        time_s: float,
        frames: Sequence[np.ndarray],
        keypoints: Sequence[np.ndarray | None] | None = None,
    ) -> FrameResult:
        """Track one time step from the raw frames of every camera."""
        return self.process_segmentations(
            frame_index, time_s, self.segment(frames), frames, keypoints
        )

    def process_segmentations(
        self,
        frame_index: int,
        time_s: float,
        segs: Sequence[Segmentation],
        frames: Sequence[np.ndarray] | None = None,
        keypoints: Sequence[np.ndarray | None] | None = None,
        heatmaps: Sequence | None = None,
        detection: Detection | None = None,
    ) -> FrameResult:
        """As :meth:`tracker.pipeline.Tracker.process_segmentations`, every track in turn (the
        built-in detector runs once, on the silhouettes before each track chooses its blobs,
        or :meth:`detect_ahead` ran it; the shadow pixels under the person it found are given
        back then, :meth:`tracker.pipeline.Tracker.give_back_shadows`)."""
        if detection is not None:
            detection.check_use(segs, keypoints)
        elif keypoints is None and frames is not None and not all(s.empty for s in segs):
            detection = self.detect_ahead(frames, segs)  # now, in turn
        if detection is not None and detection.ran:
            keypoints, heatmaps = detection.keypoints, detection.heatmaps
            segs = self.tracks[0].give_back_shadows(segs, detection.people)
        results = [
            t.process_segmentations(frame_index, time_s, segs, frames, keypoints, heatmaps)
            for t in self.tracks
        ]
        revised: set[int] = set()
        for i, r in enumerate(results):
            for rev in r.revisions:
                held = self._open.get(rev.frame_index)
                if held is not None:
                    held[i] = rev
                    revised.add(rev.frame_index)
        self._open[int(frame_index)] = [_without_revisions(r) for r in results]
        out = combine(self._open[int(frame_index)])
        out.revisions = [combine(self._open[f]) for f in sorted(revised)]
        pending = self.pending_from
        for f in [f for f in self._open if pending is None or f < pending]:
            del self._open[f]
        return out


def _without_revisions(result: FrameResult) -> FrameResult:
    """``result`` without the earlier frames' revisions it carries (they are filed apart)."""
    return replace(result, revisions=[]) if result.revisions else result
