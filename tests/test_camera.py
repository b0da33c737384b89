from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from tracker.camera import (
    Camera,
    CameraFileError,
    check_image_size,
    load_camera,
    load_cameras,
    save_camera,
)


@pytest.fixture
def cam() -> Camera:
    return Camera.look_at(
        name="living-room",
        position=[3.0, -3.0, 2.5],
        target=[0.0, 0.0, 1.0],
        dist=[0.1, -0.05, 0.001, 0.002, 0.01],
    )


def _write(tmp_path: Path, data: dict, name: str = "cam.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data))
    return p


def test_projection_matches_opencv(cam: Camera) -> None:
    pts = np.random.default_rng(0).uniform(-1, 1, (200, 3)) + [0, 0, 1]
    rvec, _ = cv2.Rodrigues(cam.R)
    ref, _ = cv2.projectPoints(pts, rvec, cam.t, cam.K, cam.dist)
    np.testing.assert_allclose(cam.project(pts), ref.reshape(-1, 2), atol=1e-9)


def test_projection_rational_model_matches_opencv() -> None:
    cam = Camera.look_at(
        name="wide",
        position=[0, -4, 2],
        target=[0, 0, 1],
        dist=[0.2, -0.1, 0.001, -0.001, 0.02, 0.05, -0.01, 0.003],
    )
    pts = np.random.default_rng(1).uniform(-1, 1, (50, 3)) + [0, 0, 1]
    rvec, _ = cv2.Rodrigues(cam.R)
    ref, _ = cv2.projectPoints(pts, rvec, cam.t, cam.K, cam.dist)
    np.testing.assert_allclose(cam.project(pts), ref.reshape(-1, 2), atol=1e-9)


def test_batched_shapes_and_behind_camera(cam: Camera) -> None:
    pts = np.zeros((4, 5, 3))
    assert cam.project(pts).shape == (4, 5, 2)
    behind = cam.center + (cam.center - np.array([0, 0, 1.0]))
    assert np.isnan(cam.project(behind[None])).all()


def test_round_trip(tmp_path: Path, cam: Camera) -> None:
    p = tmp_path / "c.yaml"
    save_camera(cam, p)
    back = load_camera(p)
    assert back.model == cam.model
    pts = np.array([[0.2, 0.3, 0.9]])
    np.testing.assert_allclose(back.project(pts), cam.project(pts))


def test_pixel_to_floor_inverts_projection(cam: Camera) -> None:
    floor = np.array([[0.5, 0.2, 0.0], [-1.0, 0.7, 0.0]])
    np.testing.assert_allclose(cam.pixel_to_floor(cam.project(floor)), floor, atol=1e-6)


def test_scaled_camera_matches_resized_image(cam: Camera) -> None:
    small = cam.scaled(160, 120)
    p = np.array([[0.1, 0.1, 1.0]])
    big_uv = cam.project(p)[0]
    small_uv = small.project(p)[0]
    np.testing.assert_allclose((big_uv + 0.5) / 4 - 0.5, small_uv, atol=1e-9)


GOOD = {
    "name": "hall",
    "image_size": [640, 480],
    "fps": 20,
    "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]],
    "dist": [],
    "R": [[1, 0, 0], [0, 0, -1], [0, 1, 0]],
    "t": [0, 1, 4],
}


def test_good_file_loads(tmp_path: Path) -> None:
    cam = load_camera(_write(tmp_path, GOOD))
    assert cam.name == "hall" and (cam.width, cam.height) == (640, 480)


def test_dist_may_be_omitted(tmp_path: Path) -> None:
    data = {k: v for k, v in GOOD.items() if k != "dist"}
    assert load_camera(_write(tmp_path, data)).dist.size == 0


@pytest.mark.parametrize(
    ("change", "field", "words"),
    [
        ({"K": None}, "K", "missing"),
        ({"R": None}, "R", "missing"),
        ({"t": None}, "t", "missing"),
        ({"image_size": None}, "image_size", "missing"),
        ({"R": [[1, 0, 0], [0, 1, 0], [0, 0.5, 1]]}, "R", "orthonormal"),
        ({"R": [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "R", "reflection"),
        ({"K": [[0, 0, 320], [0, 500, 240], [0, 0, 1]]}, "K", "focal"),
        ({"K": [[500, 0, 320], [0, -5, 240], [0, 0, 1]]}, "K", "focal"),
        ({"dist": [0.1, 0.2, 0.3]}, "dist", "coefficients"),
        ({"image_size": [640, -1]}, "image_size", "positive"),
        ({"t": [0, 1]}, "t", ""),
        ({"fps": 0}, "fps", ""),
        ({"colour": "red"}, "colour", "unknown key"),
    ],
)
def test_bad_files_name_file_and_field(
    tmp_path: Path, change: dict, field: str, words: str
) -> None:
    data = dict(GOOD)
    for k, v in change.items():
        if v is None:
            data.pop(k)
        else:
            data[k] = v
    p = _write(tmp_path, data)
    with pytest.raises(CameraFileError) as exc:
        load_camera(p)
    msg = str(exc.value)
    assert str(p) in msg
    assert field in msg
    assert words in msg


def test_not_yaml_missing_and_not_a_mapping(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\n")
    with pytest.raises(CameraFileError, match="not valid YAML"):
        load_camera(bad)
    with pytest.raises(CameraFileError, match="no such file"):
        load_camera(tmp_path / "absent.yaml")
    lst = tmp_path / "list.yaml"
    lst.write_text("- 1\n- 2\n")
    with pytest.raises(CameraFileError, match="mapping"):
        load_camera(lst)


def test_image_size_mismatch_and_unique_names(tmp_path: Path) -> None:
    p = _write(tmp_path, GOOD)
    cam = load_camera(p)
    with pytest.raises(CameraFileError, match="image_size"):
        check_image_size(cam, 320, 240)
    q = _write(tmp_path, GOOD, "other.yaml")
    with pytest.raises(CameraFileError, match="unique"):
        load_cameras([p, q])
