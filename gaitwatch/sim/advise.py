"""Camera-placement advice: where on the floor a camera can measure gait, and how well.

For a site's camera file, :func:`measurable_floor` finds the floor cells where a standing
person (a 0.3 m radius cylinder, feet to ``person_height_m``) is entirely inside the image and
at least ``min_person_px`` pixels tall. :func:`advise` then lays straight walking paths across
that area (across the view, towards the camera, and both diagonals), renders each walk through
the camera with the scene synthesiser and measures, on the rendered silhouettes, how often the
whole body is in view and how tall it is. Given a ``tracker_fn`` it also runs the tracker on
each rendered path and scores it against the ground truth (per-joint position error).

``tracker_fn`` is called as ``tracker_fn(clip)`` with a :class:`SimClip` and must return a
:class:`~gaitwatch.trajectory.Trajectory` of the 19 key points whose ``frames`` index the clip's
frames (frames where nobody was tracked may be absent).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gaitwatch.conventions import (
    L_ANKLE,
    L_HEEL,
    L_HIP,
    L_KNEE,
    L_TOE,
    R_ANKLE,
    R_HEEL,
    R_HIP,
    R_KNEE,
    R_TOE,
    SACRUM,
)
from gaitwatch.sim.motion import place_on_path, procedural_walk
from gaitwatch.sim.scene import SceneConfig
from gaitwatch.sim.synth import Scene, build_scene, render_background, render_frames
from gaitwatch.trajectory import Trajectory
from tracker.camera import Camera

log = logging.getLogger(__name__)

LOWER_LIMB = (L_HIP, R_HIP, L_KNEE, R_KNEE, L_ANKLE, R_ANKLE, L_HEEL, R_HEEL, L_TOE, R_TOE)


@dataclass
class FloorRegion:
    """Floor cells where gait can be measured by one camera.

    Attributes
    ----------
    cells : ndarray (N, 2)
        Centres of the measurable cells (world x, y, metres).
    cell_m : float
        Cell size (m).
    person_px : ndarray (N,)
        Height in pixels of a standing person at each cell.
    """

    cells: np.ndarray
    cell_m: float
    person_px: np.ndarray

    @property
    def area_m2(self) -> float:
        return float(len(self.cells) * self.cell_m**2)

    @property
    def extent(self) -> tuple[float, float, float, float] | None:
        """(xmin, xmax, ymin, ymax) of the cells' outer edges, or None if empty."""
        if not len(self.cells):
            return None
        h = self.cell_m / 2
        lo, hi = self.cells.min(0) - h, self.cells.max(0) + h
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])

    @property
    def centroid(self) -> np.ndarray | None:
        return self.cells.mean(0) if len(self.cells) else None

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Whether points (N, 2) fall in a measurable cell."""
        if not len(self.cells):
            return np.zeros(len(xy), dtype=bool)
        keys = {tuple(k) for k in np.floor(self.cells / self.cell_m).astype(np.int64).tolist()}
        q = np.floor(np.asarray(xy) / self.cell_m).astype(np.int64)
        return np.array([tuple(k) in keys for k in q.tolist()], dtype=bool)


def measurable_floor(
    camera: Camera,
    *,
    person_height_m: float = 1.8,
    person_radius_m: float = 0.3,
    min_person_px: float = 60.0,
    cell_m: float = 0.1,
    max_range_m: float = 15.0,
    margin_px: float = 2.0,
) -> FloorRegion:
    """Floor cells where a whole standing person is in view and tall enough in the image."""
    w, h = camera.width, camera.height
    border = np.concatenate(
        [
            np.stack([np.linspace(0, w - 1, 64), np.zeros(64)], 1),
            np.stack([np.linspace(0, w - 1, 64), np.full(64, h - 1.0)], 1),
            np.stack([np.zeros(64), np.linspace(0, h - 1, 64)], 1),
            np.stack([np.full(64, w - 1.0), np.linspace(0, h - 1, 64)], 1),
            np.stack(np.meshgrid(np.linspace(0, w - 1, 16), np.linspace(0, h - 1, 16)), -1).reshape(
                -1, 2
            ),
        ]
    )
    c = camera.center
    hits = camera.pixel_to_floor(border)
    hits = hits[np.isfinite(hits).all(1)]
    far = np.linalg.norm(hits[:, :2] - c[:2], axis=1) > max_range_m
    hits = hits[~far]
    if len(hits) == 0:
        return FloorRegion(np.zeros((0, 2)), cell_m, np.zeros(0))
    lo = np.floor(hits[:, :2].min(0) / cell_m) * cell_m
    hi = np.ceil(hits[:, :2].max(0) / cell_m) * cell_m
    xs = np.arange(lo[0], hi[0], cell_m) + cell_m / 2
    ys = np.arange(lo[1], hi[1], cell_m) + cell_m / 2
    gx, gy = np.meshgrid(xs, ys)
    cells = np.stack([gx.ravel(), gy.ravel()], 1)
    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ring = person_radius_m * np.stack([np.cos(ang), np.sin(ang)], 1)
    # (N, 8 + 8 + 2, 3): feet ring, head ring, foot centre, head centre
    n = len(cells)
    feet = np.concatenate([cells[:, None, :] + ring[None], np.zeros((n, 8, 1))], 2)
    head = feet.copy()
    head[..., 2] = person_height_m
    centre0 = np.concatenate([cells, np.zeros((n, 1))], 1)[:, None]
    centre1 = centre0.copy()
    centre1[..., 2] = person_height_m
    pts = np.concatenate([feet, head, centre0, centre1], 1)
    px = camera.project(pts)
    inside = (
        np.isfinite(px).all(-1)
        & (px[..., 0] >= margin_px)
        & (px[..., 0] <= w - 1 - margin_px)
        & (px[..., 1] >= margin_px)
        & (px[..., 1] <= h - 1 - margin_px)
    ).all(1)
    tall = np.linalg.norm(px[:, -1] - px[:, -2], axis=1)
    ok = inside & (tall >= min_person_px) & (np.linalg.norm(cells - c[:2], axis=1) <= max_range_m)
    return FloorRegion(cells[ok], cell_m, tall[ok])


@dataclass
class SimClip:
    """One rendered walk, as given to a tracker callable.

    Attributes
    ----------
    cameras : list of Camera
    frames : list of ndarray (T, H, W, 3) uint8 RGB
        One stack of frames per camera.
    backgrounds : list of ndarray (H, W, 3) uint8 RGB
        The empty scene per camera.
    fps : float
    truth : Trajectory
        Ground truth of the clip (frames 0 .. T-1).
    scene : Scene
    """

    cameras: list[Camera]
    frames: list[np.ndarray]
    backgrounds: list[np.ndarray]
    fps: float
    truth: Trajectory
    scene: Scene

    @classmethod
    def of_scene(cls, scene: Scene, frames: list[np.ndarray], fps: float) -> SimClip:
        """The clip of a one-camera ``scene`` from its rendered RGB ``frames`` (one per time
        step), with the empty scene's image and the scene's truth."""
        return cls(
            cameras=list(scene.cameras),
            frames=[np.stack(frames)],
            backgrounds=[render_background(scene, 0)],
            fps=fps,
            truth=scene.truth,
            scene=scene,
        )


TrackerFn = Callable[[SimClip], Trajectory]


@dataclass
class PathResult:
    """A walking path across the measurable floor and what the camera made of it."""

    label: str
    start: tuple[float, float]
    end: tuple[float, float]
    length_m: float
    frames: int
    whole_body_pct: float
    person_px_median: float
    person_px_range: tuple[float, float]
    error_mm: float | None = None
    lower_limb_error_mm: float | None = None
    frames_lost: int | None = None


@dataclass
class Advice:
    """The advice for one camera."""

    camera: str
    image_size: tuple[int, int]
    region: FloorRegion
    min_person_px: float
    paths: list[PathResult] = field(default_factory=list)
    tracker: str | None = None
    notes: list[str] = field(default_factory=list)
    background: np.ndarray | None = None  # empty scene (H, W, 3) uint8 RGB, for overlays
    distance_m: tuple[float, float] | None = None  # nearest, farthest measurable floor point

    def to_dict(self) -> dict:
        ext = self.region.extent
        return {
            "camera": self.camera,
            "image_size": list(self.image_size),
            "measurable_area_m2": round(self.region.area_m2, 3),
            "extent_m": None if ext is None else [round(v, 3) for v in ext],
            "min_person_px": self.min_person_px,
            "person_px_range": (
                None
                if not len(self.region.person_px)
                else [float(self.region.person_px.min()), float(self.region.person_px.max())]
            ),
            "distance_m": None if self.distance_m is None else list(self.distance_m),
            "tracker": self.tracker,
            "paths": [p.__dict__ for p in self.paths],
            "notes": self.notes,
        }


def pose_errors(truth: Trajectory, estimate: Trajectory) -> tuple[float, float, int]:
    """Mean per-joint position error (mm) over all 19 points and over the lower limbs, and the
    number of truth frames without an estimate. Frames are matched by frame number."""
    est = {int(f): i for i, f in enumerate(estimate.frames)}
    idx_t = [i for i, f in enumerate(truth.frames) if int(f) in est]
    lost = len(truth) - len(idx_t)
    if not idx_t:
        return math.nan, math.nan, lost
    idx_e = [est[int(truth.frames[i])] for i in idx_t]
    d = np.linalg.norm(truth.positions[idx_t] - estimate.positions[idx_e], axis=-1) * 1000.0
    return float(np.nanmean(d)), float(np.nanmean(d[:, list(LOWER_LIMB)])), lost


def _longest_run(region: FloorRegion, centre: np.ndarray, heading: float, step: float = 0.05):
    """Longest segment of the line through ``centre`` along ``heading`` inside the region."""
    d = np.array([math.cos(heading), math.sin(heading)])
    s = np.arange(-20.0, 20.0, step)
    pts = centre + s[:, None] * d
    inside = region.contains(pts)
    best, cur_start, best_seg = 0.0, None, None
    for i, ok in enumerate(np.append(inside, False)):
        if ok and cur_start is None:
            cur_start = i
        elif not ok and cur_start is not None:
            length = (i - 1 - cur_start) * step
            if length > best:
                best, best_seg = length, (s[cur_start], s[i - 1])
            cur_start = None
    if best_seg is None:
        return None
    return centre + best_seg[0] * d, centre + best_seg[1] * d


def _clip_to_distance(traj: Trajectory, distance: float) -> Trajectory:
    s = traj.positions[:, SACRUM, :2]
    travelled = np.linalg.norm(s - s[0], axis=1)
    n = int(np.searchsorted(travelled, distance)) + 1
    n = max(2, min(n, len(traj)))
    return Trajectory(
        positions=traj.positions[:n],
        times=traj.times[:n],
        frames=traj.frames[:n],
        fps=traj.fps,
        source=traj.source,
        events=[e for e in traj.events if e["time_s"] <= traj.times[n - 1]],
        stature_m=traj.stature_m,
    )


def advise(
    camera: Camera,
    tracker_fn: TrackerFn | None = None,
    *,
    motion: Trajectory | None = None,
    config: SceneConfig | None = None,
    person_height_m: float = 1.8,
    min_person_px: float = 60.0,
    min_path_m: float = 1.5,
    max_path_m: float = 6.0,
    tracker_name: str | None = None,
) -> Advice:
    """Advice for one camera: measurable floor, rendered walks across it, optional accuracy.

    Parameters
    ----------
    camera : Camera
        The site's camera (its own image size is used).
    tracker_fn : callable, optional
        ``tracker_fn(SimClip) -> Trajectory``; when given, each rendered path is tracked and
        scored (mean per-joint error in mm, lower limbs, frames lost).
    motion : Trajectory, optional
        A recorded walk to move onto each path (cropped to the path's length); the procedural
        walk otherwise.
    config : SceneConfig, optional
        Rendering settings (fps, seed, body, lighting...); ``image_size`` is the camera's.
    """
    cfg = (config or SceneConfig(fps=15.0)).model_copy(
        update={"image_size": (camera.width, camera.height), "masks": True}
    )
    region = measurable_floor(camera, person_height_m=person_height_m, min_person_px=min_person_px)
    advice = Advice(
        camera=camera.name,
        image_size=(camera.width, camera.height),
        region=region,
        min_person_px=min_person_px,
        tracker=tracker_name
        or (getattr(tracker_fn, "__name__", "tracker") if tracker_fn else None),
    )
    if len(region.cells):
        dist = np.linalg.norm(region.cells - camera.center[:2], axis=1)
        advice.distance_m = (float(dist.min()), float(dist.max()))
    if not len(region.cells):
        advice.notes.append(
            f"no floor area where a whole {person_height_m:.1f} m person is in view and at least "
            f"{min_person_px:.0f} px tall: lower or tilt the camera down, or move it back"
        )
        return advice
    view = camera.R[2].copy()
    view[2] = 0
    base = math.atan2(view[1], view[0]) if np.linalg.norm(view) > 1e-6 else 0.0
    centre = region.centroid
    headings = {
        "across the view": base + math.pi / 2,
        "towards the camera": base + math.pi,
        "diagonal (left)": base + 3 * math.pi / 4,
        "diagonal (right)": base + math.pi / 4,
    }
    for label, heading in headings.items():
        seg = _longest_run(region, centre, heading)
        if seg is None:
            continue
        a, b = seg
        length = float(np.linalg.norm(b - a)) - 0.3
        if length < min_path_m:
            advice.notes.append(f"path {label}: only {length:.1f} m of straight measurable walk")
            continue
        length = min(length, max_path_m)
        d = (b - a) / np.linalg.norm(b - a)
        start = 0.5 * (a + b) - 0.5 * length * d
        h = math.atan2(d[1], d[0])
        if motion is not None:
            walk = _clip_to_distance(place_on_path(motion, tuple(start), h), length)
        else:
            walk = procedural_walk(
                distance_m=length, start=(float(start[0]), float(start[1])), heading_rad=h
            )
        scene = build_scene(walk, cfg, cameras=[camera])
        if advice.background is None:
            advice.background = render_background(scene, 0)
        whole, heights, frames = 0, [], []
        for _, images, masks in render_frames(scene):
            m = masks[0]
            if tracker_fn is not None:
                frames.append(images[0])
            rows = np.flatnonzero(m.any(1))
            cols = np.flatnonzero(m.any(0))
            if not len(rows):
                continue
            heights.append(float(rows[-1] - rows[0] + 1))
            touches = rows[0] == 0 or cols[0] == 0 or rows[-1] == m.shape[0] - 1
            touches = touches or cols[-1] == m.shape[1] - 1
            whole += int(not touches)
        n = scene.n_frames
        res = PathResult(
            label=label,
            start=(round(float(start[0]), 3), round(float(start[1]), 3)),
            end=(
                round(float(start[0] + length * d[0]), 3),
                round(float(start[1] + length * d[1]), 3),
            ),
            length_m=round(length, 3),
            frames=n,
            whole_body_pct=round(100.0 * whole / max(n, 1), 1),
            person_px_median=float(np.median(heights)) if heights else 0.0,
            person_px_range=(min(heights), max(heights)) if heights else (0.0, 0.0),
        )
        if tracker_fn is not None:
            clip = SimClip.of_scene(scene, frames, cfg.fps)
            est = tracker_fn(clip)
            res.error_mm, res.lower_limb_error_mm, res.frames_lost = pose_errors(scene.truth, est)
        advice.paths.append(res)
    if not advice.paths:
        advice.notes.append(f"no straight walk of at least {min_path_m:.1f} m fits the area")
    return advice


def format_advice(advice: Advice) -> str:
    """A readable report for an installer."""
    r = advice.region
    lines = [f"Camera {advice.camera!r} ({advice.image_size[0]}x{advice.image_size[1]} px)"]
    ext = r.extent
    if ext is None:
        lines.append("  Gait cannot be measured anywhere on the floor.")
    else:
        lines.append(
            f"  Floor area where gait can be measured: {r.area_m2:.1f} m^2 "
            f"(x {ext[0]:.1f} .. {ext[1]:.1f} m, y {ext[2]:.1f} .. {ext[3]:.1f} m)"
        )
        if advice.distance_m is not None:
            lines.append(
                f"  From {advice.distance_m[0]:.1f} m to {advice.distance_m[1]:.1f} m from the "
                "camera (horizontal distance)."
            )
        lines.append(
            f"  A 1.8 m person is {r.person_px.min():.0f} .. {r.person_px.max():.0f} px tall "
            f"there (minimum {advice.min_person_px:.0f} px)."
        )
    if advice.paths:
        lines.append("  Rendered walks:")
        for p in advice.paths:
            line = (
                f"    {p.label:<20} {p.length_m:4.1f} m, {p.frames:3d} frames: whole body in view "
                f"{p.whole_body_pct:5.1f} %, person {p.person_px_range[0]:.0f}-"
                f"{p.person_px_range[1]:.0f} px"
            )
            if p.error_mm is not None:
                line += (
                    f"; error {p.error_mm:.0f} mm (lower limbs {p.lower_limb_error_mm:.0f} mm), "
                    f"{p.frames_lost} frames lost"
                )
            lines.append(line)
    if advice.tracker is None:
        lines.append(
            "  Accuracy: not measured (no tracker given); the figures above are geometric."
        )
    else:
        errs = [p.error_mm for p in advice.paths if p.error_mm is not None]
        if errs:
            lines.append(f"  Accuracy ({advice.tracker}): mean error {np.nanmean(errs):.0f} mm.")
    for note in advice.notes:
        lines.append(f"  Note: {note}")
    return "\n".join(lines)


def advice_overlay(camera: Camera, region: FloorRegion, background: np.ndarray) -> np.ndarray:
    """The background (H, W, 3) uint8 RGB with the measurable floor tinted green."""
    import cv2

    out = background.copy()
    if not len(region.cells):
        return out
    h = region.cell_m / 2
    corners = np.stack(
        [
            region.cells + [-h, -h],
            region.cells + [h, -h],
            region.cells + [h, h],
            region.cells + [-h, h],
        ],
        1,
    )
    corners = np.concatenate([corners, np.zeros(corners.shape[:2] + (1,))], -1)
    px = camera.project(corners)
    mask = np.zeros(out.shape[:2], np.uint8)
    for quad in px:
        if np.isfinite(quad).all():
            cv2.fillConvexPoly(mask, np.rint(quad).astype(np.int32), 1)
    green = np.array([40, 200, 60], dtype=np.float32)
    sel = mask.astype(bool)
    out[sel] = (0.55 * out[sel] + 0.45 * green).astype(np.uint8)
    return out
