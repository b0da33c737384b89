"""Assemble and render a synthetic scene: motion + body + room + cameras + light + noise.

:func:`build_scene` prepares everything that does not change frame to frame (ground truth at
the video rate, the body, default camera placements around the walk or site cameras, the room,
one backdrop per camera, the light over time); :func:`render_frames` then yields, frame by
frame, one 8-bit RGB image and one person mask per camera. :func:`render_background` gives the
empty scene at frame 0's lighting.

Random streams: one ``numpy.random.SeedSequence(seed)`` spawns independent generators for the
room, the body's colours, the lighting, the background images' noise and each camera's frame
noise, so a scene is identical for identical settings and seed.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from gait.bouts import BoutSettings
from gaitwatch.conventions import HEAD, L_HIP, L_TOE, R_HIP, R_TOE, SACRUM
from gaitwatch.sim.motion import (
    complete_for_render,
    resample,
    scale_to_stature,
    stature_of,
    walking_direction,
)
from gaitwatch.sim.person import BodyModel, Mesh
from gaitwatch.sim.render import LABEL_FLOOR, LABEL_PERSON, LightRig, draw_person, shadow_coverage
from gaitwatch.sim.room import (
    LABEL_FURNITURE,
    Backdrop,
    Box,
    RoomScene,
    furniture,
    render_backdrop,
)
from gaitwatch.sim.scene import ResolvedBody, SceneConfig, resolve_body
from gaitwatch.trajectory import Trajectory
from tracker.camera import Camera

log = logging.getLogger(__name__)

UP = np.array([0.0, 0.0, 1.0])


@dataclass
class Scene:
    """A scene ready to render.

    Attributes
    ----------
    config : SceneConfig
    truth : Trajectory
        Ground truth at the video rate (frame k at ``k / fps`` s), all 19 key points finite.
    synthesised : list of str
        Key points absent from the source and filled in (see ``motion.complete_for_render``).
    body : ResolvedBody
    cameras : list of Camera
    room : RoomScene
    backdrops : list of Backdrop
        One per camera.
    gain : ndarray (T,)
        Global light gain per frame (1 at frame 0).
    lamp_on : ndarray (T,)
        Lamp level per frame in [0, 1].
    """

    config: SceneConfig
    truth: Trajectory
    synthesised: list[str]
    body: ResolvedBody
    cameras: list[Camera]
    room: RoomScene
    backdrops: list[Backdrop]
    gain: np.ndarray
    lamp_on: np.ndarray
    seedseq: np.random.SeedSequence
    source: str = ""
    model: BodyModel = field(init=False)

    def __post_init__(self) -> None:
        self.model = BodyModel(self.body)

    @property
    def n_frames(self) -> int:
        return len(self.truth)


def _path_frame(truth: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Centre (3,), walking direction d (3,), its left n (3,) and the path length (m)."""
    s = truth.positions[:, SACRUM].copy()
    s[:, 2] = 0
    d = walking_direction(truth)
    if d is None:  # walking on the spot (treadmill): the body's forward axis from the hips
        lat = np.nanmean(truth.positions[:, L_HIP] - truth.positions[:, R_HIP], axis=0)
        lat[2] = 0
        d = np.cross(lat, UP)
        d = d / np.linalg.norm(d) if np.linalg.norm(d) > 1e-9 else np.array([1.0, 0.0, 0.0])
    n = np.cross(UP, d)
    along = s @ d
    across = s @ n
    centre = d * 0.5 * (along.min() + along.max()) + n * 0.5 * (across.min() + across.max())
    return centre, d, n, float(along.max() - along.min())


def _extent_points(truth: Trajectory, step: int) -> np.ndarray:
    """Key points plus head top and toe tips of every ``step``-th frame, for framing."""
    p = truth.positions[::step]
    S = stature_of(truth)
    top = p[:, HEAD] + 0.08 * S * UP
    return np.concatenate([p.reshape(-1, 3), top, p[:, L_TOE], p[:, R_TOE]])


