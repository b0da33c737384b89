"""Motions for the scene synthesiser: a procedural walk, and preparing recorded motion to render.

* :func:`procedural_walk` builds a steady straight walk of the 19 key points from stature, speed,
  cadence and path, with the feet planted on footprints (no foot sliding): heel rocker, foot flat,
  toe rocker, then a minimum-jerk swing. Hip and knee follow from two-link inverse kinematics, so
  their angles are physiological (knee about 5-15 degrees in stance, about 60 degrees in swing,
  hip about +25 to -15 degrees). Its gait events are exact and returned with the trajectory.
* :func:`complete_for_render` fills what a recording lacks so a body can be drawn: short gaps
  are interpolated in time, a missing upper body (lower-limb-only recordings) is replaced by an
  upright trunk, head and hanging arms of proportional size placed on the pelvis, and missing
  feet (heel, toe) are built from the ankle and the walking direction.
* :func:`resample` interpolates key points to the video frame rate, :func:`place_on_path` moves
  and turns a walk onto a floor path, :func:`scale_to_stature` changes the subject's height.

Body proportions are fractions of stature ``S`` after Drillis and Contini (as tabulated by
Winter, *Biomechanics and Motor Control of Human Movement*): thigh 0.245 S, shank 0.246 S, ankle
height 0.039 S, foot length 0.152 S, upper arm 0.186 S, forearm 0.146 S, hip joint height
0.530 S, shoulder height 0.818 S, head centre about 0.935 S.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from gaitwatch.conventions import (
    HEAD,
    L_ANKLE,
    L_ELBOW,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_SHOULDER,
    L_TOE,
    L_WRIST,
    N_KEYPOINTS,
    NECK,
    R_ANKLE,
    R_ELBOW,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_SHOULDER,
    R_TOE,
    R_WRIST,
    SACRUM,
)
from gaitwatch.errors import InputError
from gaitwatch.trajectory import Trajectory
from gaitwatch.trajectory import resample as resample_trajectory

log = logging.getLogger(__name__)

UP = np.array([0.0, 0.0, 1.0])

# Segment proportions (fractions of stature), see the module docstring.
THIGH = 0.245
SHANK = 0.246
ANKLE_H = 0.039
HEEL_BACK = 0.032  # heel (back of the heel at the sole) behind the ankle centre
TOE_FWD = 0.074  # second metatarsal head ahead of the ankle centre
HIP_HALF = 0.05  # half the distance between the hip joint centres
SHOULDER_HALF = 0.10
UPPER_ARM = 0.186
FOREARM = 0.146
HIP_TO_NECK = 0.288  # hip joint level to C7
NECK_TO_HEAD = 0.117
SACRUM_BACK = 0.055
SACRUM_UP = 0.03


class MotionError(InputError):
    """A motion that cannot be rendered (the message names the source and what is missing)."""


@dataclass(frozen=True)
class WalkParams:
    """Parameters of :func:`procedural_walk` (SI units; cadence in steps per minute)."""

    height_m: float = 1.75
    speed_m_s: float = 1.2
    cadence_steps_min: float = 110.0
    distance_m: float = 4.0
    start: tuple[float, float] = (0.0, 0.0)
    heading_rad: float = 0.0
    step_width_m: float = 0.10
    fps: float = 100.0


def _smoothstep(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3 - 2 * s)


def _minjerk(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)


def _rot_local(x: float, z: float, pitch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotate a (forward, up) foot-local vector by pitch (toes up positive)."""
    c, s = np.cos(pitch), np.sin(pitch)
    return x * c - z * s, x * s + z * c


