"""Gait parameters from video against the same analysis of the true key points (end to end).

``bench/gait_accuracy.py`` measures the gait analysis on laboratory markers with added white
noise; ``bench/accuracy.py`` measures the tracker's key points. Neither says what a caregiver
gets: gait parameters computed from tracked video, whose errors are not white (legs swapped for
a few frames, a depth slide, knees bent too far). Here each shared walk is rendered as in the
accuracy benchmark (the same scenes, bodies, clothes and cameras: ``accuracy.build``), but over
the whole recording, tracked by the default tracker (``accuracy.track``: the key points as
``gaitwatch track`` writes them, leg labels and smoothing included), and both the tracked key
points and the true key points at the same frame rate go through ``gait.analysis.analyse`` with
the same settings, except the key points' source: the truth is analysed as laboratory markers
(``source = "markers"``, the event calibration chosen against force plates), the tracked
key points as video (the default). The difference is the error tracking adds to the gait
parameters.

Per scene it prints the strides found (truth / video), the heel-strike and toe-off timing
(median absolute and, in brackets, median signed error of the matched events, ms; events of
the truth's analysis with no video event of the same foot and type within 0.2 s count as
missed, video events matched to none as extra), walking speed, cadence and stride length over
the matched strides (relative error, %; ``gait.evaluation.parameter_errors_pct``), and the
recording summaries' stance and double support (percentage points), step width (mm) and knee
range of motion and peak swing flexion (degrees), and the transfers (sit-to-stand,
stand-to-sit) of both analyses matched by type and start within 1 s, with the median start and
duration errors; then the medians of the absolute errors (and of the signed event errors) per
gait and camera set. ``--recordings 75_19`` (CMU: sits down and stands up twice) measures the
transfers.

The recordings are short (2.4-6 s, 1-4 strides each), so one scene's parameters rest on one
or two strides: read the medians, not single rows.

Run::

    python3 bench/gait_video.py                         # walks and crouch gait, 2 views, seed 0
    python3 bench/gait_video.py --recordings 07_06,newwalk --views oblique --seed 1 --no-out
"""

from __future__ import annotations

import argparse
import math
import shlex
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parent))
import accuracy as A  # noqa: E402  (the accuracy benchmark's scenes and tracking loop)

from gait.analysis import GaitConfig, analyse  # noqa: E402
from gait.evaluation import match_events, parameter_errors_pct  # noqa: E402
from gait.filtering import GaitInputError  # noqa: E402
from gaitwatch.evaluation import evaluate  # noqa: E402
from gaitwatch.trajectory import Trajectory, write_joints_csv  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DEFAULT_RECORDINGS = (
    "07_04",
    "07_06",
    "16_18",
    "ma-walk1",
    "rajagopal",
    "newwalk",
    *A.PATHOLOGICAL,
)
DEFAULT_VIEWS = ("oblique", "side+frontal")
EVENT_TOLERANCE_S = 0.2
#: A video transfer matches a true one of the same type starting within this time (s).
TRANSFER_TOLERANCE_S = 1.0

#: Summary fields compared as differences: (label, getter, scale, unit)
SUMMARY_FIELDS = (
    ("stance", lambda s: s.stance_pct, 1.0, "pp"),
    ("double support", lambda s: s.double_support_pct, 1.0, "pp"),
    ("step width", lambda s: s.step_width_m, 1000.0, "mm"),
    ("knee ROM", lambda s: s.kinematics.knee_rom_deg, 1.0, "deg"),
    ("knee peak swing", lambda s: s.kinematics.knee_peak_swing_flexion_deg, 1.0, "deg"),
)
PCT_FIELDS = (
    ("speed", "walking_speed_m_s"),
    ("cadence", "cadence_steps_min"),
    ("stride length", "stride_length_m"),
)


@dataclass
class SceneResult:
    recording: str
    view: str
    all_mm: float = math.nan
    strides_truth: int = 0
    strides_video: int = 0
    matched: int = 0
    hs_ms: float = math.nan
    to_ms: float = math.nan
    hs_bias_ms: float = math.nan
    to_bias_ms: float = math.nan
    missed: int = 0
    extra: int = 0
    pct: dict[str, float] = field(default_factory=dict)
    diff: dict[str, float] = field(default_factory=dict)
    error: str = ""
    ncams: int = 1
    transfers_truth: int = 0
    transfers_video: int = 0
    transfers_matched: int = 0
    transfer_start_ms: float = math.nan  # median |start error| of the matched transfers
    transfer_duration_ms: float = math.nan  # median |duration error|

    @property
    def gait(self) -> str:
        if self.recording in A.TRANSFERS:
            return "transfers"
        return "crouch" if self.recording in A.PATHOLOGICAL else "walk"


