"""The 2D key-point cue on the accuracy benchmark's scenes, paired with the tracker without it.

For each scene of the plan (``bench/accuracy.py``'s scenes, rendered straight to the tracker
unless ``--codec``), every camera's frames are given to a 2D pose detector run in another
interpreter (``--detector-python``; ``bench/keypoints_mediapipe.py``, which needs MediaPipe and
so NumPy < 2, hence not gaitwatch's own environment), and the scene is tracked twice with the
same seeds: with the defaults (or ``--base-config``; since session 36 the defaults run the cue
with the built-in detector, ``--base-config bench/configs/no-keypoints.toml`` leaves the cue
out) and with the key-point cue on (the defaults of ``[keypoints]``, or ``--config``), the
outside detector's detections given per frame. Prints each
run's errors and the paired differences (cue minus base, mean +- standard error) per camera
count and view. Also prints how far the detector's leg points lie from the true key points
projected (per view: median over frames of the mean distance under the better assignment of
the legs, as a share of the person's height in the image, and how often its leg labels are
exchanged).

Run::

    python3 -m venv /tmp/mediapipe && /tmp/mediapipe/bin/pip install mediapipe==0.10.21
    python3 bench/keypoint_cue.py --detector-python /tmp/mediapipe/bin/python --seeds 0,1
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import accuracy as A  # noqa: E402

LEGS = (11, 12, 13, 14, 15, 16, 17, 18)  # knees, ankles, heels, toes (left, right alternating)
EXCHANGED = (12, 11, 14, 13, 16, 15, 18, 17)


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--detector-python", type=Path, required=True, help="the detector's interpreter"
    )
    ap.add_argument("--detector", type=Path, default=A.DETECTOR, help="the detection script")
    ap.add_argument("--recordings", help="comma list (with --views; default: the accuracy plan)")
    ap.add_argument("--views", help="comma list of view specs")
    ap.add_argument("--seeds", default="0", help="comma list of scene seeds")
    ap.add_argument("--tracker-offset", type=int, default=900, help="tracker seed = scene seed + N")
    ap.add_argument("--max-frames", type=int, default=40)
    ap.add_argument("--codec", action="store_true", help="through the video codec (default: not)")
    ap.add_argument("--config", type=Path, help="settings of the cue's run (default: the cue on)")
    ap.add_argument("--base-config", type=Path, help="settings of the base run (default: none)")
    ap.add_argument("--data", type=Path, default=A.DATA, help="the shared recordings folder")
    args = ap.parse_args(argv)
    try:
        args.seed_list = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        ap.error(f"--seeds must be a comma list of integers, not {args.seeds!r}")
    return args


def detector_error(dets: list[np.ndarray], truth, cams) -> tuple[float, float]:
    """Median share of the person's image height between the detected and the true leg
    points (better assignment of the legs), and the share of frames with the labels
    exchanged, over cameras and frames."""
    errs, swapped = [], []
    for cam, det in zip(cams, dets, strict=True):
        n = min(len(det), len(truth))
        uv = cam.project(truth.positions[:n])
        height = uv[:, :, 1].max(axis=1) - uv[:, :, 1].min(axis=1)
        for t in range(n):
            d = det[t, :, :2]
            if not np.isfinite(d[list(LEGS)]).all():
                continue
            same = np.linalg.norm(d[list(LEGS)] - uv[t, list(LEGS)], axis=1).mean()
            other = np.linalg.norm(d[list(EXCHANGED)] - uv[t, list(LEGS)], axis=1).mean()
            errs.append(min(same, other) / height[t])
            swapped.append(other < same)
    return float(np.median(errs)) if errs else float("nan"), float(np.mean(swapped or [np.nan]))


def paired(rows: list[tuple], label: str) -> str:
    """One line of paired differences (cue - base) over ``rows`` of (base, cue) scores."""
    b = np.array([r[0] for r in rows])
    c = np.array([r[1] for r in rows])
    d = c - b
    se = d.std(axis=0, ddof=1) / np.sqrt(len(d)) if len(d) > 1 else np.zeros(3)
    cells = [
        f"{b[:, j].mean():.1f} -> {c[:, j].mean():.1f} ({d[:, j].mean():+.1f} +- {se[j]:.1f})"
        for j in range(3)
    ]
    better = int((d[:, 0] < 0).sum())
    return f"| {label} | {len(rows)} | " + " | ".join(cells) + f" | {better} / {len(rows)} |"


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if not A.ready(args, "keypoint_cue"):
        return 2
    from tqdm import tqdm

    from gaitwatch.evaluation import evaluate
    from tracker.config import TrackerConfigError

    try:
        base_settings = A.tracker_settings(args.base_config)
        cue_settings = A.tracker_settings(args.config) or {"keypoints": {"enabled": True}}
    except TrackerConfigError as err:
        print(f"keypoint_cue: {err}", file=sys.stderr)
        return 2
    if not A.variant_config("ipf", cue_settings).keypoints.enabled:
        print("keypoint_cue: the cue's settings do not enable [keypoints]", file=sys.stderr)
        return 2
    plan = A.make_plan(args)
    groups: dict[str, list[tuple]] = {}
    det_err: dict[str, list[tuple[float, float]]] = {}
    bar = tqdm(total=2 * len(plan) * len(args.seed_list) * args.max_frames, file=sys.stderr)
    with tempfile.TemporaryDirectory(prefix="gaitwatch-keypoints-") as tmpd:
        for seed in args.seed_list:
            for si, (rec, view) in enumerate(plan):
                work = Path(tmpd) / f"s{seed}-{si}"
                work.mkdir()
                scene = A.build(rec, view, args.max_frames, seed, args.data)
                frames, masks, bgs, cams, truth = A.scene_frames(scene, not args.codec, work)
                bar.set_description(f"{rec} {view.label} seed {seed}: detecting")
                dets = A.detect_keypoints(args.detector_python, args.detector, frames, work)
                det_err.setdefault(view.label, []).append(detector_error(dets, truth, cams))
                per_frame = A.per_frame_keypoints(dets, len(frames))
                scores = []
                for settings, kps in ((base_settings, None), (cue_settings, per_frame)):
                    bar.set_description(f"{rec} {view.label} seed {seed}")
                    est, _ = A.track(
                        frames, masks, bgs, cams, scene.body.stature_m, scene.config.fps,
                        "ipf", seed + args.tracker_offset, bar, settings=settings, keypoints=kps,
                    )  # fmt: skip
                    m = evaluate(truth, est)
                    scores.append((m.mpjpe_mm, m.lower_limb_mm, m.knee_flexion_rmse_deg))
                print(
                    f"{seed} {rec:9s} {view.label:14s} all / lower mm, knee deg: base "
                    f"{scores[0][0]:.0f} / {scores[0][1]:.0f}, {scores[0][2]:.1f}; cue "
                    f"{scores[1][0]:.0f} / {scores[1][1]:.0f}, {scores[1][2]:.1f}",
                    file=sys.stderr,
                )
                for label in (f"{len(cams)} / {view.label}", f"{len(cams)} camera(s)", "all"):
                    groups.setdefault(label, []).append(tuple(scores))
    bar.close()
    print(
        f"2D key-point cue minus base (IPF; scene seeds {args.seeds}, tracker seed offset "
        f"{args.tracker_offset}; {args.max_frames} frames; "
        f"{'through the video codec' if args.codec else 'rendered straight'})\n"
    )
    print("| cameras / view | runs | all mm | lower mm | knee RMSE deg | cue better |")
    print("|---|---|---|---|---|---|")
    for label in sorted(groups):
        print(paired(groups[label], label))
    print("\n| view | detector's leg points off (median, share of height) | labels exchanged |")
    print("|---|---|---|")
    for label, vals in sorted(det_err.items()):
        e = np.array(vals)
        off, exchanged = 100 * np.nanmedian(e[:, 0]), 100 * np.nanmean(e[:, 1])
        print(f"| {label} | {off:.1f} % | {exchanged:.0f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