def procedural_walk(params: WalkParams | None = None, **kwargs: float) -> Trajectory:
    """A steady straight walk of the 19 key points.

    Parameters
    ----------
    params : WalkParams, optional
        All settings; keyword arguments override its fields (``procedural_walk(speed_m_s=1.0)``).

    Returns
    -------
    Trajectory
        ``positions`` (T, 19, 3) in metres, sampled at ``params.fps``, for the time the pelvis
        takes to cover ``distance_m``; ``events`` holds every heel strike and toe off (left heel
        strike at t = 0, right half a stride later). Stride length is
        ``speed * 120 / cadence``; stance is 60 % of the stride.
    """
    p = params or WalkParams()
    if kwargs:
        p = WalkParams(**{**p.__dict__, **kwargs})
    if not (0.8 <= p.height_m <= 2.4):
        raise MotionError(f"walk: height_m {p.height_m} outside 0.8..2.4 m")
    if p.speed_m_s <= 0 or p.cadence_steps_min <= 0 or p.distance_m <= 0 or p.fps <= 0:
        raise MotionError("walk: speed, cadence, distance and fps must be positive")
    S = p.height_m
    T = 120.0 / p.cadence_steps_min  # stride time
    stride = p.speed_m_s * T
    duration = p.distance_m / p.speed_m_s
    n = int(math.floor(duration * p.fps)) + 1
    t = np.arange(n) / p.fps
    f = np.array([math.cos(p.heading_rad), math.sin(p.heading_rad), 0.0])
    lat = np.cross(UP, f)  # subject's left
    start = np.array([p.start[0], p.start[1], 0.0])

    heel_x, toe_x, ank_h = -HEEL_BACK * S, TOE_FWD * S, ANKLE_H * S
    contact = toe_x - heel_x
    heel_ahead = max(0.05, (0.6 * stride - contact) / 2.0)
    p_hs, p_to = math.radians(15.0), math.radians(-35.0)

    out = np.zeros((n, N_KEYPOINTS, 3))
    phases = {}
    ankles = {}
    for side, offset, sgn in (("left", 0.0, 1.0), ("right", 0.5, -1.0)):
        u = t / T - offset
        k = np.floor(u)
        phi = u - k
        phases[side] = (phi, k)

        def heel_print(kk: np.ndarray, sgn: float = sgn, offset: float = offset) -> np.ndarray:
            d = p.speed_m_s * (kk + offset) * T + heel_ahead
            return start + d[:, None] * f + sgn * 0.5 * p.step_width_m * lat

        hk = heel_print(k)
        hk1 = heel_print(k + 1)
        # Foot pose in its sagittal plane: forward coordinate along f, height z, pitch.
        fx = np.zeros(n)  # ankle forward offset from the footprint heel
        fz = np.zeros(n)
        pitch = np.zeros(n)
        # heel rocker
        m = phi < 0.1
        pitch[m] = p_hs * (1 - _smoothstep(phi[m] / 0.1))
        hx, hz = _rot_local(heel_x, -ank_h, pitch[m])
        fx[m], fz[m] = -hx, -hz
        # foot flat
        m = (phi >= 0.1) & (phi < 0.45)
        fx[m], fz[m] = -heel_x, ank_h
        # toe rocker: toe fixed at heel print + contact
        m = (phi >= 0.45) & (phi < 0.6)
        pitch[m] = p_to * _smoothstep((phi[m] - 0.45) / 0.15)
        tx, tz = _rot_local(toe_x, -ank_h, pitch[m])
        fx[m], fz[m] = contact - tx, -tz
        base = hk.copy()
        # swing: from the toe-off ankle to the next heel-strike ankle
        m = phi >= 0.6
        s = (phi[m] - 0.6) / 0.4
        mj = _minjerk(s)
        tx, tz = _rot_local(toe_x, -ank_h, np.full(m.sum(), p_to))
        a_to = hk[m] + (contact - tx)[:, None] * f + (-tz)[:, None] * UP
        hx, hz = _rot_local(heel_x, -ank_h, np.full(m.sum(), p_hs))
        a_hs = hk1[m] + (-hx)[:, None] * f + (-hz)[:, None] * UP
        a_sw = a_to + mj[:, None] * (a_hs - a_to)
        a_sw += (0.03 * S * np.sin(np.pi * s))[:, None] * UP
        pitch[m] = p_to + (p_hs - p_to) * _smoothstep(s / 0.8)
        ankle = base + fx[:, None] * f + fz[:, None] * UP
        ankle[m] = a_sw
        hx, hz = _rot_local(heel_x, -ank_h, pitch)
        tx, tz = _rot_local(toe_x, -ank_h, pitch)
        heel = ankle + hx[:, None] * f + hz[:, None] * UP
        toe = ankle + tx[:, None] * f + tz[:, None] * UP
        low = np.minimum(heel[:, 2], toe[:, 2])
        lift = np.where(low < 0, -low, 0.0)
        for a in (ankle, heel, toe):
            a[:, 2] += lift
        ankles[side] = (ankle, heel, toe)

    # Pelvis: constant speed, vertical bob (highest at mid-stance), sway towards the stance leg.
    phi_l = phases["left"][0]
    centre = start + (p.speed_m_s * t)[:, None] * f
    centre = centre + (0.012 * S * np.cos(2 * np.pi * (phi_l - 0.3)))[:, None] * lat
    bob = 0.012 * S * np.cos(4 * np.pi * (phi_l - 0.3))
    yaw = -math.radians(4.0) * np.cos(2 * np.pi * phi_l)
    lat_p = np.cos(yaw)[:, None] * lat - np.sin(yaw)[:, None] * f
    f_p = np.cross(lat_p, UP)
    hips = {
        "left": centre + HIP_HALF * S * lat_p,
        "right": centre - HIP_HALF * S * lat_p,
    }
    # Pelvis height: as high as the legs allow (knee nearly straight at the extremes).
    lmax = 0.997 * (THIGH + SHANK) * S
    allowed = []
    for side in ("left", "right"):
        d = ankles[side][0] - hips[side]
        dh2 = d[:, 0] ** 2 + d[:, 1] ** 2
        allowed.append(ankles[side][0][:, 2] + np.sqrt(np.maximum(lmax**2 - dh2, 0)) - bob)
    h0 = float(np.min(np.minimum(*allowed)))
    for side in ("left", "right"):
        hips[side][:, 2] = h0 + bob
    centre[:, 2] = h0 + bob

    for side, (ih, ik, ia, ihe, ito) in {
        "left": (L_HIP, L_KNEE, L_ANKLE, L_HEEL, L_TOE),
        "right": (R_HIP, R_KNEE, R_ANKLE, R_HEEL, R_TOE),
    }.items():
        ankle, heel, toe = ankles[side]
        out[:, ih] = hips[side]
        out[:, ik] = two_link_knee(hips[side], ankle, THIGH * S, SHANK * S, f)
        out[:, ia], out[:, ihe], out[:, ito] = ankle, heel, toe
    out[:, SACRUM] = centre - SACRUM_BACK * S * f_p + SACRUM_UP * S * UP

    # Upper body: upright trunk with a slight forward lean, counter-rotating shoulders,
    # arms swinging opposite to the legs.
    neck = centre + HIP_TO_NECK * S * UP + 0.02 * S * f
    out[:, NECK] = neck
    out[:, HEAD] = neck + NECK_TO_HEAD * S * UP + 0.015 * S * f
    lat_s = np.cos(-0.5 * yaw)[:, None] * lat - np.sin(-0.5 * yaw)[:, None] * f
    for sgn, (i_sh, i_el, i_wr), ph in (
        (1.0, (L_SHOULDER, L_ELBOW, L_WRIST), phi_l),
        (-1.0, (R_SHOULDER, R_ELBOW, R_WRIST), phases["right"][0]),
    ):
        sh = neck + sgn * SHOULDER_HALF * S * lat_s - 0.015 * S * UP
        swing = math.radians(15.0) * np.cos(2 * np.pi * (ph - 0.5)) + math.radians(3.0)
        abd = math.radians(8.0)
        down = -UP * math.cos(abd) + sgn * lat_s * math.sin(abd)
        d_ua = np.cos(swing)[:, None] * down + np.sin(swing)[:, None] * f
        el = sh + UPPER_ARM * S * d_ua
        fl = swing + math.radians(20.0)
        d_fa = np.cos(fl)[:, None] * down + np.sin(fl)[:, None] * f
        out[:, i_sh], out[:, i_el], out[:, i_wr] = sh, el, el + FOREARM * S * d_fa

    events = []
    for side, offset in (("left", 0.0), ("right", 0.5)):
        k = 0
        while True:
            ths = (k + offset) * T
            if ths > t[-1]:
                break
            events.append({"side": side, "type": "heel_strike", "time_s": float(ths)})
            if ths + 0.6 * T <= t[-1]:
                events.append({"side": side, "type": "toe_off", "time_s": float(ths + 0.6 * T)})
            k += 1
        if offset > 0 and t[-1] >= 0.1 * T:  # right foot already in stance at t = 0
            events.append({"side": side, "type": "toe_off", "time_s": float(0.1 * T)})
    events.sort(key=lambda e: e["time_s"])
    return Trajectory(
        positions=out,
        times=t,
        fps=p.fps,
        source=(
            f"procedural walk (height {S:.2f} m, {p.speed_m_s:.2f} m/s, "
            f"{p.cadence_steps_min:.0f} steps/min)"
        ),
        events=events,
    )


