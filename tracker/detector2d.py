"""The built-in 2D human-pose detector of the key-point cue: BlazePose GHUM (full) through LiteRT.

The 2D key-point cue (:mod:`tracker.keypoints2d`) scores poses against the key points a 2D pose
detector finds in each frame. This module is the detector gaitwatch ships, so that the cue works
with no outside program: MediaPipe's pose landmark model (``models/pose_landmark_full.tflite``,
BlazePose GHUM 3D, full; Apache 2.0, see ``models/README.md``) run by Google's LiteRT interpreter
(the ``ai-edge-litert`` package). MediaPipe itself is not used: its releases that carry the model
need NumPy < 2 and an OpenCV build of their own.

* **Where to look**: MediaPipe finds the person with a second network; the tracker already has
  the silhouette. The first crop is the square around the chosen blobs' bounding box, centred
  on it, ``crop_scale`` (1.3) times its longer side: the size MediaPipe's own region of
  interest has around a walking person (the model's alignment points gave 1.29-1.32 times the
  box on a rendered walk). Then, as MediaPipe tracks, each camera's crop follows the person
  from the previous frame's alignment points, turned with the body
  (:meth:`PoseDetector.detect_frames`). It is resampled to the model's 256 x 256 input
  (averaged first when it shrinks), black outside the frame.
* **What it gives**: per camera an array ``(19, 3)`` in the CONVENTIONS key-point order, ``(u,
  v, visibility)`` in the frame's pixels (:data:`TO_BLAZEPOSE`: the head is BlazePose's nose,
  the toes its foot index points; neck and sacrum are NaN, BlazePose has none), or None when
  the model's presence score is below ``min_presence`` or there is no silhouette.
* **Refined on the heatmaps** (``refine``, on by default): the model also gives a 64 x 64
  heatmap per landmark; as MediaPipe's own pose pipeline does, each landmark moves to the
  confidence-weighted centre of its heatmap's 7 x 7 cells around it
  (:func:`refine_from_heatmap`). On the benchmark's renderings the leg points' mean error
  falls by a fifth (docs/tracker.md, "Session 42").
* **The heatmaps kept** (``heatmaps``; the tracker asks for them with two cameras or more, the
  key-point cue's ``score_multi_camera``): each detection's maps, as probabilities in the key
  points' order, with the affine map of the camera's pixels to their cells
  (:class:`tracker.keypoints2d.KeypointHeatmaps`, :attr:`PoseDetector.last_heatmaps`), for the
  cue to score the model's points on (docs/tracker.md, "Session 43").
* **The frame mirrored** (``mirror``; opt-in, the tracker uses it with two cameras or more): the
  model also runs on the frame mirrored left to right and the two sets of key points are
  averaged, their sides matched part by part, legs and arms each on its own
  (:meth:`PoseDetector._with_mirrored`): the network's errors on an image and on its mirror
  are partly independent.
* **The person's pixels** (:meth:`PoseDetector.person_mask`): the model's own segmentation
  output, warped back into the frame, for the empty scene estimated from the footage
  (:func:`tracker.background.people_in_samples`), which leaves the person out of its median;
  and, with ``people`` (``keypoints.shadow_given_back``, on with two cameras), each
  detection's own output (:attr:`PoseDetector.last_people`, :meth:`PoseDetector.person_pixels`),
  under which the tracker gives the silhouette back the pixels its shadow test removed.
* **Cost**: one inference per camera and frame (two with ``mirror``), about 17-22 ms each on
  one core of this machine.

The model is loaded once per :class:`PoseDetector` (the first :meth:`~PoseDetector.detect`); an
interpreter is not shared between threads.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from gaitwatch.conventions import KP, N_KEYPOINTS, SIDES, SIDES_EXCHANGED
from tracker.keypoints2d import KeypointHeatmaps

log = logging.getLogger(__name__)

#: The model file shipped with the package.
MODEL_PATH = Path(__file__).parent / "models" / "pose_landmark_full.tflite"
#: The model's input side in pixels.
INPUT_SIZE = 256
#: Landmarks in the model's output (33 body points, then its alignment and auxiliary points).
N_LANDMARKS = 39
#: CONVENTIONS key-point index -> BlazePose landmark index (neck and sacrum have none).
TO_BLAZEPOSE: dict[int, int] = {
    0: 0,  # head <- nose
    3: 11, 4: 12, 5: 13, 6: 14, 7: 15, 8: 16,  # shoulders, elbows, wrists
    9: 23, 10: 24, 11: 25, 12: 26, 13: 27, 14: 28,  # hips, knees, ankles
    15: 29, 16: 30, 17: 31, 18: 32,  # heels, toes <- foot index
}  # fmt: skip
_OURS = np.array(list(TO_BLAZEPOSE))
_THEIRS = np.array(list(TO_BLAZEPOSE.values()))
#: BlazePose's landmark order with the sides exchanged (the landmarks of a mirrored image).
_MIRROR = np.arange(N_LANDMARKS)
for _a, _b in ((1, 4), (2, 5), (3, 6), (7, 8), (9, 10), *((i, i + 1) for i in range(11, 33, 2))):
    _MIRROR[[_a, _b]] = _MIRROR[[_b, _a]]
#: The parts whose sides the mirrored detection matches each on its own: (the points exchanged
#: together, the points that decide). The legs with the hips, decided by the knees, ankles,
#: heels and toes; the arms with the shoulders, decided by the shoulders, elbows and wrists.
_LEG_POINTS = [KP[f"{s}_{n}"] for n in ("knee", "ankle", "heel", "toe") for s in SIDES]
_ARM_POINTS = [KP[f"{s}_{n}"] for n in ("shoulder", "elbow", "wrist") for s in SIDES]
_MIRROR_PARTS: tuple[tuple[list[int], list[int]], ...] = (
    ([KP["left_hip"], KP["right_hip"], *_LEG_POINTS], _LEG_POINTS),
    (_ARM_POINTS, _ARM_POINTS),
)


def _mean_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Mean image distance between the points of two key-point sets ``(n, >= 2)`` that both
    have (infinity when none)."""
    d = np.linalg.norm(a[:, :2] - b[:, :2], axis=1)
    d = d[np.isfinite(d)]
    return float(d.mean()) if len(d) else np.inf


