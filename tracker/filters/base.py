"""The small interface every body-part filter implements, and the steps they share.

A filter holds a weighted particle set of poses (``(N, 31)``, :mod:`tracker.dof` layout) and
advances it one frame at a time against a likelihood::

    f = make_filter("ipf", config, rng=np.random.default_rng(0))
    f.initialise(poses, weights)          # from the exhaustive search (tracker.init)
    f.set_root(root)                      # body origin of this frame (tracker.origin)
    est = f.step(likelihood, dt=0.05)     # predict + measure; est.pose (31,), est.weight

The likelihood is anything with ``weights(poses (N, 31)) -> (N,)`` (and, optionally,
``weights_factored(base, left_leg, right_leg)``, see
:class:`tracker.likelihood.SilhouetteLikelihood`).
Every random draw comes from the injected ``numpy.random.Generator``; filters never do I/O.

Shared steps are plain functions (filterpy style): :func:`select_distinct`,
:func:`resample_systematic`, :func:`sigma_vector`, :func:`split_budget`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from tracker.dof import ANGLE_MASK, DOF, DOF_NAMES, N_DOF, ROOT_DOFS, clamp


@runtime_checkable
class Likelihood(Protocol):
    """What a filter needs from a likelihood: one weight per pose, larger is better."""

    def weights(self, poses: np.ndarray) -> np.ndarray:  # (N, 31) -> (N,)
        ...


@dataclass(frozen=True)
class Estimate:
    """The filter's estimate of one frame.

    Attributes
    ----------
    pose : ndarray, shape (31,)
        The heaviest particle (metres, radians).
    weight : float
        Its likelihood weight.
    """

    pose: np.ndarray
    weight: float


def select_distinct(poses: np.ndarray, weights: np.ndarray, m: int) -> np.ndarray:
    """Indices of the ``m`` heaviest distinct particles, heaviest first.

    Parameters
    ----------
    poses : ndarray, shape (N, D)
    weights : ndarray, shape (N,)
    m : int
        How many to keep; fewer are returned when there are fewer distinct poses.

    Returns
    -------
    ndarray of int, shape (min(m, distinct),)
        Sorted by decreasing weight (ties: lower index first). Among identical poses the
        heaviest one is kept.

    Notes
    -----
    Looks for duplicates among the ``4 m`` heaviest first (a partial sort), and over the whole
    set only when those hold fewer than ``m`` distinct poses.
    """
    w = np.asarray(weights, dtype=np.float64)
    n = w.shape[0]
    k = min(n, 4 * m)
    if k < n:
        kth = -np.partition(-w, k - 1)[k - 1]
        top = np.flatnonzero(w >= kth)  # every tie of the k-th weight too: exact order
        idx = _distinct_sorted(poses, w, top, m)
        if idx.size >= m:
            return idx
    return _distinct_sorted(poses, w, np.arange(n), m)


#: Odd multipliers of the row hash (:func:`_row_hashes`), one per column; fixed, not random.
_HASH_MULT = (np.random.default_rng(0x5E1EC7).integers(0, 2**62, size=N_DOF) * 2 + 1).astype(
    np.uint64
)


def _row_hashes(rows: np.ndarray) -> np.ndarray:
    """A uint64 hash of each row's bytes (N, D) float64 -> (N,): equal rows, equal hashes."""
    bits = rows.view(np.uint64)
    d = bits.shape[1]
    mult = _HASH_MULT[:d] if d <= _HASH_MULT.size else np.resize(_HASH_MULT, d)
    return (bits * mult).sum(axis=1, dtype=np.uint64)  # wraps modulo 2**64