def _value(x) -> float:
    return math.nan if x is None else float(x)


def compare(
    truth: Trajectory,
    video: Trajectory,
    config: GaitConfig,
    reference: GaitConfig | None = None,
) -> SceneResult:
    """Gait analysis of both trajectories and their differences (recording and view unset).

    ``config`` analyses the tracked key points; ``reference`` (default: ``config`` with
    ``source = "markers"``, the calibration for laboratory markers) the true ones.
    """
    res = SceneResult("", "")
    if len(video) == 0:
        res.error = "no pose"
        return res
    res.all_mm = evaluate(truth, video).mpjpe_mm
    if reference is None:
        reference = config.model_copy(update={"source": "markers"})
    ref = analyse(truth, reference)
    try:
        est = analyse(video, config)
    except GaitInputError as err:
        res.error = str(err)
        return res
    compare_transfers(ref.transfers, est.transfers, res)
    res.strides_truth, res.strides_video = len(ref.strides), len(est.strides)
    ref_events = [e.model_dump() for e in ref.events]
    ev = match_events(est.events, ref_events, EVENT_TOLERANCE_S)
    res.hs_ms, res.to_ms = ev.median_abs_ms("heel_strike"), ev.median_abs_ms("toe_off")
    res.hs_bias_ms, res.to_bias_ms = (
        1000 * float(np.median(ev.errors[t])) if ev.errors[t] else math.nan
        for t in ("heel_strike", "toe_off")
    )
    res.missed = sum(ev.missed.values())
    matched_events = sum(len(v) for v in ev.errors.values())
    res.extra = max(0, len(est.events) - matched_events)
    pct, res.matched = parameter_errors_pct(est.strides, ref.strides)
    res.pct = {label: float(pct[key]) for label, key in PCT_FIELDS}
    for label, get, scale, _ in SUMMARY_FIELDS:
        res.diff[label] = scale * (_value(get(est.summary)) - _value(get(ref.summary)))
    return res


def compare_transfers(truth: list, video: list, res: SceneResult) -> None:
    """Match the video's transfers to the truth's (same type, start within
    ``TRANSFER_TOLERANCE_S``, nearest first, each at most once) and fill ``res``'s counts and
    median absolute start and duration errors."""
    res.transfers_truth, res.transfers_video = len(truth), len(video)
    pairs = sorted(
        (abs(v.start_s - t.start_s), i, j)
        for i, t in enumerate(truth)
        for j, v in enumerate(video)
        if v.type == t.type and abs(v.start_s - t.start_s) <= TRANSFER_TOLERANCE_S
    )
    used_t, used_v, start, duration = set(), set(), [], []
    for d, i, j in pairs:
        if i in used_t or j in used_v:
            continue
        used_t.add(i)
        used_v.add(j)
        start.append(1000 * d)
        duration.append(1000 * abs(video[j].duration_s - truth[i].duration_s))
    res.transfers_matched = len(start)
    res.transfer_start_ms = float(statistics.median(start)) if start else math.nan
    res.transfer_duration_ms = float(statistics.median(duration)) if start else math.nan


def _f(x: float, digits: int = 1, signed: bool = True) -> str:
    if x is None or not math.isfinite(x):
        return "-"
    return f"{x:+.{digits}f}" if signed else f"{x:.{digits}f}"


def scene_table(results: list[SceneResult]) -> str:
    head = [
        "recording",
        "view",
        "all mm",
        "strides truth / video (matched)",
        "HS ms (bias)",
        "TO ms (bias)",
        "events missed / extra",
        *(f"{label} %" for label, _ in PCT_FIELDS),
        *(f"{label} {unit}" for label, _, _, unit in SUMMARY_FIELDS),
        "transfers truth / video (matched)",
        "transfer start / duration ms",
    ]
    rows = []
    for r in results:
        if r.error:
            rows.append([r.recording, r.view, _f(r.all_mm, 0, False), r.error] + ["-"] * 12)
            continue
        rows.append(
            [
                r.recording,
                r.view,
                _f(r.all_mm, 0, False),
                f"{r.strides_truth} / {r.strides_video} ({r.matched})",
                f"{_f(r.hs_ms, 0, False)} ({_f(r.hs_bias_ms, 0)})",
                f"{_f(r.to_ms, 0, False)} ({_f(r.to_bias_ms, 0)})",
                f"{r.missed} / {r.extra}",
                *(_f(r.pct.get(label, math.nan)) for label, _ in PCT_FIELDS),
                *(_f(r.diff.get(label, math.nan)) for label, *_ in SUMMARY_FIELDS),
                f"{r.transfers_truth} / {r.transfers_video} ({r.transfers_matched})",
                f"{_f(r.transfer_start_ms, 0, False)} / {_f(r.transfer_duration_ms, 0, False)}",
            ]
        )
    return A.md_table(head, rows)