def default_cameras(truth: Trajectory, config: SceneConfig) -> list[Camera]:
    """Home-camera placements (side, oblique, frontal) around the walk, as close as possible
    with the whole body in view in every frame (4 % margin).

    side: on the walker's left, looking across the path; oblique: 45 degrees ahead-left;
    frontal: ahead on the path, the walker approaching. All at ``camera_height_m`` looking at
    a point 0.8 m above the path's centre.
    """
    centre, d, n, length = _path_frame(truth)
    pts = _extent_points(truth, max(1, len(truth) // 40))
    w, h = config.image_size
    dirs = {"side": n, "oblique": (n + d) / math.sqrt(2), "frontal": d}
    cams = []
    for i, view in enumerate(config.views):
        u = dirs[view]
        best = None
        for dist in np.arange(1.5, 25.0, 0.1):
            pos = centre + u * dist + UP * config.camera_height_m
            if view == "frontal" and dist < 0.5 * length + 1.0:
                continue
            cam = Camera.look_at(
                name=f"cam{i}-{view}",
                position=pos,
                target=centre + 0.8 * UP,
                image_size=(w, h),
                hfov_deg=config.hfov_deg,
                fps=config.fps,
            )
            px = cam.project(pts)
            m = 0.04 * w
            if (
                np.isfinite(px).all()
                and (px[:, 0] > m).all()
                and (px[:, 0] < w - m).all()
                and (px[:, 1] > m).all()
                and (px[:, 1] < h - m).all()
            ):
                best = cam
                break
        if best is None:
            raise ValueError(f"no {view} camera position frames the whole walk")
        cams.append(best)
    return cams


def _lighting(
    config: SceneConfig, n: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Gain (n,) and lamp level (n,) per frame: three slow sines (2-12 s periods) with gain 1 at
    frame 0 and |gain - 1| <= drift_amplitude; ``switch`` turns the lamp off over two frames."""
    lt = config.lighting
    t = np.arange(n) / config.fps
    gain = np.ones(n)
    periods = rng.uniform(2.0, 12.0, 3)
    phases = rng.uniform(0, 2 * np.pi, 3)
    if lt.mode in ("drift", "switch") and lt.drift_amplitude > 0:
        wave = sum(
            np.sin(2 * np.pi * t / p + ph) - np.sin(ph)
            for p, ph in zip(periods, phases, strict=True)
        )
        gain = 1 + lt.drift_amplitude * wave / 6.0  # each term lies in [-2, 2]
    lamp = np.ones(n)
    if lt.mode == "switch":
        ts = lt.switch_time_s if lt.switch_time_s is not None else 0.5 * t[-1]
        lamp = np.clip(1 - (t - ts) * config.fps / 2.0, 0, 1)  # off over two frames
    return gain, lamp


def _place_occluder(
    kind: str, camera: Camera, truth: Trajectory, rng: np.random.Generator
) -> list[Box]:
    """Furniture between ``camera`` and the walk, as close to the path as clearance allows."""
    s = truth.positions[:, SACRUM, :2]
    c = camera.center[:2]
    d2 = np.sum((s - c) ** 2, axis=1)
    p = s[np.argsort(d2)[len(d2) // 3]]  # a point on the near part of the path
    mid = 0.5 * (s.min(axis=0) + s.max(axis=0))
    p = 0.5 * (p + mid)
    u = c - p
    dist_cam = float(np.linalg.norm(u))
    u /= max(dist_cam, 1e-9)
    yaw = math.atan2(u[1], u[0])
    for gap in np.arange(0.75, max(0.8, dist_cam - 0.6), 0.05):
        boxes = furniture(kind, p + gap * u, yaw, rng)
        clear = min(float(b.footprint_distance(s).min()) for b in boxes)
        if clear > 0.3:
            return boxes
    log.warning("no room for a %s between %s and the walk; none placed", kind, camera.name)
    return []


#: Sitting, for the chairs: the sacrum below this fraction of its standing height (its 90th
#: percentile over the recording): the gait analysis's sitting threshold ...
SEATED_FRACTION = BoutSettings.sitting_height_fraction
#: ... for at least this long (s).
SEATED_MIN_S = 0.5
#: The hip centres' height over the seat of someone seated (m).
HIP_OVER_SEAT_M = 0.09


def _place_chairs(truth: Trajectory, rng: np.random.Generator) -> list[Box]:
    """A chair under each place where the person sits: the seat's centre under the hip
    centres, its top a little below them (the buttocks' flesh, ``HIP_OVER_SEAT_M``), facing
    the way the person faces; sittings within 0.3 m of each other share a chair."""
    pos = truth.positions
    sac = pos[:, SACRUM, 2]
    if not np.isfinite(sac).any():
        return []
    low = sac < SEATED_FRACTION * np.nanpercentile(sac, 90)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], low.astype(int), [0]])))
    boxes: list[Box] = []
    placed: list[np.ndarray] = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if (b - a) / truth.fps < SEATED_MIN_S:
            continue
        hips = 0.5 * (pos[a:b, L_HIP] + pos[a:b, R_HIP])
        across = np.nanmedian(pos[a:b, L_HIP, :2] - pos[a:b, R_HIP, :2], 0)
        if not (np.isfinite(hips).any() and np.isfinite(across).all()):
            continue
        forward = np.array([across[1], -across[0]]) / max(float(np.linalg.norm(across)), 1e-9)
        centre = np.nanmedian(hips[:, :2], axis=0)
        if any(np.linalg.norm(centre - q) < 0.3 for q in placed):
            continue
        seat = float(np.clip(np.nanmedian(hips[:, 2]) - HIP_OVER_SEAT_M, 0.2, 0.6))
        yaw = math.atan2(forward[1], forward[0])
        boxes += furniture("chair", centre, yaw, rng, seat_height_m=seat)
        placed.append(centre)
    if not boxes:
        log.warning("nobody sits in this motion; no chair placed")
    return boxes


def build_scene(
    motion: Trajectory,
    config: SceneConfig,
    cameras: Sequence[Camera] | None = None,
) -> Scene:
    """Prepare a scene: truth at the video rate, body, cameras, room, backdrops, light.

    Parameters
    ----------
    motion : Trajectory
        Source motion (any rate; NaN key points are filled, see ``complete_for_render``).
    config : SceneConfig
    cameras : list of Camera, optional
        Site cameras (resized to ``config.image_size`` if needed); default placements from
        ``config.views`` around the walk otherwise.
    """
    ss = np.random.SeedSequence(config.seed)
    r_room, r_body, r_light, r_furn = (np.random.default_rng(s) for s in ss.spawn(4))
    filled, synthesised = complete_for_render(motion)
    if config.body.height_m is not None or config.body.preset in ("tall", "short"):
        from gaitwatch.sim.scene import SHAPE_PRESETS

        target = config.body.height_m or SHAPE_PRESETS[config.body.preset][0]
        filled = scale_to_stature(filled, float(target))
    truth = resample(filled, config.fps, config.max_frames)
    if len(truth) < 1:
        raise ValueError("the motion is shorter than one video frame")
    stature = stature_of(truth)
    body = resolve_body(config.body, config.clothing, stature, r_body)
    body = body.model_copy(update={"stature_m": stature})
    w, h = config.image_size
    if cameras:
        cams = []
        for c in cameras:
            c2 = c if (c.width, c.height) == (w, h) else c.scaled(w, h)
            # the written camera file carries the video's frame rate
            c2 = Camera.from_params(
                name=c2.name, image_size=(w, h), K=c2.K, R=c2.R, t=c2.t, dist=c2.dist.tolist(),
                fps=config.fps,
            )  # fmt: skip
            c2.source = c.source
            cams.append(c2)
    else:
        cams = default_cameras(truth, config)
    centre, d, n, _ = _path_frame(truth)
    # room: the walk with a margin, and the cameras just inside the walls
    s = truth.positions[:, :, :2].reshape(-1, 2)
    pts = np.concatenate(
        [
            s.min(0, keepdims=True) - config.room.margin_m,
            s.max(0, keepdims=True) + config.room.margin_m,
        ]
        + [c.center[None, :2] - 0.3 for c in cams]
        + [c.center[None, :2] + 0.3 for c in cams]
    )
    height = max(config.room.height_m, max(c.center[2] for c in cams) + 0.3)
    lamp = centre + 0.6 * n + (height - 0.05) * UP
    lights = LightRig(
        lamp=lamp, ambient=config.lighting.ambient, lamp_power=config.lighting.lamp_power
    )
    kind = config.room.floor
    if kind == "random":
        kind = ("wood", "tiles")[int(r_room.integers(2))]
    room = RoomScene(
        xmin=float(pts[:, 0].min()),
        xmax=float(pts[:, 0].max()),
        ymin=float(pts[:, 1].min()),
        ymax=float(pts[:, 1].max()),
        height=float(height),
        lights=lights,
        rng=r_room,
        floor_kind=kind,
    )
    if config.room.occluder == "chair":
        room.furniture = _place_chairs(truth, r_furn)
    elif config.room.occluder != "none":
        room.furniture = _place_occluder(config.room.occluder, cams[0], truth, r_furn)
    backdrops = [render_backdrop(room, c) for c in cams]
    gain, lamp_on = _lighting(config, len(truth), r_light)
    return Scene(
        config=config,
        truth=truth,
        synthesised=synthesised,
        body=body,
        cameras=cams,
        room=room,
        backdrops=backdrops,
        gain=gain,
        lamp_on=lamp_on,
        seedseq=ss,
        source=motion.source,
    )


def _finish(scene: Scene, img: np.ndarray, gain: float, rng: np.random.Generator) -> np.ndarray:
    """Gain, optical blur, sensor noise, 8-bit quantisation: linear RGB -> uint8 RGB."""
    nz = scene.config.noise
    out = img.astype(np.float32) * np.float32(gain * 255.0)
    if nz.blur_px > 0:
        out = cv2.GaussianBlur(out, (0, 0), nz.blur_px)
    if nz.sigma_dn > 0:
        noise = rng.standard_normal(out.shape, dtype=np.float32)
        noise *= np.float32(nz.sigma_dn)
        out += noise
    out += np.float32(0.5)
    np.clip(out, 0, 255, out=out)
    img8 = out.astype(np.uint8)
    if nz.jpeg_quality is not None:
        ok, buf = cv2.imencode(".jpg", img8, [cv2.IMWRITE_JPEG_QUALITY, int(nz.jpeg_quality)])
        if ok:
            img8 = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
    return img8


def compose(
    scene: Scene, cam_index: int, frame: int, mesh: Mesh | None
) -> tuple[np.ndarray, np.ndarray]:
    """Linear RGB image (H, W, 3) and person mask (H, W) of one camera at one frame, before
    gain and sensor effects. ``mesh=None`` gives the empty scene."""
    bd = scene.backdrops[cam_index]
    cam = scene.cameras[cam_index]
    lt = scene.config.lighting
    on = float(scene.lamp_on[frame])
    lamp = bd.lamp
    if mesh is not None and on > 0 and lt.shadow_strength > 0:
        # soft shadow: drawn at half resolution, blurred, scaled back up
        h, w = bd.depth.shape
        small = cam.scaled(max(w // 2, 1), max(h // 2, 1))
        depth_small = cv2.resize(
            bd.depth, (small.width, small.height), interpolation=cv2.INTER_NEAREST
        )
        cov = shadow_coverage(small, mesh, scene.room.lights.lamp, depth_small)
        if lt.shadow_blur_px > 0:
            cov = cv2.GaussianBlur(cov, (0, 0), max(lt.shadow_blur_px / 2, 0.5))
        cov = cv2.resize(cov, (w, h), interpolation=cv2.INTER_LINEAR)
        cov *= bd.labels == LABEL_FLOOR
        lamp = lamp * (1 - np.float32(lt.shadow_strength) * cov)[..., None]
    img = bd.ambient + np.float32(on) * lamp
    labels = bd.labels.copy()
    if mesh is not None:
        zbuf = bd.depth.copy()
        draw_person(cam, mesh, scene.room.lights, on, zbuf, img, labels, scene.model.pattern)
    return img, labels == LABEL_PERSON


def render_background(scene: Scene, cam_index: int) -> np.ndarray:
    """The empty scene (8-bit RGB) at frame 0's lighting, with its own sensor noise."""
    rng = np.random.default_rng(_child(scene, 100 + cam_index))
    img, _ = compose(scene, cam_index, 0, None)
    return _finish(scene, img, float(scene.gain[0]), rng)


def occluder_mask(scene: Scene, cam_index: int) -> np.ndarray | None:
    """The furniture's pixels in one camera (bool (H, W)), what an installer would mark for
    ``gaitwatch track --occluder``; None when the room has no furniture in view."""
    mask = scene.backdrops[cam_index].labels == LABEL_FURNITURE
    return mask if mask.any() else None


def _child(scene: Scene, key: int) -> np.random.SeedSequence:
    return np.random.SeedSequence(scene.seedseq.entropy, spawn_key=(1000 + key,))


def render_frames(
    scene: Scene, cams: Sequence[int] | None = None
) -> Iterator[tuple[int, list[np.ndarray], list[np.ndarray]]]:
    """Yield ``(frame, images, masks)``: 8-bit RGB images (H, W, 3) and boolean person masks
    (H, W), one per camera (all, or those listed in ``cams``)."""
    idx = list(range(len(scene.cameras))) if cams is None else list(cams)
    rngs = [np.random.default_rng(_child(scene, i)) for i in idx]
    for k in range(scene.n_frames):
        mesh = scene.model.mesh(scene.truth.positions[k])
        images, masks = [], []
        for i, rng in zip(idx, rngs, strict=True):
            img, mask = compose(scene, i, k, mesh)
            images.append(_finish(scene, img, float(scene.gain[k]), rng))
            masks.append(mask)
        yield k, images, masks
