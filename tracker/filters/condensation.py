"""Condensation (Isard & Blake 1998), the baseline: resample in proportion to weight, diffuse.

Each frame: draw N particles from the previous set in proportion to weight (systematic
resampling, one uniform draw from the injected generator), add white Gaussian noise to every DOF
(per-DOF sigma stated for 20 Hz and scaled with ``sqrt(dt / 0.05)``, a random walk), clamp to the
joint limits, weigh all N. The estimate is the heaviest particle. N defaults to the IPF's M * q^n
so that both filters make the same number of likelihood evaluations per frame.
"""

from __future__ import annotations

import numpy as np

from tracker.config import CondensationConfig
from tracker.filters.base import Filter, Likelihood, resample_systematic, sigma_vector


class CondensationFilter(Filter):
    """Sampling-importance-resampling with Gaussian diffusion on all DOFs."""

    name = "condensation"

    def __init__(
        self,
        config: CondensationConfig | None = None,
        *,
        particles: int,
        limits: tuple[np.ndarray, np.ndarray],
        rng: np.random.Generator,
        reference_dt: float = 0.05,
    ) -> None:
        super().__init__(limits=limits, rng=rng, reference_dt=reference_dt)
        if particles < 1:
            raise ValueError("particles must be >= 1")
        self.config = config or CondensationConfig()
        self.n = int(particles)
        self.sigma = sigma_vector(self.config.sigma, self.config.sigma_scale)

    @property
    def evaluations_per_step(self) -> int:
        return self.n

    def _step(self, likelihood: Likelihood, dt: float) -> None:
        self.last_evaluations = 0
        idx = resample_systematic(self.weights, self.n, self.rng)
        p = self.particles[idx].copy()
        self._diffuse(p, self.sigma * np.sqrt(dt / self.reference_dt))
        self.clamp(p)
        self.weights = self._weigh(likelihood, p)
        self.particles = p
