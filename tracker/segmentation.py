"""Background subtraction: camera frames -> binary silhouettes at the likelihood resolution.

Pure computation on numpy arrays (OpenCV for the image operations); no file I/O.

Two families of modes, chosen by :class:`SegmentationConfig`:

``static``
    The method's own: an image of the empty scene, a per-pixel colour difference (the maximum
    absolute difference over the B, G, R channels), a threshold. Shadows -- pixels darker than
    the background by a bounded ratio but of the same chromaticity -- are removed
    (``shadow_suppression``). An optional global gain compensates a uniform change of
    brightness between the background image and the footage.
``mog2`` / ``knn``
    OpenCV's adaptive Gaussian-mixture (MOG2) or k-nearest-neighbours (KNN) background models,
    learned from the footage itself, for homes where the light changes. Their shadow detection
    marks shadows 127, which count as background when shadow suppression is on.

Frames may be segmented at a reduced working resolution (``work_scale``, e.g. 0.5 for 640x480
footage and a 160x120 likelihood) for speed; the full-resolution mask, labels and blobs are then
scaled back up (nearest neighbour).

Then, in every mode: morphological opening (removes speckle) and closing (fills small holes),
connected components, removal of blobs smaller than the minimum area, and a downscale to the
likelihood resolution by area interpolation re-thresholded at 0.5 (a low-resolution pixel is
foreground when at least half of the full-resolution pixels it covers are).

The result, :class:`Segmentation`, carries the full-resolution mask, the low-resolution mask the
likelihood uses, and the blobs (area, bounding box, centroid), so that a tracker can follow the
one blob consistent with its track (:func:`keep_blobs`) and detect that nobody is in view
(``empty``). It also keeps the foreground before the clean-up and the pixels the shadow test
removed, so that pixels found elsewhere to be the person's (a 2D pose detector's person
segmentation) can be given back (:meth:`Segmenter.with_shadow_given_back`): the shadow test also
takes dark or grey clothes for a shadow.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Annotated, Literal

import cv2
import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from gaitwatch.errors import InputError

log = logging.getLogger(__name__)

_KNN_SEED_FRAMES = 10
_EPS = 1.0  # added to channel sums so that black pixels have a defined chromaticity


class SegmentationError(InputError):
    """A frame or background image that cannot be segmented (wrong shape or type)."""


def _odd_or_zero(v: int, name: str) -> int:
    if v < 0:
        raise ValueError(f"{name} must be >= 0")
    if v > 1 and v % 2 == 0:
        raise ValueError(f"{name} must be odd (or 0/1 for none), not {v}")
    return v


class SegmentationConfig(BaseModel):
    """Settings of background subtraction. Unknown keys are rejected."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    mode: Annotated[
        Literal["static", "mog2", "knn"],
        Field(
            description="static: difference to an image of the empty scene; mog2/knn: OpenCV's "
            "adaptive background models learned from the footage"
        ),
    ] = "static"
    threshold: Annotated[
        float,
        Field(
            gt=0,
            le=255,
            description="static mode: a pixel is foreground when its largest per-channel "
            "absolute difference to the background exceeds this (0..255 grey levels)",
        ),
    ] = 30.0
    blur: Annotated[
        int,
        Field(
            description="Gaussian pre-blur kernel size in working-resolution pixels (odd; 0 or "
            "1 for none): robust to sensor noise, widens silhouettes by about a pixel; with "
            "work_scale <= 0.5 the downscale already averages the noise and 0 is enough"
        ),
    ] = 3
    global_gain: Annotated[
        bool,
        Field(
            description="static mode: scale the background by the median frame/background "
            "brightness ratio before differencing (compensates a uniform light change)"
        ),
    ] = False
    shadow_suppression: Annotated[bool, Field(description="treat cast shadows as background")] = (
        True
    )
    shadow_min_ratio: Annotated[
        float,
        Field(
            gt=0,
            lt=1,
            description="a shadow is at least this fraction of the background's brightness "
            "(static mode; in mog2 mode OpenCV's shadow threshold)",
        ),
    ] = 0.4
    shadow_max_ratio: Annotated[
        float,
        Field(
            gt=0,
            le=1.2,
            description="static mode: a shadow is at most this fraction of the background's "
            "brightness",
        ),
    ] = 0.95
    shadow_chroma_tol: Annotated[
        float,
        Field(
            gt=0,
            lt=1,
            description="static mode: largest difference of normalised chromaticity "
            "(B, G, R each divided by B+G+R) between a shadow pixel and the background",
        ),
    ] = 0.04
    open_kernel: Annotated[
        int, Field(description="opening kernel size in pixels (odd; 0 or 1 for none)")
    ] = 3
    close_kernel: Annotated[
        int, Field(description="closing kernel size in pixels (odd; 0 or 1 for none)")
    ] = 5
    min_blob_fraction: Annotated[
        float,
        Field(
            ge=0,
            lt=1,
            description="blobs smaller than this fraction of the image area are removed",
        ),
    ] = 0.002
    min_blob_pixels: Annotated[
        int,
        Field(
            ge=0,
            description="blobs smaller than this many full-resolution pixels are removed "
            "(the larger of the two minimums applies)",
        ),
    ] = 0
    work_scale: Annotated[
        float,
        Field(
            gt=0,
            le=1,
            description="segment frames downscaled by this factor (area interpolation), for "
            "speed; kernel sizes are in downscaled pixels; the full-resolution mask, labels "
            "and blobs are scaled back up",
        ),
    ] = 1.0
    output_size: Annotated[
        tuple[int, int] | None,
        Field(
            description="likelihood resolution (width, height) of Segmentation.mask; None "
            "keeps the frame's resolution"
        ),
    ] = (160, 120)
    history: Annotated[
        int, Field(gt=0, description="mog2/knn: number of frames the model remembers")
    ] = 300
    mog2_var_threshold: Annotated[
        float,
        Field(gt=0, description="mog2: squared Mahalanobis distance to count as foreground"),
    ] = 16.0
    knn_dist2_threshold: Annotated[
        float,
        Field(gt=0, description="knn: squared distance to the nearest samples for foreground"),
    ] = 400.0
    learning_rate: Annotated[
        float,
        Field(
            ge=-1,
            le=1,
            description="mog2/knn: model update rate per frame; -1 lets OpenCV choose (1/history)",
        ),
    ] = -1.0

    @field_validator("blur", "open_kernel", "close_kernel")
    @classmethod
    def _odd(cls, v: int, info: ValidationInfo) -> int:
        return _odd_or_zero(v, info.field_name or "kernel")

    @field_validator("output_size")
    @classmethod
    def _size_positive(cls, v: tuple[int, int] | None) -> tuple[int, int] | None:
        if v is not None and (v[0] <= 0 or v[1] <= 0):
            raise ValueError("width and height must be positive")
        return v

    @model_validator(mode="after")
    def _ratios(self) -> SegmentationConfig:
        if self.shadow_min_ratio >= self.shadow_max_ratio:
            raise ValueError("shadow_min_ratio must be below shadow_max_ratio")
        return self


