"""``gaitwatch track``: synchronised camera footage -> 3D poses in an MCAP pose log.

::

    gaitwatch track VIDEO [VIDEO ...] --camera CAM.yaml [--camera CAM.yaml ...]
                    [--height METRES] [--background IMAGE ...] [--filter ipf|apf|condensation]
                    [--seed N] --out POSES.mcap
                    [--occluder MASK|none ...] [--config TRACKER.toml|yaml]
                    [--particles N] [--tracks N] [--max-frames N]
                    [--segmentation static|mog2|knn] [--threads N] [--allow-length-mismatch]
                    [--no-smoothing] [--no-revise] [--keypoints FILE|none ...]
                    [--detector blazepose|none]

One VIDEO (a file OpenCV reads, or a folder of numbered PNG/JPEG frames) per ``--camera``, in the
same order. Frames are processed one at a time (memory does not grow with the footage) and each is
written to the pose log as soon as it is final: a pose, or a "no pose" status with its reason.
Each frame's leg labels are chosen by smooth motion of the feet half a second later
(:mod:`tracker.leglabels`; ``[leg_labels]`` in ``--config``; with one camera and the 2D key-point
cue the tracker's own labels are kept), then the key points of each
continuous track are smoothed over 0.45 s (:mod:`tracker.smoothing`, a centred quadratic fit,
quartic for the ankles, heels and toes; ``--no-smoothing`` or ``[smoothing]`` in ``--config`` to
change), so a frame is written about three quarters of a second of footage after it was read. The
first frames of each track, from the initial search until the track has settled 0.9 s after its
last re-initialisation, are tracked again backwards from the settled state
(:class:`tracker.config.ReviseConfig`; ``--no-revise`` or ``[revise]`` in ``--config``) and written
as revised: those frames are written up to 4 s of footage after they were read, in frame order;
memory stays bounded. The pose vector and weight are each frame's own (final) estimate's. The log
is finalised even when tracking stops on an error (a corrupt frame, videos of different lengths),
so the poses written so far stay readable; the error is then reported on one line and the exit code
is non-zero. Every random draw comes from one generator seeded by ``--seed``: the same seed gives
the same poses.

``--tracks N`` runs N independent tracks on the same silhouettes, each with 1/N of the
evaluations, and writes the mean of their key points (:mod:`tracker.ensemble`): with two
cameras the key points come nearer the truth (two tracks: 3.2 mm over 48 benchmark runs,
docs/tracker.md, "Session 57"; through one camera no gain was measured), but over whole
recordings the mean of the tracks swings the knee about 3 degrees less and the crouch walks
lose ("Session 58"); about 1.6 times slower with two and 2.4 with three; the pose vector
written is the first track's.

``--occluder`` gives, per camera, an image of the frame's size whose non-zero (white) pixels are
furniture that can stand between the camera and the person (a table, a sofa's back); ``none``
for a camera without. The tracker then neither rewards nor penalises the model there: without
it, legs hidden behind a table pull the estimate out of shape and off in depth. ``gaitwatch
simulate`` writes such masks for its furniture (docs/tracker.md, "Furniture in front of the
walk"; without them the tracker learns what it can).

The 2D key-point cue (docs/tracker.md, "2D key-point cue"; ``[keypoints]`` of ``--config``)
scores the model's legs against the knees, ankles and feet a 2D pose detector finds in each frame
too. By default the built-in detector (BlazePose, :mod:`tracker.detector2d`) runs on every frame;
``--detector none`` turns the cue off. ``--keypoints`` gives instead, per camera, a file of
another detector's key points for each frame (CSV or NumPy, :mod:`service.keypoints`; ``none``
for a camera without), and the built-in detector does not run.
"""

from __future__ import annotations

import argparse
import itertools
import logging
import sys
import time
from contextlib import closing
from pathlib import Path

import numpy as np

from gaitwatch.errors import InputError
from tracker.config import FILTER_NAMES, TrackerConfig, TrackerConfigError, load_tracker_config

log = logging.getLogger(__name__)


