"""Camera footage: one frame source per camera, read in step, streaming.

A source is either a video file (anything OpenCV's FFmpeg back end reads) or a folder of
numbered PNG/JPEG frames (ordered by the numbers in the file names: ``f2.png`` before
``f10.png``). Frames come out as uint8 BGR arrays (H, W, 3), one at a time: nothing holds more
than the current frame of each camera, so memory does not grow with the length of the footage.

Times
    ``time_s`` is seconds from the source's first frame: the video's own timestamps
    (``CAP_PROP_POS_MSEC``) when it has them, else ``frame_index / fps`` with the video's frame
    rate, else the camera file's ``fps``, else the ``fps`` argument. A folder has no timestamps.

Errors
    Every problem is a :class:`VideoError` (a :class:`gaitwatch.errors.InputError`) with a
    one-line message naming the file. Problems found when a source is opened (missing file, not
    a video, first frame undecodable, empty folder, frame size differing from the camera file)
    are raised by :func:`open_source` / :func:`open_videos`. Problems further on (a frame that
    cannot be decoded, a file cut short, a folder frame of another size, videos of different
    lengths) are raised *lazily* by the iterator, after every earlier frame has been yielded,
    so a caller that writes results frame by frame keeps everything up to the bad frame.

Videos of different lengths
    :class:`SyncedVideos` stops at the shortest. With ``on_length_mismatch="error"`` (the
    default: the footage is not what the user thinks it is) it then raises
    :class:`VideoLengthError` naming the files; with ``"stop"`` it logs a warning and sets
    :attr:`SyncedVideos.length_mismatch`.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, NamedTuple

import cv2
import numpy as np

from gaitwatch.errors import InputError
from tracker.camera import Camera, CameraFileError, check_image_size

log = logging.getLogger(__name__)

# FFmpeg prints its own diagnostics of a corrupt file on stderr, around our one-line error.
# Quiet by default (read when OpenCV first loads FFmpeg); set OPENCV_FFMPEG_LOGLEVEL=24 to see
# them.
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")


@contextlib.contextmanager
def _quiet_opencv() -> Iterator[None]:
    """Silence OpenCV's own warnings (e.g. on a file it cannot open) for the duration."""
    try:
        from cv2.utils import logging as cvlog

        old = cvlog.getLogLevel()
        cvlog.setLogLevel(cvlog.LOG_LEVEL_ERROR)
    except (ImportError, AttributeError):  # pragma: no cover - older OpenCV builds
        yield
        return
    try:
        yield
    finally:
        cvlog.setLogLevel(old)


IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg"})
# A read that fails earlier than this many frames before the container's announced frame
# count is a decoding error (file cut short or corrupt), not the end of the video. Container
# counts of well-formed files can be a little off (estimated from duration x rate).
_COUNT_SLACK_FRAMES = 2
_COUNT_SLACK_FRACTION = 0.02


class VideoError(InputError):
    """Footage that cannot be used; the message names the file."""


class VideoDecodeError(VideoError):
    """A frame further into a source could not be decoded (file cut short or corrupt)."""


class VideoLengthError(VideoError):
    """The synchronised sources do not have the same number of frames."""


@dataclass(frozen=True)
class Frame:
    """One decoded frame of one source.

    Attributes
    ----------
    index : int
        0-based frame number in its source.
    time_s : float
        Seconds from the source's first frame.
    image : numpy.ndarray
        uint8 (H, W, 3), BGR.
    """

    index: int
    time_s: float
    image: np.ndarray


class SyncedFrame(NamedTuple):
    """One step of :class:`SyncedVideos`: unpacks as ``index, time_s, frames``.

    ``time_s`` is the first source's time; ``frames`` holds one uint8 (H, W, 3) BGR image per
    source, in the order the sources were given.
    """

    index: int
    time_s: float
    frames: list[np.ndarray]


def natural_key(name: str) -> tuple:
    """Sort key that orders embedded numbers by value: ``f2`` < ``f10``."""
    parts = re.split(r"(\d+)", name.lower())
    return tuple((0, int(p), p) if p.isdigit() else (1, 0, p) for p in parts if p != "")