def two_link_knee(
    hip: np.ndarray, ankle: np.ndarray, l1: float, l2: float, forward: np.ndarray
) -> np.ndarray:
    """Knee centres (T, 3) from hip and ankle centres (T, 3), bending towards ``forward``."""
    d = ankle - hip
    dist = np.linalg.norm(d, axis=1)
    dist = np.clip(dist, abs(l1 - l2) + 1e-6, (l1 + l2) * 0.99999)
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    fw = np.broadcast_to(forward, d.shape)
    perp = fw - np.sum(fw * u, axis=1, keepdims=True) * u
    perp /= np.maximum(np.linalg.norm(perp, axis=1, keepdims=True), 1e-9)
    a = (l1**2 - l2**2 + dist**2) / (2 * dist)
    b = np.sqrt(np.maximum(l1**2 - a**2, 0.0))
    return hip + a[:, None] * u + b[:, None] * perp


# -- preparing recorded motion -------------------------------------------------------------------


def estimate_stature(positions: np.ndarray) -> float:
    """Standing height (m) estimated from key points (T, 19, 3): head, else neck, else hips."""
    head = positions[:, HEAD, 2]
    if np.isfinite(head).sum() > 0:
        # the head is highest at mid-stance, close to its standing height
        return float(np.nanpercentile(head, 95) / 0.935)
    neck = positions[:, NECK, 2]
    if np.isfinite(neck).sum() > 0:
        return float(np.nanpercentile(neck, 95) / 0.83)
    hips = positions[:, [L_HIP, R_HIP], 2]
    if np.isfinite(hips).sum() > 0:
        # hip joints are at 0.53 S standing, a little lower while walking
        return float(np.nanmedian(hips) / 0.52)
    raise MotionError("cannot estimate stature: neither head nor hips are known")


