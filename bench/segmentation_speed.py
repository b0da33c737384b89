"""Segmentation and video-decoding speed: milliseconds per frame at 640x480.

Run: ``python3 bench/segmentation_speed.py [--frames N]``. Prints measured figures; asserts
nothing. Frames are synthetic (textured room, a moving person-like shape, sensor noise), the
same for every configuration. OpenCV's thread count is set to 1 and then 2.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from service.video import open_videos
from tracker.segmentation import SegmentationConfig, Segmenter

W, H = 640, 480


def _scene(n: int, rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
    coarse = rng.uniform(60, 200, (12, 16, 3)).astype(np.float32)
    bg = np.clip(cv2.resize(coarse, (W, H), interpolation=cv2.INTER_CUBIC), 0, 255)
    bg = bg.astype(np.uint8)
    frames = []
    for i in range(n):
        f = bg.astype(np.float32)
        m = np.zeros((H, W), np.uint8)
        cx = 100 + (i * 7) % 440
        cv2.circle(m, (cx, 110), 22, 1, -1)
        cv2.rectangle(m, (cx - 30, 135), (cx + 30, 290), 1, -1)
        cv2.line(m, (cx - 12, 290), (cx - 30 + (i % 9) * 4, 440), 1, 20)
        cv2.line(m, (cx + 12, 290), (cx + 30 - (i % 9) * 4, 440), 1, 20)
        f[m.astype(bool)] = (200, 40, 230)
        f += rng.normal(0, 4, f.shape).astype(np.float32)
        frames.append(np.clip(f, 0, 255).astype(np.uint8))
    return bg, frames


def _time_segmenter(cfg: SegmentationConfig, bg: np.ndarray, frames: list[np.ndarray]) -> float:
    seg = Segmenter(cfg, bg)
    for f in frames[:5]:  # warm-up
        seg.apply(f)
    t0 = time.perf_counter()
    for f in frames:
        seg.apply(f)
    return (time.perf_counter() - t0) / len(frames) * 1000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    bg, frames = _scene(args.frames, rng)

    print(f"segmentation, {W}x{H} frames -> 160x120 masks, ms/frame (frames/s)")
    print(f"{'mode':8} {'work_scale':>10} {'1 thread':>18} {'2 threads':>18}")
    for mode in ("static", "mog2", "knn"):
        for scale, blur in ((1.0, 3), (0.5, 0)):
            cfg = SegmentationConfig(mode=mode, work_scale=scale, blur=blur)
            row = []
            for threads in (1, 2):
                cv2.setNumThreads(threads)
                ms = _time_segmenter(cfg, bg, frames)
                row.append(f"{ms:7.2f} ({1000 / ms:6.0f})")
            print(f"{mode:8} {scale:>10g} {row[0]:>18} {row[1]:>18}")

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.avi"
        w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (W, H))
        for f in frames:
            w.write(f)
        w.release()
        for threads in (1, 2):
            cv2.setNumThreads(threads)
            t0 = time.perf_counter()
            n = sum(1 for _ in open_videos([path]))
            ms = (time.perf_counter() - t0) / n * 1000
            print(f"video decode (MJPG {W}x{H}), {threads} thread(s): {ms:.2f} ms/frame")


if __name__ == "__main__":
    main()
