"""Frames per second of the whole ``gaitwatch track`` path, on 1 and 2 threads.

Renders a synthetic walking clip (the body model's silhouettes over a textured background,
640x480 MP4 per camera, 20 fps; see ``tracker.synthetic``) and runs ``gaitwatch track`` on it in a
subprocess per setting: decode, segmentation (static background), origin search, IPF with 6561
particles at 160x120 likelihood resolution, MCAP writing. Each setting runs twice, on a short
and on the full clip; the difference gives the steady-state rate without start-up and the
first frame's exhaustive initialisation, both are printed::

    python3 bench/track_speed.py [--frames 80] [--cameras 2] [--threads 1 2] [--filter ipf]
        [--config TRACKER.toml]

Target (issue 3) on the 2-core machine: >= 30 frames/s, aim 100.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np


def make_clip(folder: Path, n_frames: int, n_cameras: int, seed: int = 0) -> list[str]:
    """Write the clip (MP4 + camera YAML + background PNG per camera); return track arguments."""
    from tracker.body import BodyModel
    from tracker.camera import save_camera
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.synthetic import render_clip, side_cameras, textured_background, walking_motion

    rng = np.random.default_rng(seed)
    body = BodyModel(1.70)
    size = (640, 480)
    cams = side_cameras(n_cameras, image_size=size, centre=(1.0, 0.0), fps=20.0)
    poses = walking_motion(body, n_frames, fps=20.0, speed_m_s=0.3, start_xy=(-0.25, 0.0))
    bgs = [textured_background(*size, rng) for _ in cams]
    renderer = SilhouetteLikelihood(body, cams)
    writers = []
    args: list[str] = []
    videos, cam_args, bg_args = [], [], []
    for c, cam in enumerate(cams):
        v = folder / f"cam{c}.mp4"
        writers.append(cv2.VideoWriter(str(v), cv2.VideoWriter_fourcc(*"mp4v"), 20.0, size))
        y = folder / f"cam{c}.yaml"
        save_camera(cam, y)
        b = folder / f"cam{c}-background.png"
        cv2.imwrite(str(b), bgs[c])
        videos.append(str(v))
        cam_args += ["--camera", str(y)]
        bg_args += ["--background", str(b)]
    for frames in render_clip(renderer, poses, bgs, rng):
        for w, f in zip(writers, frames, strict=True):
            w.write(f)
    for w in writers:
        w.release()
    args = [*videos, *cam_args, *bg_args]
    return args


_CHILD = (
    "import resource, sys\n"
    "from service.commands.track import main\n"
    "rc = main(sys.argv[1:])\n"
    "print('maxrss_kb', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n"
    "sys.exit(rc)\n"
)


def run_track(
    args: list[str], out: Path, threads: int, frames: int, filt: str
) -> tuple[float, float]:
    """Seconds the ``track`` loop took (as the command reports it) for ``frames`` frames, and the
    process's peak resident memory in MB."""
    cmd = [
        sys.executable,
        "-c",
        _CHILD,
        "-q",
        *args,
        "--out",
        str(out),
        "--threads",
        str(threads),
        "--max-frames",
        str(frames),
        "--filter",
        filt,
        "--no-progress",
    ]
    res = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"track failed ({res.returncode}): {res.stderr.strip()}")
    m = re.search(r"(\d+) frame\(s\): (\d+) with a pose.*?; ([0-9.]+) s \(", res.stdout)
    rss = re.search(r"maxrss_kb (\d+)", res.stdout)
    if not m or int(m.group(1)) != frames or not rss:
        raise SystemExit(f"unexpected output: {res.stdout!r}")
    if int(m.group(2)) != frames:
        print(f"  note: only {m.group(2)} of {frames} frames had a pose")
    return float(m.group(3)), int(rss.group(1)) / 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=80)
    ap.add_argument("--short", type=int, default=10, help="frames of the short run")
    ap.add_argument("--cameras", type=int, default=2)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--filter", default="ipf")
    ap.add_argument("--config", help="tracker settings file (TOML or YAML) for gaitwatch track")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="gaitwatch-bench-") as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        track_args = make_clip(folder, args.frames, args.cameras)
        if args.config:
            track_args += ["--config", str(Path(args.config).resolve())]
        print(
            f"clip: {args.frames} frames, {args.cameras} camera(s), 640x480 MP4, 20 fps "
            f"(rendered in {time.perf_counter() - t0:.1f} s); filter {args.filter}, 6561 "
            "particles, likelihood 160x120" + (f"; settings {args.config}" if args.config else "")
        )
        # Warm the numba cache once over the whole clip so that no timed run pays compilation:
        # kernels first used late in a track (re-detection, the backward pass) compile then,
        # and a fresh install's short run would otherwise take longer than the full one.
        run_track(track_args, folder / "warm.mcap", max(args.threads), args.frames, args.filter)
        for th in args.threads:
            t_short, rss_short = run_track(
                track_args, folder / "s.mcap", th, args.short, args.filter
            )
            t_full, rss_full = run_track(
                track_args, folder / "f.mcap", th, args.frames, args.filter
            )
            steady = (
                f"{(args.frames - args.short) / (t_full - t_short):6.1f} frames/s"
                if t_full > t_short
                else "not measurable (the short run took as long)"
            )
            print(
                f"threads {th}: {args.frames / t_full:6.1f} frames/s overall "
                f"({args.frames} frames in {t_full:.2f} s, first-frame initialisation included); "
                f"{steady} steady state (frames {args.short}-{args.frames}: {t_short:.2f} s for "
                f"the first {args.short}); peak memory {rss_short:.0f} MB after "
                f"{args.short} frames, {rss_full:.0f} MB after {args.frames}"
            )


if __name__ == "__main__":
    main()
