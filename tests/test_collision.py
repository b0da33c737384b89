"""Non-penetration prior: depths of capsule pairs, the factor, and its use in the likelihood."""

from __future__ import annotations

import numpy as np
import pytest

from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.collision import ARM_TRUNK_PAIRS, CollisionPrior
from tracker.dof import DOF, LEFT_LEG, RIGHT_LEG
from tracker.likelihood import SilhouetteLikelihood


def _arm_pose(body: BodyModel, **deg: float) -> np.ndarray:
    p = body.neutral_pose(x=0.3, y=-0.2, yaw=0.7)
    for name, value in deg.items():
        p[DOF[name]] = np.radians(value)
    return p


def test_rest_and_arms_out_keep_their_weight() -> None:
    body = BodyModel(1.72)
    prior = CollisionPrior()
    poses = np.stack(
        [
            body.neutral_pose(),
            _arm_pose(body, l_shoulder_abduction=25, r_shoulder_abduction=25),
            _arm_pose(body, l_shoulder_flexion=40, r_shoulder_flexion=-30, r_elbow_flexion=60),
        ]
    )
    np.testing.assert_allclose(prior.factors(body, body.points(poses)), 1.0)


def test_an_arm_through_the_trunk_weighs_nothing() -> None:
    body = BodyModel(1.72)
    prior = CollisionPrior()
    # right arm swung 20 deg across the body: the upper arm and forearm pass through the trunk
    pose = _arm_pose(body, r_shoulder_abduction=-20)
    depths = prior.depths(body, body.points(pose[None]))[0]
    worst = ARM_TRUNK_PAIRS[int(np.argmax(depths))]
    assert worst[0].startswith("right_") and depths.max() > 0.05
    assert prior.factors(body, body.points(pose[None]))[0] == 0.0


def test_the_factor_falls_with_depth() -> None:
    body = BodyModel(1.72)
    prior = CollisionPrior(tolerance_m=0.0, softness_m=0.05)
    angles = [0, -2, -4, -6, -8, -10]
    poses = np.stack([_arm_pose(body, l_shoulder_abduction=a) for a in angles])
    pts = body.points(poses)
    excess = (prior.depths(body, pts) - prior.allowance(body)).max(axis=1)
    f = prior.factors(body, pts)
    assert np.all(np.diff(excess) > 0)  # deeper with every step across
    assert f[0] == pytest.approx(1.0) and np.all(np.diff(f) <= 0) and f[-1] < f[1]
    expected = np.clip(1 - np.maximum(excess, 0) / 0.05, 0, 1) ** 2
    np.testing.assert_allclose(f, expected)


def test_depth_of_two_known_capsules() -> None:
    """Forearm held horizontally into the pelvis: the depth is the radii minus the distance."""
    body = BodyModel(1.80)
    prior = CollisionPrior([("left_forearm", "pelvis")])
    pts = body.points(body.neutral_pose()[None]).copy()
    (fa, fb), (pa, pb) = (
        body.cap_ab[body.capsule_names.index("left_forearm")],
        body.cap_ab[body.capsule_names.index("pelvis")],
    )
    pts[0, pa], pts[0, pb] = [0.0, -0.1, 1.0], [0.0, 0.1, 1.0]  # pelvis axis along y
    pts[0, fa], pts[0, fb] = [-0.2, 0.05, 1.03], [0.2, 0.05, 1.03]  # forearm along x, 3 cm above
    r_f = body.radii[body.capsule_names.index("left_forearm")]
    r_p = body.radii[body.capsule_names.index("pelvis")]
    # closest points: the middles of both axes (s = t = 0.5)
    expected = (r_f.mean() + r_p.mean()) - 0.03
    np.testing.assert_allclose(prior.depths(body, pts)[0, 0], expected, atol=1e-12)


def test_the_allowance_follows_the_body() -> None:
    """A heavier build touches its trunk deeper at rest: its rest pose still weighs 1."""
    prior = CollisionPrior(tolerance_m=0.0)
    slim, heavy = BodyModel(1.7, girth=0.9), BodyModel(1.7, girth=1.3)
    assert prior.allowance(heavy).max() > prior.allowance(slim).max()
    for body in (slim, heavy):
        assert prior.factors(body, body.points(body.neutral_pose()[None]))[0] == 1.0


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="unknown capsule"):
        CollisionPrior([("left_forearm", "belly")])
    with pytest.raises(ValueError, match="leg capsules"):
        CollisionPrior([("left_thigh", "right_thigh")])
    with pytest.raises(ValueError, match="at least one"):
        CollisionPrior(())
    with pytest.raises(ValueError, match="softness_m"):
        CollisionPrior(softness_m=0.0)
    with pytest.raises(ValueError, match="shape"):
        CollisionPrior().depths(BodyModel(1.7), np.zeros((3, 4)))


def test_likelihood_multiplies_by_the_factor_in_both_paths() -> None:
    body = BodyModel(1.75)
    cam = Camera.look_at(name="c", position=[4.0, 0.5, 1.6], target=[0, 0, 0.9]).scaled(160, 120)
    lik = SilhouetteLikelihood(body, [cam])
    truth = body.neutral_pose()
    lik.set_silhouettes([lik.render_mask(truth, 0)])
    base = np.stack(
        [truth, _arm_pose(body, l_shoulder_abduction=-15), _arm_pose(body, r_elbow_flexion=30)]
    )
    rng = np.random.default_rng(3)
    left = base[:, None, list(LEFT_LEG)] + rng.normal(0, 0.1, (3, 4, 6))
    right = base[:, None, list(RIGHT_LEG)] + rng.normal(0, 0.1, (3, 5, 6))
    plain_w, plain_f = lik.weights(base), lik.weights_factored(base, left, right)
    prior = CollisionPrior()
    lik.collision = prior
    f = prior.factors(body, body.points(base))
    assert f[0] == 1.0 and f[1] == 0.0
    np.testing.assert_allclose(lik.weights(base), plain_w * f)
    np.testing.assert_allclose(lik.weights_factored(base, left, right), plain_f * f[:, None, None])
    # the factored weights still equal the weights of the poses they stand for
    poses = np.repeat(base[:, None, None, :], 4, axis=1).repeat(5, axis=2)
    poses[..., list(LEFT_LEG)] = left[:, :, None, :]
    poses[..., list(RIGHT_LEG)] = right[:, None, :, :]
    np.testing.assert_allclose(
        lik.weights(poses.reshape(-1, poses.shape[-1])).reshape(3, 4, 5),
        lik.weights_factored(base, left, right),
    )


def test_the_tracker_attaches_the_prior_only_when_enabled() -> None:
    from tracker.config import TrackerConfig
    from tracker.pipeline import Tracker

    cam = Camera.look_at(name="c", position=[4.0, 0.5, 1.6], target=[0, 0, 0.9])
    off = Tracker([cam], TrackerConfig(), rng=np.random.default_rng(0), height_m=1.7)
    assert off.likelihood.collision is None
    cfg = TrackerConfig.model_validate({"collision": {"enabled": True, "tolerance_m": 0.02}})
    on = Tracker([cam], cfg, rng=np.random.default_rng(0), height_m=1.7)
    assert isinstance(on.likelihood.collision, CollisionPrior)
    assert on.likelihood.collision.tolerance_m == 0.02
    with pytest.raises(ValueError, match="softness_m"):
        TrackerConfig.model_validate({"collision": {"softness_m": 0}})
