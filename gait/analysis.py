"""``analyse(trajectory) -> GaitReport``: the whole gait analysis of one recording.

Steps: uniform grid, left/right swap repair, gap filling and 6 Hz low-pass
(:mod:`gait.filtering`); walking direction (:mod:`gait.geometry`); heel strikes and toe offs
(:mod:`gait.events`); strides and their parameters (:mod:`gait.parameters`); bouts and the
activity timeline (:mod:`gait.bouts`); joint angles (:mod:`gait.kinematics`); margin of
stability (:mod:`gait.balance`); transfers and TUG (:mod:`gait.transfers`); falls
(:mod:`gait.falls`); fall risk (:mod:`gait.risk`).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from gait.balance import centre_of_mass, extrapolated_com, margins_at
from gait.bouts import (
    BoutSettings,
    activity_segments,
    group_bouts,
    posture_labels,
    seated_frames,
    standing_height,
)
from gait.events import EventSettings, GaitEvent, detect_events
from gait.falls import FallSettings, detect_falls
from gait.filtering import Prepared, prepare, quiet_nanmean
from gait.geometry import heading, heading_angle
from gait.kinematics import hip_flexion, knee_flexion, stride_curve, trunk_lean
from gait.parameters import StrideCalc, StrideSettings, compute_strides, summarise
from gait.result import (
    TUG,
    Activity,
    BalanceSummary,
    Bout,
    Event,
    Fall,
    GaitReport,
    KinematicsSummary,
    Stride,
    Summary,
    Transfer,
)
from gait.risk import assess
from gait.transfers import TransferSettings, detect_transfers, detect_tug
from gaitwatch.conventions import SACRUM
from gaitwatch.trajectory import Trajectory

log = logging.getLogger(__name__)


#: Where the key points come from: tracked from video, or laboratory markers.
KeypointSource = Literal["video", "markers"]

#: Heel-strike refinement per key-point source (docs/gait.md, "Gait events"): the fraction of
#: the stance foot's backward speed relative to the sacrum at which heel strike is placed after
#: Zeni's peak. 0.4 was chosen against the laboratory files' force plates and event markers.
#: Tracked key points are blurred in time (the tracker's search and output smoothing), which
#: already delays Zeni's peak; with 0.2 their heel strikes come nearer those of the true key
#: points analysed with 0.4 (shared walks and crouch gait, one and two cameras, 20 and 30 fps;
#: docs/gait.md, "Events of tracked key points").
HS_VELOCITY_FRACTION: dict[str, float] = {"markers": 0.4, "video": 0.2}
#: Toe-off refinement per key-point source: 0 is Zeni's toe off, which matches the laboratory
#: events; blurred tracked key points put Zeni's toe off early, and 0.1 moves it nearer the
#: truth's.
TO_VELOCITY_FRACTION: dict[str, float] = {"markers": 0.0, "video": 0.1}


class GaitConfig(BaseModel):
    """Settings of :func:`analyse` (validated; unknown keys are refused)."""

    model_config = ConfigDict(extra="forbid")

    cutoff_hz: float = Field(6.0, gt=0, description="low-pass cut-off for positions, Hz")
    max_gap_s: float = Field(0.25, ge=0, description="longest gap filled by interpolation, s")
    fix_swaps: bool = Field(True, description="repair left/right leg swaps")
    treadmill_speed_m_s: float = Field(0.0, ge=0, description="belt speed; 0 = overground")
    min_strides: int = Field(2, ge=1, description="strides a walking bout needs at least")
    max_turn_deg: float = Field(30.0, gt=0, description="largest direction change per stride")
    source: KeypointSource = Field(
        "video",
        description="where the key points come from: 'video' (tracked, e.g. by gaitwatch track) "
        "or 'markers' (laboratory motion capture); sets the event refinements' defaults",
    )
    hs_velocity_fraction: float | None = Field(
        None,
        ge=0,
        lt=1,
        description="heel-strike refinement (None: by source, HS_VELOCITY_FRACTION)",
    )
    to_velocity_fraction: float | None = Field(
        None,
        ge=0,
        lt=1,
        description="toe-off refinement (None: by source, TO_VELOCITY_FRACTION; 0: Zeni's)",
    )
    long_lie_s: float = Field(60.0, gt=0, description="time on the floor that is a long lie, s")
    include_curves: bool = Field(True, description="mean hip/knee curves in the summaries")

    @property
    def heel_strike_fraction(self) -> float:
        """The heel-strike refinement's fraction in use: ``hs_velocity_fraction`` if set, else
        the calibration of the key points' ``source`` (:data:`HS_VELOCITY_FRACTION`)."""
        if self.hs_velocity_fraction is not None:
            return self.hs_velocity_fraction
        return HS_VELOCITY_FRACTION[self.source]

    @property
    def toe_off_fraction(self) -> float:
        """The toe-off refinement's fraction in use: ``to_velocity_fraction`` if set, else the
        calibration of the key points' ``source`` (:data:`TO_VELOCITY_FRACTION`)."""
        if self.to_velocity_fraction is not None:
            return self.to_velocity_fraction
        return TO_VELOCITY_FRACTION[self.source]


