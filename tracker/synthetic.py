"""Small synthetic clips for the tracker's tests and speed benchmark (no file I/O).

A walking motion made of DOF sinusoids (:func:`walking_motion`), rendered as flat-coloured
silhouettes of the tracker's own body model over a textured background
(:func:`render_clip`). This is deliberately the *model's* own appearance, so it measures the
filters and the pipeline, not how well the model fits real people; the scene synthesiser
(``gaitwatch.sim``) renders independent bodies for accuracy studies.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import cv2
import numpy as np

from gaitwatch.conventions import L_HEEL, L_TOE, R_HEEL, R_TOE
from tracker.camera import Camera
from tracker.dof import DOF, N_DOF
from tracker.init import walking_phase_angles


def walking_motion(
    body,
    n_frames: int,
    *,
    fps: float = 20.0,
    speed_m_s: float = 1.0,
    cadence_steps_min: float = 105.0,
    start_xy: Sequence[float] = (0.0, 0.0),
    heading: float = 0.0,
    phase0: float = 0.0,
) -> np.ndarray:
    """Poses (T, 31) of a straight walk with the root height keeping the lower foot on the floor.

    Parameters
    ----------
    body : tracker.body.BodyModel
    n_frames : int
    fps : float
    speed_m_s : float
        Walking speed along ``heading`` (radians, 0 = +x).
    cadence_steps_min : float
        Steps per minute (a gait cycle is two steps).
    start_xy : (x, y)
        Root position at frame 0, metres.
    phase0 : float
        Gait-cycle phase of the left leg at frame 0 (0 = left heel strike).
    """
    t = np.arange(n_frames) / fps
    phase = phase0 + t * cadence_steps_min / 120.0
    hl, kl = walking_phase_angles(phase)
    hr, kr = walking_phase_angles(phase + 0.5)
    p = np.repeat(np.asarray(body.neutral_pose(0.0, 0.0, heading))[None], n_frames, axis=0)
    p[:, DOF["root_x"]] = start_xy[0] + np.cos(heading) * speed_m_s * t
    p[:, DOF["root_y"]] = start_xy[1] + np.sin(heading) * speed_m_s * t
    p[:, DOF["l_hip_flexion"]] = np.radians(hl)
    p[:, DOF["r_hip_flexion"]] = np.radians(hr)
    p[:, DOF["l_knee_flexion"]] = np.radians(kl)
    p[:, DOF["r_knee_flexion"]] = np.radians(kr)
    p[:, DOF["l_shoulder_flexion"]] = np.radians(-0.6 * (hr - 10.0))
    p[:, DOF["r_shoulder_flexion"]] = np.radians(-0.6 * (hl - 10.0))
    p[:, DOF["l_elbow_flexion"]] = p[:, DOF["r_elbow_flexion"]] = np.radians(20.0)
    p[:, DOF["root_yaw"]] = heading + np.radians(3.0) * np.sin(2 * np.pi * phase)
    p[:, DOF["root_z"]] = 0.0
    feet = np.asarray(body.forward(p))[:, [L_HEEL, R_HEEL, L_TOE, R_TOE], 2]
    p[:, DOF["root_z"]] = -feet.min(axis=1)
    assert p.shape == (n_frames, N_DOF)
    return p


def side_cameras(
    n: int = 2,
    *,
    image_size: tuple[int, int] = (640, 480),
    centre: Sequence[float] = (1.0, 0.0),
    fps: float = 20.0,
) -> list[Camera]:
    """Home-like cameras 2.3 m high looking down at a walkway along x through ``centre``.

    The first is side-on (4.5 m away, on the -y side), the second oblique, the third frontal.
    """
    cx, cy = centre
    spots = [
        ((cx, cy - 4.5, 2.3), "side"),
        ((cx + 3.2, cy - 3.2, 2.3), "oblique"),
        ((cx + 4.5, cy + 0.5, 2.3), "frontal"),
    ]
    cams = []
    for i in range(n):
        pos, name = spots[i % len(spots)]
        cams.append(
            Camera.look_at(
                name=f"{name}{i}",
                position=pos,
                target=(cx, cy, 0.8),
                image_size=image_size,
                hfov_deg=62.0,
                fps=fps,
            )
        )
    return cams


def textured_background(width: int, height: int, rng: np.random.Generator) -> np.ndarray:
    """A smooth random colour texture, uint8 (H, W, 3) BGR, values well away from the person."""
    small = rng.integers(60, 150, size=(max(2, height // 16), max(2, width // 16), 3))
    img = cv2.resize(small.astype(np.uint8), (width, height), interpolation=cv2.INTER_CUBIC)
    return img


def render_clip(
    renderer,
    poses: np.ndarray,
    backgrounds: Sequence[np.ndarray],
    rng: np.random.Generator,
    *,
    colour: Sequence[int] = (200, 40, 230),
    noise: float = 3.0,
) -> Iterator[list[np.ndarray]]:
    """Frames (one uint8 BGR image per camera) of the model in ``poses`` over ``backgrounds``.

    Parameters
    ----------
    renderer
        Anything with ``render_mask(pose, camera_index) -> bool (H, W)`` at the backgrounds'
        resolution, e.g. ``SilhouetteLikelihood(body, cameras)``.
    poses : ndarray, shape (T, 31)
    backgrounds : sequence of uint8 (H, W, 3)
    rng : numpy.random.Generator
        Sensor noise (Gaussian, sigma ``noise`` grey levels).
    """
    col = np.asarray(colour, dtype=np.uint8)
    for pose in poses:
        frames = []
        for c, bg in enumerate(backgrounds):
            img = bg.copy()
            m = np.asarray(renderer.render_mask(pose, c), dtype=bool)
            img[m] = col
            if noise > 0:
                n = rng.normal(0.0, noise, size=img.shape)
                img = np.clip(img + n, 0, 255).astype(np.uint8)
            frames.append(img)
        yield frames
