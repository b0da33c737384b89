"""Body-part particle filters behind one small interface: IPF and its two baselines.

``make_filter(name, config, rng=...)`` builds one of :data:`FILTERS` from a
:class:`tracker.config.TrackerConfig`; the baselines get the same number of likelihood
evaluations per frame as the IPF (``config.evaluations_per_frame``).
"""

from __future__ import annotations

import numpy as np

from tracker.config import FILTER_NAMES, TrackerConfig
from tracker.filters.apf import AnnealedParticleFilter
from tracker.filters.base import (
    Estimate,
    Filter,
    Likelihood,
    resample_systematic,
    select_distinct,
    sigma_vector,
    split_budget,
)
from tracker.filters.condensation import CondensationFilter
from tracker.filters.ipf import IntervalParticleFilter

FILTERS: dict[str, type[Filter]] = {
    "ipf": IntervalParticleFilter,
    "apf": AnnealedParticleFilter,
    "condensation": CondensationFilter,
}


def make_filter(
    name: str,
    config: TrackerConfig | None = None,
    *,
    rng: np.random.Generator,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
    share: float = 1.0,
) -> Filter:
    """Build the filter ``name`` ("ipf", "apf" or "condensation") from ``config``.

    Parameters
    ----------
    name : str
    config : TrackerConfig, optional
        Defaults to ``TrackerConfig()``.
    rng : numpy.random.Generator
        The filter's only source of randomness.
    limits : (low (31,), high (31,)), optional
        Metres / radians; default ``config.joint_limits().arrays()``.
    share : float
        Share (0-1] of the configured likelihood evaluations per step
        (:meth:`TrackerConfig.divided_budget` by ``1 / share``), alike for every filter.
    """
    config = config or TrackerConfig()
    if name not in FILTERS:
        raise ValueError(f"unknown filter {name!r}; choose one of {', '.join(FILTER_NAMES)}")
    if not 0 < share <= 1:
        raise ValueError(f"share must lie in (0, 1], not {share}")
    if share < 1:
        config = config.divided_budget(1 / share)
    limits = limits if limits is not None else config.joint_limits().arrays()
    common = {"limits": limits, "rng": rng, "reference_dt": config.reference_dt_s}
    if name == "ipf":
        return IntervalParticleFilter(config.ipf, **common)
    if name == "apf":
        return AnnealedParticleFilter(
            config.apf, evaluations=config.evaluations_per_frame, **common
        )
    return CondensationFilter(config.condensation, particles=config.evaluations_per_frame, **common)


__all__ = [
    "FILTERS",
    "AnnealedParticleFilter",
    "CondensationFilter",
    "Estimate",
    "Filter",
    "IntervalParticleFilter",
    "Likelihood",
    "make_filter",
    "resample_systematic",
    "select_distinct",
    "sigma_vector",
    "split_budget",
]
