"""How near the truth the likelihood's own optimum lies, on the accuracy benchmark's footage.

``bench/search_ceiling.py`` asks how well the filters search when the likelihood is perfect
(the tracker's own body as footage). This benchmark asks the other half of the question on the
realistic footage of ``bench/accuracy.py`` (people of other shapes and clothes, the video codec,
the segmentation): if a search found, in every frame, the heaviest pose *near the truth*, how
accurate would the tracker be? For each scene the unchanged tracker runs as in the accuracy
benchmark, and after each frame (the likelihood then holds that frame's silhouettes, the colour
cue's frame and the body the tracker has estimated so far):

1. **truth fit**: the tracker's body is fitted to the true key points (least squares over the
   31 DOF within the tracker's joint limits, ``accuracy.fit_pose``): the pose nearest the truth
   that the body can take;
2. **nearest optimum**: from the truth fit the weight is climbed by a wide deterministic
   coordinate search of the whole pose (:func:`tracker.refine.refine_pose` with the root, four
   levels, two sweeps; :data:`CLIMB`): the likelihood's local optimum nearest the truth;
3. **estimate climbed**: the tracker's estimate is climbed by the same search, so that the
   truth's basin and the tracker's are compared at their optima;
4. the four poses are weighed with the tracker's weight (silhouette and colour cue).

The key points of the truth fit, the nearest optimum and the estimate climbed go through the
tracker's output
stage (leg labels, smoothing, one camera's depth stage: ``tracker.output.written_keypoints``)
and are scored against the truth like the tracker's own written key points. The
nearest-optimum error is what a search that always found the likelihood's best pose in the
truth's basin would write: the part of the error that no better search can remove and only a
better likelihood (or body model) can. It is not a strict bound (a search that stops short of
an optimum can land nearer the truth or farther), and where the estimate outweighs the nearest
optimum the likelihood prefers a pose farther from the truth outright.

Run::

    python3 bench/likelihood_ceiling.py --seeds 0,1,2 --direct      # the default plan, IPF
    python3 bench/likelihood_ceiling.py --recordings 07_06 --views oblique --max-frames 12
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import accuracy as A  # noqa: E402  (the accuracy benchmark's scenes and tracking loop)

#: The wide local search climbing from the truth fit (``tracker.config.RefineConfig`` fields).
CLIMB = {
    "enabled": True,
    "offsets": 4,
    "levels": 4,
    "shrink": 0.5,
    "sweeps": 2,
    "range_flexion_deg": 20.0,
    "range_leg_deg": 12.0,
    "range_upper_deg": 12.0,
    "root": True,
    "range_root_m": 0.10,
    "range_root_deg": 10.0,
}


@dataclass
class CeilingProbe:
    """Called after each frame by ``accuracy.track``: fits the tracker's body to the truth,
    climbs the weight from there and from the estimate, and keeps the three poses' key points
    and the four weights."""

    truth: object  # gaitwatch.trajectory.Trajectory
    climb: object  # tracker.config.RefineConfig
    frames: list[int] = field(default_factory=list)
    fit_pts: list[np.ndarray] = field(default_factory=list)
    opt_pts: list[np.ndarray] = field(default_factory=list)
    climbed_pts: list[np.ndarray] = field(default_factory=list)
    #: per frame: estimate, truth fit, nearest optimum, estimate climbed
    weights: list[tuple[float, float, float, float]] = field(default_factory=list)
    _row: dict[int, int] = field(default_factory=dict)
    _x: np.ndarray | None = None

    def __post_init__(self) -> None:
        self._row = {int(f): i for i, f in enumerate(self.truth.frames)}

    def __call__(self, tr, k: int, res) -> None:
        from tracker.refine import refine_pose

        i = self._row.get(k)
        if i is None or not res.has_pose:
            return
        target = self.truth.positions[i]
        if not np.isfinite(target).all():
            return
        lik = tr.likelihood
        body = lik.body
        x0 = A.start_pose(body, self.truth, i) if self._x is None else self._x
        fit = A.fit_pose(body, target, x0, tr.limits)
        self._x = fit
        w = np.asarray(lik.weights(np.stack([res.pose, fit])), dtype=np.float64)
        opt = refine_pose(lik, fit, float(w[1]), self.climb, limits=tr.limits)
        up = refine_pose(lik, res.pose, float(w[0]), self.climb, limits=tr.limits)
        self.frames.append(k)
        self.fit_pts.append(np.asarray(body.forward(fit[None]))[0])
        self.opt_pts.append(np.asarray(body.forward(opt.pose[None]))[0])
        self.climbed_pts.append(np.asarray(body.forward(up.pose[None]))[0])
        self.weights.append((float(w[0]), float(w[1]), float(opt.weight), float(up.weight)))

    def written(self, which: str, cfg, fps: float, cams):
        """The ``which`` ('fit', 'opt' or 'climbed') key points as a Trajectory, through the
        tracker's output stage."""
        from gaitwatch.trajectory import Trajectory
        from tracker.output import written_keypoints
        from tracker.smoothing import single_camera_eye

        series = {"fit": self.fit_pts, "opt": self.opt_pts, "climbed": self.climbed_pts}
        pts = np.stack(series[which])
        frames = np.array(self.frames)
        times = frames / fps
        restarts = np.zeros(len(frames), dtype=bool)
        eye = single_camera_eye(cams)
        pts = written_keypoints(times, pts, cfg, fps, restarts, frames=frames, eye=eye)
        return Trajectory(positions=pts, times=times, frames=list(self.frames), fps=fps)


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--recordings", help=f"comma list among {', '.join(A.RECORDINGS)} (with --views)"
    )
    ap.add_argument("--views", help="comma list of view specs (default: the accuracy plan)")
    ap.add_argument("--filter", default="ipf", help=f"one of {', '.join(A.FILTER_VARIANTS)}")
    ap.add_argument("--seeds", default="0", help="comma list of scene seeds")
    ap.add_argument("--tracker-offset", type=int, default=0, help="tracker seed = scene seed + N")
    ap.add_argument("--max-frames", type=int, default=40)
    ap.add_argument("--direct", action="store_true", help="track rendered frames (no video codec)")
    ap.add_argument("--data", type=Path, default=A.DATA, help="the shared recordings folder")
    ap.add_argument(
        "--config",
        type=Path,
        help="tracker settings file (TOML or YAML, as for gaitwatch track) under the filter",
    )
    args = ap.parse_args(argv)
    if args.filter not in A.FILTER_VARIANTS:
        ap.error(f"unknown filter {args.filter!r}")
    if args.max_frames < 2:
        ap.error("--max-frames must be at least 2")
    try:
        args.seed_list = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        ap.error(f"--seeds must be a comma list of integers, not {args.seeds!r}")
    return args


