"""The tracking pipeline: frames -> silhouettes -> body origin -> body parts -> 3D pose.

:class:`Tracker` takes the synchronised frames of all cameras one time step at a time (no file
I/O: the caller decodes video and writes the pose log) and returns a :class:`FrameResult`:

1. **Segmentation** per camera (:class:`tracker.segmentation.Segmenter`), silhouettes at the
   likelihood resolution. No silhouette above the minimum size in any camera -> no pose
   ("nobody in view"), and the track is re-initialised when someone appears.
2. **Blob choice**: with several blobs in a camera, keep the one consistent with the track — the
   largest overlap with the previous estimate's model mask, else the centroid closest to the
   projected predicted sacrum; without a track, the largest blob. Blobs lying mostly inside the
   predicted model (a person split in two by the segmentation) are kept with it. Logged.
3. **Initialisation** (first frame, after nobody was in view, after loss): the exhaustive search of
   :mod:`tracker.init` seeds the filter, followed by one filter step. At the first one the
   search runs once per ``config.init.girths`` value; the girth is then scored on the refined
   particles over ``init.girth_frames`` frames and kept fixed (when the tracker built the model).
4. Otherwise the **origin search** (:mod:`tracker.origin`) moves the root, holding the previous
   body-part configuration, then the **filter** (IPF, APF or Condensation) updates the body parts,
   then (``origin.after_filter``) the origin is searched again holding the new legs.
5. **Leg-swap check**: the heaviest particles are weighed with their legs exchanged; a heavier
   one becomes the estimate and joins the particle set (``config.leg_swap``).
   **Re-detection** (``config.redetect``): a reduced initial search around this frame's
   silhouette floor point and the current heading; a clearly heavier result becomes the
   estimate (a track that slid off the person is caught before it is lost).
6. **Heading check**: when the origin moves faster than a walking threshold in a direction far
   from the heading (the front/back ambiguity of silhouettes), re-initialise facing the walking
   direction if that weighs about as much (``config.heading_check``).
7. **Lost track**: best weight below ``lost_weight`` for ``lost_frames`` frames in a row ->
   re-initialise on that frame (kept if it weighs more than the filter's estimate).

Memory does not grow with the length of the footage: the tracker keeps one particle set and the
previous estimate. Every random draw comes from the injected generator.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import cv2
import numpy as np

from gaitwatch.conventions import L_ANKLE, L_HEEL, L_TOE, R_ANKLE, R_HEEL, R_TOE, SACRUM
from tracker.config import TrackerConfig
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, wrap_angle
from tracker.filters import Filter, make_filter, select_distinct
from tracker.init import floor_point, initial_search
from tracker.origin import search_origin
from tracker.segmentation import Segmentation, Segmenter, keep_blobs

log = logging.getLogger(__name__)

NOBODY_IN_VIEW = "nobody in view"
NO_FLOOR_POINT = "silhouette does not meet the floor in any camera"

_MAX_SPEED_M_S = 2.5


@dataclass
class FrameResult:
    """What the tracker found in one frame.

    Attributes
    ----------
    frame_index : int
    time_s : float
    pose : ndarray (31,) or None
        Metres / radians (:mod:`tracker.dof`); None when no pose (see ``reason``).
    joints : ndarray (19, 3) or None
        World frame, metres, CONVENTIONS key-point order.
    weight : float
        Likelihood weight of the estimate (0 without a pose).
    status : str
        "tracked", "initialised", "reinitialised" or "no_pose".
    reason : str
        Why there is no pose.
    notes : list of str
        Remarks worth logging (several blobs and which one was followed, re-initialisation).
    evaluations : int
        Likelihood evaluations spent on this frame (origin search, filter, initialisation).
    """

    frame_index: int
    time_s: float
    pose: np.ndarray | None
    joints: np.ndarray | None
    weight: float
    status: str
    reason: str = ""
    notes: list[str] = field(default_factory=list)
    evaluations: int = 0

    @property
    def has_pose(self) -> bool:
        return self.pose is not None


@contextmanager
def _numba_threads(n: int):
    """Run the numba kernels inside the block on ``n`` threads (restored afterwards).

    Small batches (the origin search weighs 12 batches of 7 poses per frame; forward kinematics
    of single poses) lose more to thread synchronisation than they gain, and on a busy machine
    each parallel call can wait milliseconds for the other thread to be scheduled; only the
    large batches (the filter's thousands of particles, the initial search) use every thread.
    """
    import numba

    old = numba.get_num_threads()
    n = max(1, min(int(n), numba.config.NUMBA_NUM_THREADS))
    if n == old:
        yield
        return
    numba.set_num_threads(n)
    try:
        yield
    finally:
        numba.set_num_threads(old)


def _single_thread():
    return _numba_threads(1)


_FEET_POINTS = [L_ANKLE, R_ANKLE, L_HEEL, R_HEEL, L_TOE, R_TOE]


def _feet_distance(body, poses: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Mean distance (metres, (K,)) of each pose's ankles, heels and toes from ``reference``'s
    (key points (19, 3))."""
    feet = np.asarray(body.forward(poses))[:, _FEET_POINTS]
    return np.linalg.norm(feet - reference[_FEET_POINTS], axis=2).mean(axis=1)


def _tie_choice(weights: np.ndarray, distance: np.ndarray, tie: float) -> int:
    """Index of the tie (weight >= (1 - tie) * max) with the smallest ``distance``; the
    heaviest when no other weighs as much."""
    w = np.asarray(weights, dtype=np.float64)
    ok = np.flatnonzero(w >= (1.0 - tie) * w.max())
    if ok.size <= 1:
        return int(np.argmax(w))
    return int(ok[int(np.argmin(distance[ok]))])


def _continuity_choice(
    body, poses: np.ndarray, weights: np.ndarray, reference: np.ndarray, tie: float
) -> int:
    """Index of the tie (weight >= (1 - tie) * max) whose feet are nearest ``reference``.

    Parameters
    ----------
    body : tracker.body.BodyModel
    poses : ndarray (K, 31)
    weights : ndarray (K,)
    reference : ndarray (19, 3)
        Key points (metres, world) of the reference pose.
    tie : float
        Relative weight tolerance (0..1).

    Returns
    -------
    int
        The heaviest candidate when no other is within the tolerance; else the tie whose
        ankles, heels and toes are nearest (mean distance, metres) their namesakes in
        ``reference`` (physical continuity: a foot in stance does not slide on the floor).
    """
    w = np.asarray(weights, dtype=np.float64)
    if np.count_nonzero(w >= (1.0 - tie) * w.max()) <= 1:
        return int(np.argmax(w))
    return _tie_choice(w, _feet_distance(body, poses, reference), tie)


class _CountingLikelihood:
    """Counts the poses weighed (for the per-frame evaluation figures)."""

    def __init__(self, inner) -> None:
        self.inner = inner
        self.count = 0
        if hasattr(inner, "weights_factored"):
            self.weights_factored = self._factored

    def weights(self, poses: np.ndarray) -> np.ndarray:
        self.count += poses.shape[0]
        return self.inner.weights(poses)

    def _factored(self, base, left, right) -> np.ndarray:
        self.count += base.shape[0] * left.shape[1] * right.shape[1]
        return self.inner.weights_factored(base, left, right)


class Tracker:
    """Markerless tracking of one person from synchronised cameras.

    Parameters
    ----------
    cameras : sequence of tracker.camera.Camera
        At the footage's resolution, in the order of the frames passed to :meth:`process`.
    config : TrackerConfig
    rng : numpy.random.Generator
        The only source of randomness (filters, no other draws).
    height_m : float
        The resident's height; scales the body model when ``body`` is not given.
    backgrounds : sequence of ndarray or None, optional
        Empty-scene images per camera (uint8 BGR). Without them, static segmentation falls back
        to the adaptive ``mog2`` mode learned from the footage.
    body : tracker.body.BodyModel, optional
    likelihood : optional
        A likelihood over ``cameras`` scaled to ``config.likelihood_size`` (default:
        :class:`tracker.likelihood.SilhouetteLikelihood`); must offer ``set_silhouettes``,
        ``weights`` and, for the blob choice, ``render_mask``.
    """

    def __init__(
        self,
        cameras: Sequence,
        config: TrackerConfig | None = None,
        *,
        rng: np.random.Generator,
        height_m: float = 1.70,
        backgrounds: Sequence[np.ndarray | None] | None = None,
        body=None,
        likelihood=None,
    ) -> None:
        self.config = config or TrackerConfig()
        c = self.config
        if not cameras:
            raise ValueError("at least one camera is needed")
        self.cameras = list(cameras)
        w, h = c.likelihood_size
        self.lik_cameras = [cam.scaled(w, h) for cam in self.cameras]
        #: Girth estimated at the first initialisation when the tracker builds the body model
        #: and the likelihood itself (config.init.girths).
        self._estimate_girth = body is None and likelihood is None
        self._girth_bodies: dict[float, object] = {}
        self._girth_scores: dict[float, float] = {}
        if body is None:
            from tracker.body import BodyModel

            body = BodyModel(height_m=height_m)
        self.body = body
        if likelihood is None:
            from tracker.likelihood import SilhouetteLikelihood

            likelihood = SilhouetteLikelihood(body, self.lik_cameras)
        self.likelihood = likelihood
        self._lik = _CountingLikelihood(likelihood)
        #: The colour cue (config.appearance), attached to the likelihood; None when off.
        self.colour = None
        if c.appearance.enabled and hasattr(likelihood, "appearance"):
            from tracker.appearance import ColourCue

            self.colour = ColourCue(
                [cam.scaled(*c.appearance.size) for cam in self.cameras], c.appearance
            )
            likelihood.appearance = self.colour
        self.limits = c.joint_limits().arrays()
        self.rng = rng
        self.filter: Filter = make_filter(c.filter, c, rng=rng, limits=self.limits)
        bgs = list(backgrounds) if backgrounds is not None else [None] * len(self.cameras)
        if len(bgs) != len(self.cameras):
            raise ValueError(f"{len(bgs)} background images for {len(self.cameras)} cameras")
        seg_cfg = c.segmentation.model_copy(update={"output_size": (w, h)})
        self.segmenters: list[Segmenter] = []
        for bg in bgs:
            sc = seg_cfg
            if bg is None and sc.mode == "static":
                sc = sc.model_copy(update={"mode": "mog2"})
            self.segmenters.append(Segmenter(sc, bg))
        if any(bg is None for bg in bgs) and seg_cfg.mode == "static":
            log.info("no background image for some cameras: learning the background (mog2)")
        self.dt_default = 1.0 / float(self.cameras[0].fps)
        import numba

        #: numba threads for the large batches (the others run on one thread).
        self.threads = numba.get_num_threads()
        # track state
        self.prev_pose: np.ndarray | None = None
        #: Key points (19, 3) of the previous estimate (the leg-identity reference).
        self._prev_joints: np.ndarray | None = None
        self.prev_time: float | None = None
        self.velocity_xy = np.zeros(2)
        self.low_count = 0
        self.need_init = True
        # (time, x, y of the estimate, x, y of the silhouettes' floor point) of recent frames
        self._path: list[tuple[float, float, float, float, float]] = []
        self._floor_now = np.full(2, np.nan)
        self._heading_checked_until = -np.inf
        self._girth_frames_left = c.init.girth_frames
        self._masks: list[np.ndarray] = []
        self._tracked_frames = 0
        #: The initial search's settings with re-detection's number of refined candidates.
        self._redetect_config = c.model_copy(
            update={"init": c.init.model_copy(update={"refine_best": c.redetect.refine_best})}
        )
        if self._estimate_girth:
            self._girth_bodies[self.body.girth] = self.body

    # -- public -----------------------------------------------------------------------------
    @property
    def filter_name(self) -> str:
        return self.filter.name

    def segment(self, frames: Sequence[np.ndarray]) -> list[Segmentation]:
        """Segment one synchronised set of frames (one per camera)."""
        if len(frames) != len(self.segmenters):
            raise ValueError(f"{len(frames)} frames for {len(self.segmenters)} cameras")
        return [s.apply(f) for s, f in zip(self.segmenters, frames, strict=True)]

    def process(self, frame_index: int, time_s: float, frames: Sequence[np.ndarray]) -> FrameResult:
        """Track one time step from the raw frames of every camera."""
        return self.process_segmentations(frame_index, time_s, self.segment(frames), frames)

    def process_segmentations(
        self,
        frame_index: int,
        time_s: float,
        segs: Sequence[Segmentation],
        frames: Sequence[np.ndarray] | None = None,
    ) -> FrameResult:
        """Track one time step from already segmented frames (one per camera).

        ``frames`` (the raw BGR frames) feed the colour cue (``config.appearance``); without
        them it does not score this time step.
        """
        with _single_thread():  # small batches; the large ones ask for every thread
            return self._process(frame_index, time_s, segs, frames)

    def _process(
        self,
        frame_index: int,
        time_s: float,
        segs: Sequence[Segmentation],
        frames: Sequence[np.ndarray] | None = None,
    ) -> FrameResult:
        self._lik.count = 0
        notes: list[str] = []
        if all(s.empty for s in segs):
            return self._no_pose(frame_index, time_s, NOBODY_IN_VIEW)
        segs = [self._choose_blobs(i, s, notes) for i, s in enumerate(segs)]
        masks = [s.mask for s in segs]
        if sum(int(m.sum()) for m in masks) < self.config.min_silhouette_px:
            return self._no_pose(frame_index, time_s, NOBODY_IN_VIEW + " (silhouette too small)")
        self.likelihood.set_silhouettes(masks)
        self._masks = masks
        if self.colour is not None:  # colour cue: this frame's colours
            if frames is None:
                self.colour.clear_frame()
            else:
                same = tuple(self.config.appearance.size) == tuple(self.config.likelihood_size)
                self.colour.set_frame(frames, masks if same else [s.mask_full for s in segs])
        fp = floor_point(self.lik_cameras, masks)
        self._floor_now = np.full(2, np.nan) if fp is None else np.asarray(fp, dtype=np.float64)
        dt = self._dt(time_s)
        if self.need_init:
            status = "initialised" if self.prev_time is None else "reinitialised"
            est = self._initialise(masks, dt)
            if est is None:
                return self._no_pose(frame_index, time_s, NO_FLOOR_POINT)
            notes.append(f"{status} the track (weight {est[1]:.3f})")
            pose, weight = est
        else:
            status = "tracked"
            pose, weight = self._track(dt)
            if weight < self.config.lost_weight:
                self.low_count += 1
                if self.low_count >= self.config.lost_frames:
                    prev_weight = weight
                    re = self._initialise(masks, dt)
                    if re is not None and re[1] > prev_weight:
                        pose, weight = re
                        status = "reinitialised"
                    notes.append(
                        f"track lost ({self.low_count} frames below weight "
                        f"{self.config.lost_weight}): re-initialised, weight {weight:.3f}"
                    )
                    self.low_count = 0
            else:
                self.low_count = 0
            if status == "tracked":
                flipped = self._check_heading(pose, weight, masks, dt, time_s)
                if flipped is not None:
                    pose, weight, note = flipped
                    status = "reinitialised"
                    notes.append(note)
        if self._estimate_girth and len(self.config.init.girths) > 1:
            self._update_girth(pose)
        pose, weight, joints = self._floor_constraint(pose, weight)
        if self.colour is not None:  # colour cue: learn from the estimate
            self._learn_colour(pose)
        self._remember(pose, time_s, dt, continuous=status == "tracked")
        self._prev_joints = joints
        for n in notes:
            log.info("frame %d: %s", frame_index, n)
        return FrameResult(
            frame_index=int(frame_index),
            time_s=float(time_s),
            pose=pose,
            joints=joints,
            weight=float(weight),
            status=status,
            notes=notes,
            evaluations=self._lik.count,
        )

    # -- steps ------------------------------------------------------------------------------
    def _dt(self, time_s: float) -> float:
        if self.prev_time is not None and time_s > self.prev_time:
            return float(time_s - self.prev_time)
        return self.dt_default

    def _learn_colour(self, pose: np.ndarray) -> None:
        """Update the colour cue's part references from the estimate (gated by its silhouette
        weight alone)."""
        from tracker.likelihood import weight_from_counts

        if not self.colour.wants_update():
            return
        counts = self.likelihood.counts(pose[None])
        sil_w = float(weight_from_counts(counts, self.likelihood.measure)[0])
        self.colour.update(self.body, pose, sil_w)

    def _set_body(self, body) -> None:
        self.body = body
        self.likelihood.body = body

    def _girth_body(self, girth: float):
        if girth not in self._girth_bodies:
            self._girth_bodies[girth] = type(self.body)(height_m=self.body.height_m, girth=girth)
        return self._girth_bodies[girth]

    def _update_girth(self, pose: np.ndarray) -> None:
        """Score every girth on this frame's refined particles; keep the best so far.

        Over the first ``init.girth_frames`` frames after the first initialisation, the heaviest
        distinct particles and the estimate are weighed with each girth's body model; the girth
        with the largest sum of best weights is used, then kept for the rest of the footage.
        """
        girths = self.config.init.girths
        f = self.filter
        idx = select_distinct(f.particles, f.weights, 9)
        cand = np.concatenate([pose[None], f.particles[idx]])
        current = self.body
        with _single_thread():
            for g in girths:
                self._set_body(self._girth_body(g))
                w = np.asarray(self._lik.weights(cand), dtype=np.float64)
                self._girth_scores[g] = self._girth_scores.get(g, 0.0) + float(w.max())
        best = max(girths, key=lambda g: self._girth_scores[g])
        self._set_body(self._girth_body(best) if best != current.girth else current)
        self._girth_frames_left -= 1
        if self._girth_frames_left <= 0:
            self._estimate_girth = False
            log.info("body girth %.2f (of %s) fits the silhouettes best", best, girths)

    def _initialise(self, masks: list[np.ndarray], dt: float) -> tuple[np.ndarray, float] | None:
        girths = self.config.init.girths
        estimate = self._estimate_girth and len(girths) > 1 and not self._girth_scores
        best = None
        for g in girths if estimate else (None,):
            if g is not None:
                self._set_body(self._girth_body(g))
            with _numba_threads(self.threads):
                res = initial_search(
                    self._lik,
                    self.body,
                    self.lik_cameras,
                    masks,
                    self.config,
                    limits=self.limits,
                    dt=dt,
                )
            if res is None:
                return None
            if best is None or res.best_weight > best[1].best_weight:
                best = (self.body, res)
        assert best is not None
        body, res = best
        if estimate:
            self._set_body(body)
        self.filter.initialise(res.poses, res.weights)
        with _numba_threads(self.threads):
            est = self.filter.step(self._lik, dt)
        self.need_init = False
        self.low_count = 0
        self.velocity_xy = np.zeros(2)
        if est.weight >= res.best_weight:
            return est.pose, est.weight
        return res.best.copy(), res.best_weight

    def _track(self, dt: float) -> tuple[np.ndarray, float]:
        assert self.prev_pose is not None
        c = self.config
        if c.origin.enabled:
            with _single_thread():
                origin = search_origin(
                    self._lik,
                    self.prev_pose,
                    c.origin,
                    limits=self.limits,
                    dt=dt,
                    reference_dt=c.reference_dt_s,
                    velocity_xy=self.velocity_xy,
                )
            self.filter.set_root(origin.pose[:6])
        with _numba_threads(self.threads):
            est = self.filter.step(self._lik, dt)
        pose, weight = est.pose, est.weight
        ref = self._prev_joints if self.config.leg_swap.continuity_tie > 0 else None
        swapped = self._check_leg_swap(pose, weight, ref, self.config.leg_swap.continuity_tie)
        if swapped is not None:
            pose, weight = swapped
        pose, weight = self._redetect(pose, weight, dt)
        if c.origin.enabled and c.origin.after_filter:
            pose, weight = self._refine_origin(pose, weight, dt)
        if c.refine.enabled:
            pose, weight = self._refine_pose(pose, weight, dt)
        return pose, weight

    def _redetect(self, pose: np.ndarray, weight: float, dt: float) -> tuple[np.ndarray, float]:
        """A reduced initial search at this frame's silhouettes; adopt if clearly heavier."""
        rc = self.config.redetect
        self._tracked_frames += 1
        if not rc.enabled or self._tracked_frames % rc.every_frames:
            return pose, weight
        span = np.radians(rc.span_deg)
        headings = pose[DOF["root_yaw"]] + (
            np.linspace(-span, span, rc.headings) if rc.headings > 1 else np.zeros(1)
        )
        # Batches of a few hundred and of 7 poses: one thread (see _numba_threads).
        with _single_thread():
            res = initial_search(
                self._lik,
                self.body,
                self.lik_cameras,
                self._masks,
                self._redetect_config,
                limits=self.limits,
                dt=dt,
                headings=headings,
            )
        if res is None or not res.best_weight > weight + rc.margin:
            return pose, weight
        self.filter.inject(res.poses[: rc.inject], res.weights[: rc.inject], reset_motion=True)
        log.debug("re-detected: weight %.3f -> %.3f", weight, res.best_weight)
        return res.best.copy(), float(res.best_weight)

    def _refine_pose(self, pose: np.ndarray, weight: float, dt: float) -> tuple[np.ndarray, float]:
        """Local coordinate search of the estimate (:mod:`tracker.refine`); joins the particles."""
        from tracker.refine import refine_top

        with _single_thread():
            res = refine_top(
                self._lik, self.filter, pose, weight, self.config, limits=self.limits, dt=dt
            )
        if not res.weight > weight:
            return pose, weight
        if self.config.refine.inject:
            self.filter.inject(res.pose[None], np.array([res.weight]))
        return res.pose.copy(), float(res.weight)

    def _refine_origin(
        self, pose: np.ndarray, weight: float, dt: float
    ) -> tuple[np.ndarray, float]:
        """Search the origin again holding the filter's new body parts; adopt if heavier."""
        c = self.config
        with _single_thread():
            res = search_origin(
                self._lik,
                pose,
                c.origin.model_copy(update={"levels": c.origin.after_filter_levels}),
                limits=self.limits,
                dt=dt,
                reference_dt=c.reference_dt_s,
                range_scale=c.origin.after_filter_range_scale,
            )
        if not res.weight > weight:
            return pose, weight
        self.filter.inject(res.pose[None], np.array([res.weight]))
        return res.pose.copy(), float(res.weight)

    def _check_leg_swap(
        self, pose: np.ndarray, weight: float, reference: np.ndarray | None, tie: float
    ) -> tuple[np.ndarray, float] | None:
        """Weigh the heaviest particles with their legs exchanged; choose the leg identity.

        Parameters
        ----------
        pose, weight
            The filter's estimate (31,) and its weight.
        reference : ndarray (19, 3) or None
            Key points (metres, world) the feet should stay near: the previous estimate while
            tracking (a stance foot does not slide on the floor), the backwards estimate of
            this frame after a heading flip; None: the heaviest candidate wins.
        tie : float
            Candidates weighing at least ``(1 - tie)`` times the heaviest are ties; among
            them the one whose feet moved least from ``reference`` is chosen.

        Returns
        -------
        (pose, weight) when another candidate than ``pose`` is chosen, else None.
        """
        ls = self.config.leg_swap
        if not ls.enabled:
            return None
        f = self.filter
        idx = select_distinct(f.particles, f.weights, ls.candidates)
        base = f.particles[idx]
        cand = base.copy()
        left, right = list(LEFT_LEG), list(RIGHT_LEG)
        cand[:, left], cand[:, right] = base[:, right], base[:, left]
        f.clamp(cand)
        with _single_thread():
            w = np.asarray(self._lik.weights(cand), dtype=np.float64)
        if reference is None or tie <= 0.0:
            k = int(np.argmax(w))
            if not w[k] > weight:
                return None
            f.inject(cand, w, reset_motion=True)
            log.debug("legs swapped: weight %.3f -> %.3f", weight, w[k])
            return cand[k].copy(), float(w[k])
        allp = np.concatenate([pose[None], base, cand])
        allw = np.concatenate([[weight], f.weights[idx], w])
        k = _continuity_choice(self.body, allp, allw, reference, tie)
        if k == 0:
            return None
        if k > base.shape[0]:
            f.inject(cand, w, reset_motion=True)
        log.debug("leg identity: weight %.3f -> %.3f (candidate %d)", weight, allw[k], k)
        return allp[k].copy(), float(allw[k])

    def _floor_constraint(
        self, pose: np.ndarray, weight: float
    ) -> tuple[np.ndarray, float, np.ndarray]:
        """Move the root height so the body respects the floor (``config.floor``).

        Returns the pose, its weight (re-weighed when moved) and its key points (19, 3). The
        filter's particles get the same root, as after an origin search.
        """
        joints = np.asarray(self.body.forward(pose[None]))[0]
        mode = self.config.floor
        if mode == "off":
            return pose, weight, joints
        low = float(joints[:, 2].min())
        tol = self.config.floor_tolerance_m
        if mode == "above":
            shift = -low if low < -tol else 0.0
        else:  # contact
            shift = -low if abs(low) > tol else 0.0
        if shift == 0.0:
            return pose, weight, joints
        moved = pose.copy()
        moved[DOF["root_z"]] += shift
        self.filter.clamp(moved[None])
        joints = np.asarray(self.body.forward(moved[None]))[0]
        with _single_thread():
            weight = float(np.asarray(self._lik.weights(moved[None]))[0])
        self.filter.set_root(moved[:6])
        return moved, weight, joints

    def _check_heading(
        self, pose: np.ndarray, weight: float, masks: list[np.ndarray], dt: float, time_s: float
    ) -> tuple[np.ndarray, float, str] | None:
        """Re-initialise facing the walking direction when the heading points backwards."""
        hc = self.config.heading_check
        if not hc.enabled:
            return None
        if time_s < self._heading_checked_until:
            return None
        path = np.array([*self._path, self._path_entry(time_s, pose)])
        path = path[path[:, 0] >= time_s - hc.window_s - 1e-9]
        if hc.source == "silhouette":
            path = path[np.isfinite(path[:, 3])][:, [0, 3, 4]]
        else:
            path = path[:, :3]
        if path.shape[0] < hc.min_frames or path[-1, 0] - path[0, 0] < hc.min_span_s - 1e-9:
            return None
        # Least-squares velocity over the window: robust to the jitter of single estimates.
        t = path[:, 0] - path[:, 0].mean()
        v = (t @ (path[:, 1:] - path[:, 1:].mean(axis=0))) / (t @ t)
        if np.hypot(*v) < hc.min_speed_m_s:
            return None
        # A walk, not jitter: the net displacement is most of the distance travelled.
        steps = np.hypot(*np.diff(path[:, 1:], axis=0).T).sum()
        net = float(np.hypot(*(path[-1, 1:] - path[0, 1:])))
        if net < hc.min_straightness * steps:
            return None
        travel = float(np.arctan2(v[1], v[0]))
        off = float(np.degrees(abs(wrap_angle(pose[DOF["root_yaw"]] - travel))))
        if off <= hc.max_angle_deg:
            return None
        span = np.radians(hc.span_deg)
        with _numba_threads(self.threads):
            res = initial_search(
                self._lik,
                self.body,
                self.lik_cameras,
                masks,
                self.config,
                limits=self.limits,
                dt=dt,
                floor_xy=pose[:2].copy(),
                headings=travel + np.linspace(-span, span, 9),
            )
        self._path = []
        self._heading_checked_until = time_s + hc.cooldown_s
        if res is None or res.best_weight < hc.accept_ratio * weight:
            return None
        if hc.leg_choice == "refine":
            new, w = self._flip_modes(pose, res.poses, res.weights, dt, hc)
        else:
            poses, weights = res.poses, res.weights
            if hc.leg_choice == "feet":
                poses, weights = self._feet_continuity(pose, poses, weights, hc)
            self.filter.initialise(poses, weights)
            with _numba_threads(self.threads):
                est = self.filter.step(self._lik, dt)
            new, w = (est.pose, est.weight) if est.weight >= weights[0] else (poses[0], weights[0])
        return (
            new.copy(),
            float(w),
            f"heading {np.degrees(pose[DOF['root_yaw']]):.0f} deg was {off:.0f} deg off the "
            f"walking direction: re-initialised facing {np.degrees(travel):.0f} deg "
            f"(weight {w:.3f}, was {weight:.3f})",
        )

    def _feet_continuity(
        self, backwards: np.ndarray, poses: np.ndarray, weights: np.ndarray, hc
    ) -> tuple[np.ndarray, np.ndarray]:
        """Of the flip's candidates, keep those with the feet where the backwards estimate had them.

        The backwards estimate fitted the silhouettes: its feet are where the image shows feet,
        only the heading (and so the leg assignment and gait phase) was wrong. Among the
        distinct candidates weighing at least ``1 - hc.feet_tie`` times the heaviest, the
        one whose ankles, heels and toes are nearest the backwards estimate's is chosen; the
        filter is seeded with it and the candidates whose feet are within
        ``hc.feet_margin_m`` as near (heaviest first).

        Returns
        -------
        poses : ndarray (K, 31), weights : ndarray (K,)
            The chosen candidate first.
        """
        ref = np.asarray(self.body.forward(backwards[None]))[0]
        d = _feet_distance(self.body, poses, ref)
        idx = select_distinct(poses, weights, hc.feet_candidates)
        k = idx[_tie_choice(weights[idx], d[idx], hc.feet_tie)]
        keep = np.flatnonzero(d <= d[k] + hc.feet_margin_m)
        keep = np.concatenate([[k], keep[keep != k]])
        return poses[keep], weights[keep]

    def _flip_modes(
        self, backwards: np.ndarray, poses: np.ndarray, weights: np.ndarray, dt: float, hc
    ) -> tuple[np.ndarray, float]:
        """Refine both leg assignments of a flip's candidates; seed the filter with the winner.

        Facing the other way, the silhouettes fit two leg assignments (which leg is in front,
        gait phase) about equally, and the coarse grid's best often has the wrong one; a filter
        seeded with every candidate refines only the heaviest's mode. The candidates are split
        in two modes: feet (ankles, heels, toes; mean distance) within ``hc.mode_separation_m``
        of the heaviest candidate's, and the rest. Each mode seeds the filter for one step; the
        heavier refined estimate wins. Within ``hc.continuity_tie`` (relative) of each other,
        the one whose feet are nearer the backwards estimate's wins (the silhouettes placed the
        feet, only the heading was wrong). The filter is left seeded with the winning mode.

        Parameters
        ----------
        backwards : ndarray (31,)
            This frame's estimate facing backwards.
        poses, weights : ndarray (K, 31), (K,)
            The flip's initial-search candidates, heaviest first.

        Returns
        -------
        pose : ndarray (31,), weight : float
        """
        first = np.asarray(self.body.forward(poses[:1]))[0]
        apart = _feet_distance(self.body, poses, first) > hc.mode_separation_m
        modes = [np.flatnonzero(~apart), np.flatnonzero(apart)]
        modes = [m for m in modes if m.size]
        results = []
        for m in modes:
            self.filter.initialise(poses[m], weights[m])
            with _numba_threads(self.threads):
                est = self.filter.step(self._lik, dt)
            if est.weight >= weights[m[0]]:
                results.append((est.pose.copy(), float(est.weight)))
            else:
                results.append((poses[m[0]].copy(), float(weights[m[0]])))
        rw = np.array([r[1] for r in results])
        cand = np.stack([r[0] for r in results])
        ref = np.asarray(self.body.forward(backwards[None]))[0]
        k = _continuity_choice(self.body, cand, rw, ref, hc.continuity_tie)
        m = modes[k]
        self.filter.initialise(
            np.concatenate([cand[k][None], poses[m]]), np.concatenate([[rw[k]], weights[m]])
        )
        if len(modes) > 1:
            log.debug("flip: leg modes weigh %s after refinement, chose %d", np.round(rw, 3), k)
        return cand[k], float(rw[k])

    def _path_entry(self, time_s: float, pose: np.ndarray) -> tuple[float, ...]:
        f = self._floor_now
        return (float(time_s), float(pose[0]), float(pose[1]), float(f[0]), float(f[1]))

    def _remember(self, pose: np.ndarray, time_s: float, dt: float, *, continuous: bool) -> None:
        if continuous:
            self._path = [*self._path, self._path_entry(time_s, pose)][-64:]
        else:
            self._path = [self._path_entry(time_s, pose)]
        if not continuous or self.prev_pose is None:
            self.velocity_xy = np.zeros(2)
        else:
            v = (pose[[DOF["root_x"], DOF["root_y"]]] - self.prev_pose[[0, 1]]) / dt
            speed = float(np.hypot(*v))
            if speed > _MAX_SPEED_M_S:
                v *= _MAX_SPEED_M_S / speed
            self.velocity_xy = v
        self.prev_pose = pose.copy()
        self.prev_time = float(time_s)

    def _no_pose(self, frame_index: int, time_s: float, reason: str) -> FrameResult:
        self.need_init = True
        self.prev_pose = None
        self._prev_joints = None
        self.prev_time = float(time_s)
        self.velocity_xy = np.zeros(2)
        self.low_count = 0
        self._path = []
        log.debug("frame %d: no pose (%s)", frame_index, reason)
        return FrameResult(
            frame_index=int(frame_index),
            time_s=float(time_s),
            pose=None,
            joints=None,
            weight=0.0,
            status="no_pose",
            reason=reason,
            evaluations=self._lik.count,
        )

    def _choose_blobs(self, cam: int, seg: Segmentation, notes: list[str]) -> Segmentation:
        """Keep the blob(s) consistent with the track when a camera sees several."""
        if len(seg.blobs) <= 1:
            return seg
        name = self.cameras[cam].name
        if self.prev_pose is None or self.need_init:
            main = seg.blobs[0]  # largest first
            x0, _, bw, _ = main.bbox
            keep = [
                b
                for b in seg.blobs
                if b is main or (b.bbox[0] < x0 + bw and b.bbox[0] + b.bbox[2] > x0)
            ]
            why = "largest (no track yet)"
        else:
            pred = self._predicted_mask(cam, seg)
            areas = np.array([b.area for b in seg.blobs], dtype=np.float64)
            overlap = np.bincount(seg.labels[pred].ravel(), minlength=seg.labels.max() + 1)
            ov = np.array([overlap[b.label] for b in seg.blobs], dtype=np.float64)
            if ov.max() > 0:
                best = int(np.argmax(ov))
                why = f"largest overlap with the track's model ({int(ov[best])} px)"
            else:
                centre = self.cameras[cam].project(self._predicted_sacrum())
                d = [np.hypot(*(np.asarray(b.centroid) - centre)) for b in seg.blobs]
                d = np.nan_to_num(np.asarray(d), nan=np.inf)
                best = int(np.argmin(d))
                why = f"closest to the track ({d[best]:.0f} px)"
            keep = [b for i, b in enumerate(seg.blobs) if i == best or ov[i] >= 0.3 * areas[i]]
            main = seg.blobs[best]
        cx, cy = main.centroid
        notes.append(
            f"camera {name}: {len(seg.blobs)} blobs, following the one at ({cx:.0f}, {cy:.0f}) "
            f"[{why}]"
            + (f" with {len(keep) - 1} part(s) inside the model" if len(keep) > 1 else "")
        )
        return keep_blobs(seg, keep)

    def _predicted_sacrum(self) -> np.ndarray:
        assert self.prev_pose is not None
        p = self.prev_pose.copy()
        p[[0, 1]] += self.velocity_xy * self.dt_default
        return np.asarray(self.body.forward(p[None]))[0, SACRUM]

    def _predicted_mask(self, cam: int, seg: Segmentation) -> np.ndarray:
        """The previous estimate's model mask, at the segmentation's full resolution (bool)."""
        assert self.prev_pose is not None
        p = self.prev_pose.copy()
        p[[0, 1]] += self.velocity_xy * self.dt_default
        small = np.asarray(self.likelihood.render_mask(p, cam), dtype=np.uint8)
        h, w = seg.labels.shape
        return cv2.resize(small, (w, h), interpolation=cv2.INTER_NEAREST).astype(bool)


__all__ = ["NOBODY_IN_VIEW", "FrameResult", "Tracker", "N_DOF"]
