"""The face check of the heading (tracker.keypoints2d.facing_evidence, KeypointCue.facing and
``heading_check.facing_*``): with no walk to follow, the detected face turns a track facing
backwards round."""

from __future__ import annotations

import numpy as np
import pytest

from gaitwatch.conventions import HEAD
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.config import IPFConfig, KeypointConfig, TrackerConfig
from tracker.dof import DOF, wrap_angle
from tracker.keypoints2d import KeypointCue, facing_evidence

SIZE = (320, 240)
FPS = 20.0


def _face_detections(body: BodyModel, pose: np.ndarray, cameras) -> list[np.ndarray]:
    """A perfect detector, the nose 0.1 m ahead of the head's centre (BlazePose's head point
    is the nose)."""
    kp = np.asarray(body.forward(pose[None]))[0].copy()
    yaw = pose[DOF["root_yaw"]]
    kp[HEAD] += 0.1 * np.array([np.cos(yaw), np.sin(yaw), 0.0])
    return [np.column_stack([cam.project(kp), np.ones(len(kp))]) for cam in cameras]


def _face(det: np.ndarray) -> np.ndarray:
    """The nose and shoulders in units of the detected height (as the cue keeps them)."""
    return det[[HEAD, 3, 4], :2] / float(np.ptp(det[:, 1]))


@pytest.fixture(scope="module")
def body() -> BodyModel:
    return BodyModel(1.72)


@pytest.fixture(scope="module")
def cameras() -> list[Camera]:
    return [
        Camera.look_at(name="side", position=[0.5, -4.0, 2.3], target=[0, 0, 0.9]).scaled(*SIZE),
        Camera.look_at(name="front", position=[4.0, 0.3, 2.3], target=[0, 0, 0.9]).scaled(*SIZE),
    ]


def test_facing_evidence_sign_and_profile(body: BodyModel, cameras: list[Camera]) -> None:
    """Seen from the side, the nose lies ahead of the shoulders: positive for the body that
    faces that way, as negative for the same body turned round; from the front the profile is
    near 0."""
    side, front = cameras
    pose = body.neutral_pose(0.0, 0.0, 0.0)  # facing +x
    joints = np.asarray(body.forward(pose[None]))[0]
    face = _face(_face_detections(body, pose, [side])[0])
    ev, profile = facing_evidence(side, face, joints)
    assert ev > 0.02 and profile > 0.95
    turned = np.asarray(body.forward(body.neutral_pose(0.0, 0.0, np.pi)[None]))[0]
    ev_back, profile_back = facing_evidence(side, face, turned)
    assert ev_back == pytest.approx(-ev, rel=0.2) and profile_back > 0.95
    front_face = _face(_face_detections(body, pose, [front])[0])
    _, profile_front = facing_evidence(front, front_face, joints)
    assert profile_front < 0.15
    # degenerate bodies and a neck behind the camera tell nothing
    assert facing_evidence(side, face, np.zeros((19, 3))) is None
    behind = Camera.look_at(name="b", position=[0.5, -4.0, 2.3], target=[0.5, -8.0, 0.9])
    assert facing_evidence(behind, face, joints) is None


def test_cue_facing_weighs_the_cameras_in_profile(body: BodyModel, cameras: list[Camera]) -> None:
    """KeypointCue.facing: positive for the detected way, negative turned round, None when no
    camera is enough in profile or nothing was detected; kept through frame_state."""
    pose = body.neutral_pose(0.0, 0.0, 0.0)
    joints = np.asarray(body.forward(pose[None]))[0]
    turned = np.asarray(body.forward(body.neutral_pose(0.0, 0.0, np.pi)[None]))[0]
    cue = KeypointCue(cameras, KeypointConfig(enabled=True))
    assert cue.facing(joints, 0.5) is None  # no frame
    dets = _face_detections(body, pose, cameras)
    cue.set_frame(dets)
    forwards, backwards = cue.facing(joints, 0.5), cue.facing(turned, 0.5)
    assert forwards > 0.02 and backwards < -0.02
    assert cue.facing(joints, 0.999) is None  # neither camera exactly in profile
    other = KeypointCue(cameras, KeypointConfig(enabled=True))
    other.restore_frame(cue.frame_state())
    assert other.facing(joints, 0.5) == pytest.approx(forwards)
    # the nose not found (or not confident): no evidence; the legs are still scored
    dets[0][HEAD, 2] = dets[1][HEAD, 2] = 0.1
    cue.set_frame(dets)
    assert cue.facing(joints, 0.5) is None and cue.has_frame
    cue.clear_frame()
    assert cue.facing(joints, 0.5) is None and cue.frame_state() is None