def stature_of(traj: Trajectory) -> float:
    """The subject's standing height: the trajectory's own when known (a synthesised walk),
    else :func:`estimate_stature` of its key points."""
    if traj.stature_m is not None:
        return float(traj.stature_m)
    return estimate_stature(traj.positions)


def _fill_gaps(positions: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Interpolate NaN gaps in time; all-NaN key points stay NaN.

    A key point whose parent in the skeleton tree (``BONES``) is known throughout is filled as
    parent + interpolated offset, so a marker lost while the limb moves stays attached to it.
    """
    from gaitwatch.conventions import BONE_INDICES

    out = positions.copy()

    def interp(values: np.ndarray) -> np.ndarray | None:
        ok = np.isfinite(values).all(axis=1)
        if ok.all() or not ok.any():
            return None
        return np.stack([np.interp(times, times[ok], values[ok, c]) for c in range(3)], 1)

    filled = interp(out[:, SACRUM])
    if filled is not None:
        out[:, SACRUM] = filled
    for parent, child in BONE_INDICES:
        if np.isfinite(out[:, parent]).all():
            off = interp(out[:, child] - out[:, parent])
            if off is not None:
                out[:, child] = out[:, parent] + off
        else:
            filled = interp(out[:, child])
            if filled is not None:
                out[:, child] = filled
    return out


def _body_axes(pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame left (lateral) and forward horizontal unit vectors from the hips."""
    lat = pos[:, L_HIP] - pos[:, R_HIP]
    lat[:, 2] = 0
    lat /= np.maximum(np.linalg.norm(lat, axis=1, keepdims=True), 1e-9)
    fwd = np.cross(lat, UP)
    return lat, fwd


def complete_for_render(traj: Trajectory) -> tuple[Trajectory, list[str]]:
    """Fill what a recording lacks so that every key point is known in every frame.

    Frames before the first and after the last frame where every recorded key point is known
    are dropped (end gaps are not extrapolated); gaps inside are interpolated.

    Returns
    -------
    Trajectory
        The kept frames (original times and frame numbers), all 19 key points finite.
    list of str
        Names of the key points that were synthesised (absent from the whole recording) rather
        than interpolated.

    Raises
    ------
    MotionError
        When hips, knees or ankles are absent from the whole recording.
    """
    from gaitwatch.conventions import KEYPOINTS

    # Keep the span where every recorded key point is known at its ends (no held values).
    present = np.isfinite(traj.positions).all(axis=2).any(axis=0)
    valid = np.isfinite(traj.positions[:, present]).all(axis=(1, 2))
    if not valid.any():
        raise MotionError(f"{traj.source or 'motion'}: no frame has all its recorded key points")
    first, last = np.flatnonzero(valid)[[0, -1]]
    if first > 0 or last < len(traj) - 1:
        log.info("%s: using frames %d..%d (key points missing outside)", traj.source, first, last)
        traj = Trajectory(
            positions=traj.positions[first : last + 1],
            times=traj.times[first : last + 1],
            frames=traj.frames[first : last + 1],
            fps=traj.fps,
            source=traj.source,
            events=[e for e in traj.events if traj.times[first] <= e["time_s"] <= traj.times[last]],
            stature_m=traj.stature_m,
        )
    pos = _fill_gaps(traj.positions, traj.times)
    missing = [j for j in range(N_KEYPOINTS) if not np.isfinite(pos[:, j]).all()]
    need = [L_HIP, R_HIP, L_KNEE, R_KNEE, L_ANKLE, R_ANKLE]
    lacking = [KEYPOINTS[j] for j in need if j in missing]
    if lacking:
        raise MotionError(
            f"{traj.source or 'motion'}: cannot render a body without {', '.join(lacking)}"
        )
    S = traj.stature_m if traj.stature_m is not None else estimate_stature(pos)
    lat, fwd = _body_axes(pos)
    mid_hip = 0.5 * (pos[:, L_HIP] + pos[:, R_HIP])
    if SACRUM in missing:
        pos[:, SACRUM] = mid_hip - SACRUM_BACK * S * fwd + SACRUM_UP * S * UP
    for ia, ih, it in ((L_ANKLE, L_HEEL, L_TOE), (R_ANKLE, R_HEEL, R_TOE)):
        if ih in missing:
            h = pos[:, ia] - HEEL_BACK * S * fwd
            h[:, 2] = np.maximum(pos[:, ia, 2] - ANKLE_H * S, 0.0)
            pos[:, ih] = h
        if it in missing:
            t_ = pos[:, ia] + TOE_FWD * S * fwd
            t_[:, 2] = np.maximum(pos[:, ia, 2] - ANKLE_H * S, 0.0)
            pos[:, it] = t_
    # Upright trunk on the pelvis: each missing point hangs from its parent (recorded or
    # itself synthesised): neck from the hips, head and shoulders from the neck, elbows from
    # the shoulders, wrists from the elbows.
    if NECK in missing:
        pos[:, NECK] = mid_hip + HIP_TO_NECK * S * UP
    if HEAD in missing:
        pos[:, HEAD] = pos[:, NECK] + NECK_TO_HEAD * S * UP + 0.015 * S * fwd
    abd = math.radians(8.0)
    for sgn, i_sh, i_el, i_wr in (
        (1, L_SHOULDER, L_ELBOW, L_WRIST),
        (-1, R_SHOULDER, R_ELBOW, R_WRIST),
    ):
        down = -UP * math.cos(abd) + sgn * lat * math.sin(abd)
        if i_sh in missing:
            pos[:, i_sh] = pos[:, NECK] + sgn * SHOULDER_HALF * S * lat - 0.015 * S * UP
        if i_el in missing:
            pos[:, i_el] = pos[:, i_sh] + UPPER_ARM * S * down
        if i_wr in missing:
            d_fa = down * math.cos(math.radians(15)) + fwd * math.sin(math.radians(15))
            pos[:, i_wr] = pos[:, i_el] + FOREARM * S * d_fa
    synthesised = [KEYPOINTS[j] for j in missing]
    if synthesised:
        log.info("%s: synthesised key points %s", traj.source, ", ".join(synthesised))
    if not np.isfinite(pos).all():
        raise MotionError(f"{traj.source or 'motion'}: key points remain unknown after filling")
    out = traj.with_positions(pos)
    return out, synthesised


def resample(traj: Trajectory, fps: float, max_frames: int | None = None) -> Trajectory:
    """:func:`gaitwatch.trajectory.resample`, with a :class:`MotionError` for a bad request."""
    try:
        return resample_trajectory(traj, fps, max_frames)
    except ValueError as err:
        raise MotionError(str(err)) from None


def walking_direction(traj: Trajectory) -> np.ndarray | None:
    """Horizontal unit vector of the sacrum's travel, or None if it hardly moves (treadmill)."""
    s = traj.positions[:, SACRUM]
    ok = np.isfinite(s).all(axis=1)
    if ok.sum() < 2:
        return None
    d = s[ok][-1] - s[ok][0]
    d[2] = 0
    nrm = np.linalg.norm(d)
    return d / nrm if nrm > 0.3 else None


def place_on_path(
    traj: Trajectory, start_xy: tuple[float, float], heading_rad: float
) -> Trajectory:
    """Turn a walk about z and move it so it starts at ``start_xy`` walking along ``heading_rad``.

    A walk that hardly travels (treadmill) keeps its facing: the body's forward axis from the
    hips is used instead of its travel.
    """
    d = walking_direction(traj)
    if d is None:
        _, fwd = _body_axes(traj.positions)
        d = np.nanmean(fwd, axis=0)
        d[2] = 0
        d /= max(np.linalg.norm(d), 1e-9)
    ang = heading_rad - math.atan2(d[1], d[0])
    c, s = math.cos(ang), math.sin(ang)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    s0 = traj.positions[0, SACRUM].copy()
    s0[2] = 0
    pos = (traj.positions - s0) @ Rz.T + np.array([start_xy[0], start_xy[1], 0.0])
    return traj.with_positions(pos)


def scale_to_stature(traj: Trajectory, height_m: float) -> Trajectory:
    """Scale a motion uniformly about the floor point under its first sacrum position.

    Every length, step and speed scales with the stature; the floor stays at z = 0.
    """
    S = stature_of(traj)
    k = height_m / S
    o = np.nan_to_num(traj.positions[0, SACRUM].copy())
    o[2] = 0
    return Trajectory(
        positions=(traj.positions - o) * k + o,
        times=traj.times.copy(),
        frames=traj.frames.copy(),
        fps=traj.fps,
        source=traj.source,
        events=list(traj.events),
        stature_m=None if traj.stature_m is None else float(height_m),
    )


_WALK_KEYS = {
    "height": "height_m",
    "speed": "speed_m_s",
    "cadence": "cadence_steps_min",
    "distance": "distance_m",
    "width": "step_width_m",
    "heading": "heading_rad",
    "fps": "fps",
}


def parse_walk_spec(spec: str) -> WalkParams:
    """``walk`` or ``walk:speed=1.1,cadence=104,height=1.68,distance=5,heading=90``
    (heading in degrees) -> :class:`WalkParams`."""
    if spec == "walk":
        return WalkParams()
    body = spec.split(":", 1)[1]
    kw: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in body.split(","))):
        key, sep, val = item.partition("=")
        if not sep or key.strip() not in _WALK_KEYS:
            keys = ", ".join(k + "=" for k in _WALK_KEYS)
            raise MotionError(f"walk spec {spec!r}: {item!r} is not one of {keys}")
        try:
            v = float(val)
        except ValueError:
            raise MotionError(f"walk spec {spec!r}: {key}={val!r} is not a number") from None
        kw[_WALK_KEYS[key.strip()]] = math.radians(v) if key.strip() == "heading" else v
    return WalkParams(**kw)


def load_motion(spec: str) -> Trajectory:
    """A motion from the command line: ``walk[:...]`` (procedural, see :func:`parse_walk_spec`),
    a ``JOINTS.csv``, an OpenSim joint-angle cycle (``.mot``, walked by foot contact, see
    :mod:`gaitwatch.sim.angles`; 1.70 m tall, three cycles), or a motion-capture file read by
    ``gaitwatch.mocap.load_mocap`` (.c3d, .trc, .bvh)."""
    from pathlib import Path

    from gaitwatch.trajectory import read_joints_csv

    if spec == "walk" or spec.startswith("walk:"):
        return procedural_walk(parse_walk_spec(spec))
    path = Path(spec)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    if path.suffix.lower() == ".csv":
        return read_joints_csv(path)
    if path.suffix.lower() == ".mot":
        from gaitwatch.sim.angles import load_angle_walk

        return load_angle_walk(path)
    try:
        from gaitwatch.mocap import load_mocap  # task D's readers
    except ImportError:
        raise MotionError(
            f"{path}: reading {path.suffix} files needs gaitwatch.mocap, which is not available"
        ) from None
    return load_mocap(path)