def row_groups(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group identical rows (bytes equal) of ``rows`` (N, D) float64.

    Returns ``(first, group)``: the index of the first row of each group (in increasing order
    of an arbitrary group key, not of position) and the group of every row (into ``first``).
    The rows are grouped by a hash of their bytes (a sort of integers, much faster than one of
    byte strings); when some row differs from its group's first row (a hash collision) they are
    grouped by the bytes themselves. Exact either way.
    """
    r = np.ascontiguousarray(rows, dtype=np.float64)
    _, first, group = np.unique(_row_hashes(r), return_index=True, return_inverse=True)
    bits = r.view(np.uint64)
    if not np.array_equal(bits, bits[first[group]]):
        void = r.view(np.dtype((np.void, r.dtype.itemsize * r.shape[1]))).ravel()
        _, first, group = np.unique(void, return_index=True, return_inverse=True)
    return first, group


def _distinct_sorted(poses: np.ndarray, w: np.ndarray, cand: np.ndarray, m: int) -> np.ndarray:
    order = cand[np.lexsort((cand, -w[cand]))]  # weight descending, then index ascending
    first, _ = row_groups(poses[order])  # np.unique's first index is the first occurrence
    first.sort()
    return order[first[:m]]


def resample_systematic(weights: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling: ``n`` indices drawn in proportion to ``weights`` (one uniform draw).

    All-zero or non-finite weights resample uniformly.
    """
    w = np.asarray(weights, dtype=np.float64)
    w = np.where(np.isfinite(w) & (w > 0), w, 0.0)
    total = w.sum()
    if total <= 0:
        w = np.ones_like(w)
        total = float(w.size)
    cdf = np.cumsum(w / total)
    cdf[-1] = 1.0
    u = (rng.random() + np.arange(n)) / n
    return np.searchsorted(cdf, u, side="right").clip(0, w.size - 1)


def sigma_vector(sigma: Mapping[str, float], scale: float = 1.0) -> np.ndarray:
    """Per-DOF sigmas (metres / degrees, missing = 0) as a (31,) vector in metres / radians."""
    s = np.array([float(sigma.get(n, 0.0)) for n in DOF_NAMES], dtype=np.float64)
    s[ANGLE_MASK] = np.radians(s[ANGLE_MASK])
    return s * scale


def split_budget(total: int, parts: int) -> list[int]:
    """Split ``total`` evaluations into ``parts`` near-equal positive sizes summing to ``total``."""
    parts = max(1, min(parts, total))
    base, extra = divmod(total, parts)
    return [base + (1 if i < extra else 0) for i in range(parts)]


class Filter(ABC):
    """A particle filter over the 31 pose DOFs.

    Parameters
    ----------
    limits : (low (31,), high (31,))
        Joint limits in metres / radians (``JointLimits.arrays()``); every particle is clamped.
    rng : numpy.random.Generator
        The only source of randomness.
    reference_dt : float
        Frame interval (s) for which the configured motion magnitudes are stated.
    """

    name: ClassVar[str] = "filter"
    #: The attributes that carry the filter from frame to frame (:meth:`load_state`).
    STATE: ClassVar[tuple[str, ...]] = ("particles", "weights", "last_evaluations")

    def __init__(
        self,
        *,
        limits: tuple[np.ndarray, np.ndarray],
        rng: np.random.Generator,
        reference_dt: float = 0.05,
    ) -> None:
        self.low = np.asarray(limits[0], dtype=np.float64)
        self.high = np.asarray(limits[1], dtype=np.float64)
        if self.low.shape != (N_DOF,) or self.high.shape != (N_DOF,):
            raise ValueError("limits must be two (31,) arrays")
        self.rng = rng
        self.reference_dt = float(reference_dt)
        self.particles = np.zeros((0, N_DOF))
        self.weights = np.zeros(0)
        self.last_evaluations = 0

    # -- interface ------------------------------------------------------------------------
    @property
    @abstractmethod
    def evaluations_per_step(self) -> int:
        """Likelihood evaluations (poses weighed) in one :meth:`step`."""

    @abstractmethod
    def _step(self, likelihood: Likelihood, dt: float) -> None:
        """Predict and measure: replace ``self.particles`` and ``self.weights``."""

    def initialise(self, poses: np.ndarray, weights: np.ndarray | None = None) -> None:
        """Start from a weighted set of poses (K, 31), e.g. the initialisation search's best."""
        poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
        if poses.ndim != 2 or poses.shape[1] != N_DOF or poses.shape[0] == 0:
            raise ValueError(f"poses must have shape (K, {N_DOF}) with K >= 1, not {poses.shape}")
        if weights is None:
            weights = np.ones(poses.shape[0])
        weights = np.asarray(weights, dtype=np.float64)
        if weights.shape != (poses.shape[0],):
            raise ValueError("weights must have one value per pose")
        self.particles = self.clamp(poses.copy())
        self.weights = weights.copy()

    def inject(self, poses: np.ndarray, weights: np.ndarray, *, reset_motion: bool = False) -> None:
        """Add weighed poses (K, 31) to the current set (e.g. a refined or leg-swapped estimate).

        Unlike :meth:`initialise` the filter keeps its motion history, unless ``reset_motion``
        (the added poses are not a continuation of the previous estimates, e.g. swapped legs).
        """
        poses = self.clamp(np.atleast_2d(np.asarray(poses, dtype=np.float64)).copy())
        self.particles = np.concatenate([poses, self.particles])
        self.weights = np.concatenate([np.asarray(weights, dtype=np.float64), self.weights])

    def set_limits(self, limits: tuple[np.ndarray, np.ndarray]) -> None:
        """New joint limits (the tracker's seated mode); the particles are clamped to them."""
        low = np.asarray(limits[0], dtype=np.float64)
        high = np.asarray(limits[1], dtype=np.float64)
        if low.shape != (N_DOF,) or high.shape != (N_DOF,):
            raise ValueError("limits must be two (31,) arrays")
        self.low, self.high = low, high
        if self.particles.size:
            self.clamp(self.particles)

    def load_state(self, other: Filter) -> None:
        """Take over the particle set and motion history of ``other``, a filter of the same
        kind (a trial run with a smaller budget, whose result is adopted)."""
        if type(other) is not type(self):
            raise TypeError(f"cannot load a {other.name} filter's state into a {self.name} one")
        for key in self.STATE:
            value = getattr(other, key)
            setattr(self, key, value.copy() if hasattr(value, "copy") else value)

    @property
    def initialised(self) -> bool:
        return self.particles.shape[0] > 0

    def reverse_motion(self) -> None:
        """Time will now run backwards (a backward pass over earlier frames): turn any motion
        the filter predicts from its past estimates around. The random-walk filters keep none."""
        return None

    def set_root(self, root: np.ndarray) -> None:
        """Give every particle the body origin (6,) found for this frame (x, y, z, yaw, pitch,
        roll)."""
        r = np.zeros((1, N_DOF))
        r[0, list(ROOT_DOFS)] = np.asarray(root, dtype=np.float64)
        self.clamp(r)
        self.particles[:, list(ROOT_DOFS)] = r[0, list(ROOT_DOFS)]

    def step(self, likelihood: Likelihood, dt: float) -> Estimate:
        """Advance one frame of interval ``dt`` seconds; returns the heaviest particle."""
        if not self.initialised:
            raise RuntimeError(f"{self.name}: step() before initialise()")
        if not dt > 0:
            raise ValueError(f"dt must be positive, not {dt}")
        self._step(likelihood, float(dt))
        return self.estimate()

    def estimate(self) -> Estimate:
        """The heaviest particle of the current set."""
        i = int(np.argmax(self.weights))
        return Estimate(pose=self.particles[i].copy(), weight=float(self.weights[i]))

    # -- shared steps ---------------------------------------------------------------------
    def clamp(self, poses: np.ndarray) -> np.ndarray:
        """Clamp poses (..., 31) to the joint limits in place and return them."""
        return clamp(poses, self.low, self.high)

    def _diffuse(self, poses: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """Add white Gaussian noise of per-DOF ``sigma`` (31,) in place; DOFs with 0 untouched."""
        active = np.flatnonzero(sigma > 0)
        if active.size:
            noise = self.rng.standard_normal((poses.shape[0], active.size))
            poses[:, active] += noise * sigma[active]
        return poses

    def _weigh(self, likelihood: Likelihood, poses: np.ndarray) -> np.ndarray:
        w = np.asarray(likelihood.weights(poses), dtype=np.float64)
        if w.shape != (poses.shape[0],):
            raise ValueError(f"likelihood returned shape {w.shape} for {poses.shape[0]} poses")
        self.last_evaluations += poses.shape[0]
        return w


__all__ = [
    "DOF",
    "Estimate",
    "Filter",
    "Likelihood",
    "resample_systematic",
    "row_groups",
    "select_distinct",
    "sigma_vector",
    "split_budget",
]
