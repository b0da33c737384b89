"""One step of the tracker from the truth, on footage of its own body (a search diagnostic).

``bench/search_ceiling.py`` tracks whole clips of the tracker's own body fitted to the truth
(the likelihood's best pose is the truth) and finds the estimate far lighter than the truth.
This benchmark asks how much of that one frame loses: before every frame t >= 1 the tracker's
state (its particles, previous pose and key points, root velocity) is reset to the fitted pose
of frame t-1, then the unchanged pipeline processes frame t. Per view it prints:

* the weights of the fitted pose of frame t and of the estimate;
* the estimate's error against the fitted key points (all joints and lower limbs, mm);
* the mean weight along the straight line in pose space from the estimate to the truth (at 0,
  1/2 and 1) and the share of frames where that line never dips below the estimate's weight by
  more than 0.005: when it rises all the way, the truth lies in the estimate's basin and a
  better local search could reach it.

Like the search ceiling, it scores the tracker on its own image of itself: a diagnostic of the
search, never a measure of accuracy. It resets private tracker state (``Tracker.filter``,
``prev_pose``, ``velocity_xy``): a benchmark, not an API. The shape is given (girth, part
girths and leg length 1.0), so only the search is measured.

Run::

    python3 bench/one_step.py --seeds 0 [--views oblique,side+frontal] [--settings '{"arms":
        {"enabled": true}}']
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import accuracy as A  # noqa: E402
from search_ceiling import (  # noqa: E402
    EXACT_BODY,
    add_scene_arguments,
    ideal_scene,
    scene_plan,
)

#: Points along the line from the estimate (0) to the truth (1).
LINE = np.linspace(0.0, 1.0, 11)


def _merge(base: dict, extra: dict) -> dict:
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in base.items()}
    for k, v in extra.items():
        out[k] = {**out.get(k, {}), **v} if isinstance(v, dict) else v
    return out


def one_step_scene(frames, bgs, cams, fits, stature, fps, seed: int, settings: dict) -> list:
    """Per frame t >= 1: (truth weight, estimate weight, error all mm, error lower mm, line
    weights (11,))."""
    from gaitwatch.evaluation import LOWER_LIMB
    from tracker.pipeline import Tracker

    lower = list(LOWER_LIMB)
    cfg = A.variant_config("ipf", _merge(EXACT_BODY, settings))
    tr = Tracker(cams, cfg, rng=np.random.default_rng(seed), height_m=stature, backgrounds=bgs)
    order = sorted(fits)
    poses = np.stack([fits[f] for f in order])
    dt = 1.0 / fps
    rows = []
    for k, imgs in enumerate(frames):
        if k >= len(poses):
            break
        if k >= 1:
            prev = poses[k - 1]
            tr.need_init = False
            tr.filter.initialise(np.repeat(prev[None], 4, axis=0), np.ones(4))
            tr.prev_pose = prev.copy()
            tr._prev_joints = np.asarray(tr.body.forward(prev[None]))[0]
            if k >= 2:
                tr.velocity_xy = (prev[:2] - poses[k - 2][:2]) / dt
        res = tr.process(k, k * dt, imgs)
        if k == 0 or res.pose is None:
            continue
        truth, est = poses[k], res.pose
        w = tr.likelihood.weights(np.stack([truth, est]))
        line = tr.likelihood.weights(est[None] + LINE[:, None] * (truth - est)[None])
        d = np.linalg.norm(tr.body.forward(est[None])[0] - tr.body.forward(truth[None])[0], axis=1)
        rows.append((w[0], w[1], 1000 * d.mean(), 1000 * d[lower].mean(), line))
    return rows


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_scene_arguments(ap)
    ap.add_argument("--settings", default="{}", help="tracker settings as JSON (merged)")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if not A.ready(args, "one_step"):
        return 2
    try:
        settings = json.loads(args.settings)
    except json.JSONDecodeError as e:
        print(f"one_step: --settings is not JSON: {e}", file=sys.stderr)
        return 2
    from tqdm import tqdm

    recs, views, seeds = scene_plan(args)
    rows: dict[str, list] = {}
    with tqdm(total=len(recs) * len(views) * len(seeds), unit="scene", file=sys.stderr) as bar:
        for seed in seeds:
            for rec in recs:
                for view in views:
                    bar.set_description(f"{rec} {view.label} seed {seed}")
                    frames, _, bgs, cams, fits, _, stature, fps = ideal_scene(
                        rec, view, args.max_frames, seed, args.data
                    )
                    rows.setdefault(view.label, []).extend(
                        one_step_scene(
                            frames,
                            bgs,
                            cams,
                            fits,
                            stature,
                            fps,
                            seed + args.tracker_offset,
                            settings,
                        )  # fmt: skip
                    )
                    bar.update(1)
    head = [
        "view", "frames", "truth weight", "estimate weight", "error all mm", "error lower mm",
        "line 0 / 0.5 / 1", "line rises",
    ]  # fmt: skip
    table = []
    for view, vals in rows.items():
        wt = np.array([r[0] for r in vals])
        we = np.array([r[1] for r in vals])
        line = np.stack([r[4] for r in vals])
        rises = np.mean(line.min(axis=1) >= line[:, 0] - 0.005)
        table.append(
            [
                view,
                str(len(vals)),
                f"{wt.mean():.3f}",
                f"{we.mean():.3f}",
                f"{np.mean([r[2] for r in vals]):.1f}",
                f"{np.mean([r[3] for r in vals]):.1f}",
                " / ".join(f"{line[:, i].mean():.3f}" for i in (0, len(LINE) // 2, -1)),
                f"{100 * rises:.0f}%",
            ]
        )
    print(
        f"One step from the truth: the tracker's own body fitted to the truth as footage (shape "
        f"given; scene seeds {args.seeds}, tracker seed offset {args.tracker_offset}, settings "
        f"{json.dumps(settings)})\n"
    )
    print(A.md_table(head, table))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
