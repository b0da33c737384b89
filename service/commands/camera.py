"""``gaitwatch camera check CAM.yaml [IMAGE] [--out OUT.png]``: is this calibration right?

Validates a camera file (``tracker.camera.load_camera``) and prints what it says in words a
person can check against the room: where the camera is, how high, where it looks, and which part
of the floor it sees. Given an image from that camera, it draws the floor grid (every 0.5 m by
default) over the floor area the camera sees and the world axes at the origin (x red, y green,
z blue, 1 m long), and writes the result next to the image (``IMAGE-check.png``) or to
``--out``. If the grid does not lie on the floor in the picture, the calibration is wrong.
"""

from __future__ import annotations

import argparse
import logging
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from gaitwatch.errors import InputError
from service.video import IMAGE_SUFFIXES, VideoError, open_source, read_image
from tracker.camera import Camera, check_image_size, load_camera

log = logging.getLogger(__name__)

# BGR colours of the drawing.
AXIS_COLOURS = {"x": (0, 0, 255), "y": (0, 200, 0), "z": (255, 0, 0)}
GRID_COLOUR = (170, 170, 170)
GRID_METRE_COLOUR = (245, 245, 245)
ORIGIN_COLOUR = (0, 255, 255)

_NEAR_M = 0.05  # points closer than this to the camera plane are not drawn
_MAX_GRID_LINES = 400


