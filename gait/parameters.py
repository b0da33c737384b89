"""Spatiotemporal gait parameters per stride and over sets of strides.

Definitions (docs/gait.md has the references):

- A stride of foot S runs from a heel strike of S to its next heel strike.
- Foot placement: the median horizontal heel position (ankle when the heel is unknown) over the
  first ``placement_window_s`` after heel strike, while the heel is loaded and nearly still.
- Stride length: horizontal distance between consecutive placements of S. Step length and width:
  the contralateral placement C inside the stride, measured along and across the stride line
  from placement to placement of S (Huxham et al. 2006).
- Stance: heel strike to toe off of S; swing: the rest of the stride. Double support: initial
  (heel strike of S to toe off of C) plus terminal (heel strike of C to toe off of S), as % of
  the stride.
- Walking speed of a set of strides: total stride length over total stride time; cadence:
  120 / mean stride time (two steps per stride).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gait.events import GaitEvent
from gait.filtering import Prepared, quiet_nanmean, quiet_nanmedian
from gait.geometry import unit
from gaitwatch.conventions import SACRUM, side_index

OTHER = {"left": "right", "right": "left"}


@dataclass(frozen=True)
class StrideSettings:
    """Plausibility limits for strides (seconds, metres)."""

    min_stride_s: float = 0.6
    max_stride_s: float = 3.0
    placement_window_s: float = 0.15
    treadmill_speed_m_s: float = 0.0
    """Belt speed for treadmill recordings (0 for overground): placements are shifted forward
    by the belt displacement so that lengths and speed refer to the belt."""
    length_ratio: tuple[float, float] = (0.8, 1.25)
    """A straight stride's length over the sacrum's horizontal travel from its first heel strike
    to its last must lie in this range, else the stride is left out. In steady walking the foot
    moves on by as much as the body; a heel strike read at the wrong time (tracked legs running
    out of phase) places the foot elsewhere."""
    length_ratio_max_turn_deg: float = 30.0
    """The ratio is checked on strides that turn less than this (a turn's chords differ)."""
    length_ratio_min_travel_m: float = 0.2
    """...and that travel at least this far (walking on the spot, an unknown treadmill)."""


@dataclass
class StrideCalc:
    """A stride with its parameters (internal; :class:`gait.result.Stride` is the output)."""

    side: str
    t0: float
    t1: float
    f0: float
    f1: float
    toe_off: float | None = None
    contra_strike: float | None = None
    contra_toe_off: float | None = None
    values: dict[str, float] = field(default_factory=dict)


def _interp_rows(x: np.ndarray, f: float) -> np.ndarray:
    """Linear interpolation of rows of ``x`` (N, ...) at fractional index ``f``."""
    i = int(np.clip(np.floor(f), 0, x.shape[0] - 1))
    j = min(i + 1, x.shape[0] - 1)
    w = float(np.clip(f - i, 0.0, 1.0))
    return (1 - w) * x[i] + w * x[j]


def foot_points(prep: Prepared, side: str) -> np.ndarray:
    """Horizontal heel positions of one foot (ankle where the heel is unknown), shape (N, 2)."""
    heel = prep.positions[:, side_index(side, "heel")]
    ankle = prep.positions[:, side_index(side, "ankle")]
    return np.where(np.isfinite(heel), heel, ankle)[:, :2]


def foot_placement(
    prep: Prepared,
    pts: np.ndarray,
    frame: float,
    settings: StrideSettings,
    forward_mean: np.ndarray | None = None,
) -> np.ndarray:
    """Horizontal foot placement (x, y) in metres after the heel strike at fractional ``frame``.

    Parameters
    ----------
    pts : ndarray, shape (N, 2)
        :func:`foot_points` of the foot.
    forward_mean : ndarray, shape (2,), optional
        Mean walking direction, for the treadmill belt shift.
    """
    a = int(np.ceil(frame))
    b = max(a + 1, int(np.ceil(frame + settings.placement_window_s * prep.fps)) + 1)
    win = pts[a:b]
    if settings.treadmill_speed_m_s and forward_mean is not None:
        shift = settings.treadmill_speed_m_s * (prep.times[a:b] - prep.times[0])
        win = win + shift[:, None] * forward_mean[None, :]
    if win.size == 0 or not np.isfinite(win).any():
        return np.full(2, np.nan)
    if np.isfinite(win).all():
        return np.median(win, axis=0)
    return quiet_nanmedian(win, axis=0)


def _first(times: list[float], lo: float, hi: float) -> float | None:
    """First of the sorted ``times`` strictly between lo and hi, or None."""
    i = bisect.bisect_right(times, lo)
    return times[i] if i < len(times) and times[i] < hi else None


def compute_strides(
    prep: Prepared,
    events: Sequence[GaitEvent],
    forward: np.ndarray,
    heading_rad: np.ndarray,
    settings: StrideSettings | None = None,
) -> list[StrideCalc]:
    """Strides of both feet with their spatiotemporal parameters.

    Parameters
    ----------
    prep : Prepared
    events : sequence of GaitEvent
        Heel strikes and toe offs (detected or laboratory), any order.
    forward : ndarray, shape (N, 3)
        Walking direction per frame.
    heading_rad : ndarray, shape (N,)
        Unwrapped heading angle, for the turn per stride.

    Returns
    -------
    list of StrideCalc
        Sorted by start time; strides longer or shorter than plausible, without a
        contralateral heel strike inside, holding a whole contralateral stride (a heel strike
        of this foot missed), or straight but not as long as the body's travel over them
        (``StrideSettings.length_ratio``), are left out.
    """
    s = settings or StrideSettings()
    by: dict[tuple[str, str], list[GaitEvent]] = {}
    for e in sorted(events, key=lambda e: e.time_s):
        by.setdefault((e.side, e.type), []).append(e)
    dt = 1.0 / prep.fps
    t_first = float(prep.times[0])
    pts = {side: foot_points(prep, side) for side in ("left", "right")}
    sacrum = prep.positions[:, SACRUM, :2]
    fw = quiet_nanmean(forward[:, :2], axis=0)
    fw = fw / np.linalg.norm(fw) if np.isfinite(fw).all() and np.linalg.norm(fw) > 0 else None

    def frame_of(e: GaitEvent) -> float:
        return e.frame if np.isfinite(e.frame) else (e.time_s - t_first) / dt

    out: list[StrideCalc] = []
    for side in ("left", "right"):
        hs = by.get((side, "heel_strike"), [])
        to = [e.time_s for e in by.get((side, "toe_off"), [])]
        c_hs = by.get((OTHER[side], "heel_strike"), [])
        c_hs_t = [e.time_s for e in c_hs]
        c_to = [e.time_s for e in by.get((OTHER[side], "toe_off"), [])]
        for a, b in zip(hs[:-1], hs[1:], strict=True):
            t0, t1 = a.time_s, b.time_s
            T = t1 - t0
            if not s.min_stride_s <= T <= s.max_stride_s:
                continue
            ci = bisect.bisect_right(c_hs_t, t0)
            if ci >= len(c_hs) or not c_hs_t[ci] < t1:
                continue
            if (
                ci + 1 < len(c_hs)
                and c_hs_t[ci + 1] < t1
                and c_hs_t[ci + 1] - c_hs_t[ci] >= s.min_stride_s
            ):
                # A whole stride of the other foot inside: this foot's heel strike between its
                # two strikes was missed, and the span is two strides, not one. (Two strikes
                # closer than a stride are one true and one spurious: the stride stays.)
                continue
            c = c_hs[ci]
            st = StrideCalc(side, t0, t1, frame_of(a), frame_of(b))
            st.toe_off = _first(to, t0, t1)
            st.contra_strike = c.time_s
            # The other foot leaves the ground after this heel strike and before its own next
            # strike: a toe off of it after that strike belongs to its next cycle.
            st.contra_toe_off = _first(c_to, t0, c.time_s)
            p0 = foot_placement(prep, pts[side], st.f0, s, fw)
            p1 = foot_placement(prep, pts[side], st.f1, s, fw)
            pc = foot_placement(prep, pts[OTHER[side]], frame_of(c), s, fw)
            d = p1 - p0
            L = float(np.hypot(*d))
            u = unit(d)
            v = pc - p0
            step_len = float(v @ u)
            step_w = float(abs(u[0] * v[1] - u[1] * v[0]))
            h0 = float(_interp_rows(heading_rad, st.f0))
            h1 = float(_interp_rows(heading_rad, st.f1))
            turn = float(np.degrees(abs(h1 - h0)))
            travel = _interp_rows(sacrum, st.f1) - _interp_rows(sacrum, st.f0)
            if s.treadmill_speed_m_s and fw is not None:
                travel = travel + s.treadmill_speed_m_s * T * fw
            moved = float(np.hypot(*travel))
            if (
                turn < s.length_ratio_max_turn_deg
                and moved >= s.length_ratio_min_travel_m
                and np.isfinite(L)
                and not s.length_ratio[0] <= L / moved <= s.length_ratio[1]
            ):
                continue  # the feet did not move on with the body: not a stride
            vals = {
                "stride_time_s": T,
                "stride_length_m": L,
                "walking_speed_m_s": L / T,
                "step_length_m": step_len,
                "step_width_m": step_w,
                "step_time_s": c.time_s - t0,
                "turn_deg": turn,
            }
            if st.toe_off is not None:
                stance = 100.0 * (st.toe_off - t0) / T
                vals["stance_pct"] = stance
                vals["swing_pct"] = 100.0 - stance
                if st.contra_toe_off is not None and c.time_s < st.toe_off:
                    ds = (st.contra_toe_off - t0) + (st.toe_off - c.time_s)
                    vals["double_support_pct"] = 100.0 * ds / T
            st.values = vals
            out.append(st)
    out.sort(key=lambda x: x.t0)
    return out


def _mean(x: np.ndarray) -> float:
    return float(np.mean(x)) if x.size else float("nan")


def _sd(x: np.ndarray) -> float:
    return float(np.std(x, ddof=1)) if x.size >= 2 else float("nan")


def _cv(x: np.ndarray) -> float:
    m = _mean(x)
    return 100.0 * _sd(x) / abs(m) if x.size >= 2 and m != 0 else float("nan")


def _sym(a: np.ndarray, b: np.ndarray) -> float:
    if not a.size or not b.size:
        return float("nan")
    ma, mb = float(np.mean(a)), float(np.mean(b))
    den = (ma + mb) / 2
    return 100.0 * abs(ma - mb) / den if den else float("nan")


def summarise(strides: Sequence[StrideCalc]) -> dict[str, float | int]:
    """Parameters over a set of strides, as :class:`gait.result.GaitParameters` fields."""

    def col(name: str, side: str | None = None) -> np.ndarray:
        vals = [st.values.get(name, np.nan) for st in strides if side is None or st.side == side]
        a = np.asarray(vals, dtype=np.float64)
        return a[np.isfinite(a)]

    T = col("stride_time_s")
    L = col("stride_length_m")
    both = [
        (st.values["stride_length_m"], st.values["stride_time_s"])
        for st in strides
        if np.isfinite(st.values.get("stride_length_m", np.nan))
    ]
    speed = sum(x for x, _ in both) / sum(t for _, t in both) if both else float("nan")
    step_l = col("step_length_m")
    step_w = col("step_width_m")
    # A stride of foot S holds the step that lands foot C (the other foot).
    step_l_left, step_l_right = col("step_length_m", "right"), col("step_length_m", "left")
    step_t_left, step_t_right = col("step_time_s", "right"), col("step_time_s", "left")
    return {
        "walking_speed_m_s": speed,
        "cadence_steps_min": 120.0 / _mean(T) if T.size else float("nan"),
        "stride_length_m": _mean(L),
        "step_length_m": _mean(step_l),
        "step_width_m": _mean(step_w),
        "stride_time_s": _mean(T),
        "stance_pct": _mean(col("stance_pct")),
        "swing_pct": _mean(col("swing_pct")),
        "double_support_pct": _mean(col("double_support_pct")),
        "stride_time_cv_pct": _cv(T),
        "step_time_s": _mean(col("step_time_s")),
        "stride_time_sd_s": _sd(T),
        "stride_length_sd_m": _sd(L),
        "stride_length_cv_pct": _cv(L),
        "step_length_sd_m": _sd(step_l),
        "step_length_cv_pct": _cv(step_l),
        "step_width_sd_m": _sd(step_w),
        "step_width_cv_pct": _cv(step_w),
        "step_length_symmetry_pct": _sym(step_l_left, step_l_right),
        "step_time_symmetry_pct": _sym(step_t_left, step_t_right),
        "stance_symmetry_pct": _sym(col("stance_pct", "left"), col("stance_pct", "right")),
        "n_strides": len(strides),
        "n_steps": int(step_l.size),
    }