#: The window (s) over which the nearest optimum's and the climbed estimate's weights are summed.
WINDOW_S = 0.5


def window_share(diff: np.ndarray, n: int) -> float:
    """Share of the windows of ``n`` consecutive frames (all of them, sliding by one) over which
    ``diff`` (per frame) sums above zero; NaN when there are fewer than ``n`` frames."""
    if diff.size < n:
        return float("nan")
    sums = np.convolve(diff, np.ones(n), mode="valid")
    return float(np.mean(sums > 0))


#: The scored key points: the tracker's written ones, then the probe's (CeilingProbe.written).
SERIES = (
    ("tracker", None),
    ("truth fit", "fit"),
    ("nearest optimum", "opt"),
    ("estimate climbed", "climbed"),
)


def mean_row(label: str, vals: list[tuple[float, ...]]) -> list[str]:
    """A table row: the mean over runs of every series' (all mm, lower mm, knee deg), the four
    weights, the nearest optimum's share of frames heavier than the estimate and than the
    estimate climbed, and its share of :data:`WINDOW_S` windows heavier than the climbed one."""
    v = np.nanmean(np.array(vals, dtype=np.float64), axis=0)
    n = 3 * len(SERIES)
    errs = [f"{v[j]:.0f} / {v[j + 1]:.0f} / {v[j + 2]:.1f}" for j in range(0, n, 3)]
    weights = " / ".join(f"{x:.3f}" for x in v[n : n + 4])
    return [label, str(len(vals)), *errs, weights,
            *(f"{100 * x:.0f}%" for x in v[n + 4 : n + 7])]  # fmt: skip