class DetectorUnavailableError(RuntimeError):
    """The detector's runtime or model file is missing."""


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.clip(x, -60.0, 60.0)))


def refine_from_heatmap(
    points: np.ndarray, heatmap: np.ndarray, kernel: int = 7, min_confidence: float = 0.5
) -> np.ndarray:
    """The landmarks ``(n, 2)`` (the model's input pixels) moved to their heatmaps' local centre,
    as MediaPipe's pose pipeline does (``RefineLandmarksFromHeatmapCalculator``, kernel 7, 0.5):
    each landmark becomes the mean of the heatmap's cells in the ``kernel`` x ``kernel`` window
    around it (the window cut at the map's edges), weighted by their sigmoid confidence, when the
    window's highest confidence is at least ``min_confidence``. A cell's column ``c`` maps to
    ``c * INPUT_SIZE / width`` input pixels, as MediaPipe maps it. ``heatmap`` ``(height, width,
    n)`` holds the logits; a landmark's cell is its position truncated towards zero, as in
    MediaPipe; landmarks outside the map stay as they are."""
    pts = np.array(points, dtype=np.float64)
    h, w, n = heatmap.shape
    if pts.shape != (n, 2):
        raise ValueError(f"{pts.shape[0]} landmarks for a heatmap of {n}")
    with np.errstate(invalid="ignore"):
        col = np.trunc(pts[:, 0] * (w / INPUT_SIZE))
        row = np.trunc(pts[:, 1] * (h / INPUT_SIZE))
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)  # NaN is outside
    idx = np.flatnonzero(inside)
    if not len(idx):
        return pts
    half = (kernel - 1) // 2
    off = np.arange(-half, half + 1)
    cols = col[idx, None].astype(int) + off  # (m, k)
    rows = row[idx, None].astype(int) + off
    cin = (cols >= 0) & (cols < w)
    rin = (rows >= 0) & (rows < h)
    vals = heatmap[
        np.clip(rows, 0, h - 1)[:, :, None], np.clip(cols, 0, w - 1)[:, None, :], idx[:, None, None]
    ]  # (m, k, k)
    conf = _sigmoid(vals.astype(np.float64)) * (rin[:, :, None] & cin[:, None, :])
    total = conf.sum(axis=(1, 2))
    ok = (conf.max(axis=(1, 2)) >= min_confidence) & (total > 0)
    cu = (conf * cols[:, None, :]).sum(axis=(1, 2)) / np.where(ok, total, 1.0)
    cv = (conf * rows[:, :, None]).sum(axis=(1, 2)) / np.where(ok, total, 1.0)
    done = idx[ok]
    pts[done, 0] = cu[ok] * (INPUT_SIZE / w)
    pts[done, 1] = cv[ok] * (INPUT_SIZE / h)
    return pts


