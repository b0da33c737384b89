"""Comparing detected gait events and parameters with reference (laboratory) ones.

Used by ``bench/gait_accuracy.py`` and the accuracy tests. The reference parameters are the
same stride computation (:func:`gait.parameters.compute_strides`, via
:func:`gait.analysis.analyse` with ``events=``) driven by the laboratory events on the clean
markers; the estimate is driven by the detected events on the (possibly degraded) trajectory.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gait.result import Event, Stride
from gaitwatch.trajectory import Trajectory


@dataclass
class EventErrors:
    """Signed timing errors (detected - reference) in seconds per event type."""

    errors: dict[str, list[float]] = field(
        default_factory=lambda: {"heel_strike": [], "toe_off": []}
    )
    missed: dict[str, int] = field(default_factory=lambda: {"heel_strike": 0, "toe_off": 0})

    def median_abs_ms(self, typ: str) -> float:
        e = np.abs(np.asarray(self.errors[typ]))
        return float(np.median(e) * 1000) if e.size else float("nan")


def match_events(
    detected: Sequence[Event] | Sequence[dict],
    reference: Sequence[dict],
    tolerance_s: float = 0.2,
) -> EventErrors:
    """Match each reference event with the nearest detected event of the same side and type.

    Reference events without a detected event within ``tolerance_s`` count as missed.
    """
    det = [e if isinstance(e, dict) else e.model_dump() for e in detected]
    out = EventErrors()
    for r in reference:
        cand = [
            d["time_s"] - r["time_s"]
            for d in det
            if d["side"] == r["side"] and d["type"] == r["type"]
        ]
        best = min(cand, key=abs) if cand else None
        if best is None or abs(best) > tolerance_s:
            out.missed[r["type"]] += 1
        else:
            out.errors[r["type"]].append(float(best))
    return out


def match_strides(
    estimate: Sequence[Stride], reference: Sequence[Stride], tolerance_s: float = 0.15
) -> list[tuple[Stride, Stride]]:
    """Pairs (estimate, reference) of strides of the same side starting within tolerance."""
    pairs = []
    for r in reference:
        cand = [
            e for e in estimate if e.side == r.side and abs(e.start_s - r.start_s) < tolerance_s
        ]
        if cand:
            pairs.append((min(cand, key=lambda e: abs(e.start_s - r.start_s)), r))
    return pairs


def aggregate(strides: Sequence[Stride]) -> dict[str, float]:
    """Walking speed (total length / total time), cadence (120 / mean stride time) and mean
    stride length of a set of strides."""
    T = np.asarray([s.stride_time_s for s in strides if s.stride_time_s], dtype=np.float64)
    L = np.asarray([s.stride_length_m for s in strides if s.stride_length_m], dtype=np.float64)
    if T.size == 0 or L.size != T.size:
        return {"walking_speed_m_s": np.nan, "cadence_steps_min": np.nan, "stride_length_m": np.nan}
    return {
        "walking_speed_m_s": float(L.sum() / T.sum()),
        "cadence_steps_min": float(120.0 / T.mean()),
        "stride_length_m": float(L.mean()),
    }


def parameter_errors_pct(
    estimate: Sequence[Stride], reference: Sequence[Stride]
) -> tuple[dict[str, float], int]:
    """Relative errors (%) of speed, cadence and stride length over the matched strides, and
    the number of matched strides."""
    pairs = match_strides(estimate, reference)
    if not pairs:
        return {k: np.nan for k in ("walking_speed_m_s", "cadence_steps_min", "stride_length_m")}, 0
    est = aggregate([p[0] for p in pairs])
    ref = aggregate([p[1] for p in pairs])
    return {k: 100.0 * (est[k] - ref[k]) / ref[k] for k in ref}, len(pairs)


def add_noise(traj: Trajectory, sd_m: float, rng: np.random.Generator) -> Trajectory:
    """A copy with Gaussian noise of ``sd_m`` metres on every coordinate."""
    pos = traj.positions + rng.normal(0.0, sd_m, traj.positions.shape)
    return traj.with_positions(pos)
