"""Interval Particle Filtering (IPF), as issue 3 describes the method.

Each frame:

1. **Selection** — sort the previous particles by weight and keep the M heaviest *distinct* ones
   (fewer distinct ones are cycled to keep M groups; their noise makes them differ).
2. **Prediction** — split the DOFs into L, the n "interesting" ones (default both hips' and both
   knees' flexion) and R, the rest. Each kept particle gets white Gaussian noise on R (one draw
   per kept particle, shared by its group), then L is replaced by a deterministic grid of q values
   per DOF inside an interval of width ``w * dt / 0.05`` around its value (shifted to lie inside
   the joint limits, so the q values stay distinct and legal), giving I = q^n neighbours per kept
   particle, N = M * I particles. Every particle is clamped to the joint limits.
3. **Measure** — weigh every particle; the estimate is the heaviest.

Defaults that go beyond the method as published (each can be switched back, see
``docs/tracker.md``):

* ``refine_share``: coarse-to-fine within the same budget. The first pass spends
  ``M1 = M - M2`` groups on intervals ``coarse_factor`` times wider; the second pass spends
  ``M2 = round(refine_share * M)`` groups on the M2 heaviest distinct particles of the first pass
  with intervals one first-pass grid step wide (half the noise on R). Still N = M * I evaluations
  (0: one pass, the method).
* ``max_per_group``: the selection keeps at most this many particles of one group of the last
  frame while other distinct particles remain (0: the M heaviest distinct, the method).

Options off by default (the method's intervals did better on the accuracy benchmark's fresh
draws, ``docs/tracker.md``):

* ``interval_centre="velocity"``: the interval centres move by the damped change of the
  estimate's L values over the last frame (a constant-velocity prediction, not learned dynamics),
  so that fast swing phases are not limited to ``w / 2`` per frame (``"value"``: the method).
* ``adaptive_width``: an interval is widened to ``adaptive_width`` times the DOF's change over the
  last frame (the observed joint speed), never narrower than ``interval_deg`` and never wider
  than ``max_interval_deg`` (0: fixed widths, the method).
* ``anneal`` (measured in session 46, ``docs/tracker.md``): an annealing stage after the grid
  passes. ``anneal_groups`` of the ``kept`` groups (``anneal.share`` of them) give their
  evaluations to ``anneal.layers`` layers, each resampled from the last weights annealed to
  ``anneal.survival_rate`` (the first layer from the grid passes' particles), diffused on every
  DOF, the root included (the baselines' random-walk sigmas times ``anneal.sigma_scale``,
  shrinking by the square root of the survival rate per layer; ``anneal.move_interesting``
  false leaves L as the grid set it) and weighed; the layers' particles join the frame's set,
  so the estimate and the next selection take the heaviest of all. Still ``kept * I``
  evaluations. The tracker turns it off below ``anneal.min_cameras`` cameras. ``share = 0``
  (the default): off, the method.

Structure exploited where exact: the I particles of a group share R, so they share the upper body
and pelvis, and (when L holds only leg DOFs) the left-leg and right-leg variants combine
independently — the likelihood's ``weights_factored(base (M,31), left (M,A,6), right (M,B,6))``
weighs the A * B = I combinations of each group from A + B leg renderings. Otherwise
``weights()`` weighs all N poses.

Particle order: group m occupies rows ``m*I .. (m+1)*I - 1``; inside a group the grid index is the
C-order product over L sorted as (left-leg DOFs, right-leg DOFs, others), i.e. ``a * B + b``.
"""

from __future__ import annotations

import numpy as np

from tracker.config import IPFConfig, _default_sigmas
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, ROOT_DOFS
from tracker.filters.apf import annealed, annealing_exponent, annealing_layers
from tracker.filters.base import (
    Filter,
    Likelihood,
    row_groups,
    select_distinct,
    sigma_vector,
    split_budget,
)