def _median_abs(values: list[float]) -> tuple[float, int]:
    v = [abs(x) for x in values if x is not None and math.isfinite(x)]
    return (statistics.median(v) if v else math.nan), len(v)


def pooled_table(results: list[SceneResult]) -> str:
    head = ["gait", "cameras", "scenes (with strides matched)", "all mm", "HS ms", "TO ms"]
    head += ["HS bias ms", "TO bias ms"]
    head += [f"{label} %" for label, _ in PCT_FIELDS]
    head += [f"{label} {unit}" for label, _, _, unit in SUMMARY_FIELDS]
    rows = []
    head += ["transfers truth / video (matched)", "transfer start / duration ms"]
    groups = sorted({(r.gait, r.ncams) for r in results}, key=lambda g: (g[0] != "walk", g))
    for gait, n in groups:
        rs = [r for r in results if (r.gait, r.ncams) == (gait, n)]
        ok = [r for r in rs if not r.error and r.matched > 0]
        row = [
            gait,
            str(n),
            f"{len(rs)} ({len(ok)})",
            _f(
                statistics.median([r.all_mm for r in rs if math.isfinite(r.all_mm)] or [math.nan]),
                0,
                False,
            ),
        ]
        for key in ("hs_ms", "to_ms"):
            m, _ = _median_abs([getattr(r, key) for r in ok])
            row.append(_f(m, 0, False))
        for key in ("hs_bias_ms", "to_bias_ms"):
            v = [getattr(r, key) for r in ok if math.isfinite(getattr(r, key))]
            row.append(_f(statistics.median(v), 0) if v else "-")
        for label, _ in PCT_FIELDS:
            m, _ = _median_abs([r.pct.get(label, math.nan) for r in ok])
            row.append(_f(m, 1, False))
        for label, *_ in SUMMARY_FIELDS:
            m, _ = _median_abs([r.diff.get(label, math.nan) for r in ok])
            row.append(_f(m, 1, False))
        ok = [r for r in rs if not r.error]
        row.append(
            f"{sum(r.transfers_truth for r in ok)} / {sum(r.transfers_video for r in ok)} "
            f"({sum(r.transfers_matched for r in ok)})"
        )
        row.append(
            " / ".join(
                _f(_median_abs([getattr(r, k) for r in ok])[0], 0, False)
                for k in ("transfer_start_ms", "transfer_duration_ms")
            )
        )
        rows.append(row)
    return A.md_table(head, rows)


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--recordings",
        default=",".join(DEFAULT_RECORDINGS),
        help=f"comma list among {', '.join(A.RECORDINGS)}",
    )
    ap.add_argument(
        "--views",
        default=",".join(DEFAULT_VIEWS),
        help="comma list of view specs, as for bench/accuracy.py (oblique, side+frontal, "
        "oblique@table, oblique:h1.2 ...)",
    )
    ap.add_argument("--filter", default="ipf", choices=A.ALL_FILTERS, help="tracker variant")
    ap.add_argument("--seed", type=int, default=0, help="scene seed (and tracker seed)")
    ap.add_argument("--tracker-seed", type=int, default=None, help="default: --seed")
    ap.add_argument(
        "--max-frames", type=int, default=None, help="frames per scene (default: the recording)"
    )
    ap.add_argument("--fps", type=float, default=20.0, help="the footage's frame rate (default 20)")
    ap.add_argument("--direct", action="store_true", help="track rendered frames (no codec)")
    A.add_background_argument(ap)
    ap.add_argument(
        "--keep",
        type=Path,
        help="write each scene's true and tracked key points here (REC_VIEW_truth.csv, "
        "REC_VIEW_video.csv; CONVENTIONS JOINTS.csv format, for `gaitwatch gait`; the truth "
        "with --source markers)",
    )
    A.add_run_args(ap, REPO / "bench" / "GAIT_VIDEO.md", "over the defaults")
    args = ap.parse_args(argv)
    if args.tracker_seed is None:
        args.tracker_seed = args.seed
    if args.max_frames is not None and args.max_frames < 2:
        ap.error("--max-frames must be at least 2")
    if not 1.0 <= args.fps <= 240.0:
        ap.error(f"--fps must be within 1..240, not {args.fps:g}")
    return args


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    if not A.ready(args, "gait_video"):
        return 2
    recs = [r.strip() for r in args.recordings.split(",") if r.strip()]
    unknown = [r for r in recs if r not in A.RECORDINGS]
    if unknown:
        print(f"gait_video: unknown recording(s): {', '.join(unknown)}", file=sys.stderr)
        return 2
    try:
        views = [A.ViewSpec.parse(v) for v in args.views.split(",")]
    except ValueError as err:
        print(f"gait_video: {err}", file=sys.stderr)
        return 2
    from tracker.config import TrackerConfigError

    try:
        settings = A.tracker_settings(args.config)
    except TrackerConfigError as err:
        print(f"gait_video: {err}", file=sys.stderr)
        return 2
    config = GaitConfig()
    results: list[SceneResult] = []
    t_start = time.perf_counter()
    plan = [(r, v) for r in recs for v in views]
    bar = tqdm(total=len(plan), unit="scene", file=sys.stderr)
    for rec, view in plan:
        bar.set_description(f"{rec} {view.label}")
        scene = A.build(rec, view, args.max_frames, args.seed, args.data, fps=args.fps)
        with tempfile.TemporaryDirectory() as td:
            frames, masks, bgs, cams, truth = A.scene_frames(scene, args.direct, Path(td))
        lighting = None
        if args.background == "median":
            lighting = A.footage_backgrounds(frames, settings)
        elif args.background == "learned":
            bgs = None
        fps = scene.config.fps
        inner = tqdm(total=len(frames), unit="frame", file=sys.stderr, leave=False)
        video, _ = A.track(
            frames, masks, bgs, cams, scene.body.stature_m, fps, args.filter,
            args.tracker_seed, inner, settings=settings, lighting=lighting,
        )  # fmt: skip
        inner.close()
        if args.keep:
            args.keep.mkdir(parents=True, exist_ok=True)
            stem = f"{rec}_{view.label.translate(str.maketrans('+@:', '-__'))}"
            write_joints_csv(truth, args.keep / f"{stem}_truth.csv")
            write_joints_csv(video, args.keep / f"{stem}_video.csv")
        res = compare(truth, video, config)
        res.recording, res.view, res.ncams = rec, view.label, len(view.views)
        results.append(res)
        tqdm.write(
            f"{rec:9s} {view.label:14s} all {_f(res.all_mm, 0, False):>4s} mm  strides "
            f"{res.strides_truth}/{res.strides_video}  HS {_f(res.hs_ms, 0, False)} ms  speed "
            f"{_f(res.pct.get('speed', math.nan))} %  cadence "
            f"{_f(res.pct.get('cadence', math.nan))} %  transfers "
            f"{res.transfers_truth}/{res.transfers_video}  {res.error}",
            file=sys.stderr,
        )
        bar.update(1)
    bar.close()
    elapsed = time.perf_counter() - t_start
    command = "python3 bench/gait_video.py " + shlex.join(argv)
    text = "\n".join(
        [
            "# Gait parameters from video against the truth's (end to end)",
            "",
            f"Command: `{command.strip()}` ({elapsed / 60:.0f} min; filter {args.filter}, "
            f"scene seed {args.seed}, tracker seed {args.tracker_seed}; "
            f"{'tracker settings ' + str(args.config) if args.config else 'tracker defaults'}; "
            f"{'rendered frames' if args.direct else 'mp4v videos read back'}).",
            "",
            "Reference: `gait.analysis.analyse` on the true key points at the footage's frame "
            'rate (as laboratory markers, `source = "markers"`); video: the same analysis on '
            'the tracked key points (`source = "video"`: gait events calibrated for tracked '
            "key points, docs/gait.md). Errors are video - "
            "truth; `%` are relative errors over the matched strides, `pp` percentage points. "
            "See the docstring of `bench/gait_video.py`.",
            "",
            "## Per scene",
            "",
            scene_table(results),
            "",
            "## Median absolute error per camera set",
            "",
            pooled_table(results),
            "",
        ]
    )
    print(text)
    if not args.no_out:
        args.out.write_text(text)
        print(f"written to {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
