"""``gaitwatch simulate``: synthetic camera footage of a motion with ground truth, and
camera-placement advice (``--advise``). See docs/simulation.md."""

from __future__ import annotations

import argparse
import json
import logging
import math
from contextlib import closing
from pathlib import Path

import numpy as np

from gaitwatch.errors import InputError

log = logging.getLogger(__name__)

VIEWS = ("side", "oblique", "frontal")


class SimulateArgumentError(InputError):
    """A bad ``gaitwatch simulate`` argument."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="render synthetic footage of a motion with ground truth, or advise on a camera",
        description=(
            "Render a motion (a mocap file, a JOINTS.csv, an OpenSim joint-angle cycle .mot, "
            "or 'walk[:speed=..,cadence=..,height=..,distance=..]' for a procedural walk) "
            "through cameras in a textured room. "
            "Writes camI.mp4, camI.yaml, camI-background.png (camI-occluder.png with furniture "
            "in view), JOINTS.csv and scene.json into --out. With --advise and --camera: report "
            "where on the floor the camera can measure gait."
        ),
    )
    p.add_argument("motion", nargs="?", default="walk", help="motion source (default: walk)")
    p.add_argument("--out", type=Path, help="output folder")
    p.add_argument(
        "--camera", action="append", type=Path, default=[], help="site camera YAML (repeatable)"
    )
    p.add_argument("--views", default="side,oblique,frontal", help="default camera placements")
    p.add_argument("--ncams", type=int, help="use the first N of --views")
    p.add_argument("--height", type=float, help="stature to scale the motion to (m)")
    p.add_argument(
        "--shape", choices=("default", "tall", "short", "heavy", "slim"), default="default"
    )
    p.add_argument("--clothing", choices=("fitted", "loose", "skirt", "coat"), default="fitted")
    p.add_argument(
        "--pattern", choices=("random", "plain", "stripes", "checks"), default="random",
        help="shirt pattern",
    )  # fmt: skip
    p.add_argument(
        "--occluder",
        choices=("none", "table", "sofa", "chair"),
        default="none",
        help="a table or sofa between the first camera and the walk, or a chair under each "
        "place where the person sits",
    )
    p.add_argument("--lighting", choices=("steady", "drift", "switch"), default="drift")
    p.add_argument("--noise", type=float, default=2.0, help="sensor noise sigma (8-bit units)")
    p.add_argument("--jpeg", type=int, metavar="Q", help="JPEG-compress every frame at quality Q")
    p.add_argument("--fps", type=float, default=25.0)
    p.add_argument("--size", help="image size WxH (default: the first --camera's, else 640x480)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-frames", type=int)
    p.add_argument("--masks", action="store_true", help="also write silhouette masks")
    p.add_argument("--png", action="store_true", help="PNG frame folders instead of mp4 videos")
    p.add_argument(
        "--keep-position",
        action="store_true",
        help="with --camera: keep the motion where it is instead of walking it across the view",
    )
    p.add_argument("--force", action="store_true", help="replace a scene already in --out")
    p.add_argument("--advise", action="store_true", help="camera-placement advice for --camera")
    p.add_argument("--min-px", type=float, default=60.0, help="--advise: min person height, px")
    p.add_argument(
        "--track",
        action="store_true",
        help="--advise: also run the tracker on each rendered walk and report its error (slow)",
    )
    p.set_defaults(func=run)


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise SimulateArgumentError(f"--size {text!r}: expected WxH, e.g. 640x480") from None
    if w < 32 or h < 32:
        raise SimulateArgumentError(f"--size {text!r}: at least 32x32")
    return w, h


def _config(args: argparse.Namespace, default_size: tuple[int, int] = (640, 480)):
    from pydantic import ValidationError

    from gaitwatch.sim.scene import SceneConfig

    views = [v.strip() for v in args.views.split(",") if v.strip()]
    bad = [v for v in views if v not in VIEWS]
    if bad or not views:
        raise SimulateArgumentError(f"--views: {', '.join(bad) or 'empty'}; choose from {VIEWS}")
    if args.ncams is not None:
        if not 1 <= args.ncams <= len(views):
            raise SimulateArgumentError(f"--ncams {args.ncams}: between 1 and {len(views)}")
        views = views[: args.ncams]
    try:
        return SceneConfig(
            views=views,
            image_size=_size(args.size) if args.size else default_size,
            fps=args.fps,
            seed=args.seed,
            max_frames=args.max_frames,
            body={"preset": args.shape, "height_m": args.height},
            clothing={"style": args.clothing, "pattern": args.pattern},
            lighting={"mode": args.lighting},
            noise={"sigma_dn": args.noise, "jpeg_quality": args.jpeg},
            room={"occluder": args.occluder},
            masks=args.masks,
            video_format="png" if args.png else "mp4",
        )
    except ValidationError as err:
        e = err.errors()[0]
        loc = ".".join(str(x) for x in e["loc"])
        raise SimulateArgumentError(f"bad setting {loc}: {e['msg']}") from None


def _place_for_cameras(motion, cameras):
    """Walk the motion across the first camera's measurable floor, side-on to it, centred on the
    nearer half of that floor area."""
    from gaitwatch.conventions import SACRUM
    from gaitwatch.sim.advise import measurable_floor
    from gaitwatch.sim.motion import place_on_path

    cam = cameras[0]
    region = measurable_floor(cam)
    if region.centroid is None:
        log.warning("%s: no floor area with the whole body in view; motion not moved", cam.name)
        return motion
    view = cam.R[2].copy()
    view[2] = 0
    heading = math.atan2(view[1], view[0]) + math.pi / 2
    s = motion.positions[:, SACRUM, :2]
    s = s[np.isfinite(s).all(1)]
    length = float(np.linalg.norm(s[-1] - s[0])) if len(s) > 1 else 0.0
    d = np.array([math.cos(heading), math.sin(heading)])
    near = region.cells[region.person_px >= np.median(region.person_px)]  # the nearer half
    start = near.mean(0) - 0.5 * length * d
    return place_on_path(motion, (float(start[0]), float(start[1])), heading)


def tracker_callable(seed: int = 0):
    """A ``tracker_fn`` for :func:`gaitwatch.sim.advise.advise`: the default tracker
    (``tracker.pipeline.Tracker``) on a rendered clip, given the empty-scene backgrounds and the
    true stature."""
    from gaitwatch.trajectory import Trajectory
    from service.tracking import tracked
    from tracker.ensemble import make_tracker
    from tracker.output import written_keypoints
    from tracker.revision import ResultQueue
    from tracker.smoothing import RESTART_STATUSES, single_camera_eye

    def track(clip) -> Trajectory:
        tracker = make_tracker(
            clip.cameras,
            rng=np.random.default_rng(seed),
            height_m=float(clip.scene.body.stature_m),
            backgrounds=[np.ascontiguousarray(b[..., ::-1]) for b in clip.backgrounds],
        )
        steps = (
            (k, k / clip.fps, [np.ascontiguousarray(f[k][..., ::-1]) for f in clip.frames])
            for k in range(len(clip.truth))
        )
        queue, results = ResultQueue(), []
        # as `gaitwatch track` runs it: decoding, segmentation and the 2D detector in threads
        with closing(tracked(tracker, steps)) as stream:
            for res in stream:
                results += queue.push(res, tracker.pending_from)
        results += queue.flush()
        results = [r for r in results if r.has_pose]
        frames = [r.frame_index for r in results]
        times = [r.frame_index / clip.fps for r in results]
        joints = [r.joints for r in results]
        restarts = [r.status in RESTART_STATUSES for r in results]
        legs_seen = [r.legs_seen for r in results]
        if not frames:
            return Trajectory(positions=np.zeros((0, 19, 3)), times=np.zeros(0), frames=[])
        # as `gaitwatch track` writes them
        smoothed = written_keypoints(
            np.array(times),
            np.stack(joints),
            tracker.config,
            clip.fps,
            np.array(restarts),
            frames=np.array(frames),
            eye=single_camera_eye(clip.cameras),
            keypoint_cue=tracker.detects_keypoints,
            legs_seen=np.array(legs_seen),
        )
        return Trajectory(positions=smoothed, times=np.array(times), frames=frames)

    track.__name__ = f"tracker (seed {seed})"
    return track


def run(args: argparse.Namespace) -> int:
    import cv2

    from gaitwatch.sim.motion import load_motion
    from tracker.camera import load_cameras

    cameras = load_cameras(args.camera) if args.camera else []
    cfg = _config(args, (cameras[0].width, cameras[0].height) if cameras else (640, 480))
    if args.advise:
        from gaitwatch.sim.advise import advice_overlay, advise, format_advice

        if not cameras:
            raise SimulateArgumentError("--advise needs at least one --camera CAM.yaml")
        motion = None if args.motion == "walk" else load_motion(args.motion)
        reports = []
        for cam in cameras:
            acfg = cfg.model_copy(update={"fps": min(cfg.fps, 15.0)})
            fn = tracker_callable(args.seed) if args.track else None
            adv = advise(
                cam,
                fn,
                motion=motion,
                config=acfg,
                min_person_px=args.min_px,
                max_path_m=3.0 if args.track else 6.0,  # the tracker is slow
            )
            print(format_advice(adv))
            reports.append(adv)
        if args.out:
            args.out.mkdir(parents=True, exist_ok=True)
            for adv, cam in zip(reports, cameras, strict=True):
                if adv.background is not None:
                    img = advice_overlay(cam, adv.region, adv.background)
                    cv2.imwrite(str(args.out / f"advice-{cam.name}.png"), img[..., ::-1])
            (args.out / "advice.json").write_text(
                json.dumps([a.to_dict() for a in reports], indent=1, default=float)
            )
        return 0
    if args.out is None:
        raise SimulateArgumentError("--out DIR is required (or --advise)")
    from gaitwatch.sim.synth import build_scene
    from gaitwatch.sim.writer import write_scene

    motion = load_motion(args.motion)
    if cameras and not args.keep_position:
        motion = _place_for_cameras(motion, cameras)
    try:
        scene = build_scene(motion, cfg, cameras=cameras or None)
    except ValueError as err:
        if isinstance(err, InputError):
            raise
        raise SimulateArgumentError(f"{args.motion}: {err}") from None
    files = write_scene(scene, args.out, overwrite=args.force, progress=not args.quiet)
    print(
        f"wrote {scene.n_frames} frames x {len(scene.cameras)} camera(s) "
        f"({cfg.image_size[0]}x{cfg.image_size[1]} at {cfg.fps:g} fps) to {files.folder}"
    )
    return 0
