"""How well the filters search when the likelihood is perfect: the tracker's own body as footage.

``bench/accuracy.py`` scores the tracker on people the synthesiser renders with their own
shapes and clothes, so its error mixes two causes: the silhouette likelihood preferring wrong
poses (the model is not the person) and the filter not finding the likelihood's best pose. This
benchmark removes the first. For each scene of the accuracy benchmark's plan:

1. the tracker's body model (``BodyModel(height_m=stature)``, girth 1.0) is fitted to the true
   key points of every frame (``accuracy.fit_model_to_truth``) and put in floor contact (its
   lowest key point at z = 0, as the tracker's ``floor = contact`` assumes);
2. those poses are rendered with the tracker's own rasteriser as flat-coloured silhouettes over
   the scene's empty-room backgrounds through the scene's cameras (``tracker.synthetic``);
3. the footage is tracked as in the accuracy benchmark (each filter at equal evaluations, given
   the backgrounds and the stature) and scored against the fitted model's key points.

Here the fitted poses are the likelihood's best poses (weight about 0.95; not 1.0 because of
the 640x480 -> 160x120 downscaling and the segmentation), so the error is the search's alone:
the printed "fit outweighs estimate" share of frames says how often the filter's estimate is
lighter than a pose it could have reached. This deliberately scores the tracker on its own
image of itself; it is a diagnostic of the search, never a measure of accuracy (issue 4).

``--exact-body`` also gives the tracker the true shape (girth, part girths and leg length 1.0,
no hem) instead of letting it estimate them.

Run::

    python3 bench/search_ceiling.py                           # oblique and side+frontal, seed 0
    python3 bench/search_ceiling.py --seeds 0,1,2,3 --filters ipf --exact-body
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import accuracy as A  # noqa: E402  (the accuracy benchmark's scenes and tracking loop)

EXACT_BODY = {"init": {"girths": [1.0], "part_girths": [1.0], "leg_lengths": [1.0], "hems": []}}


def ideal_scene(rec: str, view: A.ViewSpec, max_frames: int, seed: int, data: Path):
    """Footage of the tracker's own body fitted to a recording: (frames, masks, backgrounds,
    cameras, fitted poses by frame, the fit's key points as a Trajectory, stature, fps)."""
    from gaitwatch.sim.synth import render_background
    from gaitwatch.trajectory import Trajectory
    from tracker.body import BodyModel
    from tracker.likelihood import SilhouetteLikelihood
    from tracker.synthetic import render_clip

    scene = A.build(rec, view, max_frames, seed, data)
    stature, fps, cams = scene.body.stature_m, scene.config.fps, scene.cameras
    fits = A.fit_model_to_truth(stature, scene.truth, 1)
    frames_idx = sorted(fits)
    body = BodyModel(height_m=stature)
    poses = np.stack([fits[f] for f in frames_idx])
    poses[:, 2] -= np.asarray(body.forward(poses))[:, :, 2].min(axis=1)  # floor contact
    bgs = [np.ascontiguousarray(render_background(scene, i)[..., ::-1]) for i in range(len(cams))]
    renderer = SilhouetteLikelihood(body, cams)
    frames = list(render_clip(renderer, poses, bgs, np.random.default_rng(seed)))
    masks = [
        [A.small_mask(np.asarray(renderer.render_mask(p, c), dtype=bool)) for c in range(len(cams))]
        for p in poses
    ]
    truth = Trajectory(
        positions=np.asarray(body.forward(poses)),
        times=np.array(frames_idx) / fps,
        frames=list(frames_idx),
        fps=fps,
    )
    return frames, masks, bgs, cams, dict(zip(frames_idx, poses, strict=True)), truth, stature, fps