def crop_box(box: tuple[float, float, float, float], scale: float) -> tuple[float, float, float]:
    """The square crop ``(centre u, centre v, side)`` around a bounding box ``(x, y, width,
    height)`` in pixels: centred on it, ``scale`` times its longer side."""
    x, y, w, h = (float(v) for v in box)
    return x + 0.5 * w, y + 0.5 * h, scale * max(w, h, 1.0)


def crop_transform(cu: float, cv: float, side: float, angle: float = 0.0) -> np.ndarray:
    """The affine map ``(2, 3)`` from frame pixels to the model's input pixels that takes the
    square of ``side`` centred on ``(cu, cv)``, turned by ``angle`` (radians, image axes: the
    crop's up is the frame's direction ``(sin angle, -cos angle)``), to the whole input."""
    s = INPUT_SIZE / side
    c, n = np.cos(angle), np.sin(angle)
    a = s * np.array([[c, n], [-n, c]])
    t = 0.5 * INPUT_SIZE - a @ np.array([cu, cv], dtype=np.float64)
    return np.column_stack([a, t])


def alignment_crop(uv: np.ndarray, scale: float = 1.25) -> tuple[float, float, float, float]:
    """The crop ``(centre u, centre v, side, angle)`` that BlazePose's alignment points (its
    landmarks 33, the hips' centre, and 34, which sets the body's extent and direction) give,
    as MediaPipe tracks a person from one frame to the next: centred on the hips, ``2 x scale``
    times the extent, turned so that the body points up."""
    c0, c1 = np.asarray(uv[33], dtype=np.float64), np.asarray(uv[34], dtype=np.float64)
    d = c1 - c0
    # the crop's up (sin a, -cos a) along d
    return (
        float(c0[0]),
        float(c0[1]),
        2.0 * scale * float(np.hypot(*d)),
        float(np.arctan2(d[0], -d[1])),
    )


def silhouette_box(blobs: Sequence) -> tuple[int, int, int, int] | None:
    """The bounding box ``(x, y, width, height)`` of blobs (:class:`tracker.segmentation.Blob`),
    or None without any."""
    boxes = [b.bbox for b in blobs]
    if not boxes:
        return None
    x0 = min(b[0] for b in boxes)
    y0 = min(b[1] for b in boxes)
    x1 = max(b[0] + b[2] for b in boxes)
    y1 = max(b[1] + b[3] for b in boxes)
    return x0, y0, x1 - x0, y1 - y0