class TrackArgumentError(InputError):
    """A ``track`` option that cannot be used."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "track",
        help="track a person in synchronised videos and write 3D poses to an MCAP pose log",
        description="Track a person in synchronised videos (one per camera) and write 3D poses "
        "to an MCAP pose log.",
    )
    p.add_argument(
        "videos", nargs="+", metavar="VIDEO", help="one video or frame folder per camera"
    )
    p.add_argument(
        "--camera", action="append", required=True, metavar="CAM.yaml", help="camera file (repeat)"
    )
    p.add_argument(
        "--height", type=float, default=1.70, metavar="METRES", help="resident's height (1.70)"
    )
    p.add_argument(
        "--background",
        action="append",
        metavar="IMAGE",
        help="image of the empty scene per camera (repeat); without: estimated from the footage "
        "(the per-pixel median of frames spread over it, the person found by the 2D detector "
        "left out)",
    )
    p.add_argument(
        "--occluder",
        action="append",
        metavar="MASK",
        help="per camera (repeat): image whose non-zero pixels are furniture in front of the "
        "walking area, or 'none'",
    )
    p.add_argument(
        "--keypoints",
        action="append",
        metavar="FILE",
        help="per camera (repeat): a 2D pose detector's key points per frame (.csv or .npy), "
        "or 'none'; turns the 2D key-point cue on",
    )
    p.add_argument(
        "--detector",
        choices=("blazepose", "none"),
        help="the built-in 2D pose detector of the key-point cue (default blazepose); none "
        "turns the cue off unless --keypoints gives the key points",
    )
    p.add_argument("--filter", choices=FILTER_NAMES, help="body-part filter (default ipf)")
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--out", required=True, metavar="POSES.mcap", help="output pose log")
    p.add_argument("--config", metavar="FILE", help="tracker settings, TOML or YAML")
    p.add_argument(
        "--particles",
        type=int,
        metavar="N",
        help="likelihood evaluations per frame (IPF keeps M = N // q^n particles; the baselines "
        "use M * q^n)",
    )
    p.add_argument(
        "--tracks",
        type=int,
        metavar="N",
        help="independent tracks whose key points are averaged, sharing the evaluations of "
        "--particles (settings [ensemble]; docs/tracker.md, 'Several tracks averaged')",
    )
    p.add_argument("--max-frames", type=int, metavar="N", help="stop after N frames")
    p.add_argument(
        "--segmentation",
        choices=("static", "mog2", "knn"),
        help="background subtraction mode (default static, against --background or the empty scene "
        "estimated from the footage; mog2/knn learn it as the footage goes)",
    )
    p.add_argument("--threads", type=int, metavar="N", help="numba threads for the likelihood")
    p.add_argument(
        "--allow-length-mismatch",
        action="store_true",
        help="videos of different lengths: stop at the shortest with a warning instead of an error",
    )
    p.add_argument(
        "--no-smoothing",
        action="store_true",
        help="write each frame's own estimate (default: key points smoothed over 0.45 s, "
        "settings [smoothing] of --config)",
    )
    p.add_argument(
        "--no-revise",
        action="store_true",
        help="no backward pass over the first frames of each track (default: re-tracked "
        "backwards once the track has settled, settings [revise] of --config)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _per_camera_images(
    paths: list[str] | None, cameras: list, option: str, what: str, allow_none: bool = False
) -> list[np.ndarray | None] | None:
    """One image per camera from a repeated option (None when it was not given), each checked
    against its camera's image size; with ``allow_none`` the word ``none`` stands for no image."""
    from service.video import read_image
    from tracker.camera import check_image_size

    if not paths:
        return None
    if len(paths) != len(cameras):
        hint = " ('none' for a camera without)" if allow_none else ""
        raise TrackArgumentError(
            f"{len(paths)} {option} image(s) for {len(cameras)} camera(s): give one per "
            f"camera{hint}"
        )
    images: list[np.ndarray | None] = []
    for cam, path in zip(cameras, paths, strict=True):
        if allow_none and path.lower() == "none":
            images.append(None)
            continue
        img = read_image(path)
        check_image_size(cam, img.shape[1], img.shape[0], what=f"{what} {path}")
        images.append(img)
    return images


def _per_camera_keypoints(paths: list[str] | None, cameras: list) -> list | None:
    """One key-point file per camera from ``--keypoints`` (None when not given; ``none`` for a
    camera without)."""
    from service.keypoints import read_keypoints

    if not paths:
        return None
    if len(paths) != len(cameras):
        raise TrackArgumentError(
            f"{len(paths)} --keypoints file(s) for {len(cameras)} camera(s): give one per "
            "camera ('none' for a camera without)"
        )
    files = [None if p.lower() == "none" else read_keypoints(p) for p in paths]
    if all(f is None for f in files):
        raise TrackArgumentError("--keypoints: every camera is 'none'")
    for f in files:
        if f is not None and not len(f):
            log.warning("%s holds no detection: the key-point cue will not score", f.path)
    return files