HEAD = [
    "cameras / view",
    "runs",
    *(f"{name}: all / lower mm / knee deg" for name, _ in SERIES),
    "weight: estimate / fit / optimum / climbed",
    "optimum outweighs estimate",
    "optimum outweighs climbed",
    f"optimum outweighs climbed over {WINDOW_S} s",
]


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    if not A.ready(args, "likelihood_ceiling"):
        return 2
    from tqdm import tqdm

    from gaitwatch.evaluation import evaluate
    from tracker.config import RefineConfig, TrackerConfigError

    try:
        settings = A.tracker_settings(args.config)
    except TrackerConfigError as err:
        print(f"likelihood_ceiling: {err}", file=sys.stderr)
        return 2
    if (settings or {}).get("ensemble", {}).get("tracks", 1) != 1:
        print("likelihood_ceiling: one track only (no [ensemble] tracks)", file=sys.stderr)
        return 2
    climb = RefineConfig.model_validate(CLIMB)
    cfg = A.variant_config(args.filter, settings)
    plan = A.make_plan(args)
    rows: dict[str, list[tuple[float, ...]]] = {}
    n = len(args.seed_list) * len(plan) * args.max_frames
    with (
        tqdm(total=n, unit="frame", file=sys.stderr) as bar,
        tempfile.TemporaryDirectory(prefix="gaitwatch-ceiling-") as tmpd,
    ):
        for seed in args.seed_list:
            for si, (rec, view) in enumerate(plan):
                bar.set_description(f"{rec} {view.label} seed {seed}: rendering")
                scene = A.build(rec, view, args.max_frames, seed, args.data)
                frames, masks, bgs, cams, truth = A.scene_frames(
                    scene, args.direct, Path(tmpd) / f"s{seed}-{si}"
                )
                fps = scene.config.fps
                probe = CeilingProbe(truth, climb)
                bar.set_description(f"{rec} {view.label} seed {seed}")
                est, _ = A.track(
                    frames, masks, bgs, cams, scene.body.stature_m, fps, args.filter,
                    seed + args.tracker_offset, bar, settings=settings, probe=probe,
                )  # fmt: skip
                if not probe.frames:
                    print(f"{seed} {rec} {view.label}: no tracked frame", file=sys.stderr)
                    continue
                scores = []
                for _, which in SERIES:
                    traj = est if which is None else probe.written(which, cfg, fps, cams)
                    m = evaluate(truth, traj)
                    scores += [m.mpjpe_mm, m.lower_limb_mm, m.knee_flexion_rmse_deg]
                w = np.array(probe.weights)
                shares = (
                    np.mean(w[:, 2] > w[:, 0]),
                    np.mean(w[:, 2] > w[:, 3]),
                    window_share(w[:, 2] - w[:, 3], max(1, round(WINDOW_S * fps))),
                )
                vals = (*scores, *w.mean(axis=0), *shares)
                label = f"{len(cams)} / {view.label}"
                rows.setdefault(label, []).append(vals)
                rows.setdefault(f"{len(cams)} camera(s), all views", []).append(vals)
                print(
                    f"{seed} {rec:9s} {view.label:14s} all / lower mm: "
                    + ", ".join(
                        f"{name} {scores[3 * j]:.0f} / {scores[3 * j + 1]:.0f}"
                        for j, (name, _) in enumerate(SERIES)
                    )
                    + "; weights "
                    + " / ".join(f"{x:.3f}" for x in w.mean(axis=0))
                    + f"; optimum heavier than estimate {100 * shares[0]:.0f}%, than climbed "
                    f"{100 * shares[1]:.0f}% (over {WINDOW_S} s {100 * shares[2]:.0f}%)",
                    file=sys.stderr,
                )
    table = [mean_row(label, vals) for label, vals in sorted(rows.items())]
    print(
        f"Likelihood ceiling ({args.filter}; scene seeds {args.seeds}, tracker seed offset "
        f"{args.tracker_offset}; {args.max_frames} frames; "
        f"{'rendered straight' if args.direct else 'through the video codec'}): the "
        "tracker's written key points, and the truth fit and the nearest optimum through the "
        "same output stage, against the truth (mean over runs)\n"
    )
    print(A.md_table(HEAD, table))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
