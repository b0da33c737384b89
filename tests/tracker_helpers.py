"""Helpers shared by the tracker's tests: footage of the tracker's own body."""

from __future__ import annotations

import numpy as np

from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.likelihood import SilhouetteLikelihood


class Counting:
    """Counts the poses weighed, as the pipeline does (factored combinations one each)."""

    def __init__(self, inner: SilhouetteLikelihood, factored: bool = True) -> None:
        self.inner = inner
        self.count = 0
        if factored:
            self.weights_factored = self._factored

    def weights(self, poses: np.ndarray) -> np.ndarray:
        self.count += np.atleast_2d(poses).shape[0]
        return self.inner.weights(poses)

    def _factored(self, base, left, right) -> np.ndarray:
        self.count += base.shape[0] * left.shape[1] * right.shape[1]
        return self.inner.weights_factored(base, left, right)


def own_likelihood(body: BodyModel, pose: np.ndarray, n_cams: int = 2) -> SilhouetteLikelihood:
    """Silhouettes of ``pose`` rendered by the tracker's own model (an exact match exists),
    through a front and a side camera at 160x120."""
    cams = [
        Camera.look_at(name="front", position=[4.0, 1.0, 1.5], target=[0, 0, 0.9]),
        Camera.look_at(name="side", position=[0.5, -4.0, 1.8], target=[0, 0, 0.9]),
    ][:n_cams]
    lik = SilhouetteLikelihood(body, [c.scaled(160, 120) for c in cams])
    lik.set_silhouettes([lik.render_mask(pose, k) for k in range(len(cams))])
    return lik


def walking_clip() -> dict:
    """Three 20 Hz frames of the model walking, seen by two 320x240 cameras: body, cameras,
    backgrounds, frames and the poses rendered."""
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    rng = np.random.default_rng(7)
    body = BodyModel(1.70)
    cams = side_cameras(2, image_size=(320, 240), fps=20.0)
    poses = walking_motion(body, 3, fps=20.0, speed_m_s=1.0)
    bgs = [textured_background(320, 240, rng) for _ in cams]
    frames = list(render_clip(SilhouetteLikelihood(body, cams), poses, bgs, rng))
    return {"body": body, "cams": cams, "bgs": bgs, "frames": frames, "poses": poses}


def factored_equals_flat(lik, base, left, right, rtol):
    """The factored weights of every leg combination equal the weights of the combined poses:
    the combined poses (flat) and their weights (M, A, B)."""
    from tracker.dof import LEFT_LEG, N_DOF, RIGHT_LEG

    m, na, nb = base.shape[0], left.shape[1], right.shape[1]
    wf = lik.weights_factored(base, left, right)
    full = np.repeat(np.repeat(base[:, None, None], na, 1), nb, 2)
    full[..., list(LEFT_LEG)] = left[:, :, None]
    full[..., list(RIGHT_LEG)] = right[:, None, :]
    flat = full.reshape(-1, N_DOF)
    w = lik.weights(flat).reshape(m, na, nb)
    np.testing.assert_allclose(wf, w, rtol=rtol, atol=1e-15)
    return flat, w


def assert_written_is_model(written: np.ndarray, model: np.ndarray) -> None:
    """The written key points (19, 3) are the model's forward kinematics ``model``, but for the
    points ``keypoints.fuse`` averages with the triangulated detections (two cameras: the hips'
    height, the sacrum and the shoulders), which lie within half of ``fuse_max_gap_m`` of the
    model's (the hips straight above or below)."""
    from gaitwatch.conventions import KP
    from tracker.config import KeypointConfig

    kc = KeypointConfig()
    fused = [KP[n] for n in ("left_hip", "right_hip", "sacrum", "left_shoulder", "right_shoulder")]
    rest = [i for i in range(len(model)) if i not in fused]
    np.testing.assert_allclose(written[rest], model[rest], atol=1e-9)
    hips = [KP["left_hip"], KP["right_hip"]]
    np.testing.assert_allclose(written[hips, :2], model[hips, :2], atol=1e-9)
    # the sacrum moves by the hips' mean step, each at most weight x gap
    reach = kc.fuse_weight * kc.fuse_max_gap_m + 1e-9
    assert np.all(np.linalg.norm(written[fused] - model[fused], axis=1) <= reach)
