"""Scene-synthesis speed: scene preparation and milliseconds per rendered camera frame.

Run: ``python3 bench/sim_speed.py [--frames N] [--size WxH]``. Prints measured figures; asserts
nothing. The motion is the procedural walk; one untimed warm-up frame compiles/loads the numba
rasteriser first. Breaks the per-frame time into body mesh, shadow + person drawing (compose)
and sensor effects (finish).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from gaitwatch.sim.motion import procedural_walk
from gaitwatch.sim.scene import SceneConfig
from gaitwatch.sim.synth import _finish, build_scene, compose, render_frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--size", default="640x480")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    motion = procedural_walk(distance_m=4.0)
    for occluder in ("none", "sofa"):
        cfg = SceneConfig(
            views=["side", "oblique", "frontal"],
            image_size=(w, h),
            max_frames=args.frames,
            room={"occluder": occluder},
        )
        warm = build_scene(motion, cfg.model_copy(update={"max_frames": 1}))
        for _ in render_frames(warm):
            pass
        t0 = time.perf_counter()
        scene = build_scene(motion, cfg)
        t_build = time.perf_counter() - t0
        t_mesh = t_comp = t_fin = 0.0
        rng = np.random.default_rng(0)
        for k in range(scene.n_frames):
            a = time.perf_counter()
            mesh = scene.model.mesh(scene.truth.positions[k])
            t_mesh += time.perf_counter() - a
            for i in range(len(scene.cameras)):
                b = time.perf_counter()
                img, _ = compose(scene, i, k, mesh)
                c = time.perf_counter()
                _finish(scene, img, float(scene.gain[k]), rng)
                t_comp += c - b
                t_fin += time.perf_counter() - c
        n_cf = scene.n_frames * len(scene.cameras)
        print(
            f"{w}x{h}, 3 cameras, occluder {occluder}: scene preparation {t_build:.2f} s; "
            f"per camera frame {1000 * (t_comp + t_fin) / n_cf:.1f} ms "
            f"(compose {1000 * t_comp / n_cf:.1f}, sensor {1000 * t_fin / n_cf:.1f}); "
            f"body mesh {1000 * t_mesh / scene.n_frames:.1f} ms per frame "
            f"({len(mesh.triangles)} triangles)"
        )


if __name__ == "__main__":
    main()
