"""Benchmark of the silhouette likelihood: fast numba path vs the OpenCV reference.

Prints, in one run: particle evaluations per second at 160x120 and 320x240 on 1 and 2 threads
(one evaluation = one pose weighed against every camera; figures for 1 and 3 cameras), the same
for the OpenCV reference (plain drawing, ``supersample=1``) and the ratio; ``weights_factored``
evaluations per second (M * A * B poses, A = B = 9 as in IPF with q = 3, n = 4); and numba's
first-call compile time in a fresh cache directory, then again with that cache filled.

Run: ``python3 bench/likelihood.py [--quick]``. Figures are wall-clock, best of 3 repetitions;
the machine load is printed alongside because shared machines make them noisy.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

_COMPILE_SNIPPET = """
import time
t0 = time.perf_counter()
import numpy as np
from tracker.body import BodyModel
from tracker.camera import Camera
from tracker.likelihood import SilhouetteLikelihood
t1 = time.perf_counter()
body = BodyModel()
cam = Camera.look_at(name="c", position=[4, 0, 1.5], target=[0, 0, 0.9]).scaled(160, 120)
lik = SilhouetteLikelihood(body, [cam])
pose = body.neutral_pose()
lik.set_silhouettes([lik.render_mask(pose, 0)])
lik.weights(pose)
lik.weights_factored(pose[None], np.zeros((1, 2, 6)), np.zeros((1, 2, 6)))
t2 = time.perf_counter()
print(f"{t1 - t0:.2f} {t2 - t1:.2f}")
"""


def _best(fn, reps: int = 3) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """(best wall-clock seconds, best CPU seconds of this process, all threads) over reps."""
    wall = cpu = np.inf
    for _ in range(reps):
        t, c = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t)
        cpu = min(cpu, time.process_time() - c)
    return wall, cpu


def _scene(width: int, height: int, n_cams: int):  # type: ignore[no-untyped-def]
    from tracker.camera import Camera

    places = [
        ([4.5, 0.5, 1.6], ()),
        ([0.3, -4.0, 2.2], ()),
        ([-3.0, 3.0, 2.5], (-0.2, 0.05, 0.0, 0.0)),
    ]
    cams = []
    for i, (pos, dist) in enumerate(places[:n_cams]):
        cam = Camera.look_at(name=f"cam{i}", position=pos, target=[0, 0, 0.9], dist=dist)
        cams.append(cam.scaled(width, height))
    return cams


def _poses(body, rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    from tracker.dof import DOF, N_DOF, JointLimits, clamp

    true = body.neutral_pose(x=0.1, y=0.0, yaw=0.3)
    for name, deg in (("l_hip_flexion", 20), ("r_hip_flexion", -10), ("r_knee_flexion", 30)):
        true[DOF[name]] = np.radians(deg)
    poses = np.repeat(true[None], n, axis=0)
    poses[:, 3:] += rng.normal(0, np.radians(5), (n, N_DOF - 3))
    poses[:, :3] += rng.normal(0, 0.03, (n, 3))
    lo, hi = JointLimits.profile("walking").arrays()
    clamp(poses, lo, hi)
    return true, poses


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller batches")
    args = ap.parse_args()

    import cv2
    import numba

    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.render_ref import counts_reference, render_reference

    cv2.setNumThreads(1)
    rng = np.random.default_rng(0)
    body = BodyModel(1.70)
    n_fast = 5_000 if args.quick else 20_000
    n_ref = 100 if args.quick else 300
    max_threads = numba.config.NUMBA_NUM_THREADS
    print(
        f"# gaitwatch likelihood benchmark  (cpus={os.cpu_count()}, numba threads available "
        f"{max_threads}, load average {os.getloadavg()[0]:.2f})"
    )
    print("# one evaluation = one pose weighed against every camera; best of 3, wall clock")
    print("# 'per CPU-s' = evaluations per CPU-second of this process (all threads): what one")
    print("# idle core would do; on a loaded machine the wall-clock figures fall behind it")

    # -- compile time: fresh cache, then the same cache again --------------------------------
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(REPO)}
        for label in ("first run (empty cache)", "second run (cache filled)"):
            out = subprocess.run(
                [sys.executable, "-c", _COMPILE_SNIPPET],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            ).stdout.split()
            print(f"numba first call, {label}: {float(out[1]):6.2f} s  (imports {out[0]} s)")

    print()
    print(
        f"{'resolution':>10} {'cams':>4} {'threads':>7} {'fast evals/s':>13} "
        f"{'cam-evals/s':>12} {'reference evals/s':>17} {'ratio':>7} {'per CPU-s':>12}"
    )
    for width, height in ((160, 120), (320, 240)):
        for n_cams in (1, 3):
            cams = _scene(width, height, n_cams)
            true, poses = _poses(body, rng, n_fast)
            sils = [render_reference(body, true, c, supersample=1) for c in cams]
            lik = SilhouetteLikelihood(body, cams)
            lik.set_silhouettes(sils)
            lik.weights(poses[:64])
            t_ref, _ = _best(
                lambda c=cams, s=sils, p=poses: counts_reference(body, c, s, p[:n_ref], 1), reps=1
            )
            ref_rate = n_ref / t_ref
            for threads in (1, 2):
                if threads > max_threads:
                    continue
                numba.set_num_threads(threads)
                t, cpu = _best(lambda lk=lik, p=poses: lk.weights(p))
                rate = n_fast / t
                print(
                    f"{width}x{height:<4} {n_cams:>4} {threads:>7} {rate:13,.0f} "
                    f"{rate * n_cams:12,.0f} {ref_rate:17,.0f} {rate / ref_rate:6.0f}x "
                    f"{n_fast / cpu:12,.0f}"
                )
            numba.set_num_threads(max_threads)

    # -- weights_factored --------------------------------------------------------------------
    print()
    print(
        f"{'resolution':>10} {'cams':>4} {'threads':>7} {'factored evals/s':>17} "
        f"{'per CPU-s':>12}  (M x 9 x 9)"
    )
    m = 200 if args.quick else 2000
    for width, height in ((160, 120), (320, 240)):
        for n_cams in (1, 3):
            cams = _scene(width, height, n_cams)
            true, base = _poses(body, rng, m)
            lik = SilhouetteLikelihood(body, cams)
            lik.set_silhouettes([render_reference(body, true, c, supersample=1) for c in cams])
            left = base[:, None, 19:25] + rng.normal(0, 0.05, (m, 9, 6))
            right = base[:, None, 25:31] + rng.normal(0, 0.05, (m, 9, 6))
            lik.weights_factored(base[:2], left[:2], right[:2])
            for threads in (1, 2):
                if threads > max_threads:
                    continue
                numba.set_num_threads(threads)
                t, cpu = _best(
                    lambda lk=lik, b=base, le=left, r=right: lk.weights_factored(b, le, r)
                )
                print(
                    f"{width}x{height:<4} {n_cams:>4} {threads:>7} {m * 81 / t:17,.0f} "
                    f"{m * 81 / cpu:12,.0f}"
                )
            numba.set_num_threads(max_threads)
    print(f"# load average at the end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