@dataclass(frozen=True)
class Blob:
    """One connected foreground region, in full-resolution pixel coordinates.

    Attributes
    ----------
    label : int
        Its label in :attr:`Segmentation.labels` (>= 1).
    area : int
        Number of full-resolution pixels.
    area_fraction : float
        ``area`` divided by the image area.
    bbox : tuple of int
        ``(x, y, width, height)`` in pixels.
    centroid : tuple of float
        ``(x, y)`` in pixels.
    """

    label: int
    area: int
    area_fraction: float
    bbox: tuple[int, int, int, int]
    centroid: tuple[float, float]


@dataclass
class Segmentation:
    """The silhouette of one frame.

    Attributes
    ----------
    mask_full : numpy.ndarray
        bool (H, W): foreground at the frame's resolution, small blobs removed.
    mask : numpy.ndarray
        bool (h, w): the same at the likelihood resolution (``output_size``).
    blobs : list of Blob
        The blobs kept, largest first.
    labels : numpy.ndarray
        int32 (H, W): 0 for background, ``blob.label`` for each blob's pixels.
    empty : bool
        True when no blob reaches the minimum area (nobody in view).
    foreground : numpy.ndarray or None
        bool: the foreground before the clean-up, shadows removed, at the working resolution
        (or at the frame's, when given so to :meth:`Segmenter.from_foreground`); None after
        :func:`keep_blobs`.
    shadow : numpy.ndarray or None
        bool, as ``foreground``: the pixels the shadow test removed from it; None without a
        shadow test.
    """

    mask_full: np.ndarray
    mask: np.ndarray
    blobs: list[Blob]
    labels: np.ndarray
    foreground: np.ndarray | None = field(default=None, repr=False)
    shadow: np.ndarray | None = field(default=None, repr=False)
    empty: bool = field(init=False)

    def __post_init__(self) -> None:
        self.empty = len(self.blobs) == 0

    @property
    def output_size(self) -> tuple[int, int]:
        """(width, height) of :attr:`mask`."""
        return self.mask.shape[1], self.mask.shape[0]


