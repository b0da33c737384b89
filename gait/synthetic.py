"""Synthetic recordings with known gait events, for tests and demonstrations.

:func:`synthetic_walk` makes a straight, steady walk of the 19 key points with exact heel
strikes and toe offs: each foot is flat on the floor from shortly after heel strike, rolls over
the toe in terminal stance, and swings to the next placement with a smooth (quintic) profile.
Knees come from two-link inverse kinematics of hip and ankle. :func:`synthetic_pose_sequence`
interpolates between standing, sitting and lying key poses (transfers, falls).
Every random draw comes from the ``rng`` argument.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gaitwatch.conventions import KP, N_KEYPOINTS
from gaitwatch.trajectory import Trajectory

THIGH_M = 0.44
SHANK_M = 0.43
FOOT_M = 0.22
ANKLE_UP_M = 0.07
ANKLE_FWD_M = 0.05
HIP_HALF_WIDTH_M = 0.09


def _quintic(u: np.ndarray, x0: float, x1: float, v0: float, v1: float = 0.0) -> np.ndarray:
    """Quintic from x0 (velocity v0) to x1 (velocity v1), zero acceleration at both ends; u in
    [0, 1], velocities per unit u."""
    d = x1 - x0
    # x(u) = x0 + v0 u + a3 u^3 + a4 u^4 + a5 u^5 with x(1)=x1, x'(1)=v1, x''(1)=0.
    A = np.array([[1, 1, 1], [3, 4, 5], [6, 12, 20]], dtype=np.float64)
    b = np.array([d - v0, v1 - v0, 0.0])
    a3, a4, a5 = np.linalg.solve(A, b)
    return x0 + v0 * u + a3 * u**3 + a4 * u**4 + a5 * u**5


def _knee(hip: np.ndarray, ankle: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """Knee positions (N, 3) from two-link IK, bending forward."""
    d = ankle - hip
    L = np.linalg.norm(d, axis=1)
    Lc = np.clip(L, 1e-6, THIGH_M + SHANK_M - 1e-9)
    # Distance along hip->ankle to the knee's foot point, and the knee's offset from the line.
    a = (THIGH_M**2 - SHANK_M**2 + Lc**2) / (2 * Lc)
    h = np.sqrt(np.clip(THIGH_M**2 - a**2, 0.0, None))
    u = d / np.maximum(L, 1e-9)[:, None]
    # Perpendicular in the sagittal plane, pointing forward.
    side = np.cross(u, forward)
    perp = np.cross(side, u)
    perp /= np.maximum(np.linalg.norm(perp, axis=1, keepdims=True), 1e-9)
    return hip + a[:, None] * u + h[:, None] * perp


def _upper_body(sac: np.ndarray, fwd: np.ndarray, left: np.ndarray, swing: np.ndarray):
    """Neck, head, shoulders, elbows, wrists (N, 3) each; ``swing`` (N,) arm swing in metres."""
    up = np.array([0.0, 0.0, 1.0])
    neck = sac + 0.50 * up + 0.03 * fwd
    head = neck + 0.20 * up + 0.02 * fwd
    out = {"neck": neck, "head": head}
    for side, sgn in (("left", 1.0), ("right", -1.0)):
        sh = neck + sgn * 0.18 * left - 0.02 * up
        arm = -sgn * swing[:, None] * fwd  # arms swing opposite to the legs
        el = sh - 0.29 * up + 0.5 * arm
        wr = el - 0.26 * up + arm
        out[f"{side}_shoulder"], out[f"{side}_elbow"], out[f"{side}_wrist"] = sh, el, wr
    return out


def synthetic_walk(
    speed_m_s: float = 1.2,
    cadence_steps_min: float = 110.0,
    n_strides: int = 6,
    fps: float = 100.0,
    heading_deg: float = 0.0,
    stance_fraction: float = 0.6,
    step_width_m: float = 0.12,
    start_xy: Sequence[float] = (0.0, 0.0),
    t0: float = 0.0,
    lead_in_s: float = 0.5,
) -> Trajectory:
    """A steady straight walk with exact events in ``Trajectory.events``.

    Parameters
    ----------
    speed_m_s, cadence_steps_min : float
        Walking speed and cadence; stride length = speed x 120 / cadence.
    n_strides : int
        Gait cycles of the left foot inside the recording.
    fps : float
        Frame rate, Hz.
    heading_deg : float
        Walking direction, degrees from +x towards +y.
    stance_fraction : float
        Stance phase as a fraction of the stride (double support is 2 x (stance - 0.5)).
    step_width_m : float
        Lateral distance between the feet's lines.
    lead_in_s : float
        Time recorded before the first left heel strike (the walk is already under way).

    Returns
    -------
    Trajectory
        Positions (T, 19, 3) in metres; ``events`` holds every heel strike and toe off inside
        the recording.
    """
    T = 120.0 / cadence_steps_min
    S = speed_m_s * T
    dur = lead_in_s + n_strides * T + 0.5 * T
    t = np.arange(0.0, dur, 1.0 / fps)
    n = t.size
    h = np.radians(heading_deg)
    fwd = np.array([np.cos(h), np.sin(h), 0.0])
    left = np.array([-np.sin(h), np.cos(h), 0.0])
    origin = np.array([start_xy[0], start_xy[1], 0.0])

    # Progress along the path (body frame: s forward, lateral, up).
    s_sac = speed_m_s * (t - lead_in_s) + 0.3 * S
    sac_z = 0.93 + 0.015 * np.cos(4 * np.pi * (t - lead_in_s) / T)
    sac_lat = 0.015 * np.sin(2 * np.pi * (t - lead_in_s) / T)
    pos = np.full((n, N_KEYPOINTS, 3), np.nan)
    sac = (
        origin
        + s_sac[:, None] * fwd
        + sac_lat[:, None] * left
        + sac_z[:, None] * np.array([0, 0, 1.0])
    )
    pos[:, KP["sacrum"]] = sac
    events: list[dict] = []
    th_hs, th_to = np.radians(15.0), np.radians(-40.0)
    for side, sgn, offset in (("left", 1.0, 0.0), ("right", -1.0, 0.5)):
        phase_t = (t - lead_in_s) / T - offset
        k = np.floor(phase_t)
        ph = phase_t - k
        # Heel placement of cycle k (heel strike at phase 0).
        P = (k + offset) * S + 0.3 * S + 0.18
        heel_s = np.empty(n)
        heel_z = np.empty(n)
        theta = np.empty(n)
        f_load, f_flat = 0.1, stance_fraction - 0.2
        m1 = ph < f_load
        heel_s[m1], heel_z[m1] = P[m1], 0.0
        theta[m1] = th_hs * (1 - ph[m1] / f_load)
        m2 = (ph >= f_load) & (ph < f_flat)
        heel_s[m2], heel_z[m2], theta[m2] = P[m2], 0.0, 0.0
        m3 = (ph >= f_flat) & (ph < stance_fraction)
        u = (ph[m3] - f_flat) / (stance_fraction - f_flat)
        theta[m3] = th_to * u**2
        toe_s = P[m3] + FOOT_M
        heel_s[m3] = toe_s - FOOT_M * np.cos(theta[m3])
        heel_z[m3] = -FOOT_M * np.sin(theta[m3])
        m4 = ph >= stance_fraction
        u = (ph[m4] - stance_fraction) / (1 - stance_fraction)
        hs0 = P[m4] + FOOT_M - FOOT_M * np.cos(th_to)
        sw_T = (1 - stance_fraction) * T
        dist = S - FOOT_M + FOOT_M * np.cos(th_to)  # heel travel in swing
        heel_s[m4] = hs0 + dist * _quintic(
            u, 0.0, 1.0, 1.2 * speed_m_s * sw_T / dist, 0.7 * speed_m_s * sw_T / dist
        )
        z0 = -FOOT_M * np.sin(th_to)
        heel_z[m4] = z0 * (1 - u) ** 2 + 0.08 * np.sin(np.pi * u) * (1 - u) ** 0.5
        theta[m4] = th_to + (th_hs - th_to) * _quintic(u, 0.0, 1.0, 0.0)
        lat = sgn * step_width_m / 2
        heel = origin + heel_s[:, None] * fwd + lat * left + heel_z[:, None] * np.array([0, 0, 1.0])
        foot_dir = np.cos(theta)[:, None] * fwd + np.sin(theta)[:, None] * np.array([0, 0, 1.0])
        foot_up = -np.sin(theta)[:, None] * fwd + np.cos(theta)[:, None] * np.array([0, 0, 1.0])
        toe = heel + FOOT_M * foot_dir
        ankle = heel + ANKLE_FWD_M * foot_dir + ANKLE_UP_M * foot_up
        hip = sac + sgn * HIP_HALF_WIDTH_M * left - np.array([0, 0, 0.05])
        knee = _knee(hip, ankle, np.broadcast_to(fwd, hip.shape))
        for name, arr in (
            ("heel", heel),
            ("toe", toe),
            ("ankle", ankle),
            ("hip", hip),
            ("knee", knee),
        ):
            pos[:, KP[f"{side}_{name}"]] = arr
        for kk in range(-1, n_strides + 2):
            ths = lead_in_s + (kk + offset) * T
            tto = ths + stance_fraction * T
            for typ, tt in (("heel_strike", ths), ("toe_off", tto)):
                if t[0] + 0.05 <= tt <= t[-1] - 0.05:
                    events.append({"side": side, "type": typ, "time_s": float(tt + t0)})
    swing = 0.15 * np.sin(2 * np.pi * (t - lead_in_s) / T)
    for name, arr in _upper_body(sac, fwd, left, swing).items():
        pos[:, KP[name]] = arr
    events.sort(key=lambda e: e["time_s"])
    return Trajectory(positions=pos, times=t + t0, fps=fps, source="synthetic walk", events=events)


def standing_pose(xy: Sequence[float] = (0.0, 0.0), heading_deg: float = 0.0) -> np.ndarray:
    """A standing pose (19, 3): sacrum at 0.93 m, feet side by side."""
    return _pose(xy, heading_deg, "stand")


def sitting_pose(xy: Sequence[float] = (0.0, 0.0), heading_deg: float = 0.0) -> np.ndarray:
    """Seated on a 0.45 m chair (19, 3)."""
    return _pose(xy, heading_deg, "sit")


def lying_pose(xy: Sequence[float] = (0.0, 0.0), heading_deg: float = 0.0) -> np.ndarray:
    """Lying on the floor on the back (19, 3)."""
    return _pose(xy, heading_deg, "lie")


def _pose(xy: Sequence[float], heading_deg: float, kind: str) -> np.ndarray:
    h = np.radians(heading_deg)
    f = np.array([np.cos(h), np.sin(h), 0.0])
    lft = np.array([-np.sin(h), np.cos(h), 0.0])
    up = np.array([0.0, 0.0, 1.0])
    o = np.array([xy[0], xy[1], 0.0])
    p = np.zeros((N_KEYPOINTS, 3))
    if kind == "lie":
        # Lying along -f (feet towards f), everything near the floor.
        sac = o + 0.12 * up
        p[KP["sacrum"]] = sac
        p[KP["neck"]] = sac - 0.5 * f
        p[KP["head"]] = sac - 0.7 * f + 0.03 * up
        for side, sg in (("left", 1), ("right", -1)):
            p[KP[f"{side}_shoulder"]] = sac - 0.48 * f + sg * 0.18 * lft
            p[KP[f"{side}_elbow"]] = sac - 0.2 * f + sg * 0.25 * lft
            p[KP[f"{side}_wrist"]] = sac + 0.05 * f + sg * 0.28 * lft
            hip = sac + sg * 0.09 * lft - 0.02 * up + 0.05 * f
            p[KP[f"{side}_hip"]] = hip
            p[KP[f"{side}_knee"]] = hip + THIGH_M * f
            p[KP[f"{side}_ankle"]] = hip + (THIGH_M + SHANK_M) * f
            p[KP[f"{side}_heel"]] = p[KP[f"{side}_ankle"]] - 0.05 * up + 0.02 * f
            p[KP[f"{side}_toe"]] = p[KP[f"{side}_ankle"]] + 0.15 * up + 0.05 * f
        return p
    sac_z = 0.93 if kind == "stand" else 0.50
    sac = o + sac_z * up
    p[KP["sacrum"]] = sac
    lean = 0.03 if kind == "stand" else 0.08
    p[KP["neck"]] = sac + 0.5 * up + lean * f
    p[KP["head"]] = p[KP["neck"]] + 0.2 * up + 0.02 * f
    for side, sg in (("left", 1), ("right", -1)):
        p[KP[f"{side}_shoulder"]] = p[KP["neck"]] + sg * 0.18 * lft - 0.02 * up
        p[KP[f"{side}_elbow"]] = p[KP[f"{side}_shoulder"]] - 0.29 * up
        p[KP[f"{side}_wrist"]] = (
            p[KP[f"{side}_elbow"]] - 0.26 * up + (0.1 * f if kind == "sit" else 0)
        )
        hip = sac + sg * 0.09 * lft - 0.05 * up
        p[KP[f"{side}_hip"]] = hip
        if kind == "stand":
            knee = hip - THIGH_M * up
            ankle = knee - SHANK_M * up
        else:
            knee = hip + THIGH_M * f
            ankle = knee - SHANK_M * up
        p[KP[f"{side}_knee"]] = knee
        p[KP[f"{side}_ankle"]] = ankle
        p[KP[f"{side}_heel"]] = np.array([ankle[0], ankle[1], 0.0]) - ANKLE_FWD_M * f
        p[KP[f"{side}_toe"]] = np.array([ankle[0], ankle[1], 0.0]) + 0.15 * f
    return p


def synthetic_pose_sequence(
    keyframes: Sequence[tuple[float, np.ndarray]],
    fps: float = 30.0,
    rng: np.random.Generator | None = None,
    noise_m: float = 0.0,
) -> Trajectory:
    """Interpolate key poses ``(time_s, pose (19, 3))`` with a smooth (cosine) blend.

    Between two key frames the pose moves from one to the other; equal consecutive poses hold
    still. Optional Gaussian noise of ``noise_m`` metres drawn from ``rng``.
    """
    times = np.arange(keyframes[0][0], keyframes[-1][0] + 1e-9, 1.0 / fps)
    kt = np.array([k[0] for k in keyframes])
    kp = np.stack([k[1] for k in keyframes])
    i = np.clip(np.searchsorted(kt, times, side="right") - 1, 0, len(kt) - 2)
    w = (times - kt[i]) / (kt[i + 1] - kt[i])
    w = 0.5 - 0.5 * np.cos(np.pi * np.clip(w, 0, 1))
    pos = (1 - w)[:, None, None] * kp[i] + w[:, None, None] * kp[i + 1]
    if noise_m:
        if rng is None:
            raise ValueError("noise needs an rng")
        pos = pos + rng.normal(0.0, noise_m, pos.shape)
    return Trajectory(positions=pos, times=times, fps=fps, source="synthetic poses")