@pytest.fixture(scope="module")
def stepping() -> dict:
    """Stepping on the spot (a treadmill walk) facing +x, seen from the side and obliquely."""
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    rng = np.random.default_rng(7)
    body = BodyModel(1.70)
    cams = side_cameras(2, image_size=SIZE, centre=(1.0, 0.0), fps=FPS)
    poses = walking_motion(body, 20, fps=FPS, speed_m_s=0.0, start_xy=(1.0, 0.0))
    bgs = [textured_background(*SIZE, rng) for _ in cams]
    frames = list(render_clip(SilhouetteLikelihood(body, cams), poses, bgs, rng))
    dets = [_face_detections(body, p, cams) for p in poses]
    return {"body": body, "cams": cams, "poses": poses, "bgs": bgs, "frames": frames, "dets": dets}


def _backward_track(
    stepping: dict, facing_s: float, swing_s: float = 0.0
) -> tuple[list, np.ndarray]:
    """Track the clip with the given detections after turning the first frame's estimate
    round; the notes and the last estimate's heading error (degrees). ``swing_s``: the swing
    check's window (0: off, to see the face check alone)."""
    from tracker.pipeline import Tracker

    cfg = TrackerConfig(
        ipf=IPFConfig(kept=9),
        keypoints={"enabled": True, "detector": "none"},
        # no walking direction is ever known (as for a walk slower than min_speed_m_s)
        heading_check={
            "facing_s": facing_s,
            "swing_s": swing_s,
            "min_speed_m_s": 5.0,
            "turn_angle_deg": 0.0,
        },
    )
    tracker = Tracker(
        stepping["cams"],
        cfg,
        rng=np.random.default_rng(2),
        backgrounds=stepping["bgs"],
        body=stepping["body"],
    )
    frames, dets = stepping["frames"], stepping["dets"]
    assert tracker.process(0, 0.0, frames[0], keypoints=dets[0]).status == "initialised"
    yaw = DOF["root_yaw"]
    tracker.filter.particles[:, yaw] = wrap_angle(tracker.filter.particles[:, yaw] + np.pi)
    tracker.prev_pose[yaw] = wrap_angle(tracker.prev_pose[yaw] + np.pi)
    notes = []
    for i in range(1, len(frames)):
        res = tracker.process(i, i / FPS, frames[i], keypoints=dets[i])
        notes += res.notes
    err = np.degrees(abs(wrap_angle(res.pose[yaw] - stepping["poses"][-1, yaw])))
    return notes, err


def test_face_check_turns_round_a_track_stepping_on_the_spot(stepping: dict) -> None:
    """No walking direction to follow: the detected face turns the backward track round within
    the window (0.5 s) and a little; without the face check it stays backwards."""
    notes, err = _backward_track(stepping, 0.5)
    assert any("detected face" in n for n in notes), notes
    assert not any("walking direction" in n for n in notes), notes
    assert err < 30.0
    notes_off, err_off = _backward_track(stepping, 0.0)
    assert not any("detected face" in n or "re-initialised" in n for n in notes_off), notes_off
    assert err_off > 150.0


def test_swing_check_turns_round_a_track_stepping_on_the_spot(stepping: dict) -> None:
    """No walking direction and no face to go by (the face check off): the raised feet, carried
    forward relative to the pelvis, turn the backward track round; without it, it stays."""
    notes, err = _backward_track(stepping, 0.0, swing_s=0.6)
    assert any("raised feet swing" in n for n in notes), notes
    assert err < 30.0
    notes_off, err_off = _backward_track(stepping, 0.0, swing_s=0.0)
    assert not any("re-initialised" in n for n in notes_off), notes_off
    assert err_off > 150.0


def test_swing_check_needs_a_body_that_stays(stepping: dict) -> None:
    """The swing check's rules: a window spanning 0.9 of swing_s, the raised feet's way more
    than max_angle_deg off the heading, consistently, feet some camera sees, a sacrum that
    does not travel, not seated, and the backward pass's mirrored time turned back."""
    from tracker.pipeline import Tracker

    cfg = TrackerConfig(ipf=IPFConfig(kept=9), heading_check={"swing_s": 0.6})
    tracker = Tracker(
        stepping["cams"], cfg, rng=np.random.default_rng(2), backgrounds=stepping["bgs"],
        body=stepping["body"],
    )  # fmt: skip
    body, poses = stepping["body"], stepping["poses"]
    joints = np.asarray(body.forward(poses))
    for k in range(13):  # 0.65 s of stepping on the spot facing +x
        tracker._remember_feet(joints[k], k / FPS, continuous=k > 0)
    t = 12 / FPS
    found = tracker._swings_backwards(np.pi, t)  # a heading facing -x: backwards
    assert found is not None
    direction, consistency = found
    assert abs(np.degrees(wrap_angle(direction))) < 30.0
    assert consistency >= cfg.heading_check.swing_consistency
    assert tracker._swings_backwards(0.0, t) is None  # facing the way the feet swing
    tracker._time_sign = -1.0  # the backward pass: the same rows swing the other way
    assert tracker._swings_backwards(0.0, t) is not None
    tracker._time_sign = 1.0
    tracker._seated = True
    assert tracker._swings_backwards(np.pi, t) is None
    tracker._seated = False
    short = tracker._feet[-6:]  # 0.25 s: too short a window
    tracker._feet = short
    assert tracker._swings_backwards(np.pi, t) is None
    tracker._feet = []
    for k in range(13):  # every camera's legs may be cut off (furniture): no feet to go by
        tracker._legs_cut_now = [True] * len(stepping["cams"])
        tracker._remember_feet(joints[k], k / FPS, continuous=k > 0)
    assert tracker._feet == [] and tracker._swings_backwards(np.pi, t) is None
    tracker._legs_cut_now = [True] + [False] * (len(stepping["cams"]) - 1)  # one camera sees them
    for k in range(13):
        tracker._remember_feet(joints[k], k / FPS, continuous=k > 0)
    assert tracker._swings_backwards(np.pi, t) is not None
    tracker._feet = []
    for k in range(13):  # the same steps carried along at 1 m/s: a walk, not on the spot
        moved = joints[k].copy()
        moved[:, 0] += 1.0 * k / FPS
        tracker._remember_feet(moved, k / FPS, continuous=k > 0)
    assert tracker._swings_backwards(np.pi, t) is None