def downscale_mask(mask: np.ndarray, size: tuple[int, int] | None) -> np.ndarray:
    """Downscale a bool mask (H, W) to ``size`` = (width, height) by majority.

    Area interpolation then a threshold at 0.5: a low-resolution pixel is foreground when at
    least half of the area it covers is. ``size`` None or equal to the mask's size returns a copy.
    """
    if size is None or (mask.shape[1], mask.shape[0]) == tuple(size):
        return mask.astype(bool, copy=True)
    small = cv2.resize(
        mask.astype(np.float32), (int(size[0]), int(size[1])), interpolation=cv2.INTER_AREA
    )
    return small >= 0.5


def keep_blobs(seg: Segmentation, blobs: Iterable[Blob | int]) -> Segmentation:
    """Restrict a segmentation to chosen blobs (by :class:`Blob` or label).

    Returns a new :class:`Segmentation` whose masks (both resolutions) hold only those blobs;
    the likelihood-resolution mask is re-derived by the same majority downscale. Used by a
    tracker to keep the person consistent with its track when several blobs are in view.
    """
    want = sorted({b.label if isinstance(b, Blob) else int(b) for b in blobs})
    known = {b.label for b in seg.blobs}
    unknown = [w for w in want if w not in known]
    if unknown:
        raise ValueError(f"labels {unknown} are not blobs of this segmentation")
    if not want:
        full = np.zeros_like(seg.mask_full)
    else:
        lut = np.zeros(int(seg.labels.max()) + 1, dtype=bool)
        lut[want] = True
        full = lut[seg.labels]
    labels = np.where(full, seg.labels, 0).astype(np.int32)
    kept = [b for b in seg.blobs if b.label in want]
    small = downscale_mask(full, seg.output_size)
    return Segmentation(mask_full=full, mask=small, blobs=kept, labels=labels)


def _as_bgr(img: np.ndarray, what: str) -> np.ndarray:
    """Validate an image and return it as uint8 (H, W, 3) BGR."""
    img = np.asarray(img)
    if img.dtype != np.uint8:
        raise SegmentationError(f"{what}: expected 8-bit pixels (uint8), got {img.dtype}")
    if img.ndim == 2:
        return cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if img.ndim == 3 and img.shape[2] == 3:
        return img
    if img.ndim == 3 and img.shape[2] == 4:
        return cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    if img.ndim == 3 and img.shape[2] == 1:
        return cv2.cvtColor(img[..., 0], cv2.COLOR_GRAY2BGR)
    raise SegmentationError(f"{what}: expected an image (H, W) or (H, W, 3), got {img.shape}")


def _upscaled_blobs(blobs: list[Blob], labels: np.ndarray, work_wh: tuple[int, int]) -> list[Blob]:
    """Blobs found at the working resolution, expressed in the full-resolution ``labels``.

    ``labels`` (int32, H x W) is the nearest-neighbour upscale of the working label image of
    size ``work_wh`` = (w, h). Areas are counted exactly; bounding boxes follow OpenCV's
    nearest mapping (full pixel X comes from working pixel floor(X * w / W)); centroids are
    scaled (exact for integer factors).
    """
    if not blobs:
        return []
    h_full, w_full = labels.shape
    fx, fy = w_full / work_wh[0], h_full / work_wh[1]
    if fx.is_integer() and fy.is_integer():  # each working pixel became fx x fy pixels
        area = {b.label: b.area * int(fx) * int(fy) for b in blobs}
    else:
        area = np.bincount(labels.ravel(), minlength=max(b.label for b in blobs) + 1)
    out = []
    for b in blobs:
        x, y, bw, bh = b.bbox
        x0, y0 = int(np.ceil(x * fx)), int(np.ceil(y * fy))
        x1, y1 = int(np.ceil((x + bw) * fx)), int(np.ceil((y + bh) * fy))
        cx, cy = b.centroid
        out.append(
            Blob(
                label=b.label,
                area=int(area[b.label]),
                area_fraction=float(area[b.label]) / (h_full * w_full),
                bbox=(x0, y0, x1 - x0, y1 - y0),
                centroid=((cx + 0.5) * fx - 0.5, (cy + 0.5) * fy - 0.5),
            )
        )
    return out


