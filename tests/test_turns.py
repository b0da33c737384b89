"""Turns and the start of a track: the heading follows a turning walk; both heading hypotheses
are kept after an initialisation until the walk decides (tracker.pipeline).

The turning walk is the body model's own walking motion (tracker.synthetic) with its heading
swept through 90 degrees in 0.8 s and its path following the heading, rendered as flat-coloured
silhouettes for two cameras (side and oblique) at 320x240, 20 Hz.
"""

from __future__ import annotations

import numpy as np
import pytest

from tracker.config import TrackerConfig
from tracker.dof import DOF, wrap_angle
from tracker.pipeline import Tracker

SIZE = (320, 240)
FPS = 20.0
N_FRAMES = 36
TURN_S = (0.6, 1.0)
TURN = np.radians(90.0)


def turning_walk(body, n_frames: int, *, speed_m_s: float = 1.0) -> np.ndarray:
    """Poses (T, 31): a straight walk along +x that turns left by 90 deg (smoothstep over
    ``TURN_S``), the path following the heading."""
    from tracker.synthetic import walking_motion

    poses = walking_motion(body, n_frames, fps=FPS, speed_m_s=speed_m_s, phase0=0.1)
    t = np.arange(n_frames) / FPS
    u = np.clip((t - TURN_S[0]) / (TURN_S[1] - TURN_S[0]), 0.0, 1.0)
    yaw = TURN * u * u * (3.0 - 2.0 * u)
    step = speed_m_s / FPS
    x = -0.2 + np.concatenate([[0.0], np.cumsum(step * np.cos(yaw[:-1]))])
    y = -0.6 + np.concatenate([[0.0], np.cumsum(step * np.sin(yaw[:-1]))])
    poses[:, DOF["root_yaw"]] += yaw
    poses[:, DOF["root_x"]] = x
    poses[:, DOF["root_y"]] = y
    return poses


@pytest.fixture(scope="module")
def turn_clip() -> dict:
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.synthetic import render_clip, side_cameras, textured_background

    rng = np.random.default_rng(7)
    body = BodyModel(1.70)
    cams = side_cameras(2, image_size=SIZE, centre=(1.0, 0.0), fps=FPS)
    poses = turning_walk(body, N_FRAMES)
    renderer = SilhouetteLikelihood(body, cams)
    bgs = [textured_background(*SIZE, rng) for _ in cams]
    frames = list(render_clip(renderer, poses, bgs, rng))
    return {"body": body, "cams": cams, "poses": poses, "bgs": bgs, "frames": frames}


def _track(clip: dict, config: TrackerConfig, seed: int = 0) -> list:
    tr = Tracker(
        clip["cams"],
        config,
        rng=np.random.default_rng(seed),
        body=clip["body"],
        backgrounds=clip["bgs"],
    )
    return [tr.process(k, k / FPS, f) for k, f in enumerate(clip["frames"])]


def _heading_error_deg(results: list, poses: np.ndarray) -> np.ndarray:
    yaw = DOF["root_yaw"]
    est = np.array([r.pose[yaw] if r.has_pose else np.nan for r in results])
    return np.degrees(np.abs(wrap_angle(est - poses[: len(results), yaw])))


def test_turning_walk_premise(turn_clip: dict) -> None:
    """The clip turns by 90 degrees and the path follows the heading."""
    p = turn_clip["poses"]
    yaw = p[:, DOF["root_yaw"]]
    assert np.degrees(yaw[-1] - yaw[0]) == pytest.approx(90.0, abs=6.0)
    v = np.diff(p[-6:, :2], axis=0).mean(axis=0)
    assert np.degrees(np.arctan2(v[1], v[0])) == pytest.approx(90.0, abs=5.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_heading_follows_a_fast_turn(turn_clip: dict, seed: int) -> None:
    """A 90 degree turn in 0.4 s (more than the origin search's reach per frame): with turn
    following the heading is within 20 degrees of the truth from 0.15 s after the turn on, but
    for at most one frame, and within 30 degrees on every frame.

    Measured without it (turn_angle_deg 0): tracker seed 1 stays 87-100 degrees behind for
    seven frames after the turn (until the backwards check), seed 0 follows. With it, tracker
    seeds 0-5 (session 42, heatmap-refined detections): at most 7-25 degrees after the turn,
    a single frame above 20 (seeds 0 and 4: 23 and 25 degrees, the same frame); with the
    detector's landmarks unrefined 8-19 degrees.
    """
    cfg = TrackerConfig.model_validate({"heading_check": {"turn_angle_deg": 25.0}})
    res = _track(turn_clip, cfg, seed)
    err = _heading_error_deg(res, turn_clip["poses"])
    after = np.arange(N_FRAMES) / FPS >= TURN_S[1] + 0.15
    shown = np.round(err).astype(int).tolist()
    assert np.nanmax(err[after]) < 30.0, shown
    assert np.sum(err[after] >= 20.0) <= 1, shown


class _HeadingBlind:
    """A silhouette likelihood that cannot tell a heading from its opposite (exactly): poses
    facing more than 90 degrees away from ``yaw`` are weighed turned by 180 degrees."""

    def __init__(self, inner) -> None:
        self.inner = inner
        self.yaw = 0.0

    @property
    def body(self):
        return self.inner.body

    @body.setter
    def body(self, value) -> None:
        self.inner.body = value

    def set_silhouettes(self, masks) -> None:
        self.inner.set_silhouettes(masks)

    def render_mask(self, pose: np.ndarray, cam: int) -> np.ndarray:
        return self.inner.render_mask(pose, cam)

    def weights(self, poses: np.ndarray) -> np.ndarray:
        p = np.array(poses, dtype=np.float64)
        yaw = DOF["root_yaw"]
        back = np.abs(wrap_angle(p[:, yaw] - self.yaw)) > np.pi / 2
        p[back, yaw] += np.pi
        return self.inner.weights(p)


@pytest.mark.parametrize("seed", [0, 1])
def test_both_headings_kept_until_the_walk_decides(turn_clip: dict, seed: int) -> None:
    """With a likelihood blind to front and back, the opposite hypothesis is kept from the
    initialisation until the walking direction decides; then the track faces the walk and the
    other hypothesis is gone."""
    from tracker.likelihood import SilhouetteLikelihood

    clip, poses = turn_clip, turn_clip["poses"]
    lik = _HeadingBlind(
        SilhouetteLikelihood(clip["body"], [c.scaled(160, 120) for c in clip["cams"]])
    )
    cfg = TrackerConfig.model_validate({"init": {"both_headings": True}})
    tr = Tracker(
        clip["cams"],
        cfg,
        rng=np.random.default_rng(seed),
        body=clip["body"],
        likelihood=lik,
        backgrounds=clip["bgs"],
    )
    yaw = DOF["root_yaw"]
    kept, decided = [], None
    for k in range(10):
        lik.yaw = float(poses[k, yaw])
        r = tr.process(k, k / FPS, clip["frames"][k])
        alt = tr._alt
        if alt is not None:
            kept.append(k)
            assert abs(wrap_angle(alt.pose[yaw] - r.pose[yaw])) > np.pi / 2
        elif decided is None:
            decided = k
            assert any("walking direction" in n for n in r.notes), r.notes
    assert kept and kept[0] == 0 and decided is not None
    # The walk needs min_frames estimates over min_span_s: not before the third frame.
    assert decided >= 2
    assert kept == list(range(decided))
    err = np.degrees(abs(wrap_angle(r.pose[yaw] - poses[9, yaw])))
    assert err < 30.0