def build_config(args: argparse.Namespace) -> TrackerConfig:
    """The tracker configuration from ``--config`` and the command-line overrides."""
    config = load_tracker_config(args.config) if args.config else TrackerConfig()
    update: dict = {}
    if args.filter:
        update["filter"] = args.filter
    if args.segmentation:
        update["segmentation"] = config.segmentation.model_copy(update={"mode": args.segmentation})
    if getattr(args, "no_smoothing", False):
        update["smoothing"] = config.smoothing.model_copy(update={"enabled": False})
    if getattr(args, "no_revise", False):
        update["revise"] = config.revise.model_copy(update={"enabled": False})
    if args.particles is not None:
        if args.particles < 1:
            raise TrackArgumentError(f"--particles must be >= 1, not {args.particles}")
        per = config.ipf.neighbours
        kept = max(1, args.particles // per)
        update["ipf"] = config.ipf.model_copy(update={"kept": kept})
        update["evaluations"] = None
    files, detector = getattr(args, "keypoints", None), getattr(args, "detector", None)
    if files or detector is not None:  # the cue on with key points from files or a detector
        kp = {"enabled": bool(files) or detector != "none"}
        if detector is not None:
            kp["detector"] = detector
        update["keypoints"] = config.keypoints.model_copy(update=kp)
    tracks = getattr(args, "tracks", None)
    if tracks is not None:
        if not 1 <= tracks <= 8:
            raise TrackArgumentError(f"--tracks must be 1 to 8, not {tracks}")
        update["ensemble"] = config.ensemble.model_copy(update={"tracks": tracks})
    if update:
        try:
            config = TrackerConfig.model_validate({**config.model_dump(), **update})
        except Exception as err:  # pydantic ValidationError
            raise TrackerConfigError(f"command-line options: {err}".splitlines()[0]) from None
    return config


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from service.poselog import PoseLogWriter
    from service.tracking import tracked
    from service.video import open_videos
    from tracker.camera import load_cameras
    from tracker.ensemble import make_tracker
    from tracker.leglabels import LegRelabeller
    from tracker.revision import ResultQueue
    from tracker.smoothing import RESTART_STATUSES, KeypointSmoother, single_camera_eye

    if not (0.5 <= args.height <= 2.5):
        raise TrackArgumentError(f"--height must be between 0.5 and 2.5 metres, not {args.height}")
    if args.max_frames is not None and args.max_frames < 1:
        raise TrackArgumentError(f"--max-frames must be >= 1, not {args.max_frames}")
    cameras = load_cameras(args.camera)
    if len(args.videos) != len(cameras):
        raise TrackArgumentError(
            f"{len(args.videos)} video(s) for {len(cameras)} --camera file(s): give one per camera"
        )
    backgrounds = _per_camera_images(args.background, cameras, "--background", "background")
    masks = _per_camera_images(args.occluder, cameras, "--occluder", "occluder mask", True)
    occluders = None if masks is None else [None if m is None else m.max(axis=2) > 0 for m in masks]
    keypoint_files = _per_camera_keypoints(args.keypoints, cameras)
    config = build_config(args)
    estimated = backgrounds is None and config.segmentation.mode == "static"
    lighting = None
    if estimated:
        # No image of the empty scene: the per-pixel median of frames spread over the footage,
        # the person the built-in detector finds in each left out (unless --detector none).
        from service.background import footage_backgrounds
        from tracker.background import LightingSwitch
        from tracker.detector2d import person_detector

        log.info("no --background: estimating the empty scene from the footage")
        lighting = LightingSwitch(
            footage_backgrounds(
                args.videos,
                cameras,
                max_frames=args.max_frames,
                tolerance=config.segmentation.threshold,
                progress=not args.no_progress,
                detector=person_detector(config.keypoints),
                segmentation=config.segmentation,
            )
        )
        backgrounds = lighting.initial()
    if args.threads is not None:
        import numba

        if args.threads < 1:
            raise TrackArgumentError(f"--threads must be >= 1, not {args.threads}")
        numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))

    videos = open_videos(
        args.videos, cameras, on_length_mismatch="stop" if args.allow_length_mismatch else "error"
    )
    rng = np.random.default_rng(args.seed)
    try:
        tracker = make_tracker(
            cameras,
            config,
            rng=rng,
            height_m=args.height,
            backgrounds=backgrounds,
            occluders=occluders,
        )
    except BaseException:
        videos.close()
        raise
    settings = {
        "tracker": config.model_dump(mode="json"),
        "seed": args.seed,
        "videos": [str(v) for v in args.videos],
        "backgrounds": list(args.background or []),
        # per camera: the empty scene estimated from the footage (False: given, or learned)
        "backgrounds_estimated": [estimated and b is not None for b in backgrounds or cameras],
        "occluders": list(args.occluder or []),
        "keypoints": list(args.keypoints or []),
    }
    total = videos.frame_count
    if args.max_frames is not None:
        total = min(total, args.max_frames) if total else args.max_frames
    out = Path(args.out)
    n_pose = n_none = 0
    relabeller = LegRelabeller.from_config(
        config.leg_labels,
        cameras[0].fps,
        single_camera=len(cameras) == 1,
        keypoint_cue=config.keypoints.enabled
        and (keypoint_files is not None or tracker.detects_keypoints),
    )
    smoother = KeypointSmoother.from_config(
        config.smoothing, cameras[0].fps, single_camera_eye(cameras)
    )
    queue = ResultQueue()  # results still open to the backward pass (config.revise)
    t0 = time.perf_counter()
    with (
        videos,
        PoseLogWriter(
            out,
            cameras=cameras,
            body_height_m=args.height,
            filter_name=tracker.filter_name,
            settings=settings,
            fps=cameras[0].fps,
        ) as writer,
        tqdm(
            total=total,
            unit="frame",
            desc="track",
            file=sys.stderr,
            disable=args.no_progress,
            dynamic_ncols=True,
        ) as bar,
    ):

        def write(done: list) -> None:
            nonlocal n_pose, n_none
            for out in done:
                res = out.item
                index, time_s = res.frame_index, res.time_s
                if res.has_pose:
                    writer.write_frame(
                        index,
                        time_s,
                        out.joints,
                        res.pose,
                        res.weight,
                        tracker.filter_name,
                        leg_length=res.leg_length,
                    )
                    n_pose += 1
                else:
                    writer.write_no_pose(index, time_s, res.reason)
                    n_none += 1
                for note in res.notes:
                    writer.write_note(index, time_s, note)

        def smooth(labelled: list) -> None:
            for f in labelled:
                legs = f.item.legs_seen  # the relabeller's item is the FrameResult
                write(smoother.push(f.time_s, f.joints, f.item, restart=f.restart, legs_seen=legs))

        def relabel(final: list) -> None:
            for res in final:
                smooth(
                    relabeller.push(
                        res.time_s,
                        res.joints if res.has_pose else None,
                        res,
                        restart=res.status in RESTART_STATUSES,
                    )
                )

        def segment(frames: list[np.ndarray]) -> list:
            if lighting is not None:  # the empty scene of the frame's lighting state
                lighting.apply(tracker, frames)
            return tracker.segment(frames)

        def given(index: int) -> list:
            return [None if f is None else f.get(index) for f in keypoint_files]

        try:
            # The next frames are decoded and segmented in a second thread meanwhile, and the
            # built-in 2D detector runs on the next frame in a third (service.tracking).
            with closing(
                tracked(
                    tracker,
                    itertools.islice(videos, args.max_frames),
                    segment=segment,
                    keypoints=None if keypoint_files is None else given,
                )
            ) as results:
                for res in results:
                    relabel(queue.push(res, tracker.pending_from))
                    bar.update(1)
                    bar.set_postfix(weight=f"{res.weight:.2f}", refresh=False)
        finally:  # the frames still held (revision, leg labels, smoothing) are written, even after
            # an error
            relabel(queue.flush())
            smooth(relabeller.flush())
            write(smoother.flush())
    elapsed = time.perf_counter() - t0
    n = n_pose + n_none
    print(
        f"tracked {n} frame(s): {n_pose} with a pose, {n_none} without; "
        f"{elapsed:.2f} s ({n / max(elapsed, 1e-9):.1f} frames/s, filter {tracker.filter_name}) "
        f"-> {out}"
    )
    if videos.length_mismatch:
        print(f"warning: {videos.length_mismatch}")
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m service.commands.track ...``: the ``track`` command alone (for benchmarks).

    Same arguments, output and exit codes as ``gaitwatch track``, without loading the other
    sub-commands.
    """
    from service.cli import EXIT_BAD_INPUT, _setup_logging

    parser = argparse.ArgumentParser(prog="gaitwatch")
    parser.add_argument("-v", "--verbose", action="count", default=0)
    parser.add_argument("-q", "--quiet", action="store_true")
    register(parser.add_subparsers(dest="command"))
    argv = list(sys.argv[1:] if argv is None else argv)
    lead = 0
    while lead < len(argv) and argv[lead] in ("-q", "--quiet", "-v", "-vv", "--verbose"):
        lead += 1
    rest = argv[lead:]
    if rest[:1] == ["track"]:
        rest = rest[1:]
    args = parser.parse_args([*argv[:lead], "track", *rest])
    _setup_logging(args.verbose, args.quiet)
    try:
        return int(args.func(args) or 0)
    except (InputError, FileNotFoundError, IsADirectoryError, PermissionError) as err:
        print(f"gaitwatch: error: {str(err).replace(chr(10), ' ')}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