class IntervalParticleFilter(Filter):
    """Interval Particle Filtering over the 31 pose DOFs (see the module docstring)."""

    name = "ipf"
    STATE = (*Filter.STATE, "_history", "_last_dt", "used_factored")

    def __init__(
        self,
        config: IPFConfig | None = None,
        *,
        limits: tuple[np.ndarray, np.ndarray],
        rng: np.random.Generator,
        reference_dt: float = 0.05,
    ) -> None:
        super().__init__(limits=limits, rng=rng, reference_dt=reference_dt)
        self.config = config or IPFConfig()
        c = self.config
        left = [DOF[n] for n in c.interesting if DOF[n] in LEFT_LEG]
        right = [DOF[n] for n in c.interesting if DOF[n] in RIGHT_LEG]
        other = [DOF[n] for n in c.interesting if DOF[n] not in LEFT_LEG + RIGHT_LEG]
        #: L in grid order: left-leg DOFs, right-leg DOFs, others.
        self.L = np.array(left + right + other, dtype=np.intp)
        self.n_left, self.n_right, self.n_other = len(left), len(right), len(other)
        self.R = np.array([i for i in range(N_DOF) if i not in set(self.L)], dtype=np.intp)
        self.q = c.q
        self.I = c.q ** len(self.L)
        #: M: the grid passes' groups; the annealing stage takes the other kept groups' share.
        self.M = c.kept - c.anneal_groups
        #: Evaluations per frame of the annealing stage (0: none) and its layers' sizes.
        self.anneal_sizes = (
            split_budget(c.anneal_groups * self.I, c.anneal.layers) if c.anneal_groups else []
        )
        #: The annealing stage's first-layer sigma per DOF at the reference dt.
        self.anneal_sigma = sigma_vector(_default_sigmas(), c.anneal.sigma_scale)
        if not c.anneal.move_interesting:
            self.anneal_sigma[self.L] = 0.0
        widths = np.array(
            [c.interval_overrides_deg.get(n, c.interval_deg) for n in self._names(self.L)]
        )
        self.widths = np.radians(widths)  # (n,) at the reference dt
        sig = sigma_vector(c.sigma)
        sig[self.L] = 0.0
        self.sigma = sig
        # (I, n) grid index of each neighbour, C order over L.
        self.combos = np.stack(
            np.unravel_index(np.arange(self.I), (self.q,) * len(self.L)), axis=1
        ).astype(np.intp)
        self.used_factored = False
        self._history: list[np.ndarray] = []  # L values of the last two estimates
        self._last_dt = reference_dt

    @staticmethod
    def _names(idx: np.ndarray) -> list[str]:
        from tracker.dof import DOF_NAMES

        return [DOF_NAMES[i] for i in idx]

    @property
    def evaluations_per_step(self) -> int:
        return self.M * self.I + sum(self.anneal_sizes)

    # -- steps ----------------------------------------------------------------------------
    def select(self) -> np.ndarray:
        """The M kept particles (M, 31): heaviest distinct first, cycled if fewer.

        With ``max_per_group`` > 0, at most that many of them share the same R values (the same
        group of the last frame) while other distinct particles remain (diversity).
        """
        cap = self.config.max_per_group
        if cap > 0:
            idx = select_distinct(self.particles, self.weights, self.M * cap)
            _, group = row_groups(self.particles[idx][:, self.R])  # the rank needs no order
            order = np.argsort(group, kind="stable")
            g_sorted = group[order]
            first = np.searchsorted(g_sorted, g_sorted, side="left")
            rank = np.empty_like(group)
            rank[order] = np.arange(group.size) - first  # rank inside its group, by weight
            ok = rank < cap
            idx = np.concatenate([idx[ok], idx[~ok]])[: self.M]
        else:
            idx = select_distinct(self.particles, self.weights, self.M)
        if idx.size < self.M:
            idx = np.resize(idx, self.M)
        return self.particles[idx].copy()

    def interval_widths(self, dt: float) -> np.ndarray:
        """Interval width (n,) of every L DOF at frame interval ``dt``, radians.

        ``interval_deg`` scaled with ``dt / 0.05``, widened to ``adaptive_width`` times the
        DOF's change over the last frame (scaled to ``dt``), at most ``max_interval_deg``
        (scaled), never narrower than the scaled ``interval_deg``.
        """
        scale = dt / self.reference_dt
        w = self.widths * scale
        c = self.config
        if c.adaptive_width > 0 and len(self._history) >= 2:
            change = np.abs(self._history[-1] - self._history[-2]) * (dt / self._last_dt)
            cap = np.radians(c.max_interval_deg) * scale
            w = np.maximum(w, np.minimum(c.adaptive_width * change, np.maximum(cap, w)))
        return w

    def interval_values(
        self, centres: np.ndarray, dt: float, widths: np.ndarray | None = None
    ) -> np.ndarray:
        """Grid values (M, n, q) of the L DOFs around ``centres`` (M, n), inside the limits.

        ``widths`` (n,) in radians at this ``dt``; default ``interval_deg`` scaled with
        ``dt / 0.05``.
        """
        w = self.widths * (dt / self.reference_dt) if widths is None else np.asarray(widths)
        lo, hi = self.low[self.L], self.high[self.L]
        w = np.minimum(w, hi - lo)
        offsets = np.linspace(-0.5, 0.5, self.q) if self.q > 1 else np.zeros(1)
        start = np.clip(centres - w / 2, lo, hi - w)  # interval shifted inside the limits
        vals = (start + w / 2)[:, :, None] + offsets[None, None, :] * w[None, :, None]
        return np.clip(vals, lo[None, :, None], hi[None, :, None])

    def initialise(self, poses: np.ndarray, weights: np.ndarray | None = None) -> None:
        super().initialise(poses, weights)
        self._history = []

    def inject(self, poses: np.ndarray, weights: np.ndarray, *, reset_motion: bool = False) -> None:
        super().inject(poses, weights, reset_motion=reset_motion)
        best = self.particles[int(np.argmax(self.weights)), self.L].copy()
        if reset_motion or not self._history:
            self._history = [best]
        else:
            self._history[-1] = best

    def reverse_motion(self) -> None:
        """The last two estimates in the other order: the velocity-centred intervals and the
        adaptive widths then follow the motion backwards."""
        self._history = self._history[::-1]

    def velocity_shift(self, dt: float) -> np.ndarray:
        """Shift (n,) of the interval centres: 0 for ``interval_centre="value"`` (the method)."""
        if self.config.interval_centre != "velocity" or len(self._history) < 2:
            return np.zeros(len(self.L))
        prev, last, last_dt = self._history[-2], self._history[-1], self._last_dt
        return self.config.velocity_damping * (last - prev) * (dt / last_dt)

    def predict(
        self,
        kept: np.ndarray,
        dt: float,
        *,
        widths: np.ndarray | None = None,
        shift: np.ndarray | None = None,
        sigma_factor: float = 1.0,
    ) -> np.ndarray:
        """The predicted particles (m * I, 31) from kept ones (m, 31).

        Parameters
        ----------
        kept : ndarray, shape (m, 31)
        dt : float
            Frame interval, s.
        widths : ndarray, shape (n,), optional
            Interval widths in radians (default: ``interval_deg`` scaled with ``dt / 0.05``).
        shift : ndarray, shape (n,), optional
            Shift of the interval centres (default :meth:`velocity_shift`).
        sigma_factor : float
            Factor on the white noise on R (0: none).
        """
        m = kept.shape[0]
        base = kept.copy()
        if sigma_factor > 0:
            base = self._diffuse(base, self.sigma * (sigma_factor * dt / self.reference_dt))
        self.clamp(base)
        centres = base[:, self.L] + (self.velocity_shift(dt) if shift is None else shift)
        vals = self.interval_values(centres, dt, widths)  # (m, n, q)
        out = np.repeat(base[:, None, :], self.I, axis=1)  # (m, I, 31)
        for k, dof in enumerate(self.L):
            out[:, :, dof] = vals[:, k, self.combos[:, k]]
        # Inside the limits by construction: base is clamped, the grid values are clipped.
        return out.reshape(m * self.I, N_DOF)

    def measure(self, likelihood: Likelihood, particles: np.ndarray) -> np.ndarray:
        """Weights (M * I,) of the predicted particles, factored by legs where exact."""
        factored = getattr(likelihood, "weights_factored", None)
        self.used_factored = False
        if (
            self.config.factored
            and factored is not None
            and self.n_other == 0
            and (self.n_left + self.n_right) > 0
        ):
            a, b = self.q**self.n_left, self.q**self.n_right
            m = particles.shape[0] // self.I
            grid = particles.reshape(m, a, b, N_DOF)
            base = np.ascontiguousarray(grid[:, 0, 0, :])
            left = np.ascontiguousarray(grid[:, :, 0, :][:, :, list(LEFT_LEG)])
            right = np.ascontiguousarray(grid[:, 0, :, :][:, :, list(RIGHT_LEG)])
            w = np.asarray(factored(base, left, right), dtype=np.float64)
            if w.shape != (m, a, b):
                raise ValueError(f"weights_factored returned {w.shape}, expected {(m, a, b)}")
            self.last_evaluations += m * a * b
            self.used_factored = True
            return w.reshape(m * a * b)
        return self._weigh(likelihood, particles)

    def pass_sizes(self) -> tuple[int, int]:
        """Groups (M1, M2) of the coarse and the fine pass; M2 = 0 for one pass."""
        m2 = int(round(self.config.refine_share * self.M)) if self.M >= 2 else 0
        m2 = min(max(m2, 0), self.M - 1)
        return self.M - m2, m2

    def _step(self, likelihood: Likelihood, dt: float) -> None:
        self.last_evaluations = 0
        kept = self.select()
        m1, m2 = self.pass_sizes()
        widths = self.interval_widths(dt)
        if m2 == 0:
            particles = self.predict(kept, dt, widths=widths)
            weights = self.measure(likelihood, particles)
        else:
            coarse = widths * self.config.coarse_factor
            p1 = self.predict(kept[:m1], dt, widths=coarse)
            w1 = self.measure(likelihood, p1)
            # Fine pass: around the heaviest distinct particles of the coarse pass, one coarse
            # grid step wide, centred on their values (they already include the velocity);
            # half the noise on R, so that no particle repeats its parent.
            idx = select_distinct(p1, w1, m2)
            if idx.size < m2:
                idx = np.resize(idx, m2)
            fine = coarse / (self.q - 1) if self.q > 1 else coarse
            p2 = self.predict(
                p1[idx], dt, widths=fine, shift=np.zeros(len(self.L)), sigma_factor=0.5
            )
            w2 = self.measure(likelihood, p2)
            particles = np.concatenate([p1, p2])
            weights = np.concatenate([w1, w2])
        if self.anneal_sizes:
            particles, weights = self.anneal(likelihood, particles, weights, dt)
        self.weights = weights
        self.particles = particles
        best = particles[int(np.argmax(self.weights)), self.L]
        self._history = [*self._history[-1:], best.copy()]
        self._last_dt = dt

    def anneal(
        self, likelihood: Likelihood, particles: np.ndarray, weights: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The annealing stage (module docstring, ``anneal``): the frame's particles and
        weights with each layer's appended."""
        rate = self.config.anneal.survival_rate
        sigma = self.anneal_sigma * np.sqrt(dt / self.reference_dt)
        pi = annealed(weights, annealing_exponent(weights, rate))
        layers = list(
            annealing_layers(self, likelihood, particles, pi, sigma, self.anneal_sizes, rate)
        )
        return (
            np.concatenate([particles, *(p for p, _, _ in layers)]),
            np.concatenate([weights, *(w for _, w, _ in layers)]),
        )


__all__ = ["IntervalParticleFilter", "ROOT_DOFS"]
