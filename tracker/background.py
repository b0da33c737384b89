"""The empty scene estimated from the footage itself: the per-pixel median of sampled frames.

Static background subtraction needs an image of the empty scene. When none was taken, a walk
gives it away: a person who crosses the view covers each pixel in a minority of the frames, so
the per-pixel median over frames spread across the footage is the empty scene, with its noise
averaged out. This is for recorded footage, where every frame can be seen before tracking
starts (``gaitwatch track`` without ``--background``); OpenCV's adaptive models (segmentation
modes ``mog2``/``knn``) learn as the footage goes and miss the person while they learn.

A pixel the person covers in more than half of the samples (someone who walks straight towards
the camera, turns on the spot or sits) would take the person's colours, and the person there
would be lost to the silhouette. So the 2D pose detector finds the person in each sample
(:func:`people_in_samples`) and the median is taken over the samples where nobody covers the
pixel; a pixel covered in nearly all of them is filled in from around it.
:func:`median_background` reports how many pixels are unsure and how many were filled in.

Pure computation on numpy arrays (OpenCV for the inpainting; the detector is given):

* :class:`FrameSampler` keeps frames evenly spaced over a stream of unknown length in one pass,
  within a memory budget (every other frame dropped, and the stride doubled, when full);
* :func:`median_background` takes the per-pixel median of the samples, band by band of rows so
  that its working memory stays a fraction of the samples', leaving out the pixels of each
  sample's :class:`PersonMask` (:func:`people_in_samples`);
* :class:`LightingStates` splits the samples by overall brightness when a light was switched
  during the footage (one median per lighting state), and :class:`LightingSwitch` hands each
  camera's segmentation the empty scene of the current frame's state.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

log = logging.getLogger(__name__)

#: Fewer samples than this give a noisy median; :func:`median_background` warns.
MIN_GOOD_SAMPLES = 9
#: Default :class:`FrameSampler` capacity: 32 to 64 frames spread over the footage.
DEFAULT_SAMPLES = 64
#: Default memory budget of the held frames per camera (about 40 frames of 1920 x 1080).
DEFAULT_MAX_BYTES = 256 << 20


class FrameSampler:
    """Keep frames evenly spaced over a stream whose length is not known in advance.

    Offer every frame in order with :meth:`offer`; the sampler keeps those whose number is a
    multiple of its stride. When ``capacity`` frames are held, every other one is dropped and the
    stride doubles. At the end it holds between ``capacity / 2`` and ``capacity`` frames (all of
    them for a stream shorter than ``capacity``) spread evenly over the stream.

    Parameters
    ----------
    capacity : int
        Most frames held (at least 2).
    max_bytes : int, optional
        Memory budget for the held frames: ``capacity`` is lowered to fit it at the first frame
        (never below 2).
    """

    def __init__(
        self, capacity: int = DEFAULT_SAMPLES, max_bytes: int | None = DEFAULT_MAX_BYTES
    ) -> None:
        if capacity < 2:
            raise ValueError(f"capacity must be >= 2, not {capacity}")
        if max_bytes is not None and max_bytes <= 0:
            raise ValueError(f"max_bytes must be > 0, not {max_bytes}")
        self.capacity = int(capacity)
        self.max_bytes = max_bytes
        self.stride = 1
        self.offered = 0
        self._kept: list[tuple[int, np.ndarray]] = []
        self._shape: tuple[int, ...] | None = None

    def offer(self, frame: np.ndarray) -> None:
        """Offer the next frame of the stream (kept as a copy when its number is sampled)."""
        frame = np.asarray(frame)
        if self._shape is None:
            self._shape = frame.shape
            if self.max_bytes is not None:
                fit = self.max_bytes // max(1, frame.nbytes)
                self.capacity = max(2, min(self.capacity, int(fit)))
        elif frame.shape != self._shape:
            raise ValueError(
                f"frame {self.offered} has shape {frame.shape}, the first had {self._shape}"
            )
        index = self.offered
        self.offered += 1
        if index % self.stride:
            return
        self._kept.append((index, frame.copy()))
        if len(self._kept) >= self.capacity:
            self.stride *= 2
            self._kept = [(i, f) for i, f in self._kept if i % self.stride == 0]

    @property
    def indices(self) -> list[int]:
        """Stream positions (0-based) of the frames held."""
        return [i for i, _ in self._kept]

    @property
    def frames(self) -> list[np.ndarray]:
        """The frames held, in stream order."""
        return [f for _, f in self._kept]


@dataclass(frozen=True)
class BackgroundEstimate:
    """The result of :func:`median_background`.

    Attributes
    ----------
    image : numpy.ndarray
        The estimated empty scene, the samples' dtype and shape.
    n_samples : int
        Frames the median was taken over.
    unsure_fraction : float
        Share of the pixels (every other row and column counted) where fewer than ``agree``
        of the samples lie within ``tolerance`` of the median (the scene changed there, or
        something stayed in one place for a good part of the footage). With people masked,
        the share is of the samples where the pixel was not masked, and a pixel filled in
        counts as unsure.
    filled_fraction : float
        Share of the pixels that a person covered in nearly every sample (fewer than
        ``min_valid`` samples left): no sample shows the scene there, and the image is filled
        in from around (OpenCV's inpainting).
    """

    image: np.ndarray
    n_samples: int
    unsure_fraction: float
    filled_fraction: float = 0.0


@dataclass(frozen=True)
class PersonMask:
    """Pixels of one sampled frame that a person covers, to be left out of the median.

    Attributes
    ----------
    x, y : int
        The frame's column and row of ``mask``'s top-left pixel.
    mask : numpy.ndarray
        bool (h, w): True where the person is.
    """

    x: int
    y: int
    mask: np.ndarray

    def rows(self, r0: int, r1: int, width: int) -> np.ndarray | None:
        """The mask over the frame's rows ``r0:r1`` (all ``width`` columns), or None when it
        covers none of them."""
        h, w = self.mask.shape
        a, b = max(r0, self.y), min(r1, self.y + h)
        c, d = max(0, self.x), min(width, self.x + w)
        if a >= b or c >= d:
            return None
        out = np.zeros((r1 - r0, width), dtype=bool)
        out[a - r0 : b - r0, c:d] = self.mask[a - self.y : b - self.y, c - self.x : d - self.x]
        return out if out.any() else None


def median_background(
    samples: Sequence[np.ndarray],
    *,
    tolerance: float = 30.0,
    agree: float = 0.8,
    band_bytes: int = 64 << 20,
    masks: Sequence[PersonMask | None] | None = None,
    min_valid: int | None = None,
) -> BackgroundEstimate:
    """The per-pixel median of ``samples`` (uint8 frames of one camera, same shape).

    Parameters
    ----------
    samples : sequence of numpy.ndarray
        (H, W, 3) or (H, W) uint8 frames spread over the footage (:class:`FrameSampler`).
    tolerance : float
        Grey levels within which a sample agrees with the median in every channel (for
        ``unsure_fraction``; the segmentation's own threshold is a good value).
    agree : float
        Share of the samples that must agree for a pixel to count as sure: below it, something
        other than the estimate was there in more than ``1 - agree`` of the footage (a person
        who lingered, or who stayed and took over the median while the scene showed through
        now and then; one who never moved cannot be told from the scene).
    band_bytes : int
        Rows are taken in bands of about this many bytes of samples, to bound the working
        memory.
    masks : sequence of PersonMask or None, optional
        Per sample, the pixels a person covers there (:func:`people_in_samples`), or None:
        each pixel's median is then taken over the samples where nobody covers it, so that
        someone who stays in one part of the view for most of the footage does not stay in
        its empty scene.
    min_valid : int, optional
        With ``masks``: a pixel left with fewer samples than this (default 3, or 5 % of the
        samples if more) is filled in from around it (OpenCV's Telea inpainting).

    Raises
    ------
    ValueError
        No samples, shapes that differ, not uint8, or not one mask (or None) per sample.
    """
    if len(samples) == 0:
        raise ValueError("no frames to estimate the background from")
    first = np.asarray(samples[0])
    if first.dtype != np.uint8:
        raise ValueError(f"frames must be uint8, not {first.dtype}")
    if first.ndim not in (2, 3):
        raise ValueError(f"frames must be (H, W) or (H, W, C), not shape {first.shape}")
    for k, s in enumerate(samples):
        if np.shape(s) != first.shape:
            raise ValueError(f"frame {k} has shape {np.shape(s)}, the first has {first.shape}")
    n = len(samples)
    if masks is not None and len(masks) != n:
        raise ValueError(f"{len(masks)} person masks for {n} frames")
    if masks is not None and all(m is None for m in masks):
        masks = None
    if min_valid is None:
        min_valid = max(3, int(np.ceil(0.05 * n)))
    if n < MIN_GOOD_SAMPLES:
        log.warning(
            "background estimated from %d frame(s) only: a person in view in about half of "
            "them stays in it",
            n,
        )
    h, w = first.shape[:2]
    row_bytes = max(1, first[0].nbytes * n)
    band = max(1, int(band_bytes // row_bytes))
    out = np.empty_like(first)
    holes = np.zeros((h, w), dtype=bool)
    unsure = counted = 0
    lo, hi = (n - 1) // 2, n // 2
    for r0 in range(0, h, band):
        r1 = min(h, r0 + band)
        stack = np.stack([np.asarray(s)[r0:r1] for s in samples])
        part = np.partition(stack, (lo, hi), axis=0)
        med = part[lo] if lo == hi else ((part[lo].astype(np.uint16) + part[hi] + 1) // 2)
        med = med.astype(np.uint8)
        excluded = None if masks is None else _excluded(masks, r0, r1, w)
        if excluded is not None:
            holes[r0:r1] = _masked_median(stack, excluded, med) < min_valid
        out[r0:r1] = med
        # The unsure share on every other row and column: a quarter of the work.
        rows = np.arange(r0 + (r0 % 2), r1, 2) - r0
        sub = stack[:, rows, ::2].astype(np.int16)
        diff = np.abs(sub - med[rows, ::2].astype(np.int16))
        if diff.ndim == 4:
            diff = diff.max(axis=3)
        close = diff <= tolerance
        if excluded is None:
            share = np.count_nonzero(close, axis=0) / n
        else:
            seen = ~excluded[:, rows, ::2]
            n_seen = np.count_nonzero(seen, axis=0)
            share = np.count_nonzero(close & seen, axis=0) / np.maximum(n_seen, 1)
            share[n_seen < min_valid] = 0.0
        unsure += int(np.count_nonzero(share < agree))
        counted += share.size
    filled = float(holes.mean())
    if filled > 0:
        # Grown a little: beside the pixels the person covers in every sample, the few
        # samples left are the least clean.
        r = max(1, round(0.004 * max(h, w)))
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        grown = cv2.dilate(holes.astype(np.uint8), kernel)
        out = cv2.inpaint(out, grown, 2 * r + 1, cv2.INPAINT_TELEA)
    return BackgroundEstimate(out, n, unsure / max(1, counted), filled)


def _excluded(
    masks: Sequence[PersonMask | None], r0: int, r1: int, width: int
) -> np.ndarray | None:
    """bool (n, r1 - r0, width): True where sample k's person covers the pixel; None when no
    mask covers these rows."""
    rows = [None if m is None else m.rows(r0, r1, width) for m in masks]
    if all(r is None for r in rows):
        return None
    out = np.zeros((len(masks), r1 - r0, width), dtype=bool)
    for k, r in enumerate(rows):
        if r is not None:
            out[k] = r
    return out


def _masked_median(stack: np.ndarray, excluded: np.ndarray, med: np.ndarray) -> np.ndarray:
    """Replace ``med`` (rows, w[, c]), in place, by the median of the samples of ``stack``
    (n, rows, w[, c]) not ``excluded`` (n, rows, w) wherever a sample is excluded; returns the
    number of samples left per pixel (rows, w)."""
    n = stack.shape[0]
    valid = n - np.count_nonzero(excluded, axis=0)
    ys, xs = np.nonzero(valid < n)
    if len(ys) == 0:
        return valid
    sub = stack[:, ys, xs]  # (n, K[, c]), a copy
    # Excluded samples sort after every other (a 255 among the rest is the same value).
    sub[excluded[:, ys, xs]] = 255
    sub.sort(axis=0)
    m = valid[ys, xs]
    lo = np.maximum((m - 1) // 2, 0)[None]
    hi = np.minimum(m // 2, n - 1)[None]
    if sub.ndim == 3:
        lo = np.repeat(lo[..., None], sub.shape[2], axis=2)
        hi = np.repeat(hi[..., None], sub.shape[2], axis=2)
    a = np.take_along_axis(sub, lo, axis=0)[0].astype(np.uint16)
    b = np.take_along_axis(sub, hi, axis=0)[0]
    med[ys, xs] = ((a + b + 1) // 2).astype(np.uint8)
    return valid


def brightness_gain(frame: np.ndarray, reference: np.ndarray, step: int = 4) -> float:
    """How much brighter ``frame`` is than ``reference`` overall: the median, over a sparse grid
    of pixels (every ``step``-th row and column), of their brightness ratio (sum over the
    channels). Robust to a person, who covers a minority of the pixels."""
    f = np.asarray(frame)[::step, ::step].astype(np.float32)
    r = np.asarray(reference)[::step, ::step].astype(np.float32)
    if f.ndim == 3:
        f, r = f.sum(axis=2), r.sum(axis=2)
    return float(np.median((f + 1.0) / (r + 1.0)))


class LightingStates:
    """The empty scene under each of the footage's lighting states (a lamp on, then off).

    The samples' brightness relative to their overall median (:func:`brightness_gain`) tells
    the states apart: sorted, the gains are split at every gap wider than ``min_step`` (as a
    ratio), and each group of at least ``min_samples`` samples gets its own median. A frame is
    then subtracted from the state whose gain is nearest its own (:meth:`for_frame`). With one
    state (no gap; slow drifts stay within one) this is :func:`median_background` of all
    samples.

    Parameters
    ----------
    samples : sequence of numpy.ndarray
        The sampled frames (:class:`FrameSampler`).
    min_step : float
        Smallest jump of relative brightness between two states (0.15: 15 %).
    min_samples : int
        Fewest samples a state needs; smaller groups join their nearer neighbour.
    tolerance, agree, masks
        As for :func:`median_background`.

    Attributes
    ----------
    overall : BackgroundEstimate
        The median of every sample.
    gains : list of float
        Each state's median gain relative to ``overall``, increasing.
    states : list of BackgroundEstimate
        Each state's estimate, in the order of ``gains``.
    first : int
        The state of the first sample.
    sample_states : list of int
        The state of each sample.
    """

    def __init__(
        self,
        samples: Sequence[np.ndarray],
        *,
        min_step: float = 0.15,
        min_samples: int = MIN_GOOD_SAMPLES,
        tolerance: float = 30.0,
        agree: float = 0.8,
        masks: Sequence[PersonMask | None] | None = None,
    ) -> None:
        if min_step <= 0 or min_samples < 1:
            raise ValueError("min_step must be > 0 and min_samples >= 1")
        self.overall = median_background(samples, tolerance=tolerance, agree=agree, masks=masks)
        ref = self.overall.image
        gains = np.array([brightness_gain(s, ref) for s in samples])
        order = np.argsort(gains)
        groups: list[list[int]] = [[int(order[0])]]
        for a, b in zip(order[:-1], order[1:], strict=True):
            if gains[b] > gains[a] * (1.0 + min_step):
                groups.append([])
            groups[-1].append(int(b))
        # Too small a group joins its nearer neighbour (in gain).
        while len(groups) > 1 and min(len(g) for g in groups) < min_samples:
            k = min(range(len(groups)), key=lambda i: len(groups[i]))
            if k == 0:
                j = 1
            elif k == len(groups) - 1:
                j = k - 1
            else:
                lo = gains[groups[k][0]] / gains[groups[k - 1][-1]]
                hi = gains[groups[k + 1][0]] / gains[groups[k][-1]]
                j = k - 1 if lo <= hi else k + 1
            groups[j] = sorted(groups[j] + groups[k], key=lambda i: gains[i])
            del groups[k]
        #: The state of the first sample (the footage's first frame, for a FrameSampler's).
        self.first = next(k for k, g in enumerate(groups) if 0 in g)
        self.sample_states = [0] * len(samples)
        for k, g in enumerate(groups):
            for i in g:
                self.sample_states[i] = k
        if len(groups) == 1:
            self.states = [self.overall]
            self.gains = [float(np.median(gains))]
        else:
            self.states = [
                median_background(
                    [samples[i] for i in g],
                    tolerance=tolerance,
                    agree=agree,
                    masks=None if masks is None else [masks[i] for i in g],
                )
                for g in groups
            ]
            self.gains = [float(np.median(gains[g])) for g in groups]

    @property
    def unsure_fraction(self) -> float:
        """The largest share of unsure pixels among the states."""
        return max(s.unsure_fraction for s in self.states)

    @property
    def filled_fraction(self) -> float:
        """The largest share of filled-in pixels among the states."""
        return max(s.filled_fraction for s in self.states)

    def state_of(self, frame: np.ndarray) -> int:
        """Index of the state whose gain is nearest ``frame``'s (in ratio)."""
        if len(self.states) == 1:
            return 0
        g = brightness_gain(frame, self.overall.image)
        return int(np.argmin([abs(np.log(g / s)) for s in self.gains]))

    def for_frame(self, frame: np.ndarray) -> np.ndarray:
        """The empty scene to subtract from ``frame``."""
        return self.states[self.state_of(frame)].image


def people_in_samples(
    samples: Sequence[np.ndarray],
    backgrounds: Sequence[np.ndarray],
    detector,
    config=None,
    *,
    max_people: int = 3,
    min_share: float = 0.25,
) -> list[PersonMask | None]:
    """Per sample, the pixels of the people in it, for :func:`median_background`'s ``masks``.

    Where to look comes from a first estimate: each sample is segmented against its own
    ``backgrounds[k]`` (the plain median of its lighting state), and the 2D pose detector
    (:meth:`tracker.detector2d.PoseDetector.person_mask`) gives the person's pixels around the
    foreground's box. The detector does not need the background to be right: where the first
    median still holds the person (someone who stayed in one part of the view), the foreground
    is the part of them that moved, and the detector finds the whole person around it. The
    detector looks first at the box of all the foreground; then, while a blob of at least
    ``min_share`` of the largest one's area lies outside the people found so far, at the box of
    those blobs (up to ``max_people`` looks per sample, until one finds nobody).

    Parameters
    ----------
    samples : sequence of numpy.ndarray
        uint8 BGR frames (H, W, 3).
    backgrounds : sequence of numpy.ndarray
        Per sample, the empty scene to segment it against (the same image may repeat).
    detector : tracker.detector2d.PoseDetector
        The detector (its model loaded on first use).
    config : tracker.segmentation.SegmentationConfig, optional
        The segmentation's settings (the defaults when None); always the ``static`` mode.

    Returns
    -------
    list of PersonMask or None
        None for a sample without foreground. Where something moved but the detector's first
        look saw nobody (a person too small, half out of view, or not a person), the square
        crop around the foreground's box is left out instead.
    """
    from tracker.detector2d import silhouette_box
    from tracker.segmentation import SegmentationConfig, Segmenter

    if len(samples) != len(backgrounds):
        raise ValueError(f"{len(backgrounds)} backgrounds for {len(samples)} frames")
    config = (config or SegmentationConfig()).model_copy(update={"mode": "static"})
    segmenters: dict[int, Segmenter] = {}
    out: list[PersonMask | None] = []
    for frame, bg in zip(samples, backgrounds, strict=True):
        seg = segmenters.get(id(bg))
        if seg is None:
            seg = segmenters[id(bg)] = Segmenter(config, bg)
        s = seg.apply(frame)
        if s.empty:
            out.append(None)
            continue
        # The box of every blob first; then, while a person-sized blob lies outside the
        # people found so far (a second person: a visitor, a carer), the box of those left.
        found: list[tuple[int, int, np.ndarray]] = []
        pending = list(s.blobs)
        least = min_share * s.blobs[0].area
        while pending and len(found) < max_people:
            box = silhouette_box(pending)
            person = detector.person_mask(frame, box)
            if person is None:
                if not found:  # something moved, the detector saw nobody: leave out its crop
                    scale = getattr(detector, "crop_scale", 1.3)
                    found.append(_square_around(box, scale, frame.shape))
                # Later, nobody is more likely where the first median still holds the person
                # (a "ghost", whose pixels show the scene in this sample): left in.
                break
            found.append(person)
            pending = [b for b in pending if b.area >= least and not _covers(person, b.centroid)]
        out.append(_union(found))
    return out


def _covers(person: tuple[int, int, np.ndarray], point: tuple[float, float]) -> bool:
    """Whether the pixel at ``point`` ``(x, y)`` lies in ``(x, y, mask)``."""
    x, y, m = person
    c, r = int(round(point[0])) - x, int(round(point[1])) - y
    return bool(0 <= r < m.shape[0] and 0 <= c < m.shape[1] and m[r, c])


def _union(people: list[tuple[int, int, np.ndarray]]) -> PersonMask:
    """One :class:`PersonMask` over the box of every ``(x, y, mask)``."""
    if len(people) == 1:
        return PersonMask(*people[0])
    x0 = min(x for x, _, _ in people)
    y0 = min(y for _, y, _ in people)
    x1 = max(x + m.shape[1] for x, _, m in people)
    y1 = max(y + m.shape[0] for _, y, m in people)
    out = np.zeros((y1 - y0, x1 - x0), dtype=bool)
    for x, y, m in people:
        out[y - y0 : y - y0 + m.shape[0], x - x0 : x - x0 + m.shape[1]] |= m
    return PersonMask(x0, y0, out)


def _square_around(
    box: tuple[int, int, int, int], scale: float, shape: tuple[int, ...]
) -> tuple[int, int, np.ndarray]:
    """``(x, y, mask)``: the square ``scale`` times the box's longer side around its centre,
    within the frame."""
    x, y, w, h = box
    side = scale * max(w, h)
    x0 = int(np.clip(np.floor(x + 0.5 * w - 0.5 * side), 0, shape[1]))
    y0 = int(np.clip(np.floor(y + 0.5 * h - 0.5 * side), 0, shape[0]))
    x1 = int(np.clip(np.ceil(x + 0.5 * w + 0.5 * side), 0, shape[1]))
    y1 = int(np.clip(np.ceil(y + 0.5 * h + 0.5 * side), 0, shape[0]))
    return x0, y0, np.ones((y1 - y0, x1 - x0), dtype=bool)


class LightingSwitch:
    """Keeps each camera's segmentation on the empty scene of the current frame's lighting state.

    Parameters
    ----------
    states : sequence of LightingStates or None
        Per camera (None: a camera whose background is given or learned, left alone).
    """

    def __init__(self, states: Sequence[LightingStates | None]) -> None:
        self.states = list(states)
        self.current = [None if s is None else s.first for s in self.states]
        #: Frames at which some camera changed state, with the camera and the new state.
        self.changes: list[tuple[int, int, int]] = []
        self._frames = 0

    def initial(self) -> list[np.ndarray | None]:
        """Per camera, the background to start from (the first frame's state), or None."""
        return [None if s is None else s.states[s.first].image for s in self.states]

    def apply(self, tracker, frames: Sequence[np.ndarray]) -> None:
        """Before ``frames`` (one per camera) are segmented: give each camera whose lighting
        state changed its state's empty scene (``tracker.set_background``)."""
        index = self._frames
        self._frames += 1
        for c, (st, frame) in enumerate(zip(self.states, frames, strict=True)):
            if st is None or len(st.states) == 1:
                continue
            k = st.state_of(frame)
            if k != self.current[c]:
                tracker.set_background(c, st.states[k].image)
                self.current[c] = k
                self.changes.append((index, c, k))
                log.info(
                    "camera %d: the light changed at frame %d (state %d of %d, brightness %.2f)",
                    c,
                    index,
                    k + 1,
                    len(st.states),
                    st.gains[k],
                )