def _brightness(img: np.ndarray) -> np.ndarray:
    """B + G + R + 1 of a uint8 (H, W, 3) image as float32 (H, W)."""
    f = img.astype(np.float32)
    return f[..., 0] + f[..., 1] + f[..., 2] + _EPS


def _kernel(size: int) -> np.ndarray | None:
    if size <= 1:
        return None
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))


class Segmenter:
    """Turns frames of one camera into :class:`Segmentation` results.

    Parameters
    ----------
    config : SegmentationConfig
        The settings.
    background : numpy.ndarray, optional
        uint8 (H, W, 3) BGR or (H, W) grey image of the empty scene. Required in ``static``
        mode; in ``mog2``/``knn`` mode it seeds the model (otherwise the model starts from the
        first frame and learns as the footage goes).

    keep_shadow : bool
        Keep the pixels the shadow test removed on each result (:attr:`Segmentation.shadow`, for
        :meth:`with_shadow_given_back`); without, ``shadow`` is None and the frame is spared
        the bookkeeping.

    Notes
    -----
    One Segmenter per camera: the adaptive modes keep state between frames.
    """

    def __init__(
        self,
        config: SegmentationConfig,
        background: np.ndarray | None = None,
        *,
        keep_shadow: bool = True,
    ) -> None:
        self.config = config
        self.keep_shadow = bool(keep_shadow)
        self._bg: np.ndarray | None = None
        self._bg_blur: np.ndarray | None = None
        self._bg_chroma: np.ndarray | None = None
        self._bg_bright: np.ndarray | None = None
        self._model: cv2.BackgroundSubtractor | None = None
        self._seeded = False
        self._shape: tuple[int, ...] | None = None
        self._open = _kernel(config.open_kernel)
        self._close = _kernel(config.close_kernel)
        #: Margin (pixels) around the foreground's box that :meth:`clean` works in.
        self._margin = 2 * (config.open_kernel // 2 + config.close_kernel // 2) + 2
        if config.mode != "static":
            self._model = self._new_model()
        if background is not None:
            self.set_background(background)
        elif config.mode == "static":
            raise SegmentationError(
                "static segmentation needs an image of the empty scene (background)"
            )

    # -- set-up -----------------------------------------------------------------------------
    def _new_model(self) -> cv2.BackgroundSubtractor:
        c = self.config
        if c.mode == "mog2":
            m = cv2.createBackgroundSubtractorMOG2(
                history=c.history,
                varThreshold=c.mog2_var_threshold,
                detectShadows=c.shadow_suppression,
            )
            m.setShadowThreshold(c.shadow_min_ratio)
        else:
            m = cv2.createBackgroundSubtractorKNN(
                history=c.history,
                dist2Threshold=c.knn_dist2_threshold,
                detectShadows=c.shadow_suppression,
            )
            m.setShadowThreshold(c.shadow_min_ratio)
        return m

    def _seed(self) -> None:
        """Initialise the adaptive model from the background image, if one was given.

        The seeded model is treated as mature: frames then update it at ``1 / history`` (when
        ``learning_rate`` is -1) instead of OpenCV's fast start-up rate, which would absorb a
        person standing still within a few frames.
        """
        if self._bg is None or self._model is None:
            return
        img = self._bg_blur
        if self.config.mode == "mog2":
            self._model.apply(img, learningRate=1.0)
        else:  # KNN fills its sample buffers over several frames
            for _ in range(_KNN_SEED_FRAMES):
                self._model.apply(img, learningRate=-1)
        self._seeded = True

    @property
    def _rate(self) -> float:
        lr = self.config.learning_rate
        if lr < 0 and self._seeded:
            return 1.0 / self.config.history
        return lr

    def _work_size(self, width: int, height: int) -> tuple[int, int]:
        s = self.config.work_scale
        return max(1, round(width * s)), max(1, round(height * s))

    def _prepare(self, img: np.ndarray) -> np.ndarray:
        """Downscale to the working resolution, then blur (uint8 BGR in, uint8 BGR out)."""
        if self.config.work_scale < 1:
            img = cv2.resize(
                img, self._work_size(img.shape[1], img.shape[0]), interpolation=cv2.INTER_AREA
            )
        k = self.config.blur
        if k <= 1:
            return img
        return cv2.GaussianBlur(img, (k, k), 0)

    def set_background(self, background: np.ndarray) -> None:
        """Use ``background`` (the empty scene) as the reference (static) or seed (mog2/knn)."""
        bg = _as_bgr(background, "background image")
        self._bg = bg
        self._shape = bg.shape
        self._bg_blur = self._prepare(bg)
        bgf = self._bg_blur.astype(np.float32)
        self._bg_bright = _brightness(self._bg_blur)
        self._bg_chroma = bgf / self._bg_bright[..., None]
        if self._model is not None:
            self.reset()

    def learn(self, frames: Iterable[np.ndarray], learning_rate: float | None = None) -> None:
        """Feed frames of the empty scene to the adaptive model (mog2/knn only)."""
        if self._model is None:
            raise ValueError("learn() is for the mog2/knn modes; static mode uses the background")
        lr = self._rate if learning_rate is None else learning_rate
        for f in frames:
            img = _as_bgr(f, "frame")
            self._check_shape(img)
            self._model.apply(self._prepare(img), learningRate=lr)

    def reset(self) -> None:
        """Forget what the adaptive model learned (re-seeded by the background if given)."""
        if self._model is not None:
            self._model = self._new_model()
            self._seeded = False
            self._seed()

    # -- per frame --------------------------------------------------------------------------
    def _check_shape(self, img: np.ndarray) -> None:
        if self._shape is None:
            self._shape = img.shape
        elif img.shape != self._shape:
            what = "the background image's" if self._bg is not None else "the first frame's"
            raise SegmentationError(
                f"frame size {img.shape[1]}x{img.shape[0]} differs from {what} "
                f"{self._shape[1]}x{self._shape[0]}"
            )

    def raw_foreground(self, frame: np.ndarray) -> np.ndarray:
        """Foreground before clean-up, shadows already removed when asked.

        bool (h, w) at the working resolution (the frame's size times ``work_scale``).
        """
        return self._foreground(frame)[0]

    def _foreground(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """:meth:`raw_foreground` and the pixels the shadow test removed (None without one)."""
        img = _as_bgr(frame, "frame")
        self._check_shape(img)
        if self._model is not None:
            out = self._model.apply(self._prepare(img), learningRate=self._rate)
            # 255 foreground, 127 shadow (only when shadow detection is on), 0 background.
            keep = self.keep_shadow and self.config.shadow_suppression
            return out > 200, (out == 127 if keep else None)
        return self._static_foreground(img)

    def _static_foreground(self, img: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        c = self.config
        bgb = self._bg_blur
        assert bgb is not None and self._bg_bright is not None and self._bg_chroma is not None
        f = self._prepare(img)
        gain = 1.0
        ref = bgb
        if c.global_gain:
            # Median brightness ratio on a sparse grid: robust to the person (a minority).
            fs = _brightness(f[::4, ::4])
            gain = float(np.median(fs / self._bg_bright[::4, ::4]))
            ref = cv2.convertScaleAbs(bgb, alpha=gain)
        d = cv2.absdiff(f, ref)
        b, g, r = cv2.split(d)
        diff = cv2.max(cv2.max(b, g), r)
        fg = diff > c.threshold
        removed = None
        if c.shadow_suppression:
            if self.keep_shadow:
                removed = np.zeros_like(fg)
            # Only the candidate pixels need the shadow test.
            idx = np.flatnonzero(fg)
            if idx.size:
                # Column-wise arithmetic: numpy reductions over a length-3 axis are slow.
                fpx = f.reshape(-1, 3)[idx].astype(np.float32)
                bch = self._bg_chroma.reshape(-1, 3)[idx]
                fb = fpx[:, 0] + fpx[:, 1] + fpx[:, 2] + _EPS
                ratio = fb / (self._bg_bright.reshape(-1)[idx] * gain)
                chroma = np.abs(fpx[:, 0] / fb - bch[:, 0])
                for k in (1, 2):
                    np.maximum(chroma, np.abs(fpx[:, k] / fb - bch[:, k]), out=chroma)
                shadow = (
                    (ratio >= c.shadow_min_ratio)
                    & (ratio <= c.shadow_max_ratio)
                    & (chroma <= c.shadow_chroma_tol)
                )
                fg.reshape(-1)[idx[shadow]] = False
                if removed is not None:
                    removed.reshape(-1)[idx[shadow]] = True
        return fg, removed

    def clean(
        self, fg: np.ndarray, pixel_scale: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray, list[Blob]]:
        """Morphology and small-blob removal on a raw bool mask (h, w).

        ``pixel_scale`` is the mask's size relative to the frame (``min_blob_pixels`` counts
        frame pixels). Returns the cleaned mask, the label image (int32, blobs relabelled
        1..n largest first) and the blobs, all at the mask's resolution.
        """
        c = self.config
        m = fg.astype(np.uint8)
        h, w = m.shape
        # Work inside the foreground's bounding box, widened by a margin that the morphology
        # cannot cross (each opening or closing moves a border by at most its kernel's
        # radius, and the margin is at least twice that) and aligned on even rows and columns
        # (the labelling scans 2x2 blocks): the masks, labels and blob statistics are those of
        # the whole frame, bit for bit, at the cost of the person's box only.
        x, y, bw, bh = cv2.boundingRect(m)
        if bw == 0 or bh == 0:
            x0, y0, x1, y1 = 0, 0, min(w, 2), min(h, 2)
        else:
            x0 = max(x - self._margin, 0) & ~1
            y0 = max(y - self._margin, 0) & ~1
            x1 = min(x + bw + self._margin, w)
            y1 = min(y + bh + self._margin, h)
        sub = m[y0:y1, x0:x1]
        if self._open is not None:
            sub = cv2.morphologyEx(sub, cv2.MORPH_OPEN, self._open)
        if self._close is not None:
            sub = cv2.morphologyEx(sub, cv2.MORPH_CLOSE, self._close)
        n, labels, stats, cents = cv2.connectedComponentsWithStats(sub, connectivity=8)
        stats[:, cv2.CC_STAT_LEFT] += x0
        stats[:, cv2.CC_STAT_TOP] += y0
        if x0 or y0:
            # OpenCV's centroid is (sum of x) / area in float64; the crop's sums are integers
            # recovered exactly from its centroids, then shifted: the whole frame's division.
            area = np.maximum(stats[:, cv2.CC_STAT_AREA], 1).astype(np.float64)
            sums = np.rint(cents * area[:, None]) + area[:, None] * np.array([x0, y0])
            cents = sums / area[:, None]
        min_area = max(c.min_blob_fraction * h * w, float(c.min_blob_pixels) * pixel_scale**2, 1.0)
        areas = stats[1:, cv2.CC_STAT_AREA]
        keep = np.flatnonzero(areas >= min_area) + 1
        keep = keep[np.argsort(-stats[keep, cv2.CC_STAT_AREA], kind="stable")]
        lut = np.zeros(n, dtype=np.int32)
        lut[keep] = np.arange(1, keep.size + 1, dtype=np.int32)
        new_labels = np.zeros((h, w), dtype=np.int32)
        new_labels[y0:y1, x0:x1] = np.take(lut, labels)
        blobs = [
            Blob(
                label=i + 1,
                area=int(stats[k, cv2.CC_STAT_AREA]),
                area_fraction=float(stats[k, cv2.CC_STAT_AREA]) / (h * w),
                bbox=(
                    int(stats[k, cv2.CC_STAT_LEFT]),
                    int(stats[k, cv2.CC_STAT_TOP]),
                    int(stats[k, cv2.CC_STAT_WIDTH]),
                    int(stats[k, cv2.CC_STAT_HEIGHT]),
                ),
                centroid=(float(cents[k, 0]), float(cents[k, 1])),
            )
            for i, k in enumerate(keep)
        ]
        return new_labels > 0, new_labels, blobs

    def apply(self, frame: np.ndarray) -> Segmentation:
        """Segment one frame: uint8 (H, W, 3) BGR or (H, W) grey -> :class:`Segmentation`."""
        fg, shadow = self._foreground(frame)
        return self.from_foreground(fg, shadow=shadow)

    def with_shadow_given_back(
        self, seg: Segmentation, person: tuple[int, int, np.ndarray]
    ) -> Segmentation:
        """``seg`` with the pixels its shadow test removed given back where ``person`` covers
        them: ``(x, y, mask)``, a bool mask of the frame's pixels from ``(x, y)`` on (e.g. a
        2D pose detector's person segmentation, :meth:`tracker.detector2d.PoseDetector.
        person_pixels`). The clean-up and blobs are done again; ``seg`` itself when it keeps
        no shadow or none of it lies under the person."""
        if seg.foreground is None or seg.shadow is None or self._shape is None:
            return seg
        x, y, m = person
        m = np.asarray(m, dtype=bool)
        height, width = self._shape[:2]
        rows, cols = seg.shadow.shape
        if (rows, cols) != (height, width):  # the working resolution
            sx, sy = cols / width, rows / height
            x0, y0 = int(np.floor(x * sx)), int(np.floor(y * sy))
            x1 = int(np.ceil((x + m.shape[1]) * sx))
            y1 = int(np.ceil((y + m.shape[0]) * sy))
            if x1 <= x0 or y1 <= y0:
                return seg
            m = cv2.resize(
                m.astype(np.uint8), (x1 - x0, y1 - y0), interpolation=cv2.INTER_NEAREST
            ).astype(bool)
            x, y = x0, y0
        # The mask's part inside the image.
        cx0, cy0 = max(x, 0), max(y, 0)
        cx1, cy1 = min(x + m.shape[1], cols), min(y + m.shape[0], rows)
        if cx1 <= cx0 or cy1 <= cy0:
            return seg
        sub = m[cy0 - y : cy1 - y, cx0 - x : cx1 - x] & seg.shadow[cy0:cy1, cx0:cx1]
        if not sub.any():
            return seg
        fg = seg.foreground.copy()
        fg[cy0:cy1, cx0:cx1] |= sub
        shadow = seg.shadow.copy()
        shadow[cy0:cy1, cx0:cx1] &= ~sub
        return self.from_foreground(fg, shadow=shadow)

    def from_foreground(self, fg: np.ndarray, *, shadow: np.ndarray | None = None) -> Segmentation:
        """The clean-up, blobs and downscale of :meth:`apply` on a raw foreground mask: bool
        (h, w) at the frame's size or at the working resolution, e.g. a person mask from
        elsewhere (the benchmark's true masks, ``bench/accuracy.py --true-masks``). ``shadow``,
        of the same size: the pixels a shadow test removed from it (kept on the result for
        :meth:`with_shadow_given_back`)."""
        fg = np.asarray(fg, dtype=bool)
        if self._shape is None:
            raise SegmentationError("no frame size yet: give a background or segment a frame")
        height, width = self._shape[:2]
        work = self._work_size(width, height)
        if fg.shape not in ((height, width), (work[1], work[0])):
            raise SegmentationError(
                f"foreground mask {fg.shape[1]}x{fg.shape[0]} is neither the frame's "
                f"{width}x{height} nor the working resolution's {work[0]}x{work[1]}"
            )
        if fg.shape == (height, width):
            mask_full, labels, blobs = self.clean(fg)
            mask = downscale_mask(mask_full, self.config.output_size)
        else:  # worked at a reduced resolution: scale the result back up
            mask_w, labels_w, blobs_w = self.clean(fg, fg.shape[1] / width)
            mask = downscale_mask(mask_w, self.config.output_size)
            labels = cv2.resize(labels_w, (width, height), interpolation=cv2.INTER_NEAREST)
            mask_full = labels > 0
            blobs = _upscaled_blobs(blobs_w, labels, (fg.shape[1], fg.shape[0]))
        if shadow is not None:
            shadow = np.asarray(shadow, dtype=bool)
            if shadow.shape != fg.shape:
                raise SegmentationError(
                    f"shadow mask {shadow.shape[1]}x{shadow.shape[0]} is not the foreground's "
                    f"{fg.shape[1]}x{fg.shape[0]}"
                )
        if not blobs:
            log.debug("segmentation: no blob above the minimum area")
        return Segmentation(
            mask_full=mask_full, mask=mask, blobs=blobs, labels=labels, foreground=fg, shadow=shadow
        )