class FrameSource:
    """Base of the frame sources: iterate to get :class:`Frame` objects, in order.

    Attributes
    ----------
    path : pathlib.Path
        The video file or folder.
    width, height : int
        Frame size in pixels (of the first frame).
    fps : float or None
        Frame rate used for times when there are no timestamps.
    frame_count : int or None
        Announced number of frames (a container's count may be approximate); None if unknown.
    frames_read : int
        Frames yielded so far.
    """

    path: Path
    width: int
    height: int
    fps: float | None
    frame_count: int | None
    frames_read: int

    def __iter__(self) -> Iterator[Frame]:
        raise NotImplementedError

    def close(self) -> None:
        """Release the file handles (idempotent)."""

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def check_camera(self, camera: Camera) -> None:
        """Raise :class:`VideoError` if the frames do not have the camera file's image size."""
        try:
            check_image_size(camera, self.width, self.height, what=f"the frames of {self.path}")
        except CameraFileError as err:
            raise VideoError(str(err)) from None


class VideoFileSource(FrameSource):
    """Frames of a video file, decoded one at a time with OpenCV (FFmpeg back end).

    Parameters
    ----------
    path : str or Path
        The video file.
    fps : float, optional
        Frame rate to use when the video announces none (e.g. the camera file's).

    Raises
    ------
    VideoError
        Missing file, a file OpenCV cannot open, or a first frame that cannot be decoded.
    """

    def __init__(self, path: str | Path, fps: float | None = None) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise VideoError(f"{self.path}: no such file")
        if not self.path.is_file():
            raise VideoError(f"{self.path}: not a file")
        with _quiet_opencv():
            cap = cv2.VideoCapture(str(self.path), cv2.CAP_FFMPEG)
        if not cap.isOpened():
            cap.release()
            raise VideoError(
                f"{self.path}: not a video OpenCV can read (unknown format or corrupt)"
            )
        ok, first = cap.read()
        if not ok or first is None:
            cap.release()
            raise VideoError(f"{self.path}: the first frame cannot be decoded (corrupt video?)")
        self._cap: cv2.VideoCapture | None = cap
        self._first: np.ndarray | None = first
        self._first_msec = float(cap.get(cv2.CAP_PROP_POS_MSEC))
        self.height, self.width = first.shape[:2]
        vfps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
        self.fps = vfps if math.isfinite(vfps) and vfps > 0 else fps
        n = cap.get(cv2.CAP_PROP_FRAME_COUNT)
        self.frame_count = int(n) if math.isfinite(n) and n > 0 else None
        self.frames_read = 0
        self._started = False
        # Timestamps are trusted while they are finite and increasing.
        self._use_msec = math.isfinite(self._first_msec) and self._first_msec >= 0
        self._last_msec = self._first_msec

    def _time(self, index: int, msec: float) -> float:
        if self._use_msec and index > 0:
            if math.isfinite(msec) and msec > self._last_msec:
                self._last_msec = msec
                return (msec - self._first_msec) / 1000.0
            log.debug("%s: no usable timestamp at frame %d; using the frame rate", self.path, index)
            self._use_msec = False
        if index == 0:
            return 0.0
        if not self.fps:
            raise VideoError(
                f"{self.path}: the video has neither timestamps nor a frame rate; "
                "give one (camera file fps)"
            )
        return index / self.fps

    def __iter__(self) -> Iterator[Frame]:
        if self._started:
            raise RuntimeError(f"{self.path}: a frame source can be iterated only once")
        self._started = True
        cap = self._cap
        if cap is None:
            return
        try:
            first, self._first = self._first, None
            assert first is not None
            self.frames_read = 1
            yield Frame(0, 0.0, first)
            index = 1
            while True:
                ok, img = cap.read()
                if not ok or img is None:
                    self._check_end(index)
                    return
                if img.shape[:2] != (self.height, self.width):
                    raise VideoDecodeError(
                        f"{self.path}: frame {index} is {img.shape[1]}x{img.shape[0]}, "
                        f"the video started at {self.width}x{self.height}"
                    )
                t = self._time(index, float(cap.get(cv2.CAP_PROP_POS_MSEC)))
                self.frames_read = index + 1
                yield Frame(index, t, img)
                index += 1
        finally:
            self.close()

    def _check_end(self, index: int) -> None:
        """At a failed read of frame ``index``: the end, or a frame that cannot be decoded."""
        n = self.frame_count
        if n is None:
            return
        slack = max(_COUNT_SLACK_FRAMES, int(_COUNT_SLACK_FRACTION * n))
        if index < n - slack:
            raise VideoDecodeError(
                f"{self.path}: frame {index} cannot be decoded (the file announces {n} frames): "
                "the video is cut short or corrupt"
            )

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None
        self._first = None


