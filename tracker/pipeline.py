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
   particles over ``init.girth_frames`` frames and kept fixed (when the tracker built the model);
   so are the part girths and, with two cameras or more, the leg length (``init.leg_lengths``)
   over the first tracked frames.
4. Otherwise the **origin search** (:mod:`tracker.origin`) moves the root, holding the previous
   body-part configuration, then the **filter** (IPF, APF or Condensation) updates the body parts,
   then (``config.arms``, opt-in, two cameras or more) each arm is searched on a grid
   (:mod:`tracker.arms`) and (``origin.after_filter``) the origin is searched again holding the
   new legs.
5. **Leg-swap check**: the heaviest particles are weighed with their legs exchanged; a heavier
   one becomes the estimate and joins the particle set (``config.leg_swap``).
   **Re-detection** (``config.redetect``): a reduced initial search around this frame's
   silhouette floor point and the current heading; a clearly heavier result becomes the
   estimate (a track that slid off the person is caught before it is lost).
6. **Heading check**: when the origin moves faster than a walking threshold in a direction far
   from the heading (the front/back ambiguity of silhouettes), re-initialise facing the walking
   direction if that weighs about as much (``config.heading_check``); with no walk to follow,
   when the 2D detector's face has been behind the heading for half a second, facing the other
   way (``heading_check.facing_s``).
7. **Lost track**: best weight below ``lost_weight`` for ``lost_frames`` frames in a row ->
   re-initialise on that frame (kept if it weighs more than the filter's estimate).

8. **Backward pass** (``config.revise``): once a new track has settled, a copy of the tracker
   tracks its first frames again backwards in time from the settled state; the revised results
   ride on a later frame's result (``FrameResult.revisions``; ``tracker.revision.ResultQueue``
   puts them in order).

Memory does not grow with the length of the footage: the tracker keeps one particle set, the
previous estimate and, for the backward pass, at most ``revise.max_s`` of low-resolution
silhouettes. Every random draw comes from the injected generator.
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from gaitwatch.conventions import (
    L_ANKLE,
    L_HEEL,
    L_TOE,
    N_KEYPOINTS,
    R_ANKLE,
    R_HEEL,
    R_TOE,
    SACRUM,
)
from tracker.arms import search_arms
from tracker.body import GIRTH_PARTS
from tracker.config import InitConfig, TrackerConfig
from tracker.detector2d import silhouette_box
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, SEATED_DOFS, wrap_angle
from tracker.filters import Filter, make_filter, select_distinct
from tracker.init import body_configurations, camera_floor_point, floor_point, initial_search
from tracker.keypoints2d import LEFT_POINTS, RIGHT_POINTS, KeypointHeatmaps
from tracker.leglabels import exchange_legs, label_vote, labels_differ
from tracker.occlusion import OcclusionLearner, background_regions
from tracker.origin import search_origin
from tracker.raster import numba_threads, prefer_passive_openmp
from tracker.segmentation import Segmentation, Segmenter, downscale_mask, keep_blobs
from tracker.smoothing import FEET, RESTART_STATUSES
from tracker.swing import swing_direction
from tracker.triangulation import fuse_along_rays, fuse_detections

log = logging.getLogger(__name__)
#: Seconds of the silhouettes' floor points kept (the seated mode's speed window is shorter).
FLOOR_HISTORY_S = 10.0
#: Indices of the DOFs the seated mode widens (tracker.dof.SEATED_DOFS).
_SEATED_IDX = np.array([DOF[n] for n in SEATED_DOFS])

#: Idle numba (OpenMP) threads sleep rather than spin; must be decided before numba starts its
#: threads (the track command sets their number after importing this module).
_PASSIVE_OPENMP = prefer_passive_openmp()

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
        Likelihood evaluations spent on this frame (origin search, filter, initialisation; for
        a revised result, also its share of the backward pass).
    revisions : list of FrameResult
        Results that replace those already returned for earlier frames (``config.revise``: the
        backward pass run when the track has settled), oldest first; usually empty.
    leg_length : float
        Relative leg length of the body model ``pose`` refers to (``BodyModel.leg_length``;
        ``joints`` is that body's forward kinematics of ``pose``).
    legs_seen : bool
        False when in no camera the estimate's feet are seen: furniture (the occluded pixels,
        given or learned) or the image's lower edge may cut the legs off
        (:func:`_legs_cut`), or the feet project well below the silhouette
        (:func:`_feet_below_silhouette`: hidden by furniture not yet learned, or misplaced).
        The feet are then the model's guess; the output stage's balance step counts the
        frame's offset as none.
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
    revisions: list[FrameResult] = field(default_factory=list)
    leg_length: float = 1.0
    legs_seen: bool = True

    @property
    def has_pose(self) -> bool:
        return self.pose is not None


@dataclass(frozen=True)
class Detection:
    """The built-in 2D detector's output on one time step's silhouettes, found before the step
    is tracked (:meth:`Tracker.detect_ahead`), so that ``gaitwatch track`` can run the
    detector of the next step in a second thread while the tracker works on this one.

    ``segs`` are the silhouettes it was found on (the very objects
    :meth:`Tracker.process_segmentations` is then given). ``ran`` is False when the step has
    nothing to detect (nobody in view, the silhouettes too small, no detector): the tracker
    would not run the detector on it either. ``keypoints``, ``heatmaps`` and ``people`` are
    what :meth:`Tracker.detect_keypoints` returned and what the detector kept
    (``last_heatmaps``, ``last_people``) right after.
    """

    segs: tuple[Segmentation, ...]
    ran: bool
    keypoints: list[np.ndarray | None] | None = None
    heatmaps: list | None = None
    people: list | None = None

    @classmethod
    def found(cls, segs: Sequence[Segmentation], keypoints, detector) -> Detection:
        """The detection ``detector`` just made on ``segs`` (its points ``keypoints``)."""
        return cls(tuple(segs), True, keypoints, detector.last_heatmaps, detector.last_people)

    @staticmethod
    def check_step(frames: Sequence, segs: Sequence, n_cameras: int) -> None:
        """Refuse a step to detect ahead that is not one frame and one segmentation per
        camera."""
        if len(frames) != n_cameras or len(segs) != n_cameras:
            raise ValueError(
                f"{len(frames)} frames and {len(segs)} segmentations for {n_cameras} cameras"
            )

    def check_use(self, segs: Sequence[Segmentation], keypoints) -> None:
        """Refuse to track with this detection a step given key points or other
        silhouettes."""
        if keypoints is not None:
            raise ValueError("key points given and a detection made ahead: give one")
        if len(self.segs) != len(segs) or any(
            a is not b for a, b in zip(self.segs, segs, strict=True)
        ):
            raise ValueError("the detection made ahead is of other silhouettes")


@dataclass
class _Observation:
    """What the estimate of one time step is made from, kept for the backward pass: the
    silhouettes at the likelihood resolution (blobs chosen) and the colour cue's frame."""

    frame_index: int
    time_s: float
    masks: list[np.ndarray]
    colour: tuple[np.ndarray, np.ndarray] | None = None
    edges: list | None = None  # the edge cue's frame_state
    keypoints: tuple | None = None  # the 2D key-point cue's frame_state


def _numba_threads(n: int):
    """Run the numba kernels inside the block on ``n`` threads (restored afterwards).

    Small batches (the origin search weighs 12 batches of 7 poses per frame; forward kinematics
    of single poses) lose more to thread synchronisation than they gain, and on a busy machine
    each parallel call can wait milliseconds for the other thread to be scheduled; only the
    large batches (the filter's thousands of particles, the grids of the initial search and of
    re-detection) use every thread. The idle threads sleep rather than spin
    (:func:`tracker.raster.prefer_passive_openmp`): spinning ones were scheduled late on a busy
    machine, which had made 2 threads slower than 1. See :func:`tracker.raster.numba_threads`.
    """
    return numba_threads(n)


def _single_thread():
    return _numba_threads(1)


def _capped_velocity(pose: np.ndarray, prev: np.ndarray, dt: float) -> np.ndarray:
    """Root velocity (m/s, (2,)) from ``prev`` to ``pose`` over ``dt``, capped at a run."""
    v = (pose[:2] - prev[:2]) / dt
    speed = float(np.hypot(*v))
    if speed > _MAX_SPEED_M_S:
        v *= _MAX_SPEED_M_S / speed
    return v


_FEET_POINTS = [L_ANKLE, R_ANKLE, L_HEEL, R_HEEL, L_TOE, R_TOE]


def part_factors(init: InitConfig, n_cameras: int) -> tuple[float, ...]:
    """The part factors tried (``init.part_girths``): with two cameras or more, none above
    ``init.part_girth_max_multi_camera``; the smallest is kept when all are above."""
    cap = init.part_girth_max_multi_camera
    factors = tuple(init.part_girths)
    if n_cameras < 2 or cap is None:
        return factors
    kept = tuple(g for g in factors if g <= cap)
    return kept or (min(factors),)


