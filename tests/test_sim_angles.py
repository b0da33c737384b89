"""A walk from a joint-angle cycle (gaitwatch.sim.angles): the kinematics reproduce the table's
angles, the stance foot carries the body forward on the floor, the stature is the one given,
and bad tables are refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gaitwatch.conventions import (
    L_ANKLE,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_TOE,
    R_ANKLE,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_TOE,
    SACRUM,
)
from gaitwatch.mocap.mot import MotTable, read_mot_table
from gaitwatch.sim.angles import AngleWalkParams, angle_walk, load_angle_walk
from gaitwatch.sim.motion import SHANK, THIGH, MotionError, estimate_stature, load_motion
from gaitwatch.sim.scene import SceneConfig
from gaitwatch.sim.synth import build_scene
from tests.conftest import shared_file

SOLES = {"left": (L_HEEL, L_TOE), "right": (R_HEEL, R_TOE)}


def _table(n: int = 41, **cols: np.ndarray) -> MotTable:
    names = ["time", *cols]
    t = np.linspace(0.0, 1.0, n)
    data = np.column_stack([t, *[np.broadcast_to(v, (n,)) for v in cols.values()]])
    return MotTable(columns=names, data=data, header={"inDegrees": "yes"})


def _sine_gait(n: int = 41) -> MotTable:
    """A crude but walkable cycle: hips swing +-20 deg in antiphase, knees bend in swing."""
    ph = np.linspace(0.0, 1.0, n)
    hip_r = 20 * np.cos(2 * np.pi * ph)
    knee_r = -30 * np.clip(np.sin(2 * np.pi * (ph - 0.55)), 0, None)
    hip_l = 20 * np.cos(2 * np.pi * (ph - 0.5))
    knee_l = -30 * np.clip(np.sin(2 * np.pi * (ph - 0.05)), 0, None)
    return _table(
        n,
        hip_flexion_r=hip_r,
        hip_flexion_l=hip_l,
        knee_angle_r=knee_r,
        knee_angle_l=knee_l,
        ankle_angle_r=np.zeros(n),
        ankle_angle_l=np.zeros(n),
    )


def _knee_flexion(p: np.ndarray, hip: int, knee: int, ankle: int) -> np.ndarray:
    u, w = p[:, knee] - p[:, hip], p[:, ankle] - p[:, knee]
    c = np.sum(u * w, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
    return np.degrees(np.arccos(np.clip(c, -1, 1)))


@pytest.mark.parametrize("name", ["normal", "crouch1", "crouch2", "crouch3", "crouch4"])
def test_angle_cycles_walk_on_the_floor(shared_data: Path, name: str) -> None:
    path = shared_file(shared_data, f"opensim/angles-{name}.mot")
    table = read_mot_table(path)
    walk = load_angle_walk(path, AngleWalkParams(height_m=1.70, cycles=3, fps=100))
    p = walk.positions
    assert np.isfinite(p).all() and walk.stature_m == 1.70
    assert walk.duration_s == pytest.approx(3.0, abs=0.011)
    S = 1.70
    # rigid segments of the given proportions
    for a, b, length in ((L_HIP, L_KNEE, THIGH), (R_KNEE, R_ANKLE, SHANK)):
        d = np.linalg.norm(p[:, a] - p[:, b], axis=1)
        np.testing.assert_allclose(d, length * S, rtol=1e-9)
    # the knee flexion of the key points is the table's (interpolated at the frame times)
    t = table.time
    ph = (walk.times % (t[-1] - t[0])) / (t[-1] - t[0])
    for side, (h, k, a) in (("r", (R_HIP, R_KNEE, R_ANKLE)), ("l", (L_HIP, L_KNEE, L_ANKLE))):
        col = table.column(f"knee_angle_{side}")
        col = col - ((t - t[0]) / (t[-1] - t[0])) * (col[-1] - col[0])  # the closed cycle
        want = np.abs(np.interp(ph, (t - t[0]) / (t[-1] - t[0]), col))
        np.testing.assert_allclose(_knee_flexion(p, h, k, a), want, atol=0.5)
    # on the floor, never under it; the body travels forward along +x, never backwards
    soles = p[:, [L_HEEL, L_TOE, R_HEEL, R_TOE], 2]
    np.testing.assert_allclose(soles.min(axis=1), 0.0, atol=1e-9)
    x = p[:, SACRUM, 0]
    assert 0.3 < x[-1] / walk.duration_s < 2.0
    hip_mid = 0.5 * (p[:, L_HIP, 0] + p[:, R_HIP, 0])
    assert np.diff(hip_mid).min() > -0.005  # 100 Hz: at most 0.5 m/s back (pelvis rotation)
    assert abs(p[-1, SACRUM, 1] - p[0, SACRUM, 1]) < 0.05
    # events: each foot strikes once per cycle, strikes alternate
    strikes = [e for e in walk.events if e["type"] == "heel_strike"]
    for side in ("left", "right"):
        assert len([e for e in strikes if e["side"] == side]) in (2, 3)
    sides = [e["side"] for e in strikes]
    assert all(a != b for a, b in zip(sides, sides[1:], strict=False))


def test_the_stance_foot_stays_put() -> None:
    walk = angle_walk(_sine_gait(), AngleWalkParams(height_m=1.80, cycles=2, fps=100))
    p = walk.positions
    k = np.arange(1, len(walk))
    low = {s: np.minimum(p[:, h, 2], p[:, t, 2]) for s, (h, t) in SOLES.items()}
    down = {s: (v[1:] < 0.01) & (v[:-1] < 0.01) for s, v in low.items()}
    for side, (heel, toe) in SOLES.items():
        other = down["right" if side == "left" else "left"]
        single = (low[side][1:] < 1e-6) & (low[side][:-1] < 1e-6) & ~other
        j = np.where(p[:, heel, 2] <= p[:, toe, 2], heel, toe)[1:]
        moved = np.linalg.norm(p[k, j, :2] - p[k - 1, j, :2], axis=1)
        assert single.sum() > 20
        # in single support the foot on the floor does not slide, but where the angles would
        # pull the pelvis backwards (this crude cycle's early stance): the pelvis then stops
        stopped = np.diff(0.5 * (p[:, L_HIP, 0] + p[:, R_HIP, 0])) < 1e-9
        assert moved[single & ~stopped].max() < 1e-6
        assert (single & stopped).sum() < 0.5 * single.sum()
        assert moved[single & stopped].max() < 0.01
    # it walks: stride length about 2 * 0.5 m forward over two cycles
    assert p[-1, SACRUM, 0] - p[0, SACRUM, 0] > 0.5


def test_the_stature_is_carried_to_the_scene() -> None:
    """A crouched walker's head is low: the scene's body must take the given stature, not the
    one estimated from the head."""
    table = _sine_gait()
    n = table.data.shape[0]
    crouch = MotTable(
        columns=table.columns,
        data=table.data.copy(),
        header=table.header,
    )
    crouch.data[:, crouch.columns.index("knee_angle_r")] -= 60
    crouch.data[:, crouch.columns.index("knee_angle_l")] -= 60
    crouch.data[:, crouch.columns.index("hip_flexion_r")] += 30
    crouch.data[:, crouch.columns.index("hip_flexion_l")] += 30
    crouch.data[:, crouch.columns.index("ankle_angle_r")] += 30
    crouch.data[:, crouch.columns.index("ankle_angle_l")] += 30
    assert n > 3
    walk = angle_walk(crouch, AngleWalkParams(height_m=1.65, cycles=1, fps=50))
    assert estimate_stature(walk.positions) < 0.95 * 1.65
    scene = build_scene(walk, SceneConfig(image_size=(160, 120), fps=10.0, views=["side"]))
    assert scene.body.stature_m == pytest.approx(1.65)
    tall = build_scene(
        walk,
        SceneConfig(image_size=(160, 120), fps=10.0, views=["side"], body={"height_m": 1.80}),
    )
    assert tall.body.stature_m == pytest.approx(1.80)
    thigh = np.linalg.norm(tall.truth.positions[:, L_HIP] - tall.truth.positions[:, L_KNEE], axis=1)
    np.testing.assert_allclose(thigh, THIGH * 1.80, rtol=1e-6)


def test_bad_tables_are_refused(tmp_path: Path) -> None:
    good = _sine_gait()
    no_knee = MotTable(
        columns=[c for c in good.columns if c != "knee_angle_l"],
        data=np.delete(good.data, good.columns.index("knee_angle_l"), axis=1),
        header=good.header,
    )
    with pytest.raises(MotionError, match="knee_angle_l"):
        angle_walk(no_knee)
    radians = MotTable(columns=good.columns, data=good.data, header={"inDegrees": "no"})
    with pytest.raises(MotionError, match="radians"):
        angle_walk(radians)
    still = _table(
        hip_flexion_r=0.0,
        hip_flexion_l=0.0,
        knee_angle_r=0.0,
        knee_angle_l=0.0,
        ankle_angle_r=0.0,
        ankle_angle_l=0.0,
    )
    with pytest.raises(MotionError, match="forward"):
        angle_walk(still)
    with pytest.raises(MotionError, match="height"):
        angle_walk(good, AngleWalkParams(height_m=3.0))
    # through load_motion, as `gaitwatch simulate` reads it
    bad = tmp_path / "bad.mot"
    bad.write_text("header\nendheader\ntime\tknee_angle_r\n0\t1\n0.1\t2\n0.2\t3\n")
    with pytest.raises(MotionError, match="hip_flexion"):
        load_motion(str(bad))