class ImageFolderSource(FrameSource):
    """Frames from a folder of numbered PNG/JPEG images, read one at a time.

    Files are ordered by :func:`natural_key`; other files are ignored. Images are read in
    colour (grey images become 3-channel BGR).

    Raises
    ------
    VideoError
        Missing folder, no image files, or a first image that cannot be decoded.
    """

    def __init__(self, path: str | Path, fps: float | None = None) -> None:
        self.path = Path(path)
        if not self.path.is_dir():
            raise VideoError(f"{self.path}: no such folder")
        files = [
            p for p in self.path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES
        ]
        if not files:
            raise VideoError(f"{self.path}: no PNG or JPEG frames in the folder")
        self.files = sorted(files, key=lambda p: natural_key(p.name))
        first = self._read(self.files[0])
        self.height, self.width = first.shape[:2]
        self._first: np.ndarray | None = first
        if fps is None and len(self.files) > 1:
            raise VideoError(
                f"{self.path}: a folder of frames has no frame rate; give one (camera file fps)"
            )
        self.fps = fps
        self.frame_count = len(self.files)
        self.frames_read = 0
        self._started = False

    @staticmethod
    def _read(p: Path) -> np.ndarray:
        img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        if img is None:
            raise VideoDecodeError(f"{p}: cannot be decoded as an image")
        return img

    def __iter__(self) -> Iterator[Frame]:
        if self._started:
            raise RuntimeError(f"{self.path}: a frame source can be iterated only once")
        self._started = True
        fps = self.fps or 1.0  # only None for a single frame, at time 0
        for index, p in enumerate(self.files):
            if index == 0:
                img, self._first = self._first, None
                assert img is not None
            else:
                img = self._read(p)
            if img.shape[:2] != (self.height, self.width):
                raise VideoDecodeError(
                    f"{p}: frame is {img.shape[1]}x{img.shape[0]}, the folder's first frame "
                    f"({self.files[0].name}) is {self.width}x{self.height}"
                )
            self.frames_read = index + 1
            yield Frame(index, index / fps, img)

    def close(self) -> None:
        self._first = None


def open_source(
    path: str | Path, *, camera: Camera | None = None, fps: float | None = None
) -> FrameSource:
    """Open one camera's footage: a video file or a folder of numbered frames.

    Parameters
    ----------
    path : str or Path
        Video file or folder of PNG/JPEG frames.
    camera : Camera, optional
        Its camera: the frame size must equal the file's ``image_size``, and its ``fps`` is the
        fallback frame rate.
    fps : float, optional
        Fallback frame rate when there is neither a video rate nor a camera.
    """
    p = Path(path)
    rate = camera.fps if camera is not None else fps
    src: FrameSource = ImageFolderSource(p, rate) if p.is_dir() else VideoFileSource(p, rate)
    if camera is not None:
        try:
            src.check_camera(camera)
        except VideoError:
            src.close()
            raise
    return src


