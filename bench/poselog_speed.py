"""Pose-log speed and memory: frames/s of PoseLogWriter and read_poselog, bytes per frame.

Run: ``python3 bench/poselog_speed.py [--frames N]``. Prints measured figures; asserts nothing.
The writer's memory is traced while writing to show that it does not grow with the number of
frames beyond MCAP's chunk index.
"""

from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from service.poselog import PoseLogWriter, read_poselog
from tracker.camera import Camera


def _write(path: Path, n: int, fps: float, trace: bool) -> tuple[float, dict[int, int]]:
    """Write ``n`` frames of a smooth synthetic walk; seconds taken and traced memory."""
    rng = np.random.default_rng(0)
    cams = [
        Camera.look_at(name="a", position=[4, 0, 2.2], target=[0, 0, 1]),
        Camera.look_at(name="b", position=[0, 4, 2.2], target=[0, 0, 1]),
    ]
    base = rng.normal([0.0, 0.0, 1.0], 0.3, size=(19, 3))
    mem: dict[int, int] = {}
    if trace:
        tracemalloc.start()
    t0 = time.perf_counter()
    with PoseLogWriter(
        path, cameras=cams, body_height_m=1.7, filter_name="ipf", settings={"M": 81}, fps=fps
    ) as log:
        for f in range(n):
            t = f / fps
            joints = base + np.array([1.2 * t, 0.0, 0.0]) + 0.02 * np.sin(t + base)
            dofs = np.concatenate([joints[2], 0.1 * np.sin(t + np.arange(28))])
            log.write_frame(f, t, joints, dofs, 0.5)
            if trace and f + 1 in (n // 10, n):
                mem[f + 1] = tracemalloc.get_traced_memory()[0]
    seconds = time.perf_counter() - t0
    if trace:
        tracemalloc.stop()
    return seconds, mem


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=20000, help="frames for the speed figures")
    ap.add_argument("--mem-frames", type=int, default=5000, help="frames for the memory trace")
    ap.add_argument("--fps", type=float, default=20.0)
    args = ap.parse_args()
    n = args.frames
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "poses.mcap"
        t_write, _ = _write(path, n, args.fps, trace=False)
        size = path.stat().st_size
        t0 = time.perf_counter()
        plog = read_poselog(path)
        t_read = time.perf_counter() - t0
        assert len(plog) == n
        _, mem = _write(path, args.mem_frames, args.fps, trace=True)
    (n1, m1), (n2, m2) = sorted(mem.items())
    per_1k = (m2 - m1) / (n2 - n1) * 1000
    print(f"frames                   {n}")
    print(
        f"write                    {n / t_write:8.0f} frames/s ({1e3 * t_write / n:.3f} ms/frame)"
    )
    print(f"read (indexed)           {n / t_read:8.0f} frames/s")
    print(f"file size                {size / n:8.0f} bytes/frame ({size / 1e6:.1f} MB)")
    print(
        f"writer memory            {m1 / 1e6:.2f} MB after {n1} frames, {m2 / 1e6:.2f} MB after "
        f"{n2}: {per_1k / 1e3:.2f} kB per 1000 frames (MCAP's chunk index)"
    )


if __name__ == "__main__":
    main()
