"""Centre of mass from the key points and the margin of stability (Hof et al. 2005).

Segment masses and centre-of-mass locations: de Leva (1996), *Adjustments to
Zatsiorsky-Seluyanov's segment inertia parameters*, J Biomech 29:1223-1230, Table 4 (male
values). The 19 key points do not mark every landmark of that table, so: the head+neck segment's
centre of mass is the ``head`` key point; the trunk runs from ``neck`` (cervicale) to the
mid-point of the hips (de Leva's MIDH); hands sit at the wrists; the foot runs from heel to toe.

Extrapolated centre of mass: ``XCoM = CoM + v_CoM / omega0`` with ``omega0 = sqrt(g / l)``,
``l`` the pendulum length, here the mean height of the centre of mass while walking (Hof, Gazendam
& Sinke 2005, *The condition for dynamic stability*, J Biomech 38:1-8). The margin of stability is
the distance from XCoM to the edge of the base of support, positive when XCoM is inside.
"""

from __future__ import annotations

import numpy as np

from gait.filtering import lowpass
from gait.geometry import left_of
from gaitwatch.conventions import KP, L_HIP, NECK, R_HIP

G = 9.81

# (proximal, distal, mass fraction, CoM fraction from proximal): de Leva 1996, male.
SEGMENTS: tuple[tuple[str, str, float, float], ...] = (
    ("head", "head", 0.0694, 0.0),
    ("neck", "mid_hip", 0.4346, 0.4486),
    ("left_shoulder", "left_elbow", 0.0271, 0.5772),
    ("right_shoulder", "right_elbow", 0.0271, 0.5772),
    ("left_elbow", "left_wrist", 0.0162, 0.4574),
    ("right_elbow", "right_wrist", 0.0162, 0.4574),
    ("left_wrist", "left_wrist", 0.0061, 0.0),
    ("right_wrist", "right_wrist", 0.0061, 0.0),
    ("left_hip", "left_knee", 0.1416, 0.4095),
    ("right_hip", "right_knee", 0.1416, 0.4095),
    ("left_knee", "left_ankle", 0.0433, 0.4459),
    ("right_knee", "right_ankle", 0.0433, 0.4459),
    ("left_heel", "left_toe", 0.0137, 0.4415),
    ("right_heel", "right_toe", 0.0137, 0.4415),
)


def centre_of_mass(positions: np.ndarray) -> np.ndarray:
    """Whole-body centre of mass in metres, shape (N, 3).

    Segments whose end points are unknown in a frame are left out of that frame and the
    remaining masses renormalised; frames without the trunk are NaN.

    Parameters
    ----------
    positions : ndarray, shape (N, 19, 3)
    """
    mid_hip = 0.5 * (positions[:, L_HIP] + positions[:, R_HIP])

    def pt(name: str) -> np.ndarray:
        return mid_hip if name == "mid_hip" else positions[:, KP[name]]

    num = np.zeros((positions.shape[0], 3))
    den = np.zeros(positions.shape[0])
    for prox, dist, m, c in SEGMENTS:
        p = pt(prox) + c * (pt(dist) - pt(prox))
        ok = np.isfinite(p).all(axis=1)
        num[ok] += m * p[ok]
        den[ok] += m
    trunk_ok = np.isfinite(positions[:, NECK]).all(axis=1) & np.isfinite(mid_hip).all(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        com = num / den[:, None]
    com[~trunk_ok | (den < 0.6)] = np.nan
    return com


def extrapolated_com(
    com: np.ndarray, fps: float, pendulum_length_m: float | None = None, cutoff_hz: float = 6.0
) -> tuple[np.ndarray, float]:
    """Hof's extrapolated centre of mass, shape (N, 3), and the pendulum length used (m).

    Parameters
    ----------
    com : ndarray, shape (N, 3)
        Centre of mass, metres.
    fps : float
        Hz.
    pendulum_length_m : float, optional
        ``l`` in ``omega0 = sqrt(g / l)``; default the median CoM height.
    """
    c = lowpass(com, fps, cutoff_hz)
    v = np.gradient(c, 1.0 / fps, axis=0) if c.shape[0] > 1 else np.zeros_like(c)
    if pendulum_length_m is None:
        pendulum_length_m = float(np.nanmedian(c[:, 2])) if np.isfinite(c[:, 2]).any() else 1.0
    w0 = np.sqrt(G / max(pendulum_length_m, 0.1))
    return c + v / w0, pendulum_length_m


def margins_at(
    xcom: np.ndarray,
    positions: np.ndarray,
    forward: np.ndarray,
    side: str,
    frame: float,
) -> tuple[float, float]:
    """Margins of stability (m) when foot ``side`` lands at fractional ``frame``.

    Mediolateral: distance from XCoM to the landing foot's line (heel-toe mid-point) along the
    outward lateral direction of that foot. Anteroposterior: distance from XCoM to the landing
    foot's toe along the walking direction.
    """
    i = int(np.clip(np.floor(frame), 0, xcom.shape[0] - 1))
    j = min(i + 1, xcom.shape[0] - 1)
    w = float(np.clip(frame - i, 0.0, 1.0))

    def at(x: np.ndarray) -> np.ndarray:
        return (1 - w) * x[i] + w * x[j]

    heel = at(positions[:, KP[f"{side}_heel"]])
    toe = at(positions[:, KP[f"{side}_toe"]])
    ankle = at(positions[:, KP[f"{side}_ankle"]])
    foot = 0.5 * (heel + toe)
    if not np.isfinite(foot).all():
        foot = ankle
    if not np.isfinite(toe).all():
        toe = ankle
    f = at(forward)
    f = f / np.linalg.norm(f) if np.isfinite(f).all() and np.linalg.norm(f) > 0 else f
    outward = left_of(f) * (1.0 if side == "left" else -1.0)
    x = at(xcom)
    ml = float((foot - x)[:2] @ outward[:2])
    ap = float((toe - x)[:2] @ f[:2])
    return ml, ap