class SyncedVideos:
    """Frame-synchronised iteration over several cameras' footage.

    Iterating yields :class:`SyncedFrame` ``(index, time_s, [frame per camera])``. Use it as a
    context manager (or call :meth:`close`) to release the files.

    Parameters
    ----------
    paths : sequence of str or Path
        One video file or frame folder per camera.
    cameras : sequence of Camera, optional
        The cameras in the same order: frame sizes are checked against their ``image_size``
        and their ``fps`` is the fallback frame rate.
    fps : float, optional
        Fallback frame rate without cameras.
    on_length_mismatch : {"error", "stop"}
        What to do when one source ends before the others (see the module notes).

    Attributes
    ----------
    sources : list of FrameSource
    frames_read : int
        Synchronised steps yielded so far.
    length_mismatch : str or None
        After iteration: a description of the length mismatch, if there was one.
    """

    def __init__(
        self,
        paths: Sequence[str | Path],
        cameras: Sequence[Camera] | None = None,
        *,
        fps: float | None = None,
        on_length_mismatch: Literal["error", "stop"] = "error",
    ) -> None:
        if not paths:
            raise VideoError("no video given")
        if cameras is not None and len(cameras) != len(paths):
            raise VideoError(
                f"{len(paths)} video(s) for {len(cameras)} camera file(s): give one per camera"
            )
        if on_length_mismatch not in ("error", "stop"):
            raise ValueError(
                f"on_length_mismatch must be 'error' or 'stop', not {on_length_mismatch!r}"
            )
        self.on_length_mismatch = on_length_mismatch
        self.sources: list[FrameSource] = []
        try:
            for i, p in enumerate(paths):
                cam = cameras[i] if cameras is not None else None
                self.sources.append(open_source(p, camera=cam, fps=fps))
        except BaseException:
            self.close()
            raise
        self.frames_read = 0
        self.length_mismatch: str | None = None
        rates = [s.fps for s in self.sources if s.fps]
        if rates and max(rates) > min(rates) * 1.01:
            log.warning(
                "the videos have different frame rates (%s): frames are paired by number",
                ", ".join(f"{s.path.name}: {s.fps:g}" for s in self.sources if s.fps),
            )
        for src, cam in zip(self.sources, cameras or [], strict=False):
            if src.fps and cam.fps and abs(src.fps - cam.fps) > 0.01 * cam.fps:
                log.warning(
                    "%s runs at %g fps but its camera file says %g: the frame times follow the "
                    "video, the tracker's windows counted in frames and the output stages "
                    "follow the camera file; set fps: %g in the camera file",
                    src.path.name,
                    src.fps,
                    cam.fps,
                    src.fps,
                )

    @property
    def frame_count(self) -> int | None:
        """Announced number of synchronised steps (the smallest announced count), if known."""
        counts = [s.frame_count for s in self.sources if s.frame_count is not None]
        return min(counts) if len(counts) == len(self.sources) else None

    def __iter__(self) -> Iterator[SyncedFrame]:
        its = [iter(s) for s in self.sources]
        try:
            while True:
                frames: list[Frame | None] = [next(it, None) for it in its]
                if all(f is None for f in frames):
                    return
                if any(f is None for f in frames):
                    self._mismatch(frames)
                    return
                got = [f for f in frames if f is not None]
                self.frames_read += 1
                yield SyncedFrame(got[0].index, got[0].time_s, [f.image for f in got])
        finally:
            self.close()

    def _mismatch(self, frames: Sequence[Frame | None]) -> None:
        n = self.frames_read
        ended = [s for s, f in zip(self.sources, frames, strict=True) if f is None]
        longer = [s for s, f in zip(self.sources, frames, strict=True) if f is not None]

        def count(s: FrameSource) -> str:
            return f"about {s.frame_count}" if s.frame_count else "more"

        msg = (
            f"videos of different lengths: {', '.join(str(s.path) for s in ended)} ended after "
            f"{n} frame(s), {', '.join(f'{s.path} has {count(s)}' for s in longer)}; "
            f"stopped at frame {n}"
        )
        self.length_mismatch = msg
        if self.on_length_mismatch == "error":
            raise VideoLengthError(msg)
        log.warning("%s", msg)

    def close(self) -> None:
        """Release every source (idempotent)."""
        for s in self.sources:
            s.close()

    def __enter__(self) -> SyncedVideos:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_videos(
    paths: Sequence[str | Path],
    cameras: Sequence[Camera] | None = None,
    *,
    fps: float | None = None,
    on_length_mismatch: Literal["error", "stop"] = "error",
) -> SyncedVideos:
    """Open one video (or frame folder) per camera for synchronised reading.

    See :class:`SyncedVideos`. Opening checks each source's first frame and size; later
    problems are raised lazily during iteration.
    """
    return SyncedVideos(paths, cameras, fps=fps, on_length_mismatch=on_length_mismatch)


def read_image(path: str | Path) -> np.ndarray:
    """Read one image (e.g. a background of the empty scene) as uint8 (H, W, 3) BGR.

    Raises :class:`VideoError` naming the file when it is missing or not an image.
    """
    p = Path(path)
    if not p.is_file():
        raise VideoError(f"{p}: no such file")
    img = cv2.imread(str(p), cv2.IMREAD_COLOR)
    if img is None:
        raise VideoError(f"{p}: cannot be decoded as an image")
    return img
