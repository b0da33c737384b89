"""Walking bouts and the activity timeline (walking, turning, standing, sitting, lying).

A walking bout is a run of consecutive straight strides (each stride overlaps or touches the
previous one, the walking direction turns less than ``max_turn_deg`` over each stride) with at
least ``min_strides`` strides of either foot, each at least ``min_stride_length_m`` long (not
stepping on the spot). Everything else is classified frame by frame from
the posture: lying (trunk more than ``lying_trunk_deg`` from vertical, or head low), sitting
(sacrum below ``sitting_height_fraction`` of its standing height), turning (upright with the
facing direction turning faster than ``turn_rate_deg_s``), walking (upright, in a bout or with
the sacrum moving faster than ``walking_speed_m_s``), standing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gait.filtering import Prepared, fill_short_gaps, lowpass
from gait.geometry import body_forward, heading_angle, sacrum_velocity
from gait.kinematics import trunk_vector
from gait.parameters import StrideCalc
from gaitwatch.conventions import HEAD, SACRUM, side_index


@dataclass(frozen=True)
class BoutSettings:
    """Bout and posture thresholds (degrees, seconds, fractions of standing sacrum height)."""

    min_strides: int = 2
    max_turn_deg: float = 30.0
    min_stride_length_m: float = 0.15
    max_link_gap_s: float = 0.05
    sitting_height_fraction: float = 0.7
    lying_trunk_deg: float = 60.0
    lying_head_height_m: float = 0.5
    turn_rate_deg_s: float = 45.0
    min_activity_s: float = 0.3
    walking_speed_m_s: float = 0.3
    """Upright frames outside bouts with the sacrum faster than this are walking too."""


def standing_height(prep: Prepared) -> float:
    """Sacrum height when standing upright (m).

    The larger of: the leg length (hip-knee + knee-ankle, medians) plus the ankle height, and
    the 90th percentile of the sacrum height. The leg estimate makes it work for recordings
    spent sitting; the percentile for recordings without legs.
    """
    pos = prep.positions
    est = []
    for side in ("left", "right"):
        hip = pos[:, side_index(side, "hip")]
        knee = pos[:, side_index(side, "knee")]
        ankle = pos[:, side_index(side, "ankle")]
        thigh = np.linalg.norm(knee - hip, axis=1)
        shank = np.linalg.norm(ankle - knee, axis=1)
        leg = (
            np.nanmedian(thigh) + np.nanmedian(shank)
            if np.isfinite(thigh + shank).any()
            else np.nan
        )
        az = np.nanpercentile(ankle[:, 2], 10) if np.isfinite(ankle[:, 2]).any() else 0.08
        est.append(leg + max(float(az), 0.0))
    sac = pos[:, SACRUM, 2]
    p90 = float(np.nanpercentile(sac, 90)) if np.isfinite(sac).any() else np.nan
    cands = [e for e in [*est, p90] if np.isfinite(e)]
    return float(max(cands)) if cands else float("nan")


def group_bouts(strides: Sequence[StrideCalc], settings: BoutSettings) -> list[list[StrideCalc]]:
    """Group straight, consecutive strides into bouts of at least ``min_strides`` strides."""
    bouts: list[list[StrideCalc]] = []
    cur: list[StrideCalc] = []
    end = -np.inf
    for st in sorted(strides, key=lambda s: s.t0):
        straight = st.values.get("turn_deg", 0.0) <= settings.max_turn_deg
        # Stepping on the spot (or a treadmill without its belt speed) is not walking.
        moves = not st.values.get("stride_length_m", np.inf) < settings.min_stride_length_m
        if not (straight and moves):
            if len(cur) >= settings.min_strides:
                bouts.append(cur)
            cur, end = [], -np.inf
            continue
        if cur and st.t0 > end + settings.max_link_gap_s:
            if len(cur) >= settings.min_strides:
                bouts.append(cur)
            cur = []
        cur.append(st)
        end = max(end if cur[:-1] else -np.inf, st.t1)
    if len(cur) >= settings.min_strides:
        bouts.append(cur)
    return bouts


def seated_frames(prep: Prepared, stand_height: float, settings: BoutSettings) -> np.ndarray:
    """Frames (N,) whose sacrum is below ``sitting_height_fraction`` of the standing height:
    seated, or lying. Either way nobody walks there."""
    with np.errstate(invalid="ignore"):
        return prep.positions[:, SACRUM, 2] < settings.sitting_height_fraction * stand_height


def posture_labels(
    prep: Prepared,
    bout_spans: Sequence[tuple[float, float]],
    stand_height: float,
    settings: BoutSettings,
    transfer_spans: Sequence[tuple[float, float]] = (),
) -> np.ndarray:
    """Activity label per frame of the prepared grid, array of str, shape (N,).

    Bouts win over transfers, transfers over posture.
    """
    pos = prep.positions
    n = prep.n
    labels = np.full(n, "unknown", dtype=object)
    trunk = trunk_vector(pos)
    with np.errstate(invalid="ignore"):
        tilt = np.degrees(np.arctan2(np.linalg.norm(trunk[:, :2], axis=1), trunk[:, 2]))
        sac = pos[:, SACRUM, 2]
        head = pos[:, HEAD, 2]
        lying = (tilt > settings.lying_trunk_deg) | (head < settings.lying_head_height_m)
        sitting = ~lying & seated_frames(prep, stand_height, settings)
        upright = ~lying & ~sitting & np.isfinite(sac)
    fwd = body_forward(pos)
    ang = heading_angle(fwd)
    rate = np.full(n, np.nan)
    ok = np.isfinite(ang)
    if ok.sum() > 4:
        a = lowpass(fill_short_gaps(ang, int(prep.fps)), prep.fps, 1.0)
        rate = np.degrees(np.abs(np.gradient(a, 1.0 / prep.fps)))
    with np.errstate(invalid="ignore"):
        turning = upright & (rate > settings.turn_rate_deg_s)
    speed = np.linalg.norm(sacrum_velocity(pos, prep.fps), axis=1)
    with np.errstate(invalid="ignore"):
        moving = upright & (speed > settings.walking_speed_m_s)
    labels[upright] = "standing"
    labels[moving] = "walking"
    labels[turning] = "turning"
    labels[sitting & np.isfinite(sac)] = "sitting"
    labels[lying & (np.isfinite(sac) | np.isfinite(head))] = "lying"
    for t0, t1 in transfer_spans:
        labels[(prep.times >= t0) & (prep.times <= t1)] = "transfer"
    for t0, t1 in bout_spans:
        labels[(prep.times >= t0) & (prep.times <= t1)] = "walking"
    return labels


def activity_segments(
    times: np.ndarray, labels: np.ndarray, min_s: float
) -> list[tuple[str, float, float]]:
    """Run-length segments ``(label, start_s, end_s)``; runs shorter than ``min_s`` merge into
    the previous segment."""
    if labels.size == 0:
        return []
    change = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [labels.size]])
    dt = (times[-1] - times[0]) / max(times.size - 1, 1)
    segs: list[list] = []
    for a, b in zip(starts, stops, strict=True):
        lab = str(labels[a])
        dur = (b - a) * dt
        if segs and (dur < min_s or segs[-1][0] == lab):
            segs[-1][2] = b
            continue
        segs.append([lab, a, b])
    # A short first run merges forward.
    if len(segs) > 1 and (segs[0][2] - segs[0][1]) * dt < min_s:
        segs[1][1] = segs[0][1]
        segs.pop(0)
    out = []
    for lab, a, b in segs:
        if out and out[-1][0] == lab:
            out[-1] = (lab, out[-1][1], float(times[b - 1]))
        else:
            out.append((lab, float(times[a]), float(times[b - 1])))
    return out
