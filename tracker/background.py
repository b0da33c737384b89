"""The empty scene estimated from the footage itself: the per-pixel median of sampled frames.

Static background subtraction needs an image of the empty scene. When none was taken, a walk
gives it away: a person who crosses the view covers each pixel in a minority of the frames, so
the per-pixel median over frames spread across the footage is the empty scene, with its noise
averaged out. This is for recorded footage, where every frame can be seen before tracking
starts (``gaitwatch track`` without ``--background``); OpenCV's adaptive models (segmentation
modes ``mog2``/``knn``) learn as the footage goes and miss the person while they learn.

Limits: a pixel the person covers in more than half of the samples (someone who stands or sits
in one place for more than half of the footage) takes the person's colours, and the person
there is lost to the silhouette; :func:`median_background` reports how many pixels are unsure.

Two pieces, pure computation on numpy arrays:

* :class:`FrameSampler` keeps frames evenly spaced over a stream of unknown length in one pass,
  within a memory budget (every other frame dropped, and the stride doubled, when full);
* :func:`median_background` takes the per-pixel median of the samples, band by band of rows so
  that its working memory stays a fraction of the samples'.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

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
        something stayed in one place for a good part of the footage).
    """

    image: np.ndarray
    n_samples: int
    unsure_fraction: float


def median_background(
    samples: Sequence[np.ndarray],
    *,
    tolerance: float = 30.0,
    agree: float = 0.8,
    band_bytes: int = 64 << 20,
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

    Raises
    ------
    ValueError
        No samples, shapes that differ, or not uint8.
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
    if n < MIN_GOOD_SAMPLES:
        log.warning(
            "background estimated from %d frame(s) only: a person in view in about half of "
            "them stays in it",
            n,
        )
    h = first.shape[0]
    row_bytes = max(1, first[0].nbytes * n)
    band = max(1, int(band_bytes // row_bytes))
    out = np.empty_like(first)
    unsure = counted = 0
    lo, hi = (n - 1) // 2, n // 2
    for r0 in range(0, h, band):
        r1 = min(h, r0 + band)
        stack = np.stack([np.asarray(s)[r0:r1] for s in samples])
        part = np.partition(stack, (lo, hi), axis=0)
        med = part[lo] if lo == hi else ((part[lo].astype(np.uint16) + part[hi] + 1) // 2)
        med = med.astype(np.uint8)
        out[r0:r1] = med
        # The unsure share on every other row and column: a quarter of the work.
        rows = np.arange(r0 + (r0 % 2), r1, 2) - r0
        sub = stack[:, rows, ::2].astype(np.int16)
        diff = np.abs(sub - med[rows, ::2].astype(np.int16))
        if diff.ndim == 4:
            diff = diff.max(axis=3)
        share = np.count_nonzero(diff <= tolerance, axis=0) / n
        unsure += int(np.count_nonzero(share < agree))
        counted += share.size
    return BackgroundEstimate(out, n, unsure / max(1, counted))
