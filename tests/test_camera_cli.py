"""``gaitwatch camera check`` through the command line entry point."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from service.cli import main
from service.commands.camera import AXIS_COLOURS, polygon_area, visible_floor
from tracker.camera import Camera, save_camera


@pytest.fixture
def cam() -> Camera:
    return Camera.look_at(
        name="living-room",
        position=[3.0, -3.0, 2.5],
        target=[0.0, 0.0, 0.5],
        dist=[0.05, -0.02, 0.0, 0.0, 0.0],
    )


@pytest.fixture
def cam_file(tmp_path: Path, cam: Camera) -> Path:
    p = tmp_path / "cam.yaml"
    save_camera(cam, p)
    return p


def test_summary_of_a_valid_file(cam_file: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["camera", "check", str(cam_file)]) == 0
    out = capsys.readouterr().out
    assert "'living-room'" in out and "valid" in out
    assert "640x480" in out
    assert "x=3.000 y=-3.000 z=2.500" in out
    assert "height above floor 2.50 m" in out
    assert "heading 135.0 deg" in out
    # Looking from 2.5 m at a point 0.5 m high, 4.24 m away: atan(2 / 4.243) = 25.2 deg down.
    assert re.search(r"tilt 25\.2 deg below horizontal", out)
    assert "floor seen" in out and "world origin at pixel" in out


def test_bad_file_exits_2_naming_the_field(
    tmp_path: Path, cam: Camera, capsys: pytest.CaptureFixture
) -> None:
    d = cam.to_dict()
    d["R"][0][0] = 2.0
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(d))
    assert main(["camera", "check", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gaitwatch: error:")
    assert "bad.yaml" in err and "R" in err and "orthonormal" in err
    assert "\n" not in err

    del d["K"]
    d["R"] = cam.to_dict()["R"]
    p.write_text(yaml.safe_dump(d))
    assert main(["camera", "check", str(p)]) == 2
    assert "K: missing key" in capsys.readouterr().err

    assert main(["camera", "check", str(tmp_path / "none.yaml")]) == 2
    assert "none.yaml: no such file" in capsys.readouterr().err


def test_image_gets_grid_and_axes(
    tmp_path: Path, cam: Camera, cam_file: Path, capsys: pytest.CaptureFixture
) -> None:
    img = np.full((480, 640, 3), 60, np.uint8)
    img_path = tmp_path / "frame.png"
    cv2.imwrite(str(img_path), img)
    assert main(["camera", "check", str(cam_file), str(img_path)]) == 0
    out_path = tmp_path / "frame-check.png"
    assert f"wrote {out_path}" in capsys.readouterr().out
    drawn = cv2.imread(str(out_path))
    assert drawn.shape == img.shape
    # The projected origin is drawn over (the yellow dot).
    u, v = np.round(cam.project(np.zeros(3))).astype(int)
    assert not np.array_equal(drawn[v, u], img[v, u])
    # Each axis is drawn in its colour at the projection of its middle (0.5 m along it).
    for i, name in enumerate("xyz"):
        p = np.zeros(3)
        p[i] = 0.5
        u, v = np.round(cam.project(p)).astype(int)
        patch = drawn[v - 1 : v + 2, u - 1 : u + 2].reshape(-1, 3).astype(int)
        assert np.abs(patch - AXIS_COLOURS[name]).sum(axis=1).min() < 60, name
    # Grid lines on the floor: a floor point on a grid line is brighter than the background,
    # the middle of a grid cell is untouched.
    u, v = np.round(cam.project(np.array([1.0, 2.25, 0.0]))).astype(int)
    assert drawn[v - 1 : v + 2, u - 1 : u + 2].max() > 120
    u, v = np.round(cam.project(np.array([1.25, 2.25, 0.0]))).astype(int)
    assert np.array_equal(drawn[v, u], img[v, u])
    # Above the horizon (top rows) nothing is drawn.
    assert np.array_equal(drawn[:5], img[:5])


def test_out_option_and_canvas_without_image(
    tmp_path: Path, cam_file: Path, capsys: pytest.CaptureFixture
) -> None:
    out = tmp_path / "sub.png"
    assert main(["camera", "check", str(cam_file), "--out", str(out), "--grid", "1"]) == 0
    drawn = cv2.imread(str(out))
    assert drawn.shape == (480, 640, 3)
    assert len(np.unique(drawn.reshape(-1, 3), axis=0)) > 10


def test_image_size_mismatch_and_bad_image(
    tmp_path: Path, cam_file: Path, capsys: pytest.CaptureFixture
) -> None:
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((240, 320, 3), np.uint8))
    assert main(["camera", "check", str(cam_file), str(small)]) == 2
    err = capsys.readouterr().err
    assert "image_size: 640x480 does not match" in err and "small.png" in err
    assert not (tmp_path / "small-check.png").exists()

    junk = tmp_path / "junk.png"
    junk.write_text("not an image")
    assert main(["camera", "check", str(cam_file), str(junk)]) == 2
    assert "junk.png: cannot be decoded" in capsys.readouterr().err


def test_visible_floor_of_a_camera_looking_down() -> None:
    # 2 m up, straight down, 90 deg horizontal field of view, 4:3 image: sees 4 m x 3 m.
    cam = Camera.look_at(
        name="down", position=[1.0, 2.0, 2.0], target=[1.0, 2.0, 0.0], hfov_deg=90.0
    )
    poly = visible_floor(cam)
    w = 2 * 2.0 * (639 / 640)  # border pixel centres span (width - 1) pixels
    h = 2 * 2.0 * (479 / 640)
    assert polygon_area(poly) == pytest.approx(w * h, rel=1e-3)
    np.testing.assert_allclose(poly.mean(axis=0), [1.0, 2.0], atol=0.02)
    # A camera below the floor sees none.
    below = Camera.look_at(name="b", position=[0, 0, -1.0], target=[0, 1, -1.0])
    assert visible_floor(below).shape == (0, 2)


def test_first_frame_of_a_video_is_used(
    tmp_path: Path, cam: Camera, cam_file: Path, capsys: pytest.CaptureFixture
) -> None:
    video = tmp_path / "clip.avi"
    w = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (640, 480))
    for _ in range(3):
        w.write(np.full((480, 640, 3), 60, np.uint8))
    w.release()
    assert main(["camera", "check", str(cam_file), str(video)]) == 0
    drawn = cv2.imread(str(tmp_path / "clip-check.png"))
    u, v = np.round(cam.project(np.zeros(3))).astype(int)
    assert np.abs(drawn[v, u].astype(int) - (0, 255, 255)).sum() < 60  # the yellow origin dot