#: A stride is left out when the person sat (or lay) in more than this fraction of its frames.
SEATED_STRIDE_FRACTION = 0.5


def _during(mask: np.ndarray, f0: float, f1: float, fraction: float = 0.0) -> bool:
    """Whether more than ``fraction`` of the frames ``f0..f1`` (fractional indices, rounded)
    are set in ``mask`` (with ``fraction`` 0: any of them)."""
    if not (np.isfinite(f0) and np.isfinite(f1)) or mask.size == 0:
        return False
    a = int(np.clip(round(min(f0, f1)), 0, mask.size - 1))
    b = int(np.clip(round(max(f0, f1)), 0, mask.size - 1))
    return bool(mask[a : b + 1].mean() > fraction)


def _nanmean(x: Sequence[float]) -> float:
    a = np.asarray([v for v in x if v is not None], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else float("nan")


class _Angles:
    """Per-frame joint angles of a prepared recording (degrees)."""

    def __init__(self, prep: Prepared, forward: np.ndarray) -> None:
        p = prep.positions
        self.knee = {s: knee_flexion(p, s) for s in ("left", "right")}
        self.hip = {s: hip_flexion(p, forward, s) for s in ("left", "right")}
        self.trunk_ap, self.trunk_ml = trunk_lean(p, forward)


def _stride_kinematics(st: StrideCalc, ang: _Angles) -> dict:
    knee = stride_curve(ang.knee[st.side], st.f0, st.f1)
    hip = stride_curve(ang.hip[st.side], st.f0, st.f1)
    out: dict = {"knee_curve": knee, "hip_curve": hip}
    if st.toe_off is not None:
        split = int(round(100 * (st.toe_off - st.t0) / (st.t1 - st.t0)))
        split = min(max(split, 1), 100)
        stance, swing = knee[:split], knee[split:]
        out["knee_peak_swing_flexion_deg"] = (
            float(np.nanmax(swing)) if np.isfinite(swing).any() else np.nan
        )
        out["knee_min_stance_flexion_deg"] = (
            float(np.nanmin(stance)) if np.isfinite(stance).any() else np.nan
        )
    out["knee_flexion_at_heel_strike_deg"] = float(knee[0])
    out["knee_rom_deg"] = (
        float(np.nanmax(knee) - np.nanmin(knee)) if np.isfinite(knee).any() else np.nan
    )
    out["hip_rom_deg"] = (
        float(np.nanmax(hip) - np.nanmin(hip)) if np.isfinite(hip).any() else np.nan
    )
    out["hip_max"] = float(np.nanmax(hip)) if np.isfinite(hip).any() else np.nan
    out["hip_min"] = float(np.nanmin(hip)) if np.isfinite(hip).any() else np.nan
    return out


def _kin_summary(
    strides: Sequence[StrideCalc],
    kin: dict[int, dict],
    ang: _Angles,
    sel: np.ndarray,
    curves: bool,
) -> KinematicsSummary:
    def m(key: str) -> float:
        return _nanmean([kin[id(s)].get(key, np.nan) for s in strides])

    def curve(side: str, key: str) -> list[float] | None:
        cs = [kin[id(s)][key] for s in strides if s.side == side]
        if not curves or not cs:
            return None
        mean = quiet_nanmean(np.asarray(cs), axis=0)
        return [round(float(v), 2) if np.isfinite(v) else None for v in mean]

    ap = ang.trunk_ap[sel]
    ml = ang.trunk_ml[sel]
    ap = ap[np.isfinite(ap)]
    ml = ml[np.isfinite(ml)]
    return KinematicsSummary(
        knee_peak_swing_flexion_deg=m("knee_peak_swing_flexion_deg"),
        knee_min_stance_flexion_deg=m("knee_min_stance_flexion_deg"),
        knee_flexion_at_heel_strike_deg=m("knee_flexion_at_heel_strike_deg"),
        knee_rom_deg=m("knee_rom_deg"),
        hip_rom_deg=m("hip_rom_deg"),
        hip_peak_extension_deg=m("hip_min"),
        hip_peak_flexion_deg=m("hip_max"),
        trunk_lean_deg=float(ap.mean()) if ap.size else None,
        trunk_sway_ml_deg=float(ml.std()) if ml.size > 1 else None,
        trunk_sway_ap_deg=float(ap.std()) if ap.size > 1 else None,
        trunk_sway_ml_range_deg=float(np.ptp(ml)) if ml.size else None,
        trunk_sway_ap_range_deg=float(np.ptp(ap)) if ap.size else None,
        knee_curve_left_deg=curve("left", "knee_curve"),
        knee_curve_right_deg=curve("right", "knee_curve"),
        hip_curve_left_deg=curve("left", "hip_curve"),
        hip_curve_right_deg=curve("right", "hip_curve"),
    )


def _balance_summary(strides: Sequence[StrideCalc], mos: dict[int, tuple[float, float]]):
    ml = np.asarray([mos[id(s)][0] for s in strides if id(s) in mos], dtype=np.float64)
    ap = np.asarray([mos[id(s)][1] for s in strides if id(s) in mos], dtype=np.float64)
    ml, ap = ml[np.isfinite(ml)], ap[np.isfinite(ap)]
    return BalanceSummary(
        mos_ml_mean_m=float(ml.mean()) if ml.size else None,
        mos_ml_min_m=float(ml.min()) if ml.size else None,
        mos_ml_sd_m=float(ml.std(ddof=1)) if ml.size > 1 else None,
        mos_ap_mean_m=float(ap.mean()) if ap.size else None,
        mos_ap_min_m=float(ap.min()) if ap.size else None,
        n_steps=int(ml.size),
    )


def analyse(
    traj: Trajectory,
    config: GaitConfig | None = None,
    events: Sequence[GaitEvent] | Sequence[dict] | None = None,
) -> GaitReport:
    """Analyse one recording.

    Parameters
    ----------
    traj : Trajectory
        19 key points in metres, z up (CONVENTIONS); missing frames and NaN key points allowed.
    config : GaitConfig, optional
    events : sequence, optional
        Use these heel strikes / toe offs (``GaitEvent`` or CONVENTIONS event dicts, e.g.
        laboratory events) instead of detecting them.

    Returns
    -------
    GaitReport
        Empty lists where nothing is found (no walking, a single step, no data).

    Raises
    ------
    gait.filtering.GaitInputError
        Fewer than two frames, or an unusable frame rate.
    """
    cfg = config or GaitConfig()
    prep = prepare(traj, cutoff_hz=cfg.cutoff_hz, max_gap_s=cfg.max_gap_s, fix_swaps=cfg.fix_swaps)
    report = GaitReport(source=traj.source)
    report.summary = Summary(duration_s=float(prep.times[-1] - prep.times[0]), fps=prep.fps)
    if not np.isfinite(prep.positions).any():
        log.warning("%s: no key point is known in any frame", traj.source or "trajectory")
        return report

    forward, _ = heading(prep.positions, prep.fps)
    head_rad = heading_angle(forward)
    bset = BoutSettings(min_strides=cfg.min_strides, max_turn_deg=cfg.max_turn_deg)
    h_stand = standing_height(prep)
    # Seated or lying (sacrum low): feet that move there are not walking.
    seated = seated_frames(prep, h_stand, bset)
    if events is None:
        evs = detect_events(
            prep,
            forward,
            EventSettings(
                hs_velocity_fraction=cfg.heel_strike_fraction,
                to_velocity_fraction=cfg.toe_off_fraction,
            ),
        )
        evs = [e for e in evs if not _during(seated, e.frame, e.frame)]
    else:
        evs = [
            e
            if isinstance(e, GaitEvent)
            else GaitEvent(
                e["side"],
                e["type"],
                float(e["time_s"]),
                (float(e["time_s"]) - prep.times[0]) * prep.fps,
            )
            for e in events
        ]
        evs.sort(key=lambda e: e.time_s)
    report.events = [Event(side=e.side, type=e.type, time_s=e.time_s) for e in evs]

    strides = compute_strides(
        prep, evs, forward, head_rad, StrideSettings(treadmill_speed_m_s=cfg.treadmill_speed_m_s)
    )
    strides = [s for s in strides if not _during(seated, s.f0, s.f1, SEATED_STRIDE_FRACTION)]
    groups = group_bouts(strides, bset)
    bout_of = {id(s): b for b, g in enumerate(groups) for s in g}

    ang = _Angles(prep, forward)
    kin = {id(s): _stride_kinematics(s, ang) for s in strides}

    com = centre_of_mass(prep.positions)
    com = np.where(np.isfinite(com), com, prep.positions[:, SACRUM])
    xcom, _ = extrapolated_com(com, prep.fps)
    mos = {}
    for s in strides:
        other = "right" if s.side == "left" else "left"
        if s.contra_strike is None:
            continue
        f = (s.contra_strike - prep.times[0]) * prep.fps
        mos[id(s)] = margins_at(xcom, prep.positions, forward, other, f)

    for s in strides:
        k = kin[id(s)]
        ml, ap = mos.get(id(s), (np.nan, np.nan))
        report.strides.append(
            Stride(
                side=s.side,  # type: ignore[arg-type]
                start_s=s.t0,
                end_s=s.t1,
                bout=bout_of.get(id(s)),
                **{k2: v for k2, v in s.values.items()},
                knee_peak_swing_flexion_deg=k.get("knee_peak_swing_flexion_deg"),
                knee_min_stance_flexion_deg=k.get("knee_min_stance_flexion_deg"),
                knee_rom_deg=k.get("knee_rom_deg"),
                hip_rom_deg=k.get("hip_rom_deg"),
                mos_ml_m=ml,
                mos_ap_m=ap,
            )
        )

    all_sel = np.zeros(prep.n, dtype=bool)
    spans = []
    for g in groups:
        t0, t1 = min(s.t0 for s in g), max(s.t1 for s in g)
        spans.append((t0, t1))
        sel = (prep.times >= t0) & (prep.times <= t1)
        all_sel |= sel
        sac = prep.positions[sel, SACRUM, :2]
        sac = sac[np.isfinite(sac).all(axis=1)]
        dist = float(np.linalg.norm(sac[-1] - sac[0])) if len(sac) > 1 else None
        report.bouts.append(
            Bout(
                start_s=t0,
                end_s=t1,
                distance_m=dist,
                **summarise(g),
                kinematics=_kin_summary(g, kin, ang, sel, cfg.include_curves),
                balance=_balance_summary(g, mos),
            )
        )
    bout_strides = [s for g in groups for s in g]
    summ = summarise(bout_strides)
    report.summary = Summary(
        **summ,
        n_bouts=len(groups),
        walking_time_s=float(sum(t1 - t0 for t0, t1 in spans)),
        duration_s=float(prep.times[-1] - prep.times[0]),
        fps=prep.fps,
        kinematics=_kin_summary(bout_strides, kin, ang, all_sel, cfg.include_curves),
        balance=_balance_summary(bout_strides, mos),
    )

    tset = TransferSettings()
    transfers = detect_transfers(prep.positions, prep.times, prep.fps, h_stand, tset)
    labels = posture_labels(prep, spans, h_stand, bset, [(t.start_s, t.end_s) for t in transfers])
    report.activities = [
        Activity(type=lab, start_s=a, end_s=b)  # type: ignore[arg-type]
        for lab, a, b in activity_segments(prep.times, labels, bset.min_activity_s)
    ]
    report.transfers = [
        Transfer(type=t.type, start_s=t.start_s, end_s=t.end_s, duration_s=t.end_s - t.start_s)  # type: ignore[arg-type]
        for t in transfers
    ]
    report.tug = [
        TUG(
            start_s=t.start_s,
            end_s=t.end_s,
            duration_s=t.end_s - t.start_s,
            walk_distance_m=t.walk_m,
            turn_deg=t.turn_deg,
            includes_turn=bool(np.isfinite(t.turn_deg) and t.turn_deg >= tset.tug_turn_deg),
        )
        for t in detect_tug(transfers, prep.positions, prep.times, tset)
    ]
    falls = detect_falls(prep.raw, prep.times, prep.fps, FallSettings(long_lie_s=cfg.long_lie_s))
    report.falls = [
        Fall(
            start_s=f.start_s,
            impact_s=f.impact_s,
            peak_descent_speed_m_s=f.peak_speed_m_s,
            on_floor_s=f.on_floor_s,
            long_lie=f.long_lie,
            got_up=f.got_up,
        )
        for f in falls
    ]
    report.risk = assess(report.summary, report.tug, report.falls)
    return report