def _path_fit(path: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Least-squares velocity of a path of (time, x, y) rows, in the rows' time, with the
    residual and total sums of squares of its positions about that linear motion."""
    t = path[:, 0] - path[:, 0].mean()
    xy = path[:, 1:] - path[:, 1:].mean(axis=0)
    v = (t @ xy) / (t @ t)
    return v, float(((xy - np.outer(t, v)) ** 2).sum()), float((xy**2).sum())


def _inside(point: tuple[float, float], box: tuple[float, float, float, float] | None) -> bool:
    """Whether ``point`` (x, y) lies inside ``box`` (x0, y0, x1, y1); False without a box."""
    return box is not None and box[0] <= point[0] <= box[2] and box[1] <= point[1] <= box[3]


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


@dataclass
class _Hypothesis:
    """The opposite heading hypothesis, tracked alongside the main one from an initialisation
    until the walking direction (or the weight) decides (``config.init.both_headings``)."""

    filter: Filter
    pose: np.ndarray
    weight: float
    joints: np.ndarray
    velocity_xy: np.ndarray
    path: list = field(default_factory=list)
    age_s: float = 0.0


class _CountingLikelihood:
    """Counts the poses weighed (for the per-frame evaluation figures)."""

    def __init__(self, inner) -> None:
        self.inner = inner
        self.count = 0
        if hasattr(inner, "weights_factored"):
            self.weights_factored = self._factored
        if hasattr(inner, "weights_moving"):
            self.weights_moving = self._moving

    @property
    def body(self):
        """The inner likelihood's body model (None without one)."""
        return getattr(self.inner, "body", None)

    def weights(self, poses: np.ndarray) -> np.ndarray:
        self.count += poses.shape[0]
        return self.inner.weights(poses)

    def _factored(self, base, left, right) -> np.ndarray:
        self.count += base.shape[0] * left.shape[1] * right.shape[1]
        return self.inner.weights_factored(base, left, right)

    def _moving(self, base, poses, capsules) -> np.ndarray:
        self.count += poses.shape[0]
        return self.inner.weights_moving(base, poses, capsules)


def frames_at_rate(frames: int, reference_dt: float, dt: float) -> int:
    """``frames`` stated at the reference frame interval (20 Hz), as a count of frames of
    interval ``dt`` covering the same time (halves rounded up; at least 1): 10 frames at 20 Hz
    are 15 at 30 Hz, 13 at 25 Hz and 6 at 12.5 Hz."""
    if not (dt > 0 and reference_dt > 0):
        raise ValueError(f"frame intervals must be positive, not {reference_dt} and {dt}")
    return max(1, math.floor(frames * reference_dt / dt + 0.5))


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
    occluders : sequence of ndarray or None, optional
        Per camera, the image pixels behind static furniture that can hide the person (bool or
        uint8, non-zero = occluder; any resolution with the camera's aspect ratio, usually the
        frame's), or None. Model pixels there count neither for nor against a pose, in the
        silhouette weight and the colour cue (docs/tracker.md, "Furniture in front of the walk").
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
        occluders: Sequence[np.ndarray | None] | None = None,
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
        self._girth_bodies: dict[tuple[float, ...], object] = {}
        self._girth_scores: dict[float, float] = {}
        #: Part factors (config.init.part_girths; with two cameras or more none above
        #: part_girth_max_multi_camera), estimated over the first tracked frames.
        self.part_factors = part_factors(c.init, len(cameras))
        self._estimate_parts = self._estimate_girth and (
            len(self.part_factors) > 1 or len(c.init.hems) > 0
        )
        self._part_scores: dict[tuple[str, float], float] = {}
        self._hem_scores: dict[tuple[float, float] | None, float] = {}
        #: Relative leg length (config.init.leg_lengths), estimated over the first tracked frames.
        self._estimate_legs = (
            self._estimate_girth
            and len(c.init.leg_lengths) > 1
            and len(cameras) >= c.init.leg_length_min_cameras
        )
        self._leg_scores: dict[float, float] = {}
        if body is None:
            from tracker.body import BodyModel

            girths, parts, legs = c.init.girths, self.part_factors, c.init.leg_lengths
            body = BodyModel(
                height_m=height_m,
                girth=girths[0] if len(girths) == 1 else 1.0,
                part_girths=dict.fromkeys(GIRTH_PARTS, parts[0]) if len(parts) == 1 else None,
                leg_length=legs[0] if len(legs) == 1 else 1.0,
            )
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
        #: The edge cue (config.edges), attached to the likelihood; None when off.
        self.edge_cue = None
        arms_only = c.edges.scope != "all"  # the cue ranks arm searches only: are there any?
        searched = c.arms.enabled and len(self.cameras) >= c.arms.min_cameras
        if c.edges.enabled and hasattr(likelihood, "edges") and (searched or not arms_only):
            from tracker.edges import EdgeCue

            self.edge_cue = EdgeCue([cam.scaled(*c.edges.size) for cam in self.cameras], c.edges)
            likelihood.edges = self.edge_cue
        #: The 2D key-point cue (config.keypoints), attached to the likelihood; None when off.
        self.keypoint_cue = None
        if c.keypoints.enabled and hasattr(likelihood, "keypoints"):
            from tracker.keypoints2d import KeypointCue

            self.keypoint_cue = KeypointCue(self.cameras, c.keypoints)
            likelihood.keypoints = self.keypoint_cue
        #: The built-in 2D pose detector (config.keypoints.detector) run on the frames that
        #: come without key points; None when the cue is off, its detector is "none" or the
        #: detector cannot run here (a warning says so).
        self.detector = self._make_detector() if self.keypoint_cue is not None else None
        #: The search of the legs' refinement on the silhouettes (config.leg_refine); None when
        #: it does not run: off, too few cameras or no key-point cue to leave out.
        lr = c.leg_refine
        self._leg_refine = (
            lr.refine_config()
            if lr.enabled and len(self.cameras) >= lr.min_cameras and self.keypoint_cue is not None
            else None
        )
        if c.collision.enabled and hasattr(likelihood, "collision"):
            from tracker.collision import CollisionPrior

            likelihood.collision = CollisionPrior(
                tolerance_m=c.collision.tolerance_m, softness_m=c.collision.softness_m
            )
        self.limits = c.joint_limits().arrays()
        #: The profile's limits and the seated mode's (config.seated; None when the profile
        #: already allows sitting or the mode is off). ``self.limits`` is one of the two.
        self._base_limits = self.limits
        seated = c.seated_limits().arrays() if c.seated.enabled else None
        if seated is not None and all(
            np.array_equal(a, b) for a, b in zip(seated, self.limits, strict=True)
        ):
            seated = None
        self._seated_limits = seated
        self._seated = False
        self._upright_frames = 0
        #: (body, limits, the seated configurations) of the last seated search.
        self._seated_configs: tuple[object, object, np.ndarray] | None = None
        self.rng = rng
        #: The settings the filters are built from: the IPF's annealing stage is off below
        #: ``ipf.anneal.min_cameras`` cameras (its groups go back to the grid).
        self._filter_config = c
        if c.ipf.anneal_groups and len(self.cameras) < c.ipf.anneal.min_cameras:
            off = c.ipf.anneal.model_copy(update={"share": 0.0})
            self._filter_config = c.model_copy(
                update={"ipf": c.ipf.model_copy(update={"anneal": off})}
            )
        self.filter: Filter = make_filter(
            c.filter, self._filter_config, rng=rng, limits=self.limits
        )
        #: The trials' smaller filter (``redetect.trial_share`` < 1), built when first needed.
        self._trial_filter: Filter | None = None
        bgs = list(backgrounds) if backgrounds is not None else [None] * len(self.cameras)
        if len(bgs) != len(self.cameras):
            raise ValueError(f"{len(bgs)} background images for {len(self.cameras)} cameras")
        seg_cfg = c.segmentation.model_copy(update={"output_size": (w, h)})
        keep_shadow = c.keypoints.gives_back_shadows(len(self.cameras))
        self.segmenters: list[Segmenter] = []
        for bg in bgs:
            sc = seg_cfg
            if bg is None and sc.mode == "static":
                sc = sc.model_copy(update={"mode": "mog2"})
            self.segmenters.append(Segmenter(sc, bg, keep_shadow=keep_shadow))
        if any(bg is None for bg in bgs) and seg_cfg.mode == "static":
            log.info("no background image for some cameras: learning the background (mog2)")
        #: Per camera, the occluders learned (config.occlusion) and given (likelihood size).
        self.occlusion: list[OcclusionLearner | None] = [
            None
            if bg is None or not c.occlusion.learn
            else OcclusionLearner(
                background_regions(bg, (w, h)), c.occlusion, lcam, self.body.height_m
            )
            for bg, lcam in zip(bgs, self.lik_cameras, strict=True)
        ]
        self._given_occ: list[np.ndarray | None] = [None] * len(self.cameras)
        #: The occluded pixels handed to the likelihood (given | learned), per camera.
        self._occ_maps: list[np.ndarray | None] = [None] * len(self.cameras)
        if occluders is not None:
            self.set_occluders(occluders)
        self.dt_default = 1.0 / float(self.cameras[0].fps)
        import numba

        #: numba threads for the large batches (the others run on one thread).
        self.threads = numba.get_num_threads()
        if self.threads > 1 and not _PASSIVE_OPENMP and numba.threading_layer() == "omp":
            log.info(
                "numba's OpenMP threads spin while idle (OMP_WAIT_POLICY is not PASSIVE): "
                "on a busy machine %d threads can be slower than one",
                self.threads,
            )
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
        #: Per camera, whether furniture or the image's edge may cut this frame's legs off.
        self._legs_cut_now: list[bool] = [False] * len(self.cameras)
        self._time_now = np.nan
        #: (time, x, y) of the silhouettes' floor point over the last seconds: a measurement,
        #: kept across re-initialisations of the estimate, cleared when nobody is in view.
        self._floor_hist: list[tuple[float, float, float]] = []
        self._heading_checked_until = -np.inf
        #: (time, evidence) of recent tracked frames: the detected face against the estimate's
        #: heading (heading_check.facing_s, KeypointCue.facing).
        self._facing: list[tuple[float, float]] = []
        #: Per recent frame (time, sacrum, left ankle, right ankle) for the swing check.
        self._feet: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []
        #: The opposite heading hypothesis after an initialisation (init.both_headings).
        self._alt: _Hypothesis | None = None
        # The shape windows are counted in frames at 20 Hz (config.reference_dt_s): the same
        # time at the cameras' frame rate, so faster footage scores its shape over as much of
        # the walk (docs/tracker.md, "Session 29").
        self._girth_frames_left = frames_at_rate(
            c.init.girth_frames, c.reference_dt_s, self.dt_default
        )
        self._part_frames_left = frames_at_rate(
            c.init.part_girth_frames, c.reference_dt_s, self.dt_default
        )
        self._leg_frames_left = frames_at_rate(
            c.init.leg_length_frames, c.reference_dt_s, self.dt_default
        )
        self._masks: list[np.ndarray] = []
        self._tracked_frames = 0
        #: Weights of the estimates at the last re-detection points; skipped frames in a row.
        self._redetect_weights: list[float] = []
        self._redetect_skipped = 0
        #: (body, limits, their body configurations) of the last re-detection.
        self._redetect_configs: tuple[object, object, np.ndarray] | None = None
        #: The initial search's settings with re-detection's number of refined candidates and
        #: flexed-walk phases.
        redetect_init = {"refine_best": c.redetect.refine_best}
        if c.redetect.flexed_phases is not None:
            redetect_init["flexed_phases"] = c.redetect.flexed_phases
        self._redetect_config = c.model_copy(
            update={"init": c.init.model_copy(update=redetect_init)}
        )
        #: The initial search's settings for the seated search (config.seated.refine_best).
        self._seated_config = c.model_copy(
            update={"init": c.init.model_copy(update={"refine_best": c.seated.refine_best})}
        )
        if self._estimate_girth:
            self._girth_bodies[self.body.shape_key] = self.body
        #: Backward pass (config.revise): the frames of the track not yet settled, with their
        #: forward results; tracked frames since the last (re-)initialisation.
        self._revising = c.revise.enabled
        self._window: list[tuple[_Observation, FrameResult]] = []
        self._settled = 0
        self._last_obs: _Observation | None = None
        #: -1 in the backward pass's copy: time runs backwards, so the walking direction is
        #: the opposite of the path's.
        self._time_sign = 1.0

    # -- public -----------------------------------------------------------------------------
    @property
    def filter_name(self) -> str:
        return self.filter.name

    def set_background(self, camera: int, image: np.ndarray) -> None:
        """Subtract ``image`` (the empty scene) from camera ``camera``'s next frames instead of
        its current background (static mode; the adaptive modes are re-seeded by it). What was
        learned from the first background (furniture regions) stays."""
        self.segmenters[camera].set_background(image)

    def segment(self, frames: Sequence[np.ndarray]) -> list[Segmentation]:
        """Segment one synchronised set of frames (one per camera)."""
        if len(frames) != len(self.segmenters):
            raise ValueError(f"{len(frames)} frames for {len(self.segmenters)} cameras")
        return [s.apply(f) for s, f in zip(self.segmenters, frames, strict=True)]

    def process(
        self,
        frame_index: int,
        time_s: float,
        frames: Sequence[np.ndarray],
        keypoints: Sequence[np.ndarray | None] | None = None,
    ) -> FrameResult:
        """Track one time step from the raw frames of every camera (``keypoints``: see
        :meth:`process_segmentations`)."""
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
        heatmaps: Sequence[KeypointHeatmaps | None] | None = None,
        detection: Detection | None = None,
    ) -> FrameResult:
        """Track one time step from already segmented frames (one per camera).

        ``frames`` (the raw BGR frames) feed the colour cue (``config.appearance``); without
        them it does not score this time step. ``keypoints`` (per camera ``(19, 3)`` detected
        ``u, v, confidence`` in the camera's image pixels, or None) feed the 2D key-point cue
        (``config.keypoints``, :mod:`tracker.keypoints2d`); without them it does not score
        this time step, unless the built-in detector finds them in ``frames``. ``heatmaps``
        (per camera :class:`tracker.keypoints2d.KeypointHeatmaps` or None) go with given
        ``keypoints``; the built-in detector's come with its points. ``detection``, from
        :meth:`detect_ahead` on these very ``segs`` (and ``frames``), stands for the built-in
        detector's run on this step; the result is the same as without it.
        """
        if detection is not None:
            detection.check_use(segs, keypoints)
        with _single_thread():  # small batches; the large ones ask for every thread
            self._last_obs = None
            res = self._process(frame_index, time_s, segs, frames, keypoints, heatmaps, detection)
            if self._revising:
                res.revisions = self._revise(res)
            return res

    @property
    def detects_keypoints(self) -> bool:
        """Whether the built-in 2D pose detector runs on frames given without key points (the
        key-point cue is on, its detector is not "none" and can run here)."""
        return self.detector is not None

    @property
    def evaluations_per_step(self) -> int:
        """The filter's likelihood evaluations per frame (:attr:`Filter.evaluations_per_step`)."""
        return int(self.filter.evaluations_per_step)

    @property
    def pending_from(self) -> int | None:
        """The oldest frame whose result a later frame may still revise (``config.revise``),
        or None: results of frames before it are final."""
        return self._window[0][0].frame_index if self._window else None

    def set_occluders(self, occluders: Sequence[np.ndarray | None] | None) -> None:
        """Pixels behind known static occluders, per camera (see the class docstring); None
        clears them. Takes effect from the next frame."""
        if occluders is None:
            small = None
        else:
            occ = list(occluders)
            if len(occ) != len(self.cameras):
                raise ValueError(f"{len(occ)} occluder masks for {len(self.cameras)} cameras")
            small = []
            for cam, lcam, o in zip(self.cameras, self.lik_cameras, occ, strict=True):
                if o is None:
                    small.append(None)
                    continue
                o = np.asarray(o)
                if o.ndim != 2:
                    raise ValueError(
                        f"occluder mask for camera {cam.name!r} must be one channel (H, W), "
                        f"got shape {o.shape}"
                    )
                h, w = o.shape
                if abs(w * cam.height - h * cam.width) > max(w, h):
                    raise ValueError(
                        f"occluder mask for camera {cam.name!r} is {w}x{h}, not the camera's "
                        f"aspect ratio ({cam.width}x{cam.height})"
                    )
                small.append(downscale_mask(o != 0, (lcam.width, lcam.height)))
        if not hasattr(self.likelihood, "set_occlusion"):
            raise ValueError("this likelihood does not take occluders (no set_occlusion)")
        self._given_occ = small or [None] * len(self.cameras)
        self._apply_occlusion()

    def _apply_occlusion(self) -> None:
        """Hand the occluded pixels (given | learned) to the likelihood and the colour cue."""
        maps: list[np.ndarray | None] = []
        for given, learner in zip(self._given_occ, self.occlusion, strict=True):
            learned = None if learner is None or not learner.occluders.any() else learner.mask
            if given is None or learned is None:
                maps.append(given if learned is None else learned)
            else:
                maps.append(given | learned)
        self.likelihood.set_occlusion(maps)
        self._occ_maps = maps
        if self.colour is not None:
            self.colour.set_occlusion(maps)

    def _make_detector(self):
        """The built-in 2D pose detector of config.keypoints, or None (see ``self.detector``)."""
        from tracker.detector2d import DetectorUnavailableError, make_detector

        try:
            return make_detector(self.config.keypoints, len(self.cameras))
        except DetectorUnavailableError as err:
            log.warning("%s: the 2D key-point cue scores only key points given to process()", err)
            return None

    def detect_keypoints(
        self, frames: Sequence[np.ndarray], segs: Sequence[Segmentation]
    ) -> list[np.ndarray | None] | None:
        """The built-in detector's key points per camera (``(19, 3)`` or None) of the person in
        each silhouette (the chosen blobs give the crop), in the cameras' image pixels; None
        without a detector."""
        if self.detector is None:
            return None
        if len(frames) != len(self.cameras):
            raise ValueError(f"{len(frames)} frames for {len(self.cameras)} cameras")
        sizes = [(cam.width, cam.height) for cam in self.cameras]
        return self.detector.detect_frames(frames, segs, sizes)

    def detect_ahead(
        self, frames: Sequence[np.ndarray], segs: Sequence[Segmentation]
    ) -> Detection | None:
        """The built-in detector run now on a time step that :meth:`process_segmentations`
        will track later, given the same ``frames`` and ``segs`` and the returned
        :class:`Detection`; None when the crop depends on the blob the track will follow (a
        camera sees several blobs): the step's detection then waits for it.

        The steps must come in their order, each detected ahead or tracked before the next is
        detected ahead: the detector's crop follows the person from step to step. Nothing but
        the detector's own state (that crop, its last output) is read or changed, so it may run
        in another thread while the tracker works on the step before."""
        Detection.check_step(frames, segs, len(self.cameras))
        segs = tuple(segs)
        if self.keypoint_cue is None or self.detector is None or all(s.empty for s in segs):
            return Detection(segs, ran=False)
        if any(len(s.blobs) > 1 for s in segs):
            return None  # the track's blob choice (_choose_blobs) decides the crop
        if sum(int(s.mask.sum()) for s in segs) < self.config.min_silhouette_px:
            return Detection(segs, ran=False)
        return Detection.found(segs, self.detect_keypoints(frames, segs), self.detector)

    def give_back_shadows(
        self, segs: Sequence[Segmentation], people: list | None
    ) -> list[Segmentation]:
        """``segs`` with the pixels their shadow test removed given back where the person
        segmentation of the built-in detector covers them (``people``: a :class:`Detection`'s;
        ``config.keypoints.shadow_given_back``, :meth:`tracker.segmentation.Segmenter.
        with_shadow_given_back`): a camera's own segmentation where the detector found nobody
        or kept no person segmentation."""
        det = self.detector
        if people is None:
            return list(segs)
        if len(people) != len(segs):
            raise ValueError(f"{len(segs)} segmentations for {len(people)} detections")
        threshold = self.config.keypoints.person_threshold
        out: list[Segmentation] = []
        for sg, seg, found in zip(self.segmenters, segs, people, strict=True):
            if found is None or seg.shadow is None or seg.foreground is None:
                out.append(seg)
                continue
            crop, logits = found
            person = det.person_pixels(crop, logits, seg.labels.shape, threshold=threshold)
            out.append(seg if person is None else sg.with_shadow_given_back(seg, person))
        return out

    def _cut(self, segs: Sequence[Segmentation]) -> list[bool]:
        """Per camera, whether furniture (the occluded pixels, given or learned) or the image's
        lower edge may cut the person's legs off (:func:`_legs_cut`; False without a
        silhouette)."""
        return [
            not seg.empty and _legs_cut(silhouette_box(seg.blobs), occ, cam)
            for cam, seg, occ in zip(self.cameras, segs, self._occ_maps, strict=True)
        ]

    def _legs_seen(
        self,
        keypoints: Sequence[np.ndarray | None] | None,
        segs: Sequence[Segmentation],
        cut: Sequence[bool] | None = None,
    ) -> list[np.ndarray | None] | None:
        """The detected key points without the legs' of a camera where furniture (the occluded
        pixels, given or learned) or the image's lower edge may cut the legs off
        (:func:`_legs_cut`): a detector guesses hidden legs and squeezes them into what it
        sees (measured on a rendered walk behind a table: knees and feet 15-30 % of the
        person's height off, with visibilities of 0.6-0.98, on the silhouette and clear of the
        table). ``cut``: :meth:`_cut` of ``segs`` when already known."""
        if keypoints is None:
            return None
        kps = list(keypoints)
        if len(kps) != len(segs):
            return kps  # a wrong count: KeypointCue.set_frame says what is wrong
        out: list[np.ndarray | None] = []
        for c, d in zip(self._cut(segs) if cut is None else cut, kps, strict=True):
            if d is not None and c:
                d = np.array(d, dtype=np.float64)
                if d.shape == (N_KEYPOINTS, 3):  # else KeypointCue.set_frame says what is wrong
                    d[list(LEG_POINTS)] = np.nan
            out.append(d)
        return out

    def _learn_occluders(self, masks: Sequence[np.ndarray], notes: list[str]) -> None:
        """Add this frame's silhouettes to the occluder evidence (config.occlusion)."""
        changed = False
        for learner, m in zip(self.occlusion, masks, strict=True):
            if learner is not None:
                changed |= learner.update(m)
        if changed:
            self._apply_occlusion()
            px = [0 if o is None else int(o.mask.sum()) for o in self.occlusion]
            notes.append("occluders learned: " + ", ".join(f"{p} px" for p in px) + " per camera")

    def _process(
        self,
        frame_index: int,
        time_s: float,
        segs: Sequence[Segmentation],
        frames: Sequence[np.ndarray] | None = None,
        keypoints: Sequence[np.ndarray | None] | None = None,
        heatmaps: Sequence[KeypointHeatmaps | None] | None = None,
        detection: Detection | None = None,
    ) -> FrameResult:
        self._lik.count = 0
        notes: list[str] = []
        if all(s.empty for s in segs):
            return self._no_pose(frame_index, time_s, NOBODY_IN_VIEW)
        chose: list[str] = []  # the blob choices' notes, made again if the silhouettes change
        chosen = [self._choose_blobs(i, s, chose) for i, s in enumerate(segs)]
        if sum(int(s.mask.sum()) for s in chosen) < self.config.min_silhouette_px:
            return self._no_pose(frame_index, time_s, NOBODY_IN_VIEW + " (silhouette too small)")
        detected = (
            self.keypoint_cue is not None
            and keypoints is None
            and frames is not None
            and self.detector is not None
        )
        if detected:  # only after its own detection: the last one's people are stale
            if detection is None:
                keypoints = self.detect_keypoints(frames, chosen)
                detection = Detection.found(chosen, keypoints, self.detector)
            elif not (
                detection.ran and all(c is s for c, s in zip(chosen, detection.segs, strict=True))
            ):  # detect_ahead and this choice disagree: a bug, not bad input
                raise RuntimeError("the detection made ahead does not match this step")
            keypoints, heatmaps = detection.keypoints, detection.heatmaps
            given_back = self.give_back_shadows(segs, detection.people)
            if any(g is not s for g, s in zip(given_back, segs, strict=True)):
                chose = []
                chosen = [self._choose_blobs(i, s, chose) for i, s in enumerate(given_back)]
        notes += chose
        segs = chosen
        masks = [s.mask for s in segs]
        self._legs_cut_now = self._cut(segs)
        if self.colour is not None:  # colour cue: this frame's colours
            if frames is None:
                self.colour.clear_frame()
            else:
                same = tuple(self.config.appearance.size) == tuple(self.config.likelihood_size)
                self.colour.set_frame(frames, masks if same else [s.mask_full for s in segs])
        if self.edge_cue is not None:  # edge cue: this frame's edges
            if frames is None:
                self.edge_cue.clear_frame()
            else:
                self.edge_cue.set_frame(frames, [s.mask_full for s in segs])
        if self.keypoint_cue is not None:  # 2D key-point cue: this frame's detections
            legs = self._legs_seen(keypoints, segs, self._legs_cut_now)
            self.keypoint_cue.set_frame(legs, heatmaps)
        if any(o is not None for o in self.occlusion):
            self._learn_occluders(masks, notes)
        obs = _Observation(int(frame_index), float(time_s), masks)
        res = self._estimate(obs, notes)
        self._last_obs = obs
        return res

    def _estimate(self, obs: _Observation, notes: list[str]) -> FrameResult:
        """Track one time step from its silhouettes (blobs chosen; the colour cue's frame set)."""
        frame_index, time_s, masks = obs.frame_index, obs.time_s, obs.masks
        self.likelihood.set_silhouettes(masks)
        self._masks = masks
        fp = floor_point(self.lik_cameras, masks)
        self._floor_now = np.full(2, np.nan) if fp is None else np.asarray(fp, dtype=np.float64)
        t = self._time_now = float(time_s)
        self._floor_hist = [e for e in self._floor_hist if t - FLOOR_HISTORY_S < e[0] < t]
        if fp is not None:
            self._floor_hist.append((t, float(fp[0]), float(fp[1])))
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
                    else:
                        self._alt = None
                    notes.append(
                        f"track lost ({self.low_count} frames below weight "
                        f"{self.config.lost_weight}): re-initialised, weight {weight:.3f}"
                    )
                    self.low_count = 0
            else:
                self.low_count = 0
            if status == "tracked" and self._alt is None:
                flipped = self._check_heading(pose, weight, masks, dt, time_s)
                if flipped is not None:
                    pose, weight, note, continuous = flipped
                    if not continuous:
                        status = "reinitialised"
                    notes.append(note)
        if self._estimate_girth and len(self.config.init.girths) > 1:
            self._update_girth(pose)
        if self._estimate_parts and status == "tracked":
            self._update_part_girths(pose)
        if self._estimate_legs and status == "tracked":
            pose, weight = self._update_leg_length(pose, weight, dt)
        pose, weight, joints = self._floor_constraint(pose, weight)
        if self._alt is not None:
            if status == "tracked":
                pose, weight, joints = self._track_alternative(
                    pose, weight, joints, dt, time_s, notes
                )
            elif status == "initialised" or status == "reinitialised":
                pose, weight, joints = self._start_alternative(pose, weight, joints, time_s)
        if self.colour is not None:  # colour cue: learn from the estimate
            self._learn_colour(pose)
        if self.edge_cue is not None:  # edge cue: the estimates' typical score
            self.edge_cue.update(self.body, pose)
        if self.keypoint_cue is not None:  # 2D key-point cue: the estimates' typical score
            self.keypoint_cue.update(self.body, pose)
        self._remember(pose, time_s, dt, continuous=status == "tracked")
        self._remember_facing(joints, time_s, continuous=status == "tracked")
        self._remember_feet(joints, time_s, continuous=status == "tracked")
        self._prev_joints = joints
        pose, joints = self._output_arms(pose, joints)
        joints = self._fuse_detections(joints)
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
            leg_length=float(self.body.leg_length),
            legs_seen=self._feet_seen(joints),
        )

    def _feet_seen(self, joints: np.ndarray) -> bool:
        """Whether some camera sees this frame's feet (:attr:`FrameResult.legs_seen`): its
        silhouette is not cut off by furniture or the image's edge, and the estimate's feet do
        not project well below it."""
        return any(
            not cut and not _feet_below_silhouette(joints, cam, mask)
            for cut, cam, mask in zip(
                self._legs_cut_now, self.lik_cameras, self._masks, strict=True
            )
        )

    # -- backward pass ---------------------------------------------------------------------
    def _revise(self, res: FrameResult) -> list[FrameResult]:
        """Keep this frame for the backward pass; run the pass once the track has settled.

        The window opens at an initialisation or re-initialisation (a heading flip included)
        and closes without a pass when a frame has no pose. A re-initialisation inside it
        restarts the count of settled frames but not the window: the frames before a flip are
        the ones facing the wrong way.
        """
        rc = self.config.revise
        obs = self._last_obs
        if obs is None or not res.has_pose:
            self._window = []
            return []
        restart = res.status in RESTART_STATUSES
        if not self._window and not restart:
            return []
        self._settled = 0 if restart else self._settled + 1
        if self.colour is not None:  # this frame's colours (estimating does not change them)
            obs.colour = self.colour.frame_state()
        if self.edge_cue is not None:
            obs.edges = self.edge_cue.frame_state()
        if self.keypoint_cue is not None:
            obs.keypoints = self.keypoint_cue.frame_state()
        self._window.append((obs, res))
        fps = 1.0 / self.dt_default
        max_frames = max(2, int(round(rc.max_s * fps)))
        if len(self._window) > max_frames:  # the oldest are final as tracked
            self._window = self._window[-max_frames:]
        if self._settled < max(1, int(round(rc.settle_s * fps))):
            return []
        window, self._window = self._window, []
        revised = self._backward_pass(window)
        if revised:
            note = (
                f"revised frames {revised[0].frame_index}-{revised[-1].frame_index}: tracked "
                "backwards from this settled frame"
            )
            res.notes.append(note)
            log.info("frame %d: %s", res.frame_index, note)
        return revised

    def _backward_copy(self) -> Tracker:
        """A copy of this tracker, now, that tracks backwards in time: motion turned around (the
        filter's, the origin's velocity, and the walking direction of the heading check and turn
        following: in reversed time the person walks backwards), nothing estimated about the
        body. Cameras, body models, segmenters and the generator are shared, not copied."""
        shared = (
            self.segmenters,
            self.cameras,
            self.lik_cameras,
            self.body,
            self._girth_bodies,
            self._redetect_configs,
            self.rng,
            self.limits,
            self._base_limits,
            self._seated_limits,
            self.detector,
        )
        memo: dict[int, object] = {id(x): x for x in shared}
        memo[id(self._window)] = []
        b = copy.deepcopy(self, memo)
        b._revising = False
        b._estimate_girth = b._estimate_parts = b._estimate_legs = False
        b._alt = None
        b._path = []
        b._facing = []
        b._feet = []
        b._floor_hist = []  # mirrored time
        b._heading_checked_until = -np.inf
        b._time_sign = -self._time_sign
        b.velocity_xy = -self.velocity_xy
        b.filter.reverse_motion()
        return b

    def _backward_pass(self, window: list[tuple[_Observation, FrameResult]]) -> list[FrameResult]:
        """Track ``window[:-1]`` backwards from the state after ``window[-1]`` (this frame).

        Time is mirrored about this frame so that it still increases. Stops at a frame without
        a pose; the frames before keep their forward results. Returns the revised results,
        oldest first: the oldest carries a re-initialisation status (the output is not
        continuous with the frame before it), as does the frame after one where the backward
        track re-initialised (a heading flip, a lost track); the others are "tracked".
        """
        if len(window) < 2:
            return []
        b = self._backward_copy()
        t0 = window[-1][0].time_s
        out: list[FrameResult] = []
        # Per revised frame: label_vote when the passes' legs disagree, else None; and the
        # frames whose backward result is not continuous with the one before (a restart).
        votes: list[int | None] = []
        breaks: set[int] = set()
        voting = self._label_votes_needed() > 0
        oldest = window[-1][1]  # the forward result of the oldest frame revised
        for obs, fwd in reversed(window[:-1]):
            b._lik.count = 0
            if b.colour is not None:
                b.colour.restore_frame(obs.colour)
            if b.edge_cue is not None:
                b.edge_cue.restore_frame(obs.edges)
            if b.keypoint_cue is not None:
                b.keypoint_cue.restore_frame(obs.keypoints)
            mirrored = _Observation(obs.frame_index, 2.0 * t0 - obs.time_s, obs.masks)
            r = b._estimate(mirrored, [])
            if not r.has_pose:
                break
            if r.status in RESTART_STATUSES and out:  # not continuous with the later frame
                out[-1].status = "reinitialised"
                breaks.add(len(out))
            if voting and fwd.has_pose and labels_differ(r.joints, fwd.joints):
                points = None if b.keypoint_cue is None else b.keypoint_cue.points
                votes.append(label_vote(r.joints, points, self.cameras))
            else:
                votes.append(None)
            out.append(
                FrameResult(
                    frame_index=fwd.frame_index,
                    time_s=fwd.time_s,
                    pose=r.pose,
                    joints=r.joints,
                    weight=r.weight,
                    status="tracked",
                    notes=list(fwd.notes),
                    evaluations=fwd.evaluations + b._lik.count,
                    legs_seen=fwd.legs_seen,
                )
            )
            oldest = fwd
        if out:
            restart = oldest.status in RESTART_STATUSES
            out[-1].status = oldest.status if restart else "reinitialised"
            self._relabel_revised(out, votes, breaks)
        return out[::-1]

    def _label_votes_needed(self) -> int:
        """The net votes a run of disagreeing frames needs (``revise.label_votes``, frames at
        20 Hz, :func:`frames_at_rate`); 0 when the votes do not decide (off, or more than
        ``revise.label_votes_max_cameras`` cameras)."""
        rc = self.config.revise
        if rc.label_votes <= 0 or len(self.cameras) > rc.label_votes_max_cameras:
            return 0
        return frames_at_rate(rc.label_votes, self.config.reference_dt_s, self.dt_default)

    def _relabel_revised(
        self, out: list[FrameResult], votes: list[int | None], breaks: set[int]
    ) -> None:
        """Exchange the legs' key points of the backward pass's results ``out`` (newest first)
        over each run of consecutive frames where its legs are the forward pass's exchanged
        (``votes[i]`` not None; a run ends at a restart, ``breaks``), when the detections favour
        the forward pass's labels on ``revise.label_votes`` more of the run's frames than not
        (the sum of ``votes``; frames at 20 Hz, :func:`frames_at_rate`), with at most
        ``revise.label_votes_max_cameras`` cameras. In place; the poses (DOFs) stay the
        backward pass's."""
        need = self._label_votes_needed()
        if need <= 0:
            return
        runs: list[list[int]] = []
        for i, v in enumerate(votes):
            if v is None:
                continue
            if runs and runs[-1][-1] == i - 1 and i not in breaks:
                runs[-1].append(i)
            else:
                runs.append([i])
        for run in runs:
            total = sum(int(votes[i] or 0) for i in run)
            if total < need:
                continue
            for i in run:
                out[i].joints = exchange_legs(out[i].joints)
                out[i].notes.append(
                    "legs exchanged to the forward pass's labels (the detections favour them "
                    f"by {total} frames over {len(run)})"
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

    def _girth_body(
        self,
        girth: float | None = None,
        parts: dict[str, float] | None = None,
        base=None,
        leg_length: float | None = None,
        hem="keep",
    ):
        """``base`` (default: the current body) with another girth, part factors, leg length
        and/or hem (cached)."""
        body = (base or self.body).with_shape(girth, parts, leg_length, hem)
        return self._girth_bodies.setdefault(body.shape_key, body)

    def _shape_score(self, body, candidates: np.ndarray) -> float:
        """Best weight of ``candidates`` (poses, n x 31) with ``body``'s volumes; the body is
        left in use (the callers set the one they keep)."""
        self._set_body(body)
        return float(np.max(np.asarray(self._lik.weights(candidates), dtype=np.float64)))

    def _shape_candidates(self, pose: np.ndarray) -> np.ndarray:
        """The estimate and the filter's 9 heaviest distinct particles (girths are scored on)."""
        f = self.filter
        idx = select_distinct(f.particles, f.weights, 9)
        return np.concatenate([pose[None], f.particles[idx]])

    def _update_part_girths(self, pose: np.ndarray) -> None:
        """Score every part factor on this frame's particles; each part keeps its best so far.

        Over the first ``init.part_girth_frames`` tracked frames, the estimate and the heaviest
        distinct particles are weighed with each body part's volumes scaled by each factor of
        :attr:`part_factors` (the other parts as they are); a part's score for a factor is the
        sum over frames of the best weight. After each frame every part takes its best-scoring
        factor; after the last the factors are fixed. The hems of ``init.hems`` and no hem are
        scored the same way; the best hem is used while its score beats no hem's by
        ``init.hem_margin``.
        """
        factors = self.part_factors
        cand = self._shape_candidates(pose)
        current = self.body
        best: dict[str, float] = {}
        hem = current.hem
        with _single_thread():
            if len(factors) > 1:
                for part in GIRTH_PARTS:
                    for g in factors:
                        body = self._girth_body(parts={part: g}, base=current)
                        w = self._shape_score(body, cand)
                        self._part_scores[(part, g)] = self._part_scores.get((part, g), 0.0) + w
                    best[part] = max(factors, key=lambda g, p=part: self._part_scores[(p, g)])
            hems = self.config.init.hems
            if hems:
                options = [None, *(tuple(h) for h in hems)]
                for h in options:
                    w = self._shape_score(self._girth_body(base=current, hem=h), cand)
                    self._hem_scores[h] = self._hem_scores.get(h, 0.0) + w
                hem = max(options, key=lambda h: self._hem_scores[h])
                if (
                    self._hem_scores[hem]
                    <= (1.0 + self.config.init.hem_margin) * self._hem_scores[None]
                ):
                    hem = None
        self._set_body(self._girth_body(parts=best, base=current, hem=hem))
        self._part_frames_left -= 1
        if self._part_frames_left <= 0:
            self._estimate_parts = False
            if not self._estimate_girth:  # both fixed: keep only the body in use
                self._girth_bodies = {self.body.shape_key: self.body}
            log.info("body part girths %s, hem %s fit the silhouettes best", best, hem)

    def _update_leg_length(
        self, pose: np.ndarray, weight: float, dt: float
    ) -> tuple[np.ndarray, float]:
        """Score every relative leg length on this frame; keep the best so far.

        Over the first ``init.leg_length_frames`` tracked frames, the estimate and the heaviest
        distinct particles are moved onto each leg length of ``init.leg_lengths`` (the same
        standing height: longer legs, shorter trunk; each pose raised or lowered so that its
        lowest sole point stays where it was) and refitted by one filter step with that body
        (the angles that suit one leg length do not suit another). A length's score is the sum
        over frames of its refitted weight; the body takes the best-scoring length after each
        frame, with its refitted estimate and particles, and keeps it after the last.

        Returns
        -------
        (pose, weight) on the body now in use.
        """
        lengths = self.config.init.leg_lengths
        cand = self._shape_candidates(pose)
        current = self.body
        z = DOF["root_z"]
        soles = [L_HEEL, R_HEEL, L_TOE, R_TOE]
        floor = np.asarray(current.forward(cand))[:, soles, 2].min(axis=1)
        trials: dict[float, tuple[np.ndarray, float, dict]] = {}
        for s in lengths:
            body = self._girth_body(base=current, leg_length=s)
            moved = cand.copy()
            moved[:, z] += floor - np.asarray(body.forward(cand))[:, soles, 2].min(axis=1)
            self._set_body(body)
            with _single_thread():
                w = np.asarray(self._lik.weights(moved), dtype=np.float64)
            order = np.argsort(-w)
            new, nw, saved = self._trial_steps(moved[order], w[order], dt, 1)
            trials[s] = (new, nw, dict(self.filter.__dict__))
            self.filter.__dict__.update(saved)
            self._leg_scores[s] = self._leg_scores.get(s, 0.0) + nw
        best = max(lengths, key=lambda s: self._leg_scores[s])
        self._set_body(self._girth_body(base=current, leg_length=best))
        if best != current.leg_length:
            pose, weight, state = trials[best]
            self.filter.__dict__.update(state)
        self._leg_frames_left -= 1
        if self._leg_frames_left <= 0:
            self._estimate_legs = False
            log.info("relative leg length %.2f (of %s) fits the silhouettes best", best, lengths)
        return pose, float(weight)

    def _update_girth(self, pose: np.ndarray) -> None:
        """Score every girth on this frame's refined particles; keep the best so far.

        Over the first ``init.girth_frames`` frames after the first initialisation, the heaviest
        distinct particles and the estimate are weighed with each girth's body model; the girth
        with the largest sum of best weights is used, then kept for the rest of the footage.
        """
        girths = self.config.init.girths
        cand = self._shape_candidates(pose)
        current = self.body
        with _single_thread():
            for g in girths:
                w = self._shape_score(self._girth_body(g), cand)
                self._girth_scores[g] = self._girth_scores.get(g, 0.0) + w
        best = max(girths, key=lambda g: self._girth_scores[g])
        self._set_body(self._girth_body(best) if best != current.girth else current)
        self._girth_frames_left -= 1
        if self._girth_frames_left <= 0:
            self._estimate_girth = False
            log.info("body girth %.2f (of %s) fits the silhouettes best", best, girths)

    def _initialise(self, masks: list[np.ndarray], dt: float) -> tuple[np.ndarray, float] | None:
        girths = self.config.init.girths
        estimate = self._estimate_girth and len(girths) > 1 and not self._girth_scores
        cue = self.keypoint_cue  # the first search sees the key-point cue too (`initial`)
        provisional = cue is not None and cue.begin_initial()
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
                if provisional:
                    cue.typical = None
                return None
            if best is None or res.best_weight > best[1].best_weight:
                best = (self.body, res)
        assert best is not None
        body, res = best
        if estimate:
            self._set_body(body)
        if provisional:
            res = replace(res, weights=res.weights * cue.end_initial(self.body, res.best))
        self.need_init = False
        self.low_count = 0
        self.velocity_xy = np.zeros(2)
        self._alt = None
        poses, weights = res.poses, res.weights
        ic = self.config.init
        if ic.both_headings:
            yaw = DOF["root_yaw"]
            back = np.abs(wrap_angle(poses[:, yaw] - poses[0, yaw])) > np.pi / 2
            if back.any() and weights[back][0] >= ic.both_headings_ratio * weights[0]:
                alt = make_filter(
                    self.config.filter, self._filter_config, rng=self.rng, limits=self.limits
                )
                apose, aweight = self._seed_and_step(alt, poses[back], weights[back], dt)
                self._alt = _Hypothesis(
                    filter=alt,
                    pose=apose,
                    weight=aweight,
                    joints=np.empty((0, 3)),
                    velocity_xy=np.zeros(2),
                )
                poses, weights = poses[~back], weights[~back]
        return self._seed_and_step(self.filter, poses, weights, dt)

    def _seed_and_step(
        self, filt: Filter, poses: np.ndarray, weights: np.ndarray, dt: float, steps: int = 1
    ) -> tuple[np.ndarray, float]:
        """Seed ``filt`` with candidates (heaviest first) and step it ``steps`` times on this
        frame's silhouettes; the heaviest of the best candidate and the steps' estimates (an
        estimate wins a tie)."""
        filt.initialise(poses, weights)
        best, w = poses[0].copy(), float(weights[0])
        for _ in range(steps):
            with _numba_threads(self.threads):
                est = filt.step(self._lik, dt)
            if est.weight >= w:
                best, w = est.pose.copy(), float(est.weight)
        return best, w

    # -- the opposite heading hypothesis (init.both_headings) --------------------------------
    def _swap_alternative(self) -> None:
        """Exchange the main track's state with the alternative hypothesis's."""
        a = self._alt
        assert a is not None
        self.filter, a.filter = a.filter, self.filter
        a.velocity_xy, self.velocity_xy = self.velocity_xy, a.velocity_xy
        if self.prev_pose is not None:
            self.prev_pose, a.pose = a.pose, self.prev_pose
        self._prev_joints, a.joints = a.joints, self._prev_joints
        self._path, a.path = a.path, self._path

    def _start_alternative(
        self, pose: np.ndarray, weight: float, joints: np.ndarray, time_s: float
    ) -> tuple[np.ndarray, float, np.ndarray]:
        """After an initialisation: floor-constrain the alternative; the heavier one leads."""
        a = self._alt
        assert a is not None
        filt, self.filter = self.filter, a.filter
        apose, aweight, ajoints = self._floor_constraint(a.pose, a.weight)
        self.filter = filt
        a.pose, a.weight, a.joints = apose, aweight, ajoints
        if aweight > weight:
            self.filter, a.filter = a.filter, self.filter
            a.pose, a.weight, a.joints = pose, weight, joints
            pose, weight, joints = apose, aweight, ajoints
        a.path = [self._path_entry(time_s, a.pose)]
        return pose, weight, joints

    def _track_alternative(
        self,
        pose: np.ndarray,
        weight: float,
        joints: np.ndarray,
        dt: float,
        time_s: float,
        notes: list[str],
    ) -> tuple[np.ndarray, float, np.ndarray]:
        """Track the opposite heading hypothesis for this frame; decide between the two.

        The walking direction (``heading_check`` source and criteria) decides when it is known:
        the hypothesis facing it more closely stays. Before, the heavier one is the estimate;
        an alternative weighing less than ``1 - init.both_headings_drop`` times the estimate,
        or older than ``init.both_headings_max_s``, is dropped.
        """
        a = self._alt
        assert a is not None
        ic, hc = self.config.init, self.config.heading_check
        prev_alt = a.pose
        self._swap_alternative()
        try:
            apose, aweight = self._track(dt)
            apose, aweight, ajoints = self._floor_constraint(apose, aweight)
        finally:
            self._swap_alternative()
        v = _capped_velocity(apose, prev_alt, dt)
        a.age_s += dt
        yaw = DOF["root_yaw"]
        # Each hypothesis has its own path (their origins differ by centimetres, as much as
        # one frame's walk); the main one's gives the walking direction.
        travel = self._walking_direction(pose, time_s, hc.source, hc.window_s)
        a.path = [*a.path, self._path_entry(time_s, apose)][-64:]
        take_alt, drop, why = aweight > weight, False, ""
        if travel is not None:
            off = abs(wrap_angle(pose[yaw] - travel))
            aoff = abs(wrap_angle(apose[yaw] - travel))
            take_alt, drop = bool(aoff < off), True
            why = f"the walking direction ({np.degrees(travel):.0f} deg) decided"
        elif min(aweight, weight) < (1.0 - ic.both_headings_drop) * max(aweight, weight):
            drop = True
            why = "the weight decided"
        elif a.age_s > ic.both_headings_max_s:
            drop = True
            why = f"undecided after {a.age_s:.1f} s: the heavier kept"
        if take_alt:
            # The alternative leads: exchange the states, this frame's results included.
            assert self.prev_pose is not None
            mv = _capped_velocity(pose, self.prev_pose, dt)
            entry = self._path_entry(time_s, pose)
            self._swap_alternative()
            self._path = self._path[:-1]  # _remember appends this frame's entry
            a.path = [*a.path, entry][-64:]
            a.pose, a.weight, a.joints, a.velocity_xy = pose, weight, joints, mv
            pose, weight, joints = apose, aweight, ajoints
        else:
            a.pose, a.weight, a.joints, a.velocity_xy = apose, aweight, ajoints, v
        if drop:
            notes.append(
                f"heading {np.degrees(pose[yaw]):.0f} deg kept, "
                f"{np.degrees(a.pose[yaw]):.0f} deg dropped: {why}"
            )
            self._alt = None
        return pose, weight, joints

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
        pose, weight = self._refine_origin(pose, weight, dt)
        if c.refine.enabled:
            pose, weight = self._refine_pose(pose, weight, dt)
        pose, weight = self._refine_legs(pose, weight)
        self._update_seated(pose)
        return pose, weight

    def _redetect(self, pose: np.ndarray, weight: float, dt: float) -> tuple[np.ndarray, float]:
        """A reduced initial search at this frame's silhouettes; adopt if clearly heavier.

        Skipped (``redetect.stable_ratio``) while the estimate weighs about as much as the
        heaviest of the last ``stable_frames`` estimates, at most ``max_skipped`` frames in a
        row: a search that is not adopted leaves the estimate and the particles as they are, and
        the searches that are adopted follow a loss of weight (a track sliding off the person).
        """
        rc = self.config.redetect
        self._tracked_frames += 1
        if not rc.enabled or self._tracked_frames % rc.every_frames:
            return pose, weight
        recent = self._redetect_weights[-rc.stable_frames :]
        if (
            rc.stable_ratio > 0
            and self._redetect_skipped < rc.max_skipped
            and len(recent) == rc.stable_frames
            and weight >= rc.stable_ratio * max(recent)
        ):
            # High and stable: a re-detection that is not adopted changes nothing.
            self._redetect_skipped += 1
            self._redetect_weights = [*recent, weight]
            return pose, weight
        self._redetect_skipped = 0
        pose, weight = self._redetect_search(pose, weight, dt)
        pose, weight = self._seated_search(pose, weight, dt)
        self._redetect_weights = [*recent, weight]
        return pose, weight

    # -- seated mode (config.seated) ----------------------------------------------------------
    def _set_limits(self, limits: tuple[np.ndarray, np.ndarray]) -> None:
        """Search within ``limits`` from now on (the filters' particles are clamped to them)."""
        self.limits = limits
        self.filter.set_limits(limits)
        if self._alt is not None:
            self._alt.filter.set_limits(limits)

    def _seated_search(
        self, pose: np.ndarray, weight: float, dt: float
    ) -> tuple[np.ndarray, float]:
        """Weigh the seated configurations around this frame's floor point under the seated
        limits; when the best outweighs the estimate by ``seated.margin`` (as it is, or after
        re-detection's trial filter steps from its best candidates), switch to those limits and
        adopt it. Only while the person is lower than a standing body of the stature
        (:meth:`_lower_than_standing`) and stands still: the silhouettes' floor point moves
        slower than ``seated.max_floor_speed_m_s`` (:meth:`_floor_speed`; not before the floor
        points since someone came into view are enough to tell)."""
        sc = self.config.seated
        if self._seated_limits is None or self._seated or not np.all(np.isfinite(self._floor_now)):
            return pose, weight
        if not self._lower_than_standing(sc.lower_fraction):
            return pose, weight
        speed = self._floor_speed(sc.speed_window_s)
        if speed is None or speed > sc.max_floor_speed_m_s:
            log.debug("seated search skipped: the floor point's speed is %s m/s", speed)
            return pose, weight
        headings = pose[DOF["root_yaw"]] + np.arange(sc.headings) * (2 * np.pi / sc.headings)
        res = self._reduced_search(headings, dt, self.threads, seated=True)
        if res is None:
            return pose, weight
        rc = self.config.redetect
        self._set_limits(self._seated_limits)
        if res.best_weight > weight + sc.margin:
            new, w = res.best.copy(), float(res.best_weight)
            self.filter.inject(res.poses[: rc.inject], res.weights[: rc.inject], reset_motion=True)
        elif rc.refine_steps > 0 and res.best_weight >= rc.refine_ratio * weight:
            # As in re-detection: a coarse seated grid seldom outweighs a refined estimate, so
            # its best candidates are refined by the filter (under the seated limits) first.
            k = rc.refine_candidates
            new, w, saved = self._trial_steps(res.poses[:k], res.weights[:k], dt, rc.refine_steps)
            new, w = self._refine_origin(new, w, dt)
            if not w > weight + sc.margin:
                self.filter.__dict__.update(saved)
                self._set_limits(self._base_limits)
                return pose, weight
        else:
            self._set_limits(self._base_limits)
            return pose, weight
        self._seated, self._upright_frames = True, 0
        log.info("seated: weight %.3f -> %.3f; the seated limits apply", weight, w)
        return new, w

    def _lower_than_standing(self, fraction: float) -> bool:
        """Whether the person is lower than someone of the body's stature standing: in every
        camera that sees them, the silhouette's height in the image is below (1 - ``fraction``)
        of that of a standing body of the stature at the silhouette's floor point (its bottom
        back-projected to the floor; depth from the feet, not from the estimate, which through
        one camera can slide away and shrink to fit)."""
        seen = 0
        for cam, mask in zip(self.lik_cameras, self._masks, strict=True):
            rows = np.flatnonzero(mask.any(axis=1))
            if rows.size == 0:
                continue
            top, bottom = int(rows[0]), int(rows[-1])
            foot = camera_floor_point(cam, mask)
            if foot is None:
                continue
            head = np.array([[foot[0], foot[1], self.body.height_m]])
            standing_top = float(np.asarray(cam.project(head))[0, 1])
            expected = bottom - standing_top
            if not np.isfinite(expected) or expected <= 0:
                continue
            seen += 1
            if bottom - top >= (1.0 - fraction) * expected:
                return False
        return seen > 0

    def _floor_speed(self, window_s: float) -> float | None:
        """Speed (m/s) of the silhouettes' floor point over the last ``window_s`` seconds: the
        distance between the medians of the window's first and last thirds over the time between
        them (the medians ride over the feet's alternation as the nearest one). None while the
        floor points known since someone came into view cover less than half the window (a
        re-initialised estimate does not reset them: they are of the silhouettes)."""
        now = self._time_now
        pts = [e for e in self._floor_hist if e[0] >= now - window_s]
        if len(pts) < 3:
            return None
        a = np.asarray(pts, dtype=np.float64)
        span = a[-1, 0] - a[0, 0]
        if span < 0.5 * window_s:
            return None
        early = a[a[:, 0] <= a[0, 0] + span / 3]
        late = a[a[:, 0] >= a[-1, 0] - span / 3]
        elapsed = float(np.median(late[:, 0]) - np.median(early[:, 0]))
        if elapsed <= 0:
            return None
        d = np.median(late[:, 1:], axis=0) - np.median(early[:, 1:], axis=0)
        return float(np.hypot(*d) / elapsed)

    def _update_seated(self, pose: np.ndarray) -> None:
        """Back to the profile's limits once the estimate has been within them (on the DOFs
        the seated mode widens) for ``seated.upright_frames`` frames in a row."""
        if not self._seated:
            return
        low, high = self._base_limits
        i = _SEATED_IDX
        inside = bool(np.all(pose[i] >= low[i] - 1e-9) and np.all(pose[i] <= high[i] + 1e-9))
        self._upright_frames = self._upright_frames + 1 if inside else 0
        if self._upright_frames >= self.config.seated.upright_frames:
            self._seated = False
            self._set_limits(self._base_limits)
            log.info("upright again: the profile's limits apply")

    def _reduced_search(
        self,
        headings: np.ndarray,
        dt: float,
        threads: int,
        *,
        seated: bool = False,
    ):
        """Re-detection's reduced initial search at this frame's silhouettes: every body
        configuration (computed once per body and limits), positions around this frame's floor
        point, the given headings (radians); its grid on ``threads`` numba threads, the
        refinement on one. ``seated``: the seated configurations only, under the seated limits,
        with ``seated.refine_best`` refined (the seated mode's search). Returns
        :func:`tracker.init.initial_search`'s result or None."""
        if seated:
            config, limits, cached = self._seated_config, self._seated_limits, self._seated_configs
        else:
            config, limits, cached = self._redetect_config, self.limits, self._redetect_configs
        if cached is None or cached[0] is not self.body or cached[1] is not limits:
            configs, labels = body_configurations(self.body, config, limits)
            if seated:
                configs = configs[[i for i, lab in enumerate(labels) if lab.startswith("seated")]]
            cached = (self.body, limits, configs)
            if seated:
                self._seated_configs = cached
            else:
                self._redetect_configs = cached
        return initial_search(
            self._lik,
            self.body,
            self.lik_cameras,
            self._masks,
            config,
            limits=limits,
            dt=dt,
            floor_xy=self._floor_now if np.all(np.isfinite(self._floor_now)) else None,
            headings=headings,
            configs=cached[2],
            threads=threads,
        )

    def _redetect_search(
        self, pose: np.ndarray, weight: float, dt: float
    ) -> tuple[np.ndarray, float]:
        """The search of :meth:`_redetect`."""
        rc = self.config.redetect
        if not np.all(np.isfinite(self._floor_now)):
            return pose, weight  # no floor point under this frame's silhouettes
        span = np.radians(rc.span_deg)
        headings = pose[DOF["root_yaw"]] + (
            np.linspace(-span, span, rc.headings) if rc.headings > 1 else np.zeros(1)
        )
        # The grid (hundreds of poses) on every thread, the refinement's 7 poses on one.
        res = self._reduced_search(headings, dt, self.threads)
        if res is None:
            return pose, weight
        if res.best_weight > weight + rc.margin:
            self.filter.inject(res.poses[: rc.inject], res.weights[: rc.inject], reset_motion=True)
            log.debug("re-detected: weight %.3f -> %.3f", weight, res.best_weight)
            return res.best.copy(), float(res.best_weight)
        if rc.refine_steps == 0 or res.best_weight < rc.refine_ratio * weight:
            return pose, weight
        # The grid's best may lie in the right basin without outweighing an estimate refined
        # over many frames: refine its best candidates with the filter before comparing.
        k = rc.refine_candidates
        new, w, saved = self._trial_steps(res.poses[:k], res.weights[:k], dt, rc.refine_steps)
        new, w = self._refine_origin(new, w, dt)
        if not w > weight + rc.margin:
            self.filter.__dict__.update(saved)
            return pose, weight
        log.debug("re-detected after refinement: weight %.3f -> %.3f", weight, w)
        return new, w

    def _trial_steps(
        self, poses: np.ndarray, weights: np.ndarray, dt: float, steps: int
    ) -> tuple[np.ndarray, float, dict]:
        """:meth:`_seed_and_step` on the tracker's filter, keeping the filter's state before the
        trial: returns the pose, its weight and that state
        (``self.filter.__dict__.update(saved)`` restores it when the trial is not adopted).
        """
        saved = dict(self.filter.__dict__)
        share = self.config.redetect.trial_share
        if share >= 1:
            best, w = self._seed_and_step(self.filter, poses, weights, dt, steps)
            return best, w, saved
        # A filter of the same kind with a share of the budget runs the trial; the tracker's
        # filter then takes over its particles, as if it had run the trial itself.
        if self._trial_filter is None:
            c = self._filter_config
            self._trial_filter = make_filter(
                c.filter, c, rng=self.rng, limits=self.limits, share=share
            )
        trial = self._trial_filter
        trial.set_limits((self.filter.low, self.filter.high))
        best, w = self._seed_and_step(trial, poses, weights, dt, steps)
        self.filter.load_state(trial)
        return best, w, saved

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

    def _refine_legs(self, pose: np.ndarray, weight: float) -> tuple[np.ndarray, float]:
        """The legs' flexion searched on the weight without the 2D key-point cue
        (``leg_refine``); the estimate and its weight with every cue."""
        if self._leg_refine is None:
            return pose, weight
        from tracker.refine import refine_pose

        self.likelihood.keypoints = None
        try:
            w0 = float(self._lik.weights(pose[None])[0])
            with _single_thread():
                res = refine_pose(self._lik, pose, w0, self._leg_refine, limits=self.limits)
        finally:
            self.likelihood.keypoints = self.keypoint_cue
        if not res.weight > w0:
            return pose, weight
        return res.pose.copy(), float(self._lik.weights(res.pose[None])[0])

    def _search_arms(self, pose: np.ndarray, weight: float) -> tuple[np.ndarray, float]:
        """Grid search of each arm (:mod:`tracker.arms`, ``arms``); joins the particles when
        heavier. Off with fewer than ``arms.min_cameras`` cameras, and while the leg length is
        being scored: the estimate's arms, searched on the body in use, would favour that body's
        leg length over the others (whose trials start from arms placed for another trunk)."""
        ac = self.config.arms
        if not ac.enabled or len(self.cameras) < ac.min_cameras or self._estimate_legs:
            return pose, weight
        rank = self._edge_rank("arm_search")
        with _single_thread():
            res = search_arms(self._lik, pose, weight, ac, limits=self.limits, rank=rank)
        if np.array_equal(res.pose, pose):  # nothing ranked above the pose
            return pose, weight
        if ac.inject:
            self.filter.inject(res.pose[None], np.array([res.weight]))
        return res.pose.copy(), float(res.weight)

    def _edge_rank(self, scope: str):
        """The edge cue's factor of poses ``(N, 31)`` for an arm search, when the cue is on in
        ``scope`` and active; None otherwise (the search ranks by weight alone)."""
        cue, body = self.edge_cue, self.body
        if cue is None or cue.config.scope != scope or not cue.active:
            return None
        return lambda poses: cue.weight_factors(body, body.points(poses))

    def _fuse_detections(self, joints: np.ndarray) -> np.ndarray:
        """The written key points with ``keypoints.fuse``'s pairs averaged with this frame's
        detections triangulated (``fuse_min_cameras`` cameras or more;
        :func:`tracker.triangulation.fuse_detections`), or with one camera ``fuse_rays``'
        pairs moved across the line of sight towards their detections
        (:func:`tracker.triangulation.fuse_along_rays`). The estimate, its particles and the
        tracker's memory keep the model's points."""
        kc = self.config.keypoints
        cue = self.keypoint_cue
        if cue is None or cue.points is None:
            return joints
        points = cue.points
        if len(self.cameras) == 1:
            return fuse_along_rays(
                joints,
                self.cameras[0],
                points[0],
                kc.fuse_rays,
                weight=kc.fuse_weight,
                max_gap_m=kc.fuse_ray_max_gap_m,
                vertical=kc.fuse_vertical,
                full=kc.fuse_rays_full,
            )
        if not kc.fuse or len(self.cameras) < kc.fuse_min_cameras:
            return joints
        return fuse_detections(
            joints,
            self.cameras,
            points,
            kc.fuse,
            weight=kc.fuse_weight,
            max_gap_m=kc.fuse_max_gap_m,
            vertical=kc.fuse_vertical,
        )

    def _output_arms(self, pose: np.ndarray, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``edges.scope = "output"``: the written pose's arms are chosen by the arm search's
        grid ranked with the edge cue (silhouette weight times edge factor); the tracker's own
        estimate, its particles and its memory keep the silhouette's arms. The cue exists only
        with the arm search (``arms.min_cameras`` cameras or more) and ranks once active."""
        rank = self._edge_rank("output")
        if rank is None:
            return pose, joints
        weight = float(self._lik.weights(pose[None])[0])
        with _single_thread():
            res = search_arms(
                self._lik, pose, weight, self.config.arms, limits=self.limits, rank=rank
            )
        if np.array_equal(res.pose, pose):
            return pose, joints
        return res.pose.copy(), np.asarray(self.body.forward(res.pose[None]))[0]

    def _refine_origin(
        self, pose: np.ndarray, weight: float, dt: float
    ) -> tuple[np.ndarray, float]:
        """After a filter's estimate: search the arms (:meth:`_search_arms`), then the origin
        again holding the new body parts; each is adopted if heavier (``origin.after_filter``;
        otherwise the pose as it is)."""
        pose, weight = self._search_arms(pose, weight)
        c = self.config
        if not (c.origin.enabled and c.origin.after_filter):
            return pose, weight
        with _single_thread():
            res = search_origin(
                self._lik,
                pose,
                c.origin.model_copy(update={"levels": c.origin.after_filter_levels}),
                limits=self.limits,
                dt=dt,
                reference_dt=c.reference_dt_s,
                range_scale=c.origin.after_filter_range_scale,
                weight=weight,
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

    def _walking_direction(
        self,
        pose: np.ndarray,
        time_s: float,
        source: str,
        window_s: float,
        min_span_s: float | None = None,
    ) -> float | None:
        """Walking direction (radians) over the last ``window_s`` seconds, or None.

        ``source`` "estimate": the estimated body origin's path; "silhouette": the silhouettes'
        floor point's; "auto": the estimate's, else the silhouettes'. None unless the path has
        at least ``heading_check.min_frames`` points over ``min_span_s``, a least-squares speed
        of ``min_speed_m_s`` and a net displacement of at least ``min_straightness`` times its
        length (a walk, not jitter); ``min_span_s`` overrides the config's span.
        """
        hc = self.config.heading_check
        if source == "auto":
            # A track stuck facing the wrong way does not move with the person: its own path
            # is no walk while the silhouettes' is. The floor point is noisier than the
            # estimate, so its path must be longer.
            travel = self._walking_direction(pose, time_s, "estimate", window_s)
            if travel is None:
                travel = self._walking_direction(
                    pose, time_s, "silhouette", window_s, max(hc.min_span_s, hc.auto_min_span_s)
                )
            return travel
        span = hc.min_span_s if min_span_s is None else min_span_s
        path = self._recent_path(pose, time_s, window_s, source)
        if path.shape[0] < hc.min_frames or path[-1, 0] - path[0, 0] < span - 1e-9:
            return None
        # Least-squares velocity over the window: robust to the jitter of single estimates.
        v = self._time_sign * _path_fit(path)[0]
        if np.hypot(*v) < hc.min_speed_m_s:
            return None
        steps = np.hypot(*np.diff(path[:, 1:], axis=0).T).sum()
        net = float(np.hypot(*(path[-1, 1:] - path[0, 1:])))
        if net < hc.min_straightness * steps:
            return None
        return float(np.arctan2(v[1], v[0]))

    def _check_heading(
        self, pose: np.ndarray, weight: float, masks: list[np.ndarray], dt: float, time_s: float
    ) -> tuple[np.ndarray, float, str, bool] | None:
        """Re-initialise facing the walking direction when the heading points backwards (with no
        walking direction known, facing the way the detected face says: ``facing_s``, or else
        the way the raised feet swing: ``swing_s``); follow a turn the heading lags
        (``heading_check.turn_angle_deg``).

        Returns
        -------
        (pose, weight, note, continuous) when the estimate changed, else None; ``continuous``
        is False after a re-initialisation (the path and velocity restart).
        """
        hc = self.config.heading_check
        if not hc.enabled:
            return None
        yaw = float(pose[DOF["root_yaw"]])
        if hc.turn_angle_deg > 0.0:
            turn_travel = self._walking_direction(pose, time_s, hc.turn_source, hc.turn_window_s)
            if turn_travel is not None:
                off = float(np.degrees(abs(wrap_angle(yaw - turn_travel))))
                if hc.turn_angle_deg < off <= hc.max_angle_deg:
                    turned = self._follow_turn(pose, weight, dt, turn_travel, off)
                    if turned is not None:
                        return (*turned, True)
        if time_s < self._heading_checked_until:
            return None
        travel = self._walking_direction(pose, time_s, hc.source, hc.window_s)
        if travel is not None:
            off = float(np.degrees(abs(wrap_angle(yaw - travel))))
            if off <= hc.max_angle_deg:
                return None
            sustained = self._walks_backwards(pose, time_s)
            ratio = hc.sustained_ratio if sustained else hc.accept_ratio
            why = "off the walking direction"
            if sustained:
                why += f" for over {hc.sustained_s} s"
        else:
            face = self._faces_backwards(pose, time_s)
            # No walk to follow: the detected face turns the heading round, or else the way the
            # raised feet swing. The candidates are refined however light, as a sustained
            # flip's (the track has faced the wrong way for the whole window), and adopted at
            # facing_ratio.
            if face is not None:
                travel, off = float(wrap_angle(yaw + np.pi)), 180.0
                why = f"away from the detected face (evidence {face:+.3f} over {hc.facing_s} s)"
            else:
                swing = self._swings_backwards(yaw, time_s)
                if swing is None:
                    return None
                travel, consistency = swing
                off = float(np.degrees(abs(wrap_angle(yaw - travel))))
                why = (
                    f"away from the way the raised feet swing (consistency {consistency:.2f} "
                    f"over {hc.swing_s} s)"
                )
            sustained, ratio = True, hc.facing_ratio
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
        self._facing = []
        self._feet = []
        self._heading_checked_until = time_s + hc.cooldown_s
        if res is None:
            return None
        rc = self.config.redetect
        if res.best_weight < hc.accept_ratio * weight:
            # The coarse grid facing the walking direction seldom matches an estimate refined
            # over many frames: refine its candidates as re-detection does before deciding. A
            # sustained flip refines them however light and accepts them lighter
            # (sustained_ratio), the face check's at facing_ratio.
            if (
                rc.refine_steps == 0
                or hc.leg_choice == "refine"
                or (res.best_weight < rc.refine_ratio * weight and not sustained)
            ):
                return None
            poses, weights = res.poses, res.weights
            if hc.leg_choice == "feet":
                poses, weights = self._feet_continuity(pose, poses, weights, hc)
            new, w, saved = self._trial_steps(poses, weights, dt, rc.refine_steps)
            if w < ratio * weight:
                self.filter.__dict__.update(saved)
                return None
        elif hc.leg_choice == "refine":
            new, w = self._flip_modes(pose, res.poses, res.weights, dt, hc)
        else:
            poses, weights = res.poses, res.weights
            if hc.leg_choice == "feet":
                poses, weights = self._feet_continuity(pose, poses, weights, hc)
            new, w, _ = self._trial_steps(poses, weights, dt, 1)
        return (
            new.copy(),
            float(w),
            f"heading {np.degrees(pose[DOF['root_yaw']]):.0f} deg was {off:.0f} deg {why}:"
            f" re-initialised facing {np.degrees(travel):.0f} deg "
            f"(weight {w:.3f}, was {weight:.3f})",
            False,
        )

    def _remember_facing(self, joints: np.ndarray, time_s: float, *, continuous: bool) -> None:
        """Keep this frame's face evidence for the face check (``heading_check.facing_s``)."""
        hc = self.config.heading_check
        if not continuous:
            self._facing = []
        if hc.facing_s <= 0 or self.keypoint_cue is None:
            return
        e = self.keypoint_cue.facing(joints, hc.facing_min_profile)
        if e is not None:
            self._facing = [*self._facing, (float(time_s), e)][-64:]

    def _remember_feet(self, joints: np.ndarray, time_s: float, *, continuous: bool) -> None:
        """Keep this frame's sacrum and ankles for the swing check (``heading_check.swing_s``).
        Only feet some camera sees: where furniture or the image's edge may cut every camera's
        legs off (:func:`_legs_cut`) the estimate's feet are guesses, and the window restarts."""
        unseen = all(self._legs_cut_now)
        if not continuous or unseen:
            self._feet = []
        if unseen or self.config.heading_check.swing_s <= 0:
            return
        j = np.asarray(joints, dtype=np.float64)
        row = (float(time_s), j[SACRUM].copy(), j[L_ANKLE].copy(), j[R_ANKLE].copy())
        self._feet = [*self._feet, row][-128:]

    def _swings_backwards(self, yaw: float, time_s: float) -> tuple[float, float] | None:
        """(direction, consistency) of the raised feet's swing (:func:`tracker.swing.
        swing_direction`) over the last ``heading_check.swing_s`` seconds when it points more
        than ``max_angle_deg`` away from the heading ``yaw`` with at least
        ``swing_consistency``, else None. Only where the body stays: a sacrum that moved
        ``min_speed_m_s`` or faster over the window travels (a turn, a walk whose direction
        the path did not settle), and its feet swing every way. Not in the seated mode
        (rising, the feet do not swing)."""
        hc = self.config.heading_check
        if hc.swing_s <= 0 or self._seated:
            return None
        rows = [r for r in self._feet if time_s - r[0] <= hc.swing_s + 1e-9]
        if len(rows) < max(hc.min_frames, 3) or rows[-1][0] - rows[0][0] < 0.9 * hc.swing_s - 1e-9:
            return None
        t = np.array([r[0] for r in rows])
        sacrum = np.stack([r[1] for r in rows])
        if np.hypot(*(sacrum[-1, :2] - sacrum[0, :2])) >= hc.min_speed_m_s * (t[-1] - t[0]):
            return None  # the body travels (turning, say): the walking direction is the guide
        found = swing_direction(t, sacrum, *(np.stack([r[i] for r in rows]) for i in (2, 3)))
        if found is None:
            return None
        direction, consistency = found
        if self._time_sign < 0:  # the backward pass's mirrored time: the feet swing back
            direction = float(wrap_angle(direction + np.pi))
        off = float(np.degrees(abs(wrap_angle(yaw - direction))))
        if consistency < hc.swing_consistency or off <= hc.max_angle_deg:
            return None
        return direction, consistency

    def _faces_backwards(self, pose: np.ndarray, time_s: float) -> float | None:
        """The mean face evidence when the detections have put the face behind the heading of
        the track for ``heading_check.facing_s`` (this frame's ``pose`` included), else None.

        Seen in profile, the detected nose lies ahead of the detected shoulders in the image
        (:meth:`tracker.keypoints2d.KeypointCue.facing`: about +0.03 to +0.08 of the person's
        height on the benchmark's footage, below -0.02 in 1 to 3 % of its frames with the true
        heading). A window of at least ``min_frames`` values spanning 0.9 of ``facing_s``
        must average below ``-facing_evidence`` with ``facing_share`` of them negative. Not in
        the seated mode.
        """
        hc = self.config.heading_check
        if hc.facing_s <= 0 or self.keypoint_cue is None or self._seated:
            # Seated (the seated mode), the detector's nose misled: CMU 75_19 through a side
            # camera put it 0.29 of the height behind the shoulders while the track faced the
            # right way.
            return None
        joints = np.asarray(self.body.forward(pose[None]))[0]
        now = self.keypoint_cue.facing(joints, hc.facing_min_profile)
        hist = [(t, e) for t, e in self._facing if abs(time_s - t) <= hc.facing_s + 1e-9]
        if now is not None:
            hist.append((float(time_s), now))
        if len(hist) < hc.min_frames:
            return None
        times, ev = (np.array(v) for v in zip(*hist, strict=True))
        if np.ptp(times) < 0.9 * hc.facing_s - 1e-9:
            return None
        mean = float(ev.mean())
        if mean < -hc.facing_evidence and float(np.mean(ev < 0)) >= hc.facing_share:
            return mean
        return None

    def _recent_path(
        self, pose: np.ndarray, time_s: float, window_s: float, source: str
    ) -> np.ndarray:
        """(time, x, y) rows of the last ``window_s`` seconds of the path, this frame included:
        the estimated origin's (``source`` "estimate") or the silhouettes' floor point's
        ("silhouette", frames without one left out)."""
        path = np.array([*self._path, self._path_entry(time_s, pose)])
        path = path[path[:, 0] >= time_s - window_s - 1e-9]
        if source == "silhouette":
            return path[np.isfinite(path[:, 3])][:, [0, 3, 4]]
        return path[:, :3]

    def _walks_backwards(self, pose: np.ndarray, time_s: float) -> bool:
        """True when the track has moved backwards for ``heading_check.sustained_s`` seconds.

        Both the silhouettes' floor point and the estimate must have walked more than
        ``max_angle_deg`` away from the heading over the path since the last check, spanning at
        least 0.9 of ``sustained_s``: two observations that agree. Alone, each misled: through
        one camera a track sliding along the line of sight looks like a walk, and on a
        treadmill the belt carries the feet, and so the floor point, while the estimate stays
        (there the floor point alone turned the heading round and the error rose). A path
        counts as a walk when its least-squares velocity reaches ``min_speed_m_s`` and explains
        at least half its scatter (over a second, summed frame-to-frame jitter fails
        ``min_straightness``).
        """
        hc = self.config.heading_check
        if hc.sustained_s <= 0:
            return False
        off = {}
        for source in ("silhouette", "estimate"):
            p = self._recent_path(pose, time_s, hc.sustained_s, source)
            off[source] = None
            if p.shape[0] < hc.min_frames or p[-1, 0] - p[0, 0] < 0.9 * hc.sustained_s - 1e-9:
                continue
            fit, resid, scatter = _path_fit(p)
            if np.hypot(*fit) < hc.min_speed_m_s or not resid <= 0.5 * scatter:
                continue
            travel = np.arctan2(*(self._time_sign * fit)[::-1])
            off[source] = float(np.degrees(abs(wrap_angle(pose[DOF["root_yaw"]] - travel))))
        sil, est = off["silhouette"], off["estimate"]
        return all(o is not None and o > hc.max_angle_deg for o in (sil, est))

    def _follow_turn(
        self, pose: np.ndarray, weight: float, dt: float, travel: float, off: float
    ) -> tuple[np.ndarray, float, str] | None:
        """Search headings around the walking direction when the heading lags a turn.

        The origin search moves the heading a few degrees per frame holding the previous legs,
        and a heading turned with the old legs weighs less than the lagging estimate: in a
        turn the estimate keeps facing the old direction. Here the reduced initial search
        (every body configuration, positions around this frame's floor point, the redetect
        config's refinement) runs at ``hc.turn_headings`` headings within ``hc.turn_span_deg``
        of the walking direction; a result heavier than the estimate by ``hc.turn_margin``
        becomes the estimate and its best candidates join the particle set.
        """
        hc = self.config.heading_check
        span = np.radians(hc.turn_span_deg)
        n = hc.turn_headings
        # The body turns ahead of its path: centre the headings beyond the walking direction,
        # on the side away from the lagging estimate.
        side = np.sign(wrap_angle(travel - pose[DOF["root_yaw"]]))
        centre = travel + side * np.radians(hc.turn_lead_deg)
        headings = centre + (np.linspace(-span, span, n) if n > 1 else np.zeros(1))
        res = self._reduced_search(headings, dt, 1)
        if res is None:
            return None
        new, w = res.best, float(res.best_weight)
        if w < hc.turn_trial_ratio * weight:
            return None
        if hc.turn_refine:
            # One filter step seeded with the turned candidates; the particle set is kept
            # unless the refined estimate wins.
            new, w, saved = self._trial_steps(res.poses, res.weights, dt, 1)
            if not w > weight + hc.turn_margin:
                self.filter.__dict__.update(saved)
                return None
            new, w = self._refine_origin(new, w, dt)
        else:
            if not w > weight + hc.turn_margin:
                return None
            k = self.config.redetect.inject
            self.filter.inject(res.poses[:k], res.weights[:k], reset_motion=True)
        return (
            new.copy(),
            w,
            f"heading {np.degrees(pose[DOF['root_yaw']]):.0f} deg was {off:.0f} deg off the "
            f"walking direction {np.degrees(travel):.0f} deg: turned to "
            f"{np.degrees(new[DOF['root_yaw']]):.0f} deg (weight {w:.3f}, was "
            f"{weight:.3f})",
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
            self.velocity_xy = _capped_velocity(pose, self.prev_pose, dt)
        self.prev_pose = pose.copy()
        self.prev_time = float(time_s)

    def _no_pose(self, frame_index: int, time_s: float, reason: str) -> FrameResult:
        self.need_init = True
        self._alt = None
        if self._seated:  # whoever comes into view next starts under the profile's limits
            self._seated = False
            self._set_limits(self._base_limits)
        self.prev_pose = None
        self._prev_joints = None
        self.prev_time = float(time_s)
        self.velocity_xy = np.zeros(2)
        self.low_count = 0
        self._path = []
        self._facing = []
        self._feet = []
        self._floor_hist = []
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
            main = seg.blobs[best]
            parts = self._part_box(main)
            keep = [
                b
                for i, b in enumerate(seg.blobs)
                if i == best or ov[i] >= 0.3 * areas[i] or _inside(b.centroid, parts)
            ]
        cx, cy = main.centroid
        notes.append(
            f"camera {name}: {len(seg.blobs)} blobs, following the one at ({cx:.0f}, {cy:.0f}) "
            f"[{why}]"
            + (f" with {len(keep) - 1} other part(s) of the person" if len(keep) > 1 else "")
        )
        return keep_blobs(seg, keep)

    def _part_box(self, main) -> tuple[float, float, float, float] | None:
        """``(x0, y0, x1, y1)``: where other parts of the person followed in blob ``main`` may
        lie (``config.part_box``): its box widened on each side and extended downwards; None
        when ``part_box`` is (0, 0)."""
        side, below = self.config.part_box
        if side == 0 and below == 0:
            return None
        x, y, w, h = main.bbox
        return (x - side * h, y, x + w + side * h, y + h + below * h)

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


#: The key-point cue's leg points (knees, ankles, heels, toes), dropped when the legs may be
#: cut off.
LEG_POINTS: tuple[int, ...] = LEFT_POINTS + RIGHT_POINTS


#: How far below the silhouette's lowest pixel in their columns the feet may project (the
#: median of the six points), as a share of the body's projected height, and still count as
#: seen. Measured offline on the benchmark's written key points: typically 0.02-0.07 of the
#: height above it; beyond the share on 0.2 % (frontal), 2.4 % (side) and 7.7 % (oblique: feet
#: misplaced) of the frames of open views, 14-15 % behind a table or sofa (up to 20 heights).
FEET_BELOW_SHARE = 0.1


def _feet_below_silhouette(joints: np.ndarray, cam, mask: np.ndarray) -> bool:
    """True when the feet of ``joints`` (19, 3) project, at the median of the six foot
    points, more than :data:`FEET_BELOW_SHARE` of the body's projected height (head to the
    lowest foot point) below the lowest foreground pixel of ``mask`` (camera ``cam``'s
    resolution) in their columns, or outside it: the silhouette does not show them. The feet
    are :data:`tracker.smoothing.FEET`."""
    if not mask.any():
        return True
    uv = cam.project(joints[FEET])
    head_v = float(cam.project(joints[0])[1])
    if not (np.isfinite(uv).all() and np.isfinite(head_v)):
        return True
    height = float(uv[:, 1].max()) - head_v
    if height <= 0:
        return True
    h, w = mask.shape
    rows = np.arange(h)[:, None]
    bottom = np.where(mask.any(axis=0), (mask * rows).max(axis=0), -1)
    cols = np.round(uv[:, 0]).astype(np.int64)
    inside = (cols >= 0) & (cols < w)
    low = bottom[np.clip(cols, 0, w - 1)]
    below = np.where(inside & (low >= 0), uv[:, 1] - low, np.inf)
    return bool(np.median(below) > FEET_BELOW_SHARE * height)


def _legs_cut(box: tuple[int, int, int, int], occ: np.ndarray | None, cam) -> bool:
    """True when the silhouette's box ``(x, y, w, h)`` (camera pixels) reaches the image's
    lower edge, or occluded pixels (``occ``, any resolution) lie under its upper half, down to
    a third of its height below it: the legs may be hidden, the silhouette cut short."""
    x, y, w, h = box
    if y + h >= cam.height - 2:
        return True
    if occ is None:
        return False
    mh, mw = occ.shape
    sx, sy = mw / cam.width, mh / cam.height
    u0, u1 = int(np.floor(x * sx)), int(np.ceil((x + w) * sx))
    v0, v1 = int(np.floor((y + 0.5 * h) * sy)), int(np.ceil((y + 4.0 * h / 3.0) * sy))
    return bool(occ[max(v0, 0) : max(v1, 0), max(u0, 0) : max(u1, 0)].any())
