"""Scene synthesis (gaitwatch.sim) and ``gaitwatch simulate``: files, ground truth against the
rendered silhouettes, determinism, body shapes, occluders, procedural walk, advice."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from gaitwatch.conventions import (
    BONE_INDICES,
    HEAD,
    KEYPOINTS,
    L_ANKLE,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_TOE,
    NECK,
    R_ANKLE,
    R_HEEL,
    R_HIP,
    R_TOE,
)
from gaitwatch.sim.advise import advise, format_advice, measurable_floor, pose_errors
from gaitwatch.sim.motion import (
    MotionError,
    complete_for_render,
    estimate_stature,
    parse_walk_spec,
    procedural_walk,
    resample,
)
from gaitwatch.sim.render import rasterize
from gaitwatch.sim.scene import SceneConfig
from gaitwatch.sim.synth import build_scene, occluder_mask, render_frames
from gaitwatch.trajectory import Trajectory, read_joints_csv
from service.cli import main
from tests.conftest import shared_file
from tracker.camera import Camera, load_camera

FEET = [L_ANKLE, R_ANKLE, L_HEEL, R_HEEL, L_TOE, R_TOE]


# -- procedural walk and motion preparation ------------------------------------------------------


def test_procedural_walk_is_physiological() -> None:
    tr = procedural_walk(height_m=1.7, speed_m_s=1.1, cadence_steps_min=104, distance_m=4.0)
    p = tr.positions
    assert np.isfinite(p).all()
    # rigid leg bones, feet never below the floor
    for a, b in BONE_INDICES:
        if a in (L_HIP, L_KNEE) and b in (L_KNEE, L_ANKLE):
            d = np.linalg.norm(p[:, a] - p[:, b], axis=1)
            assert d.std() < 1e-3 * d.mean()
    assert p[:, FEET, 2].min() > -1e-9
    # knee flexion: nearly straight in stance, about 60 degrees in swing
    u = p[:, L_HIP] - p[:, L_KNEE]
    v = p[:, L_ANKLE] - p[:, L_KNEE]
    cos = np.sum(u * v, 1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
    flex = 180 - np.degrees(np.arccos(np.clip(cos, -1, 1)))
    assert flex.min() < 15 and 45 < flex.max() < 75
    # walking speed and cadence as asked
    speed = (p[-1, 2, 0] - p[0, 2, 0]) / tr.duration_s
    assert speed == pytest.approx(1.1, rel=0.02)
    hs = sorted(e["time_s"] for e in tr.events if e["type"] == "heel_strike")
    assert 60.0 / np.median(np.diff(hs)) == pytest.approx(104, rel=0.01)
    # left heel planted at its heel strike: no sliding during foot-flat
    t_hs = [e["time_s"] for e in tr.events if e["side"] == "left" and e["type"] == "heel_strike"]
    k0 = int(round((t_hs[1] + 0.12 * 120 / 104) * tr.fps))
    k1 = int(round((t_hs[1] + 0.4 * 120 / 104) * tr.fps))
    assert np.ptp(p[k0:k1, L_HEEL], axis=0).max() < 1e-6
    assert estimate_stature(p) == pytest.approx(1.7, rel=0.06)


def test_walk_spec_and_errors() -> None:
    wp = parse_walk_spec("walk:speed=0.9,heading=90,height=1.6")
    assert wp.speed_m_s == 0.9 and wp.height_m == 1.6
    assert wp.heading_rad == pytest.approx(math.pi / 2)
    with pytest.raises(MotionError, match="bogus"):
        parse_walk_spec("walk:bogus=1")


def test_missing_upper_body_is_filled_and_missing_legs_refused() -> None:
    tr = procedural_walk(distance_m=2.0, fps=50)
    pos = tr.positions.copy()
    pos[:, :9][:, [HEAD, NECK, 3, 4, 5, 6, 7, 8]] = np.nan  # lower-limb-only recording
    pos[10:14, L_ANKLE] = np.nan  # a gap inside
    lower = Trajectory(positions=pos, times=tr.times, fps=50, source="lower")
    filled, synth = complete_for_render(lower)
    assert np.isfinite(filled.positions).all()
    assert set(synth) == {KEYPOINTS[j] for j in (HEAD, NECK, 3, 4, 5, 6, 7, 8)}
    # upright: the neck above the mid-hip, the head above the neck, proportional height
    mid_hip = filled.positions[:, [9, 10]].mean(1)
    assert np.allclose(filled.positions[:, NECK, :2], mid_hip[:, :2], atol=1e-9)
    head = filled.positions[:, HEAD, 2]
    assert 1.45 < np.median(head) < 1.75
    # the interior gap is interpolated close to the truth
    err = np.linalg.norm(filled.positions[10:14, L_ANKLE] - tr.positions[10:14, L_ANKLE], axis=1)
    assert err.max() < 0.03
    pos[:, L_KNEE] = np.nan
    with pytest.raises(MotionError, match="left_knee"):
        complete_for_render(Trajectory(positions=pos, times=tr.times, source="no knees"))


def test_place_on_path_and_scale_to_stature() -> None:
    from gaitwatch.sim.motion import place_on_path, scale_to_stature

    tr = procedural_walk(distance_m=2.0, fps=50, height_m=1.75)
    moved = place_on_path(tr, (2.0, 3.0), math.pi / 2)
    s = moved.positions[:, 2]
    np.testing.assert_allclose(s[0, :2], [2.0, 3.0], atol=1e-9)
    travel = s[-1, :2] - s[0, :2]
    assert travel[1] == pytest.approx(2.0, abs=0.05) and abs(travel[0]) < 0.05
    # rigid motion: bone lengths and heights unchanged
    np.testing.assert_allclose(moved.positions[..., 2], tr.positions[..., 2], atol=1e-9)
    tall = scale_to_stature(tr, 1.95)
    assert estimate_stature(tall.positions) == pytest.approx(1.95, rel=1e-6)
    assert tall.positions[:, FEET, 2].min() > -1e-9


def test_resample_interpolates_linearly() -> None:
    t = np.arange(0, 1.0001, 0.01) + 5.0
    pos = np.zeros((len(t), 19, 3))
    pos[..., 0] = 2.0 * t[:, None]
    tr = Trajectory(positions=pos, times=t, fps=100)
    out = resample(tr, 30.0)
    assert len(out) == 31 and out.times[0] == 0 and out.frames[-1] == 30
    np.testing.assert_allclose(out.positions[:, 0, 0], 2.0 * (5.0 + out.times), atol=1e-9)


# -- renderer ------------------------------------------------------------------------------------


def test_rasterizer_coverage_and_depth_order() -> None:
    h, w = 40, 50
    zbuf = np.full((h, w), np.inf)
    img = np.zeros((h, w, 1))
    lab = np.zeros((h, w), np.uint8)
    far = np.array([[[5.0, 5.0], [45.0, 5.0], [5.0, 35.0]]])
    near = np.array([[[10.0, 10.0], [30.0, 10.0], [10.0, 30.0]]])
    rasterize(far, np.full((1, 3), 4.0), np.full((1, 3, 1), 1.0), 1, zbuf, img, lab)
    area = (lab == 1).sum()
    assert abs(area - 0.5 * 40 * 30) < 40 + 30 + 2  # within one edge row of the exact area
    rasterize(near, np.full((1, 3), 2.0), np.full((1, 3, 1), 2.0), 2, zbuf, img, lab)
    # the nearer triangle wins, whatever order: draw the far one again on top
    rasterize(far, np.full((1, 3), 4.0), np.full((1, 3, 1), 1.0), 1, zbuf, img, lab)
    assert lab[15, 15] == 2 and img[15, 15, 0] == 2.0 and zbuf[15, 15] == 2.0
    assert lab[6, 40] == 1 and lab[38, 48] == 0


def test_body_mesh_normals_point_outwards() -> None:
    from gaitwatch.sim.person import BodyModel
    from gaitwatch.sim.scene import BodyShape, Clothing, resolve_body

    tr = procedural_walk(distance_m=1.0)
    body = resolve_body(BodyShape(), Clothing(), 1.75, np.random.default_rng(0))
    kp = tr.positions[10]
    mesh = BodyModel(body).mesh(kp)
    assert np.isfinite(mesh.vertices).all() and mesh.triangles.max() < len(mesh.vertices)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-9)
    # vertices of the head ellipsoid: normals point away from the head centre
    near_head = np.linalg.norm(mesh.vertices - kp[HEAD], axis=1) < 0.13
    top = near_head & (mesh.vertices[:, 2] > kp[HEAD, 2] + 0.05)
    assert top.sum() > 10
    assert (np.sum(mesh.normals[top] * (mesh.vertices[top] - kp[HEAD]), axis=1) > 0).all()
    # the body is wider than its skeleton: every key point lies inside the mesh's bounds
    lo, hi = mesh.vertices.min(0), mesh.vertices.max(0)
    assert (kp >= lo - 1e-9).all() and (kp <= hi + 1e-9).all()


# -- the written scene ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("scene")
    rc = main(
        [
            "-q",
            "simulate",
            "walk:distance=2.6,speed=1.2",
            "--out",
            str(out),
            "--views",
            "side,oblique",
            "--size",
            "320x240",
            "--fps",
            "25",
            "--masks",
            "--png",
            "--seed",
            "3",
        ]
    )
    assert rc == 0
    return out


def _frame_count(path: Path) -> tuple[int, tuple[int, int]]:
    cap = cv2.VideoCapture(str(path))
    n, size = 0, (0, 0)
    while True:
        ok, f = cap.read()
        if not ok:
            break
        n, size = n + 1, (f.shape[1], f.shape[0])
    return n, size


def test_scene_files(scene_dir: Path) -> None:
    meta = json.loads((scene_dir / "scene.json").read_text())
    truth = read_joints_csv(scene_dir / "JOINTS.csv")
    n = meta["n_frames"]
    assert len(truth) == n == round(2.6 / 1.2 * 25) + 1
    assert truth.fps == pytest.approx(25.0)
    assert np.isfinite(truth.positions).all()
    assert meta["seed"] == 3 and "procedural walk" in meta["source_motion"]
    assert len(meta["lighting"]["gain"]) == n and meta["lighting"]["gain"][0] == 1.0
    for i, cam in enumerate(meta["cameras"]):
        c = load_camera(scene_dir / cam["camera"])
        assert (c.width, c.height) == (320, 240)
        bg = cv2.imread(str(scene_dir / f"cam{i}-background.png"))
        assert bg.shape == (240, 320, 3)
        # no furniture: no occluder mask
        assert "occluder" not in cam and not (scene_dir / f"cam{i}-occluder.png").exists()
        frames = sorted((scene_dir / f"cam{i}").glob("*.png"))
        masks = sorted((scene_dir / f"cam{i}-masks").glob("*.png"))
        assert len(frames) == len(masks) == n
        # VIDEO may be a folder of numbered frames: OpenCV reads it as an image sequence
        cnt, size = _frame_count(scene_dir / f"cam{i}" / "%06d.png")
        assert cnt == n and size == (320, 240)


def test_truth_matches_silhouettes(scene_dir: Path) -> None:
    truth = read_joints_csv(scene_dir / "JOINTS.csv")
    for i in range(2):
        cam = load_camera(scene_dir / f"cam{i}.yaml")
        inside = total = 0
        for k in range(0, len(truth), 4):
            mask = cv2.imread(str(scene_dir / f"cam{i}-masks" / f"{k:06d}.png"), 0) > 0
            assert mask.any()
            px = cam.project(truth.positions[k])
            assert np.isfinite(px).all()
            ij = np.rint(px).astype(int)
            # key points are inside the body: in the silhouette (3x3 neighbourhood)
            dil = cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
            hit = dil[ij[:, 1].clip(0, 239), ij[:, 0].clip(0, 319)]
            inside += hit.sum()
            total += len(hit)
            # the silhouette's box is the key points' box plus the body's thickness
            rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
            tall = px[:, 1].max() - px[:, 1].min()
            margin = 0.2 * tall + 3
            assert rows[0] >= px[:, 1].min() - margin and rows[-1] <= px[:, 1].max() + margin
            assert cols[0] >= px[:, 0].min() - margin and cols[-1] <= px[:, 0].max() + margin
            assert rows[0] < px[HEAD, 1] and rows[-1] > px[FEET, 1].max() - 2
        assert inside / total > 0.97


def test_background_is_frame_zero_without_person(scene_dir: Path) -> None:
    for i in range(2):
        bg = cv2.imread(str(scene_dir / f"cam{i}-background.png")).astype(float)
        f0 = cv2.imread(str(scene_dir / f"cam{i}" / "000000.png")).astype(float)
        mask = cv2.imread(str(scene_dir / f"cam{i}-masks" / "000000.png"), 0) > 0
        near = cv2.dilate(mask.astype(np.uint8), np.ones((41, 41), np.uint8)) > 0
        diff = np.abs(f0 - bg).mean(axis=2)
        assert diff[~near].mean() < 3.5  # sensor noise only (sigma 2 in each image)
        assert diff[mask].mean() > 15  # the person differs from the room


def test_cli_mp4_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "s"
    args = ["-q", "simulate", "walk:distance=1", "--out", str(out), "--views", "frontal"]
    args += ["--size", "160x120", "--max-frames", "6", "--shape", "slim", "--clothing", "coat"]
    assert main(args) == 0
    n, size = _frame_count(out / "cam0.mp4")
    assert n == 6 and size == (160, 120)
    assert main(args) == 2  # the existing scene is not overwritten
    assert "already holds a scene" in capsys.readouterr().err
    assert main(args + ["--force"]) == 0
    assert main(["simulate", "--out", str(tmp_path / "x"), "--size", "big"]) == 2
    assert main(["simulate", "--advise"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("gaitwatch: error: --advise needs")


# -- in-memory scenes: determinism, shapes, occluders --------------------------------------------


def _masks_and_images(motion: Trajectory, **cfg) -> tuple[list, list, object]:
    base = {"views": ["side"], "image_size": (320, 240), "fps": 25.0}
    scene = build_scene(motion, SceneConfig(**{**base, **cfg}))
    ims, masks = [], []
    for _, i, m in render_frames(scene):
        ims.append(i[0])
        masks.append(m[0])
    return ims, masks, scene


@pytest.fixture(scope="module")
def short_walk() -> Trajectory:
    return procedural_walk(distance_m=2.4, fps=50)


def test_determinism_with_seed(short_walk: Trajectory) -> None:
    a, _, _ = _masks_and_images(short_walk, seed=5, max_frames=2)
    b, _, _ = _masks_and_images(short_walk, seed=5, max_frames=2)
    c, _, _ = _masks_and_images(short_walk, seed=6, max_frames=2)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[1], c[1])


def test_body_shapes_change_the_silhouette(short_walk: Trajectory) -> None:
    area = {}
    for shape in ("slim", "default", "heavy"):
        _, m, _ = _masks_and_images(short_walk, body={"preset": shape}, max_frames=1, seed=1)
        area[shape] = m[0].sum()
    assert area["slim"] < 0.92 * area["default"] < 0.92**2 * area["heavy"]
    # clothing that widens the trunk and thighs widens the silhouette too
    _, m, _ = _masks_and_images(short_walk, clothing={"style": "coat"}, max_frames=1, seed=1)
    assert m[0].sum() > 1.05 * area["default"]


def test_cloth_pattern_shows_on_the_shirt(short_walk: Trajectory) -> None:
    spread = {}
    for pattern in ("plain", "stripes"):
        ims, masks, sc = _masks_and_images(
            short_walk,
            max_frames=1,
            seed=1,
            views=["frontal"],
            clothing={"pattern": pattern, "shirt": (200, 60, 60)},
            noise={"sigma_dn": 0, "blur_px": 0},
        )
        kp = sc.truth.positions[0]
        # the chest, seen from the front: between the neck and the sacrum
        u, v = np.rint(sc.cameras[0].project(0.4 * kp[NECK] + 0.6 * kp[2])).astype(int)
        assert masks[0][v - 4 : v + 5, u - 4 : u + 5].all()
        patch = ims[0][v - 4 : v + 5, u - 4 : u + 5].astype(float).mean(axis=2)
        spread[pattern] = patch.std()
    assert spread["stripes"] > 3 * spread["plain"] + 3


def test_occluder_hides_the_legs(short_walk: Trajectory) -> None:
    def foot_visibility(occluder: str) -> tuple[float, float]:
        _, masks, sc = _masks_and_images(
            short_walk, room={"occluder": occluder}, seed=2, noise={"sigma_dn": 0}, fps=10.0
        )
        cam = sc.cameras[0]
        feet = head = 0.0
        for k, m in enumerate(masks):
            px = np.rint(cam.project(sc.truth.positions[k])).astype(int)
            ok = (px[:, 0] >= 0) & (px[:, 0] < 320) & (px[:, 1] >= 0) & (px[:, 1] < 240)
            vis = np.zeros(19, bool)
            vis[ok] = m[px[ok, 1], px[ok, 0]]
            feet += vis[FEET].mean()
            head += vis[HEAD]
        return feet / len(masks), head / len(masks)

    feet_free, head_free = foot_visibility("none")
    feet_sofa, head_sofa = foot_visibility("sofa")
    assert feet_free > 0.9 and head_free > 0.9
    assert feet_sofa < 0.5 * feet_free
    assert head_sofa > 0.9


def _sittings(places: list[tuple[float, float]], heading_deg: float = 90.0) -> Trajectory:
    """Standing, sitting down at each place in turn (2 s seated), standing up; 20 Hz."""
    from gait.synthetic import sitting_pose, standing_pose, synthetic_pose_sequence

    keys: list[tuple[float, np.ndarray]] = []
    t = 0.0
    for xy in places:
        st, si = standing_pose(xy, heading_deg), sitting_pose(xy, heading_deg)
        keys += [(t, st), (t + 0.5, st), (t + 1.5, si), (t + 3.5, si), (t + 4.5, st)]
        t += 5.0
    return synthetic_pose_sequence(keys, fps=20.0)


def test_a_chair_where_the_person_sits(caplog) -> None:
    from gait.synthetic import sitting_pose

    cfg = {"views": ["oblique"], "image_size": (320, 240), "fps": 10.0}
    room = {"occluder": "chair"}
    sc = build_scene(_sittings([(0.5, 0.2)]), SceneConfig(**cfg, room=room))
    seat, back = sc.room.furniture
    hips = 0.5 * (sitting_pose((0.5, 0.2), 90.0)[L_HIP] + sitting_pose((0.5, 0.2), 90.0)[R_HIP])
    assert np.hypot(seat.centre[0] - hips[0], seat.centre[1] - hips[1]) < 0.02
    assert seat.size[2] == pytest.approx(hips[2] - 0.09, abs=0.01)  # the seat under the thighs
    # the back behind the person (who faces +y), above the seat
    assert back.centre[1] < seat.centre[1] - 0.1 and back.size[2] > seat.size[2] + 0.3
    assert math.isclose(math.sin(seat.yaw), 1.0, abs_tol=0.05)
    # the person's seated thighs are drawn over the seat: the chair is in the background image
    # and in the occluder mask, as a real chair would be
    assert occluder_mask(sc, 0) is not None and occluder_mask(sc, 0).any()
    # two sittings at one place share a chair; at two places each has one
    sc = build_scene(_sittings([(0.5, 0.2), (0.6, 0.25)]), SceneConfig(**cfg, room=room))
    assert len(sc.room.furniture) == 2
    sc = build_scene(_sittings([(0.5, 0.2), (2.0, 0.2)]), SceneConfig(**cfg, room=room))
    assert len(sc.room.furniture) == 4
    # nobody sits in a walk: no chair, and a warning says so
    with caplog.at_level("WARNING"):
        sc = build_scene(procedural_walk(distance_m=2.0, fps=20), SceneConfig(**cfg, room=room))
    assert sc.room.furniture == [] and "no chair" in caplog.text


def test_occluder_mask_written_where_the_furniture_is(tmp_path: Path) -> None:
    """With furniture, ``camI-occluder.png`` marks its pixels (for ``track --occluder``) and
    the scene lists it; a scene written over it without furniture removes it."""
    out = tmp_path / "table"
    args = ["-q", "simulate", "walk:distance=2.0", "--out", str(out), "--views", "oblique"]
    args += ["--size", "320x240", "--fps", "10", "--masks", "--png", "--occluder", "table"]
    assert main([*args, "--seed", "4"]) == 0
    meta = json.loads((out / "scene.json").read_text())
    assert meta["cameras"][0]["occluder"] == "cam0-occluder.png"
    occ = cv2.imread(str(out / "cam0-occluder.png"), cv2.IMREAD_GRAYSCALE)
    assert occ.shape == (240, 320) and set(np.unique(occ)) == {0, 255}
    assert 0.02 < (occ > 0).mean() < 0.6
    bg = cv2.imread(str(out / "cam0-background.png"))
    # the table is one flat colour in the background; the walls and floor around it are not
    assert bg[occ > 0].std(axis=0).max() < bg[occ == 0].std(axis=0).max()
    # the walk passes behind it: the person's pixels there are few (a hand over the top)
    masks = [cv2.imread(str(m), cv2.IMREAD_GRAYSCALE) > 0 for m in (out / "cam0-masks").glob("*")]
    on = sum(int((m & (occ > 0)).sum()) for m in masks)
    assert on < 0.02 * sum(int(m.sum()) for m in masks)
    # replaced by a scene without furniture: the old mask goes
    assert main([*args[:-2], "--occluder", "none", "--seed", "4", "--force"]) == 0
    assert not (out / "cam0-occluder.png").exists()


# -- advice --------------------------------------------------------------------------------------


def test_measurable_floor_of_a_home_camera() -> None:
    cam = Camera.look_at(
        name="hall", position=[0, 0, 2.4], target=[3.5, 0, 0.7], image_size=(320, 240)
    )
    r = measurable_floor(cam, min_person_px=60)
    assert 5.0 < r.area_m2 < 80.0
    xmin, xmax, ymin, ymax = r.extent
    assert 1.0 < xmin < 4.0 and xmax < 10.0 and ymin < 0 < ymax  # in front, centred
    # nearer means taller, and no cell below the size limit
    near = r.cells[:, 0] < np.percentile(r.cells[:, 0], 20)
    assert r.person_px[near].mean() > r.person_px[~near].mean()
    assert r.person_px.min() >= 60
    # a stricter size limit shrinks the area; a camera facing the ceiling sees no floor
    assert measurable_floor(cam, min_person_px=100).area_m2 < r.area_m2
    up = Camera.look_at(name="up", position=[0, 0, 2.4], target=[3, 0, 4.0], image_size=(320, 240))
    assert measurable_floor(up).area_m2 == 0


def test_advise_renders_paths_and_scores_a_tracker() -> None:
    cam = Camera.look_at(
        name="hall", position=[0, 0, 2.4], target=[3.5, 0, 0.7], image_size=(320, 240)
    )
    offset = np.array([0.01, 0.0, 0.0])

    def fake_tracker(clip):
        assert clip.frames[0].shape[1:] == (240, 320, 3)
        assert clip.backgrounds[0].shape == (240, 320, 3)
        t = clip.truth
        return Trajectory(
            positions=t.positions[1:] + offset, times=t.times[1:], frames=t.frames[1:]
        )

    cfg = SceneConfig(fps=8.0)
    adv = advise(cam, fake_tracker, config=cfg, max_path_m=2.0, tracker_name="fake")
    assert adv.paths and adv.region.area_m2 > 5
    for p in adv.paths:
        assert p.whole_body_pct > 90 and p.person_px_range[0] >= 50
        assert p.error_mm == pytest.approx(10.0, abs=1e-6)  # known error in, same error out
        assert p.frames_lost == 1
    text = format_advice(adv)
    assert "Floor area where gait can be measured" in text and "fake" in text


def test_advise_tracks_its_clips_as_gaitwatch_track_does(monkeypatch) -> None:
    """``simulate --advise --track``'s tracker callable (service.tracking: the 2D detector of
    the next frame beside the tracker) follows a rendered walk, with the same key points as
    every detection made in turn."""
    import service.tracking as tracking
    from gaitwatch.sim.advise import SimClip
    from service.commands.simulate import tracker_callable

    walk = procedural_walk(distance_m=1.6, fps=20)
    cfg = SceneConfig(views=["oblique"], image_size=(320, 240), fps=20.0, max_frames=8, seed=1)
    scene = build_scene(walk, cfg)
    frames = [i[0] for _, i, _ in render_frames(scene)]
    clip = SimClip.of_scene(scene, frames, cfg.fps)
    runs = []
    for ahead in (True, False):
        monkeypatch.setattr(tracking, "DETECT_AHEAD", ahead)
        runs.append(tracker_callable(0)(clip))
    a, b = runs
    assert list(a.frames) == list(b.frames) and len(a.frames) >= 6
    assert np.array_equal(a.positions, b.positions)
    e_all, _, _ = pose_errors(scene.truth, a)
    assert e_all < 250.0  # mm: followed, not lost (one camera, 8 frames)


def test_pose_errors_known_offset() -> None:
    tr = procedural_walk(distance_m=1.0, fps=20)
    est = Trajectory(positions=tr.positions + [0, 0.003, 0.004], times=tr.times)
    e_all, e_low, lost = pose_errors(tr, est)
    assert e_all == pytest.approx(5.0) and e_low == pytest.approx(5.0) and lost == 0


# -- a real recording ----------------------------------------------------------------------------


def test_lower_limb_recording_renders(shared_data: Path) -> None:
    mocap = pytest.importorskip("gaitwatch.mocap")
    path = shared_file(shared_data, "c3d/gait-raw.c3d")
    motion = mocap.load_mocap(path)
    _, masks, sc = _masks_and_images(motion, max_frames=3, views=["oblique"], seed=0)
    assert "head" in sc.synthesised and "left_knee" not in sc.synthesised
    cam = sc.cameras[0]
    for k, m in enumerate(masks):
        px = np.rint(cam.project(sc.truth.positions[k])).astype(int)
        assert m[px[:, 1].clip(0, 239), px[:, 0].clip(0, 319)].mean() > 0.9
