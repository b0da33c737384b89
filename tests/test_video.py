"""Frame sources: video files, frame folders, synchronised reading and every kind of bad footage."""

from __future__ import annotations

import logging
import tracemalloc
from pathlib import Path

import cv2
import numpy as np
import pytest

from gaitwatch.errors import InputError
from service.video import (
    ImageFolderSource,
    SyncedFrame,
    VideoDecodeError,
    VideoError,
    VideoFileSource,
    VideoLengthError,
    natural_key,
    open_source,
    open_videos,
    read_image,
)
from tests.conftest import shared_file
from tracker.camera import Camera

W, H = 64, 48


def _img(i: int, w: int = W, h: int = H) -> np.ndarray:
    """Frame i: a flat grey level that encodes i (survives JPEG compression)."""
    return np.full((h, w, 3), 10 + 12 * (i % 20), np.uint8)


def _level(img: np.ndarray) -> int:
    return round((float(img.mean()) - 10) / 12)


def _write_video(path: Path, n: int, fourcc: str = "MJPG", fps: float = 20.0, size=(W, H)) -> Path:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, size)
    if not w.isOpened():
        pytest.skip(f"OpenCV cannot write {fourcc} to {path.suffix}")
    for i in range(n):
        w.write(_img(i, *size))
    w.release()
    return path


def _write_folder(path: Path, n: int, names=lambda i: f"frame{i}.png") -> Path:
    path.mkdir()
    for i in range(n):
        cv2.imwrite(str(path / names(i)), _img(i))
    return path


def _cam(size=(W, H), fps: float = 20.0) -> Camera:
    return Camera.look_at(name="c", position=[3, 0, 2], target=[0, 0, 1], image_size=size, fps=fps)


@pytest.mark.parametrize(("fourcc", "ext"), [("MJPG", ".avi"), ("mp4v", ".mp4")])
def test_video_file_frames_and_times(tmp_path: Path, fourcc: str, ext: str) -> None:
    p = _write_video(tmp_path / f"v{ext}", 25, fourcc, fps=25.0)
    with VideoFileSource(p) as src:
        assert (src.width, src.height) == (W, H)
        assert src.fps == pytest.approx(25.0)
        assert src.frame_count == 25
        frames = list(src)
    assert [f.index for f in frames] == list(range(25))
    assert [_level(f.image) for f in frames] == [i % 20 for i in range(25)]
    np.testing.assert_allclose([f.time_s for f in frames], np.arange(25) / 25.0, atol=1e-6)
    assert all(f.image.shape == (H, W, 3) and f.image.dtype == np.uint8 for f in frames)


def test_folder_natural_order_and_camera_fps(tmp_path: Path) -> None:
    d = _write_folder(tmp_path / "cam0", 12, names=lambda i: f"img_{i + 1}.png")
    (d / "notes.txt").write_text("not a frame")
    cv2.imwrite(str(d / "img_13.jpg"), _img(12))
    src = open_source(d, camera=_cam(fps=10.0))
    assert isinstance(src, ImageFolderSource)
    assert src.frame_count == 13
    frames = list(src)
    # img_2 before img_10: natural order, not lexicographic.
    assert [_level(f.image) for f in frames] == list(range(13))
    np.testing.assert_allclose([f.time_s for f in frames], np.arange(13) / 10.0)
    assert sorted(["f10", "f2", "f1"], key=natural_key) == ["f1", "f2", "f10"]


def test_synced_iteration_yields_index_time_frames(tmp_path: Path) -> None:
    a = _write_video(tmp_path / "a.avi", 10)
    b = _write_folder(tmp_path / "b", 10)
    got = []
    with open_videos([a, b], [_cam(), _cam()]) as vids:
        assert vids.frame_count == 10
        for step in vids:
            assert isinstance(step, SyncedFrame)
            i, t, frames = step
            assert len(frames) == 2
            assert _level(frames[0]) == _level(frames[1]) == i
            got.append((i, t))
    assert [g[0] for g in got] == list(range(10))
    np.testing.assert_allclose([g[1] for g in got], np.arange(10) / 20.0, atol=1e-6)
    assert vids.frames_read == 10 and vids.length_mismatch is None


def test_missing_and_not_a_video(tmp_path: Path) -> None:
    with pytest.raises(VideoError, match="nope.avi: no such file"):
        VideoFileSource(tmp_path / "nope.avi")
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(np.random.default_rng(0).integers(0, 256, 20000, np.uint8).tobytes())
    with pytest.raises(VideoError, match="junk.mp4"):
        open_source(junk)
    text = tmp_path / "cam.yaml"
    text.write_text("name: x\n")
    with pytest.raises(VideoError, match=r"cam\.yaml"):
        open_source(text)
    assert issubclass(VideoError, InputError)


def test_truncated_video_yields_frames_then_raises(tmp_path: Path) -> None:
    p = _write_video(tmp_path / "full.avi", 30)
    cut = tmp_path / "cut.avi"
    data = p.read_bytes()
    # Cut in the middle of frame 15's data (chunks are tagged "00dc" in an AVI).
    chunks = [i for i in range(len(data)) if data.startswith(b"00dc", i)]
    cut.write_bytes(data[: chunks[15] + 60])
    got: list[int] = []
    with pytest.raises(VideoDecodeError, match=r"cut\.avi: frame \d+ cannot be decoded"):
        for f in VideoFileSource(cut):
            got.append(_level(f.image))
    # Everything before the cut came out, in order.
    assert 14 <= len(got) <= 16
    assert got == [i % 20 for i in range(len(got))]