class ImageCheckError(InputError):
    """The image given to ``camera check`` cannot be used or the output cannot be written."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("camera", help="camera file tools (check a calibration)")
    csub = p.add_subparsers(dest="camera_command", metavar="ACTION")
    c = csub.add_parser(
        "check",
        help="validate a camera file, summarise it, and draw the floor grid on an image",
        description=__doc__.split("\n\n", 1)[1] if __doc__ else None,
    )
    c.add_argument("camera", metavar="CAM.yaml", type=Path, help="camera file (CONVENTIONS)")
    c.add_argument(
        "image",
        metavar="IMAGE",
        type=Path,
        nargs="?",
        help="a frame from this camera (an image, or a video or frame folder whose first "
        "frame is used) to draw the floor grid and world axes on",
    )
    c.add_argument(
        "--out",
        type=Path,
        help="output PNG (default: IMAGE stem + '-check.png' beside IMAGE; without IMAGE the "
        "drawing is made on a grey canvas of the camera's image size)",
    )
    c.add_argument("--grid", type=float, default=0.5, help="grid spacing in metres (0.5)")
    c.add_argument(
        "--max-range",
        type=float,
        default=15.0,
        help="ignore floor farther than this from the camera, metres (15)",
    )
    c.set_defaults(func=run_check)

    def _no_action(args: argparse.Namespace) -> int:
        p.print_help()
        return 2

    p.set_defaults(func=_no_action)


# -- geometry -----------------------------------------------------------------------------------
def _border_pixels(camera: Camera, per_edge: int = 64) -> np.ndarray:
    """Pixels around the image border, clockwise from the top-left corner, shape (4*per_edge, 2)."""
    w, h = camera.width - 1.0, camera.height - 1.0
    s = np.linspace(0.0, 1.0, per_edge, endpoint=False)
    top = np.stack([s * w, np.zeros_like(s)], axis=1)
    right = np.stack([np.full_like(s, w), s * h], axis=1)
    bottom = np.stack([(1 - s) * w, np.full_like(s, h)], axis=1)
    left = np.stack([np.zeros_like(s), (1 - s) * h], axis=1)
    return np.concatenate([top, right, bottom, left])


def visible_floor(camera: Camera, max_range: float = 15.0, per_edge: int = 64) -> np.ndarray:
    """Polygon (N, 2) of floor points (x, y in metres) the camera sees, within ``max_range``.

    The rays through the image border are intersected with the floor; a ray that misses the
    floor, or meets it farther than ``max_range`` (horizontal distance from the camera), is cut
    at ``max_range`` in its horizontal direction. Empty (0, 2) when the camera is not above
    the floor.
    """
    c = camera.center
    if c[2] <= 0:
        return np.zeros((0, 2))
    d = camera.pixel_rays(_border_pixels(camera, per_edge))
    hn = np.linalg.norm(d[:, :2], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(d[:, 2] < 0, -c[2] / d[:, 2], np.inf)
        hit = c[:2] + s[:, None] * d[:, :2]
        far = c[:2] + max_range * d[:, :2] / hn[:, None]
    use_far = (s * hn > max_range) | ~np.isfinite(s)
    pts = np.where(use_far[:, None], far, hit)
    return pts[np.all(np.isfinite(pts), axis=1)]


def polygon_area(poly: np.ndarray) -> float:
    """Area of a simple polygon (N, 2) by the shoelace formula."""
    if len(poly) < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


@dataclass
class _View:
    """What to keep of a projection: normalised-coordinate bounds of the field of view."""

    xlim: tuple[float, float]
    ylim: tuple[float, float]


def _field_of_view(camera: Camera) -> _View:
    """Bounds of the undistorted normalised coordinates of the image, with a margin."""
    px = _border_pixels(camera, 32).reshape(-1, 1, 2)
    und = cv2.undistortPoints(px, camera.K, camera.dist if camera.dist.size else None)
    und = und.reshape(-1, 2)
    lo, hi = und.min(axis=0), und.max(axis=0)
    m = 0.1 * (hi - lo)
    return _View((lo[0] - m[0], hi[0] + m[0]), (lo[1] - m[1], hi[1] + m[1]))


def _project_visible(camera: Camera, view: _View, pts: np.ndarray) -> np.ndarray:
    """Project world points (N, 3) to pixels (N, 2); NaN behind the camera or far outside view.

    Points outside the (slightly enlarged) field of view are dropped because polynomial lens
    distortion folds them back into the image at false places.
    """
    pc = camera.to_camera(pts)
    z = pc[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        xn, yn = pc[:, 0] / z, pc[:, 1] / z
    ok = (
        (z > _NEAR_M)
        & (xn >= view.xlim[0])
        & (xn <= view.xlim[1])
        & (yn >= view.ylim[0])
        & (yn <= view.ylim[1])
    )
    uv = camera.project(pts)
    uv[~ok] = np.nan
    return uv


def _draw_polyline(
    img: np.ndarray, uv: np.ndarray, colour: tuple[int, int, int], thickness: int
) -> None:
    """Draw the runs of consecutive finite points of uv (N, 2) as anti-aliased polylines."""
    ok = np.all(np.isfinite(uv), axis=1)
    if ok.sum() < 2:
        return
    # Split into runs of consecutive valid points.
    idx = np.flatnonzero(ok)
    breaks = np.flatnonzero(np.diff(idx) > 1) + 1
    shift = 4
    for run in np.split(idx, breaks):
        if run.size < 2:
            continue
        pts = np.round(uv[run] * (1 << shift)).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(img, [pts], False, colour, thickness, cv2.LINE_AA, shift)


def _segment(a: np.ndarray, b: np.ndarray, step: float) -> np.ndarray:
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
    s = np.linspace(0.0, 1.0, n)[:, None]
    return a + s * (b - a)


def draw_check(
    camera: Camera, image: np.ndarray, grid: float = 0.5, max_range: float = 15.0
) -> np.ndarray:
    """Draw the floor grid and the world axes on a copy of ``image`` (uint8 H x W x 3 BGR).

    Grid lines every ``grid`` metres over the floor area the camera sees (whole metres
    brighter); axes from the origin, 1 m long: x red, y green, z blue; the origin a yellow dot.
    """
    out = image.copy()
    th = max(1, round(camera.width / 640))
    view = _field_of_view(camera)
    poly = visible_floor(camera, max_range)
    if len(poly) >= 3:
        lo = np.floor(poly.min(axis=0) / grid) * grid
        hi = np.ceil(poly.max(axis=0) / grid) * grid
        n_lines = (hi - lo) / grid + 1
        if n_lines.sum() > _MAX_GRID_LINES:
            f = float(np.ceil(n_lines.sum() / _MAX_GRID_LINES))
            log.warning("floor area large: grid spacing %.2f m instead of %.2f m", grid * f, grid)
            grid *= f
        step = min(grid / 8, 0.05)
        for axis in (0, 1):  # lines of constant x, then of constant y
            other = 1 - axis
            for v in np.arange(lo[axis], hi[axis] + grid / 2, grid):
                a = np.zeros(3)
                b = np.zeros(3)
                a[axis] = b[axis] = v
                a[other], b[other] = lo[other], hi[other]
                whole = abs(v - round(v)) < 1e-6
                _draw_polyline(
                    out,
                    _project_visible(camera, view, _segment(a, b, step)),
                    GRID_METRE_COLOUR if whole else GRID_COLOUR,
                    th,
                )
    origin = np.zeros(3)
    for i, name in enumerate("xyz"):
        tip = np.zeros(3)
        tip[i] = 1.0
        uv = _project_visible(camera, view, _segment(origin, tip, 0.01))
        _draw_polyline(out, uv, AXIS_COLOURS[name], 3 * th)
        end = uv[-1]
        if np.all(np.isfinite(end)):
            cv2.putText(
                out,
                name,
                (int(end[0]) + 4 * th, int(end[1]) - 4 * th),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.6 * th,
                AXIS_COLOURS[name],
                max(1, th),
                cv2.LINE_AA,
            )
    o = _project_visible(camera, view, origin[None])[0]
    if np.all(np.isfinite(o)):
        cv2.circle(out, (int(round(o[0])), int(round(o[1]))), 4 * th, ORIGIN_COLOUR, -1)
    return out


# -- summary ------------------------------------------------------------------------------------
def summary(camera: Camera, source: str, max_range: float = 15.0) -> list[str]:
    """Lines describing the camera for a person: placement, orientation, floor seen."""
    K = camera.K
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    hfov = np.degrees(2 * np.arctan2(camera.width / 2, fx))
    vfov = np.degrees(2 * np.arctan2(camera.height / 2, fy))
    c = camera.center
    fwd = camera.R[2]  # optical axis in the world
    right = camera.R[0]  # image x axis in the world
    heading = np.degrees(np.arctan2(fwd[1], fwd[0]))
    heading_txt = (
        f"heading {heading:.1f} deg (from +x towards +y)"
        if np.hypot(fwd[0], fwd[1]) > 1e-6
        else "straight down or up"
    )
    tilt = np.degrees(-np.arcsin(np.clip(fwd[2], -1, 1)))
    roll = round(float(np.degrees(np.arcsin(np.clip(-right[2], -1, 1)))), 1) + 0.0  # not -0.0
    dist = (
        "none"
        if camera.dist.size == 0 or not np.any(camera.dist)
        else f"{camera.dist.size} coefficients [" + ", ".join(f"{v:.4g}" for v in camera.dist) + "]"
    )
    lines = [
        f"camera {camera.name!r} ({source}): valid",
        f"  image: {camera.width}x{camera.height} px, {camera.fps:g} fps",
        f"  focal: fx={fx:.1f} fy={fy:.1f} px, principal point ({cx:.1f}, {cy:.1f}); "
        f"field of view {hfov:.1f} x {vfov:.1f} deg",
        f"  distortion: {dist}",
        f"  centre (world): x={c[0]:.3f} y={c[1]:.3f} z={c[2]:.3f} m; "
        f"height above floor {c[2]:.2f} m",
        f"  looking along ({fwd[0]:.3f}, {fwd[1]:.3f}, {fwd[2]:.3f}): {heading_txt}, "
        f"tilt {abs(tilt):.1f} deg "
        f"{'below' if tilt >= 0 else 'above'} horizontal, roll {roll:.1f} deg",
    ]
    poly = visible_floor(camera, max_range)
    if len(poly) < 3:
        lines.append("  floor seen: none (the camera is not above the floor or looks up)")
    else:
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        lines.append(
            f"  floor seen (within {max_range:g} m): x {lo[0]:.2f} .. {hi[0]:.2f} m, "
            f"y {lo[1]:.2f} .. {hi[1]:.2f} m, area {polygon_area(poly):.1f} m2"
        )
        w, h = camera.width - 1, camera.height - 1
        corners = {
            "bottom-left": (0, h),
            "bottom-right": (w, h),
            "top-right": (w, 0),
            "top-left": (0, 0),
        }
        hits = camera.pixel_to_floor(np.array(list(corners.values()), dtype=float))
        parts = []
        for name, p in zip(corners, hits, strict=True):
            horiz = np.hypot(*(p[:2] - c[:2])) if np.all(np.isfinite(p)) else np.inf
            if np.isfinite(horiz) and horiz <= max_range:
                parts.append(f"{name} ({p[0]:.2f}, {p[1]:.2f})")
            else:
                parts.append(f"{name} beyond {max_range:g} m or above the horizon")
        lines.append("  image corners on the floor: " + "; ".join(parts))
    o = _project_visible(camera, _field_of_view(camera), np.zeros((1, 3)))[0]
    if np.all(np.isfinite(o)) and 0 <= o[0] < camera.width and 0 <= o[1] < camera.height:
        lines.append(f"  world origin at pixel ({o[0]:.1f}, {o[1]:.1f})")
    else:
        lines.append("  world origin: not in view")
    if c[2] <= 0:
        lines.append("  warning: the camera centre is not above the floor (z <= 0)")
    if tilt < 0:
        lines.append("  warning: the camera looks upwards; is R the world -> camera rotation?")
    return lines


def _first_image(path: Path) -> np.ndarray:
    """An image file, or the first frame of a video or frame folder (uint8 BGR)."""
    if path.is_file() and path.suffix.lower() in IMAGE_SUFFIXES | {".bmp", ".tif", ".tiff"}:
        return read_image(path)
    try:
        return read_image(path)
    except VideoError:
        pass
    with open_source(path, fps=1.0) as src:
        return next(iter(src)).image


def run_check(args: argparse.Namespace) -> int:
    camera = load_camera(args.camera)
    if args.grid <= 0:
        raise InputError(f"--grid: must be positive, not {args.grid}")
    if args.max_range <= 0:
        raise InputError(f"--max-range: must be positive, not {args.max_range}")
    for line in summary(camera, str(args.camera), args.max_range):
        print(line)
    if args.image is None and args.out is None:
        return 0
    if args.image is not None:
        image = _first_image(args.image)
        check_image_size(camera, image.shape[1], image.shape[0], what=f"the image {args.image}")
        out = args.out or args.image.with_name(args.image.stem + "-check.png")
    else:
        image = np.full((camera.height, camera.width, 3), 90, np.uint8)
        out = args.out
    drawn = draw_check(camera, image, args.grid, args.max_range)
    try:
        ok = cv2.imwrite(str(out), drawn)
    except cv2.error as err:
        raise ImageCheckError(f"{out}: cannot write the image ({err.err})") from None
    if not ok:
        raise ImageCheckError(f"{out}: cannot write the image")
    print(f"wrote {out}")
    return 0