class PoseDetector:
    """BlazePose GHUM (full) on a crop of a frame (module docstring).

    Parameters
    ----------
    crop_scale : float
        The crop's side over the silhouette box's longer side.
    min_presence : float
        Below this presence score the model saw nobody: no detection.
    threads : int
        The interpreter's threads.
    model_path : path, optional
        The ``.tflite`` file (default :data:`MODEL_PATH`).
    refine : bool
        Move each landmark to its heatmap's local centre, as MediaPipe's pose pipeline does
        (:func:`refine_from_heatmap`).
    mirror : bool
        Also run the model on the frame mirrored (the crop mirrored with it) and average the
        two sets of key points (:meth:`_with_mirrored`): one more inference per camera and
        frame. The crop followed to the next frame stays the first inference's.
    heatmaps : bool
        Also keep each detection's heatmaps (:attr:`last_heatmaps`, for the key-point cue's
        ``score = "heatmap"``): the first inference's, as probabilities, in the key points'
        order.
    people : bool
        Also keep each detection's person segmentation (:attr:`last_people`): the first
        inference's, no inference added.
    """

    def __init__(
        self,
        crop_scale: float = 1.3,
        min_presence: float = 0.5,
        threads: int = 1,
        model_path: str | Path | None = None,
        mirror: bool = False,
        refine: bool = True,
        heatmaps: bool = False,
        people: bool = False,
    ) -> None:
        if not crop_scale > 0:
            raise ValueError(f"crop_scale must be > 0, not {crop_scale}")
        if not 0 <= min_presence <= 1:
            raise ValueError(f"min_presence must be in [0, 1], not {min_presence}")
        if threads < 1:
            raise ValueError(f"threads must be >= 1, not {threads}")
        self.crop_scale = float(crop_scale)
        self.min_presence = float(min_presence)
        self.threads = int(threads)
        self.mirror = bool(mirror)
        self.refine = bool(refine)
        self.heatmaps = bool(heatmaps)
        self.people = bool(people)
        #: Per camera of the last :meth:`detect_frames` the detection's heatmaps or None (with
        #: ``heatmaps``; else None).
        self.last_heatmaps: list[KeypointHeatmaps | None] | None = None
        #: Per camera of the last :meth:`detect_frames` the detection's person segmentation
        #: ``(crop, logits)`` for :meth:`person_pixels`, or None (with ``people``; else None).
        self.last_people: list[tuple[tuple, np.ndarray] | None] | None = None
        self._heat_raw: np.ndarray | None = None  # the last inference's heatmap logits
        self.model_path = Path(model_path) if model_path is not None else MODEL_PATH
        self._interp = None
        self._io: tuple[int, int, int, int | None] | None = None
        self._seg_index: int | None = None  # the person segmentation output (Identity_2)
        #: Per camera index the crop followed from the last frame (:meth:`detect_frames`).
        self._follow: dict[int, tuple[float, float, float, float]] = {}

    # -- the model -------------------------------------------------------------------------
    def load(self) -> None:
        """Load the model (done by the first :meth:`detect`); raises
        :class:`DetectorUnavailableError` when the runtime or the file is missing."""
        if self._interp is not None:
            return
        try:
            from ai_edge_litert.interpreter import Interpreter
        except ImportError as err:
            raise DetectorUnavailableError(
                "the 2D pose detector needs the ai-edge-litert package "
                f"(pip install ai-edge-litert): {err}"
            ) from None
        if not self.model_path.is_file():
            raise DetectorUnavailableError(f"pose model not found: {self.model_path}")
        try:
            interp = Interpreter(model_path=str(self.model_path), num_threads=self.threads)
            interp.allocate_tensors()
        except (ValueError, RuntimeError) as err:
            raise DetectorUnavailableError(
                f"{self.model_path}: not a model LiteRT can run: {err}".splitlines()[0]
            ) from None
        inp = interp.get_input_details()[0]
        if tuple(inp["shape"]) != (1, INPUT_SIZE, INPUT_SIZE, 3):
            raise DetectorUnavailableError(
                f"{self.model_path}: input shape {tuple(inp['shape'])}, expected "
                f"(1, {INPUT_SIZE}, {INPUT_SIZE}, 3)"
            )
        outs = {d["name"]: d for d in interp.get_output_details()}
        try:
            marks, flag = outs["Identity"], outs["Identity_1"]
        except KeyError:
            raise DetectorUnavailableError(
                f"{self.model_path}: not a BlazePose landmark model (outputs {sorted(outs)})"
            ) from None
        if int(np.prod(marks["shape"])) != 5 * N_LANDMARKS:
            raise DetectorUnavailableError(
                f"{self.model_path}: {int(np.prod(marks['shape']))} landmark values, expected "
                f"{5 * N_LANDMARKS}"
            )
        heat = None
        if self.refine or self.heatmaps:
            hm = outs.get("Identity_3")
            if hm is None or len(hm["shape"]) != 4 or int(hm["shape"][3]) != N_LANDMARKS:
                raise DetectorUnavailableError(
                    f"{self.model_path}: no landmark heatmap output to refine the landmarks "
                    "with or to score by (refine = false and heatmaps = false run without)"
                )
            heat = int(hm["index"])
        seg = outs.get("Identity_2")
        if seg is not None and tuple(seg["shape"][1:3]) == (INPUT_SIZE, INPUT_SIZE):
            self._seg_index = int(seg["index"])
        self._interp = interp
        self._io = (int(inp["index"]), int(marks["index"]), int(flag["index"]), heat)

    @property
    def has_people(self) -> bool:
        """Whether the loaded model has the person segmentation output (False before
        :meth:`load`)."""
        return self._seg_index is not None

    def __deepcopy__(self, memo: dict) -> PoseDetector:
        """Copies share the loaded interpreter (a model is read-only; the tracker's backward
        copy runs no detector)."""
        memo[id(self)] = self
        return self

    # -- detection -------------------------------------------------------------------------
    def landmarks(
        self, image_bgr: np.ndarray, crop: tuple[float, float, float, float]
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """The model's 39 landmarks ``(39, 2)`` in frame pixels, their visibility ``(39,)`` in
        [0, 1] and the presence score, on the crop ``(centre u, centre v, side, angle)``
        (:func:`crop_transform`)."""
        img = np.asarray(image_bgr)
        if img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
            raise ValueError(
                f"the detector takes uint8 BGR frames (H, W, 3), got {img.dtype} {img.shape}"
            )
        self.load()
        m = crop_transform(*crop)
        scale = INPUT_SIZE / crop[2]
        src, warp = img, m
        if scale < 1.0:  # shrinking: average the pixels first (no aliasing), then turn
            h, w = img.shape[:2]
            dw, dh = max(1, round(w * scale)), max(1, round(h * scale))
            src = cv2.resize(img, (dw, dh), interpolation=cv2.INTER_AREA)
            sx, sy = dw / w, dh / h  # a resized pixel x' = s (x + 0.5) - 0.5
            warp = m.copy()
            warp[:, 0] /= sx
            warp[:, 1] /= sy
            warp[:, 2] += m[:, :2] @ np.array([0.5 / sx - 0.5, 0.5 / sy - 0.5])
        x = cv2.warpAffine(
            src,
            warp,
            (INPUT_SIZE, INPUT_SIZE),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(0, 0, 0),
        )
        x = cv2.cvtColor(x, cv2.COLOR_BGR2RGB).astype(np.float32)
        x *= 1.0 / 255.0
        inp, marks_i, flag_i, heat_i = self._io  # type: ignore[misc]
        self._interp.set_tensor(inp, x[None])
        self._interp.invoke()
        raw = np.asarray(self._interp.get_tensor(marks_i), dtype=np.float64).reshape(N_LANDMARKS, 5)
        heat = None if heat_i is None else self._interp.get_tensor(heat_i)[0]
        if heat is not None and self.refine:
            raw[:, :2] = refine_from_heatmap(raw[:, :2], heat)
        self._heat_raw = heat.copy() if heat is not None and self.heatmaps else None
        # The presence output is a probability already (0.00003 on a black crop).
        presence = float(np.clip(np.asarray(self._interp.get_tensor(flag_i)).ravel()[0], 0, 1))
        uv = (raw[:, :2] - m[:, 2]) @ np.linalg.inv(m[:, :2]).T  # input -> frame pixels
        return uv, _sigmoid(raw[:, 3]), presence

    @staticmethod
    def _keypoints(uv: np.ndarray, vis: np.ndarray) -> np.ndarray:
        """The landmarks as CONVENTIONS key points ``(19, 3)`` (NaN where BlazePose has none)."""
        out = np.full((N_KEYPOINTS, 3), np.nan)
        out[_OURS, :2] = uv[_THEIRS]
        out[_OURS, 2] = vis[_THEIRS]
        return out

    def detect(
        self,
        image_bgr: np.ndarray,
        box: tuple[float, float, float, float] | None,
        crop: tuple[float, float, float, float] | None = None,
    ) -> np.ndarray | None:
        """Key points ``(19, 3)`` ``(u, v, visibility)`` in the frame's pixels of the person in
        ``box`` ``(x, y, width, height)`` (the crop around it, or ``crop``, :meth:`landmarks`);
        None without a box or when the model sees nobody."""
        det = self._detect(image_bgr, box, crop)
        return None if det is None else det[0]

    def _detect(self, image_bgr, box, crop):
        """:meth:`detect`, the crop the model's alignment points give for the next frame, the
        heatmaps (with ``heatmaps``) and the person segmentation ``(crop, logits)`` (with
        ``people`` and a model that has it), all of the first inference."""
        if box is None or box[2] <= 0 or box[3] <= 0:
            return None
        if crop is None:
            crop = (*crop_box(box, self.crop_scale), 0.0)
        uv, vis, presence = self.landmarks(image_bgr, crop)
        if presence < self.min_presence:
            return None
        kp = self._keypoints(uv, vis)
        heat = self._heatmaps(crop) if self.heatmaps else None
        person = None
        if self.people and self._seg_index is not None:
            person = (crop, self._interp.get_tensor(self._seg_index)[0, :, :, 0].copy())
        if self.mirror:
            kp = self._with_mirrored(kp, image_bgr, crop)
        return kp, alignment_crop(uv), heat, person

    def _heatmaps(self, crop) -> KeypointHeatmaps | None:
        """The last inference's heatmaps as :class:`KeypointHeatmaps` of the frame's pixels
        (a cell's column ``c`` at ``c x 4`` input pixels, as :func:`refine_from_heatmap`)."""
        if self._heat_raw is None:
            return None
        logits = self._heat_raw
        rows, cols = logits.shape[:2]
        maps = np.zeros((N_KEYPOINTS, rows, cols), dtype=np.float32)
        maps[_OURS] = np.moveaxis(_sigmoid(logits[:, :, _THEIRS].astype(np.float64)), 2, 0)
        to_map = crop_transform(*crop) * np.array([[cols / INPUT_SIZE], [rows / INPUT_SIZE]])
        return KeypointHeatmaps(maps, to_map)

    def _with_mirrored(self, kp: np.ndarray, image_bgr: np.ndarray, crop) -> np.ndarray:
        """``kp`` averaged with the key points the model finds on the mirrored frame (the same
        crop mirrored), mapped back and their sides matched to ``kp``'s part by part: the legs
        (with the hips) exchanged or not, whichever puts the legs' points nearer ``kp``'s, and
        the arms (with the shoulders) likewise on their own, since the model may label a
        person's arms and legs differently. A point missing from either stays
        ``kp``'s; the confidence is the lower of the two. ``kp`` when the mirrored crop shows
        nobody."""
        img = np.ascontiguousarray(np.asarray(image_bgr)[:, ::-1])
        w = img.shape[1]
        cu, cv, side, angle = crop
        uv, vis, presence = self.landmarks(img, (w - 1 - cu, cv, side, -angle))
        if presence < self.min_presence:
            return kp
        uv, vis = uv[_MIRROR], vis[_MIRROR]
        uv[:, 0] = w - 1 - uv[:, 0]
        other = self._keypoints(uv, vis)
        exchanged = other[list(SIDES_EXCHANGED)]
        for part, decide in _MIRROR_PARTS:
            if _mean_distance(exchanged[decide], kp[decide]) < _mean_distance(
                other[decide], kp[decide]
            ):
                other[part] = exchanged[part]
        out = kp.copy()
        both = np.isfinite(kp[:, :2]).all(axis=1) & np.isfinite(other[:, :2]).all(axis=1)
        out[both, :2] = 0.5 * (kp[both, :2] + other[both, :2])
        out[both, 2] = np.minimum(kp[both, 2], other[both, 2])
        return out

    def person_mask(
        self,
        image_bgr: np.ndarray,
        box: tuple[float, float, float, float],
        *,
        threshold: float = 0.3,
        grow: float = 0.04,
    ) -> tuple[int, int, np.ndarray] | None:
        """The pixels of the person in ``box`` ``(x, y, width, height)``, from the model's
        segmentation output (a person probability per input pixel), or None when the model
        sees nobody there.

        The model runs on the crop around the box (:func:`crop_box`), then, as MediaPipe looks
        a second time, on the crop its alignment points give (:func:`alignment_crop`: centred
        on the person, turned with them). Pixels of probability ``threshold`` or more are the
        person's, grown by ``grow`` times the crop's side (the mask's edge, hair, a loose
        sleeve). Returns ``(x, y, mask)``: the bool mask of a box of the frame whose top-left
        pixel is ``(x, y)``. Raises :class:`DetectorUnavailableError` when the model has no
        segmentation output."""
        if box[2] <= 0 or box[3] <= 0:
            return None
        self.load()
        if self._seg_index is None:
            raise DetectorUnavailableError(f"{self.model_path}: no person segmentation output")
        crop = (*crop_box(box, self.crop_scale), 0.0)
        uv, _, presence = self.landmarks(image_bgr, crop)
        if presence < self.min_presence:
            return None
        logits = self._interp.get_tensor(self._seg_index)[0, :, :, 0].copy()
        second = alignment_crop(uv)
        if second[2] > 1.0:
            _, _, presence2 = self.landmarks(image_bgr, second)
            if presence2 >= self.min_presence:  # else the first crop's output stays
                crop = second
                logits = self._interp.get_tensor(self._seg_index)[0, :, :, 0]
        return self.person_pixels(crop, logits, image_bgr.shape, threshold=threshold, grow=grow)

    @staticmethod
    def person_pixels(
        crop: tuple[float, float, float, float],
        logits: np.ndarray,
        shape: tuple[int, ...],
        *,
        threshold: float = 0.5,
        grow: float = 0.0,
    ) -> tuple[int, int, np.ndarray] | None:
        """The model's person segmentation ``logits`` (one per input pixel) on ``crop`` warped
        into a frame of ``shape`` (rows, columns, ...): the pixels of probability
        ``threshold`` or more, grown by ``grow`` times the crop's side, as ``(x, y, mask)``
        (:meth:`person_mask`); None when the crop lies outside the frame."""
        prob = _sigmoid(np.asarray(logits)).astype(np.float32)
        # The crop's corners in the frame give the box the mask is warped into.
        to_input = crop_transform(*crop)
        to_frame = cv2.invertAffineTransform(to_input)
        corners = np.array([[0, 0], [INPUT_SIZE, 0], [0, INPUT_SIZE], [INPUT_SIZE, INPUT_SIZE]])
        uvc = corners @ to_frame[:, :2].T + to_frame[:, 2]
        h, w = shape[:2]
        pad = int(np.ceil(grow * crop[2])) + 1
        x0 = int(np.clip(np.floor(uvc[:, 0].min()) - pad, 0, w))
        y0 = int(np.clip(np.floor(uvc[:, 1].min()) - pad, 0, h))
        x1 = int(np.clip(np.ceil(uvc[:, 0].max()) + pad + 1, 0, w))
        y1 = int(np.clip(np.ceil(uvc[:, 1].max()) + pad + 1, 0, h))
        if x1 <= x0 or y1 <= y0:
            return None
        warp = to_frame.copy()
        warp[:, 2] -= (x0, y0)
        back = cv2.warpAffine(
            prob, warp, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR, borderValue=0.0
        )
        mask = (back >= threshold).astype(np.uint8)
        k = 2 * int(round(grow * crop[2])) + 1
        if k > 1:
            mask = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
        return x0, y0, mask.astype(bool)

    def reset(self) -> None:
        """Forget the crops followed from frame to frame (:meth:`detect_frames`)."""
        self._follow = {}

    def detect_frames(
        self,
        frames: Sequence[np.ndarray],
        segs: Sequence,
        sizes: Sequence[tuple[int, int]] | None = None,
    ) -> list[np.ndarray | None]:
        """Per camera the key points of the person in the silhouette (``segs``:
        :class:`tracker.segmentation.Segmentation`, whose blobs give the box), successive
        frames of a video: as MediaPipe does, each camera's crop follows the person from the
        previous frame's alignment points (:func:`alignment_crop`: it covers legs that furniture
        hides from the silhouette and turns with a person who bends or lies down) while the
        silhouette box's centre stays inside it, else it is the box's (:func:`crop_box`).
        ``sizes``, per camera ``(width, height)`` of the camera's image, rescales the points
        when a frame is of another size."""
        if len(frames) != len(segs):
            raise ValueError(f"{len(frames)} frames for {len(segs)} segmentations")
        follow = self._follow
        out: list[np.ndarray | None] = []
        heats: list[KeypointHeatmaps | None] = []
        people: list[tuple[tuple, np.ndarray] | None] = []
        self.last_heatmaps = heats if self.heatmaps else None
        self.last_people = people if self.people else None
        for k, (frame, seg) in enumerate(zip(frames, segs, strict=True)):
            box = None if seg.empty else silhouette_box(seg.blobs)
            crop = follow.pop(k, None)
            heats.append(None)
            people.append(None)
            if box is None:
                out.append(None)
                continue
            if crop is not None and not _inside(crop, box):
                crop = None
            found = self._detect(frame, box, crop)
            if found is None and crop is not None:  # lost: from the silhouette again
                found = self._detect(frame, box, None)
            if found is None:
                out.append(None)
                continue
            det, follow[k], heat, people[k] = found
            if sizes is not None:
                w, h = sizes[k]
                fh, fw = frame.shape[:2]
                if (fw, fh) != (w, h):
                    det[:, 0] *= w / fw
                    det[:, 1] *= h / fh
                    if heat is not None:  # the camera's pixels -> the frame's -> cells
                        heat = KeypointHeatmaps(
                            heat.maps, heat.to_map * np.array([fw / w, fh / h, 1.0])
                        )
            heats[k] = heat
            out.append(det)
        return out


def _inside(crop: tuple[float, float, float, float], box: tuple) -> bool:
    """True when the box's centre lies in the crop's inner half and the crop is no smaller than
    the box's longer side (a crop followed from an earlier frame still holds the person)."""
    cu, cv, side, _ = crop
    x, y, w, h = box
    du, dv = x + 0.5 * w - cu, y + 0.5 * h - cv
    return bool(max(abs(du), abs(dv)) < 0.25 * side and side >= max(w, h))


def make_detector(config, n_cameras: int = 1) -> PoseDetector | None:
    """The detector of a :class:`tracker.config.KeypointConfig` for a tracker with
    ``n_cameras`` cameras (None when the cue is off or its ``detector`` is ``"none"``; the
    mirrored inference with ``mirror`` and at least ``mirror_min_cameras`` cameras; the person
    segmentation kept with ``shadow_given_back`` and at least ``shadow_given_back_min_cameras``
    cameras). Raises :class:`DetectorUnavailableError` when it cannot run."""
    if not config.enabled or config.detector == "none":
        return None
    det = PoseDetector(
        crop_scale=config.crop_scale,
        min_presence=config.min_presence,
        threads=config.threads,
        refine=config.heatmap_refine,
        mirror=config.mirror and n_cameras >= config.mirror_min_cameras,
        heatmaps=config.score_for(n_cameras) == "heatmap",
        people=config.gives_back_shadows(n_cameras),
    )
    det.load()
    if det.people and not det.has_people:
        log.warning(
            "%s has no person segmentation output: the shadow pixels are not given back",
            det.model_path,
        )
    return det


def person_detector(config) -> PoseDetector | None:
    """The built-in detector with a :class:`tracker.config.KeypointConfig`'s crop, presence and
    threads, to find the person in frames sampled for an estimated empty scene
    (:func:`tracker.background.people_in_samples`): None when its ``detector`` is ``"none"``
    (the model is loaded on first use)."""
    if config.detector == "none":
        return None
    return PoseDetector(
        crop_scale=config.crop_scale,
        min_presence=config.min_presence,
        threads=config.threads,
        refine=False,
    )