def test_cut_mp4_cannot_be_opened(tmp_path: Path) -> None:
    p = _write_video(tmp_path / "full.mp4", 20, "mp4v")
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    with pytest.raises(VideoError, match=r"cut\.mp4"):
        open_source(cut)


def test_frame_size_differs_from_camera(tmp_path: Path) -> None:
    p = _write_video(tmp_path / "v.avi", 5)
    with pytest.raises(VideoError, match=r"image_size: 640x480 does not match.*v\.avi.*64x48"):
        open_videos([p], [_cam(size=(640, 480))])
    d = _write_folder(tmp_path / "f", 3)
    with pytest.raises(VideoError, match=r"image_size"):
        open_source(d, camera=_cam(size=(32, 24)))


def test_videos_of_different_lengths(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    a = _write_video(tmp_path / "a.avi", 12)
    b = _write_video(tmp_path / "b.avi", 8)
    seen: list[int] = []
    with pytest.raises(VideoLengthError, match=r"b\.avi ended after 8 frame"):
        for i, _t, _frames in open_videos([a, b]):
            seen.append(i)
    assert seen == list(range(8))  # all common frames were handed out before the error

    vids = open_videos([a, b], on_length_mismatch="stop")
    with caplog.at_level(logging.WARNING):
        n = sum(1 for _ in vids)
    assert n == 8
    assert vids.length_mismatch is not None and "a.avi" in vids.length_mismatch
    assert "different lengths" in caplog.text


def test_folder_errors(tmp_path: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("x")
    with pytest.raises(VideoError, match="no PNG or JPEG frames"):
        open_source(empty, fps=20)
    with pytest.raises(VideoError, match="no such"):
        ImageFolderSource(tmp_path / "absent", fps=20)
    with pytest.raises(VideoError, match="frame rate"):
        ImageFolderSource(_write_folder(tmp_path / "norate", 3))

    mixed = _write_folder(tmp_path / "mixed", 6)
    cv2.imwrite(str(mixed / "frame4.png"), _img(4, 32, 24))
    got: list[int] = []
    with pytest.raises(VideoDecodeError, match=r"frame4\.png: frame is 32x24"):
        for f in open_source(mixed, fps=20):
            got.append(f.index)
    assert got == [0, 1, 2, 3]

    bad = _write_folder(tmp_path / "bad", 5)
    (bad / "frame2.png").write_bytes(b"\x89PNG not really")
    got = []
    with pytest.raises(VideoDecodeError, match=r"frame2\.png: cannot be decoded"):
        for f in open_source(bad, fps=20):
            got.append(f.index)
    assert got == [0, 1]


def test_camera_count_must_match(tmp_path: Path) -> None:
    a = _write_video(tmp_path / "a.avi", 3)
    with pytest.raises(VideoError, match="one per camera"):
        open_videos([a], [_cam(), _cam()])


def test_streaming_memory_does_not_grow(tmp_path: Path) -> None:
    size = (320, 240)
    p = _write_video(tmp_path / "long.avi", 120, size=size)
    frame_bytes = size[0] * size[1] * 3
    tracemalloc.start()
    try:
        n = 0
        for _i, _t, frames in open_videos([p]):
            n += 1
            del frames
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert n == 120
    assert peak < 10 * frame_bytes  # a handful of frames, not the whole video (120)


def test_read_image(tmp_path: Path) -> None:
    p = tmp_path / "bg.png"
    cv2.imwrite(str(p), _img(3))
    assert read_image(p).shape == (H, W, 3)
    with pytest.raises(VideoError, match="bg2.png: no such file"):
        read_image(tmp_path / "bg2.png")
    (tmp_path / "x.png").write_text("no")
    with pytest.raises(VideoError, match="x.png: cannot be decoded"):
        read_image(tmp_path / "x.png")


def test_real_footage_first_frames(shared_data: Path) -> None:
    p = shared_file(shared_data, "video/outdoor-walk-1768x994-30fps.mp4")
    cam = Camera.look_at(
        name="tripod", position=[0, -5, 1.5], target=[0, 0, 1], image_size=(1768, 994), fps=30
    )
    times = []
    with open_videos([p], [cam]) as vids:
        assert vids.frame_count == 230
        for i, t, frames in vids:
            assert frames[0].shape == (994, 1768, 3)
            times.append(t)
            if i == 9:
                break
    np.testing.assert_allclose(times, np.arange(10) / 30.0, atol=1e-3)


def test_video_rate_unlike_the_camera_files_is_warned(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    v = _write_video(tmp_path / "a.avi", 3, fps=30.0)
    with caplog.at_level(logging.WARNING), open_videos([v], [_cam(fps=20.0)]) as vids:
        assert vids.sources[0].fps == pytest.approx(30.0)
    assert "a.avi runs at 30 fps but its camera file says 20" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING), open_videos([v], [_cam(fps=30.0)]):
        pass
    assert "camera file says" not in caplog.text