def test_face_check_window_rule_and_seated_mode(stepping: dict) -> None:
    """The window must span 0.9 of facing_s with min_frames values, average below
    -facing_evidence with facing_share of them negative; never in the seated mode."""
    from tracker.pipeline import Tracker

    cfg = TrackerConfig(ipf=IPFConfig(kept=9), keypoints={"enabled": True, "detector": "none"})
    tracker = Tracker(
        stepping["cams"], cfg, rng=np.random.default_rng(2), backgrounds=stepping["bgs"],
        body=stepping["body"],
    )  # fmt: skip
    frames, dets = stepping["frames"], stepping["dets"]
    tracker.process(0, 0.0, frames[0], keypoints=dets[0])
    turned = stepping["poses"][0].copy()
    turned[DOF["root_yaw"]] = np.pi  # the body facing -x: the detected face is behind it
    t = 0.5
    tracker._facing = [(0.05 * k, -0.05) for k in range(10)]  # 0.0 ... 0.45 s
    mean = tracker._faces_backwards(turned, t)
    assert mean is not None and mean < -0.02
    tracker._facing = [(0.05 * k, 0.05) for k in range(10)]
    assert tracker._faces_backwards(stepping["poses"][0], t) is None  # facing the face
    tracker._facing = [(0.05 * k, -0.05) for k in range(5, 10)]  # spans 0.25 s only
    assert tracker._faces_backwards(turned, t) is None
    tracker._facing = [(0.05 * k, -0.05 if k % 2 else 0.01) for k in range(10)]  # half positive
    assert tracker._faces_backwards(turned, t) is None
    tracker._facing = [(0.05 * k, -0.05) for k in range(10)]
    tracker._seated = True
    assert tracker._faces_backwards(turned, t) is None


@pytest.mark.parametrize("heading", [0.5 * np.pi, -0.5 * np.pi])
def test_first_search_sees_the_detections(heading: float) -> None:
    """The first initial search scores its candidates with the key-point cue (``initial``,
    before any estimate gave the typical score). A walker at heel strike facing away from the
    camera or towards it: the silhouette alone looks alike both ways (without the cue both
    came out 155-157 deg off), the detected legs and feet tell. The cue is then active, its
    typical score near the first estimate's."""
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.pipeline import Tracker
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    rng = np.random.default_rng(11)
    body = BodyModel(1.70)
    cams = side_cameras(1, image_size=SIZE, centre=(1.0, 0.0), fps=FPS)
    pose = walking_motion(body, 1, fps=FPS, start_xy=(1.0, 0.0), heading=heading)
    bgs = [textured_background(*SIZE, rng) for _ in cams]
    frames = list(render_clip(SilhouetteLikelihood(body, cams), pose, bgs, rng))
    kp = {"enabled": True, "detector": "none", "initial": True}
    cfg = TrackerConfig(ipf=IPFConfig(kept=9), keypoints=kp)
    tracker = Tracker(cams, cfg, rng=np.random.default_rng(3), backgrounds=bgs, body=body)
    res = tracker.process(0, 0.0, frames[0], keypoints=_face_detections(body, pose[0], cams))
    assert res.status == "initialised"
    err = np.degrees(abs(wrap_angle(res.pose[DOF["root_yaw"]] - heading)))
    assert err < 45.0, err
    cue = tracker.keypoint_cue
    first = float(cue.scores(tracker.body, tracker.body.points(res.pose[None]))[0])
    assert cue.active and cue.typical == pytest.approx(first, rel=0.15)