def add_scene_arguments(ap: argparse.ArgumentParser) -> None:
    """The options choosing the ideal scenes (also ``bench/one_step.py``'s)."""
    ap.add_argument("--recordings", help=f"comma list among {', '.join(A.RECORDINGS)}")
    ap.add_argument("--views", default="oblique,side+frontal", help="comma list of view specs")
    ap.add_argument("--seeds", default="0", help="comma list of scene seeds")
    ap.add_argument("--tracker-offset", type=int, default=0, help="tracker seed = scene seed + N")
    ap.add_argument("--max-frames", type=int, default=40)
    ap.add_argument("--data", type=Path, default=A.DATA)


def scene_plan(args: argparse.Namespace) -> tuple[list[str], list[A.ViewSpec], list[int]]:
    """Recordings (default: the accuracy plan's), views and scene seeds of the options."""
    default_recs = list(dict.fromkeys(r for r, _ in A.DEFAULT_PLAN))
    recs = args.recordings.split(",") if args.recordings else default_recs
    views = [A.ViewSpec.parse(v) for v in args.views.split(",")]
    return recs, views, [int(s) for s in args.seeds.split(",")]


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_scene_arguments(ap)
    ap.add_argument("--filters", default=",".join(A.FILTERS), help="comma list of filters")
    ap.add_argument("--exact-body", action="store_true", help="give the tracker the true shape")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if not A.ready(args, "search_ceiling"):
        return 2
    from tqdm import tqdm

    from gaitwatch.evaluation import evaluate

    recs, views, seeds = scene_plan(args)
    filters = args.filters.split(",")
    settings = EXACT_BODY if args.exact_body else None
    rows: dict[tuple[str, str], list[tuple[float, ...]]] = {}
    n = len(recs) * len(views) * len(seeds) * len(filters) * args.max_frames
    with tqdm(total=n, unit="frame", file=sys.stderr) as bar:
        for seed in seeds:
            for rec in recs:
                for view in views:
                    bar.set_description(f"{rec} {view.label} seed {seed}: fit and render")
                    frames, masks, bgs, cams, fits, truth, stature, fps = ideal_scene(
                        rec, view, args.max_frames, seed, args.data
                    )
                    for filt in filters:
                        bar.set_description(f"{rec} {view.label} seed {seed}: {filt}")
                        est, info = A.track(
                            frames, masks, bgs, cams, stature, fps, filt,
                            seed + args.tracker_offset, bar, fits=fits, settings=settings,
                        )  # fmt: skip
                        m = evaluate(truth, est)
                        print(
                            f"{seed} {rec:9s} {view.label:13s} {filt:12s} all {m.mpjpe_mm:6.1f} "
                            f"lower {m.lower_limb_mm:6.1f} knee {m.knee_flexion_rmse_deg:5.1f} "
                            f"| fit weight {info['fit_weight']:.3f}, "
                            f"estimate {info['weight']:.3f}, "
                            f"fit heavier {100 * info['fit_beats_estimate']:.0f}%",
                            file=sys.stderr,
                        )
                        rows.setdefault((view.label, filt), []).append(
                            (
                                m.mpjpe_mm,
                                m.lower_limb_mm,
                                m.knee_flexion_rmse_deg,
                                info["fit_weight"],
                                info["weight"],
                                info["fit_beats_estimate"],
                            )
                        )
    head = [
        "view", "filter", "runs", "all mm", "lower mm", "knee RMSE deg",
        "fit weight", "estimate weight", "fit outweighs estimate",
    ]  # fmt: skip
    table = []
    for (view, filt), vals in rows.items():
        v = np.array(vals)
        mean = v.mean(axis=0)
        table.append(
            [view, filt, str(len(v)), f"{mean[0]:.1f}", f"{mean[1]:.1f}", f"{mean[2]:.1f}"]
            + [f"{mean[3]:.3f}", f"{mean[4]:.3f}", f"{100 * mean[5]:.0f}%"]
        )
    shape = "the true shape given" if args.exact_body else "shape estimated by the tracker"
    print(
        f"Search ceiling: the tracker's own body fitted to the truth as footage ({shape}; "
        f"scene seeds {args.seeds}, tracker seed offset {args.tracker_offset}); errors against "
        "the fitted key points\n"
    )
    print(A.md_table(head, table))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
