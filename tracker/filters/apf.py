"""The annealed particle filter (Deutscher, Blake & Reid, CVPR 2000), the second baseline.

Each frame runs ``layers`` annealing layers sharing the frame's evaluation budget (sizes differ by
at most one so that the total equals the IPF's M * q^n exactly). At each layer the particles are
resampled in proportion to the annealed weights ``pi ~ w ** beta`` of the previous layer (for the
first layer, of the previous frame's last layer), diffused with Gaussian noise and weighed. The
exponent ``beta`` of each layer is chosen by bisection so that the particle survival rate
``alpha = 1 / (N * sum(pi ** 2))`` equals the target (default 0.5), and the noise shrinks by
``sqrt(alpha)`` per layer (the covariance by ``alpha``), as in Deutscher et al. The estimate is the
heaviest particle of the last layer.
"""

from __future__ import annotations

import numpy as np

from tracker.config import APFConfig
from tracker.filters.base import (
    Filter,
    Likelihood,
    resample_systematic,
    sigma_vector,
    split_budget,
)


def survival_rate(log_w: np.ndarray, beta: float) -> float:
    """Survival rate ``1 / (N * sum(pi^2))`` of ``pi ~ exp(beta * log_w)`` (-inf = weight 0)."""
    z = beta * log_w
    finite = np.isfinite(z)
    if not finite.any():
        return 1.0
    z = np.where(finite, z - z[finite].max(), -np.inf)
    pi = np.exp(z)
    pi /= pi.sum()
    return float(1.0 / (log_w.size * np.sum(pi * pi)))


def annealing_exponent(weights: np.ndarray, alpha: float, iters: int = 40) -> float:
    """The exponent beta >= 0 whose annealed weights ``w ** beta`` have survival rate ``alpha``.

    Bisection on ``log(beta)`` (the rate decreases with beta); capped at ``beta = 1e4``.
    """
    w = np.asarray(weights, dtype=np.float64)
    with np.errstate(divide="ignore"):
        log_w = np.where(w > 0, np.log(np.maximum(w, 1e-300)), -np.inf)
    if not np.isfinite(log_w).any():
        return 0.0
    lo, hi = -8.0, 4.0  # log10(beta)
    if survival_rate(log_w, 10**hi) >= alpha:
        return 10**hi
    if survival_rate(log_w, 10**lo) <= alpha:
        return 10**lo
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        if survival_rate(log_w, 10**mid) > alpha:
            lo = mid
        else:
            hi = mid
    return float(10 ** (0.5 * (lo + hi)))


def annealed(weights: np.ndarray, beta: float) -> np.ndarray:
    """Normalised ``w ** beta`` (uniform when every weight is 0)."""
    w = np.asarray(weights, dtype=np.float64)
    with np.errstate(divide="ignore"):
        log_w = np.where(w > 0, np.log(np.maximum(w, 1e-300)), -np.inf) * beta
    if not np.isfinite(log_w).any():
        return np.full(w.size, 1.0 / w.size)
    finite = np.isfinite(log_w)
    pi = np.where(finite, np.exp(log_w - log_w[finite].max()), 0.0)
    return pi / pi.sum()


def annealing_layers(
    filt: Filter,
    likelihood: Likelihood,
    poses: np.ndarray,
    pi: np.ndarray,
    sigma: np.ndarray,
    sizes: list[int],
    alpha: float,
):
    """Annealing layers of ``filt`` (its generator, diffusion, limits and evaluation count):
    for each size, resample ``size`` of the previous layer's poses in proportion to their
    annealed weights ``pi`` (the first layer: of ``poses``), diffuse by ``sigma`` (shrunk by
    ``sqrt(alpha)`` per layer), clamp and weigh. Yields each layer's (poses, weights, beta),
    ``beta`` the exponent whose annealed weights have survival rate ``alpha``."""
    p = poses
    for size in sizes:
        p = p[resample_systematic(pi, size, filt.rng)]  # a copy
        filt._diffuse(p, sigma)
        filt.clamp(p)
        w = filt._weigh(likelihood, p)
        beta = annealing_exponent(w, alpha)
        pi = annealed(w, beta)
        sigma = sigma * np.sqrt(alpha)
        yield p, w, beta


class AnnealedParticleFilter(Filter):
    """Annealed particle filtering with survival-rate-driven annealing (see module docstring)."""

    name = "apf"
    STATE = (*Filter.STATE, "pi", "betas")

    def __init__(
        self,
        config: APFConfig | None = None,
        *,
        evaluations: int,
        limits: tuple[np.ndarray, np.ndarray],
        rng: np.random.Generator,
        reference_dt: float = 0.05,
    ) -> None:
        super().__init__(limits=limits, rng=rng, reference_dt=reference_dt)
        self.config = config or APFConfig()
        self.sizes = split_budget(int(evaluations), self.config.layers)
        self.sigma = sigma_vector(self.config.sigma, self.config.sigma_scale)
        self.pi = np.zeros(0)
        self.betas: list[float] = []

    @property
    def evaluations_per_step(self) -> int:
        return int(sum(self.sizes))

    def initialise(self, poses: np.ndarray, weights: np.ndarray | None = None) -> None:
        super().initialise(poses, weights)
        w = self.weights
        self.pi = annealed(w, annealing_exponent(w, self.config.survival_rate))

    def _step(self, likelihood: Likelihood, dt: float) -> None:
        self.last_evaluations = 0
        alpha = self.config.survival_rate
        sigma = self.sigma * np.sqrt(dt / self.reference_dt)
        pi = self.pi
        if pi.shape != (self.particles.shape[0],):
            pi = annealed(self.weights, 1.0)
        layers = list(
            annealing_layers(self, likelihood, self.particles, pi, sigma, self.sizes, alpha)
        )
        self.betas = [beta for _, _, beta in layers]
        self.particles, self.weights, _ = layers[-1]
        self.pi = annealed(self.weights, self.betas[-1])
