"""The room: a box with procedurally textured floor and walls, furniture and a ceiling lamp.

Textures are evaluated at the world point each pixel's ray meets (perspective-correct by
construction), at 2x2 samples per pixel averaged down. Everything random comes from the
injected generator: plank or tile layout and colours, wall paint and its mottling, pictures and
a door on the walls, furniture fabric.

A :class:`Backdrop` is the empty room seen by one camera, split into the part lit by the
ambient light and the part lit by the lamp (so the lamp can switch off and cast the person's
shadow), with a depth buffer and a surface label per pixel; the person is drawn into copies of
it, so furniture occludes the person correctly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import map_coordinates

from gaitwatch.sim.render import (
    LABEL_FLOOR,
    LABEL_FURNITURE,
    LABEL_ROOM,
    LightRig,
    project_mesh,
    rasterize,
)
from tracker.camera import Camera

FLOOR, CEILING, WALL_X0, WALL_X1, WALL_Y0, WALL_Y1 = range(6)


class ValueNoise:
    """Smooth 2-D value noise: a random grid sampled bilinearly with wrap-around."""

    def __init__(self, rng: np.random.Generator, size: int = 64) -> None:
        self.grid = rng.random((size, size))

    def __call__(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return map_coordinates(self.grid, [u, v], order=1, mode="grid-wrap")

    def fractal(self, u: np.ndarray, v: np.ndarray, octaves: int = 3) -> np.ndarray:
        out, amp, norm = np.zeros_like(u), 1.0, 0.0
        for o in range(octaves):
            f = 2.0**o
            out += amp * self(u * f + 17.3 * o, v * f + 5.1 * o)
            norm += amp
            amp *= 0.5
        return out / norm - 0.5  # about -0.5..0.5, mean 0


@dataclass
class Box:
    """An axis-aligned (in its own yaw) box: centre of its base on the floor, size, colour."""

    centre: tuple[float, float, float]
    size: tuple[float, float, float]  # along its x, y, z
    yaw: float
    colour: tuple[float, float, float]

    def mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vertices (24, 3), flat normals (24, 3), triangles (12, 3)."""
        hx, hy, hz = self.size[0] / 2, self.size[1] / 2, self.size[2]
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        faces = [  # (normal, four corners counter-clockwise seen from outside)
            ((1, 0, 0), [(hx, -hy, 0), (hx, hy, 0), (hx, hy, hz), (hx, -hy, hz)]),
            ((-1, 0, 0), [(-hx, hy, 0), (-hx, -hy, 0), (-hx, -hy, hz), (-hx, hy, hz)]),
            ((0, 1, 0), [(hx, hy, 0), (-hx, hy, 0), (-hx, hy, hz), (hx, hy, hz)]),
            ((0, -1, 0), [(-hx, -hy, 0), (hx, -hy, 0), (hx, -hy, hz), (-hx, -hy, hz)]),
            ((0, 0, 1), [(-hx, -hy, hz), (hx, -hy, hz), (hx, hy, hz), (-hx, hy, hz)]),
            ((0, 0, -1), [(-hx, hy, 0), (hx, hy, 0), (hx, -hy, 0), (-hx, -hy, 0)]),
        ]
        verts, norms, tris = [], [], []
        for i, (n, corners) in enumerate(faces):
            verts += corners
            norms += [n] * 4
            tris += [(4 * i, 4 * i + 1, 4 * i + 2), (4 * i, 4 * i + 2, 4 * i + 3)]
        v = np.asarray(verts, float) @ rot.T + np.asarray(self.centre)
        return v, np.asarray(norms, float) @ rot.T, np.asarray(tris, np.int64)

    def footprint_distance(self, xy: np.ndarray) -> np.ndarray:
        """Horizontal distance (N,) from points (N, 2) to the box's footprint (0 inside)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        d = np.asarray(xy, float) - np.asarray(self.centre[:2])
        local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], 1)
        q = np.abs(local) - np.array([self.size[0] / 2, self.size[1] / 2])
        return np.linalg.norm(np.maximum(q, 0), axis=1)


def furniture(
    kind: str,
    centre_xy: np.ndarray,
    yaw: float,
    rng: np.random.Generator,
    seat_height_m: float = 0.45,
) -> list[Box]:
    """Boxes of a piece of furniture; its long side along the yaw direction's perpendicular.

    ``yaw`` is the direction the front faces (towards the camera); a sofa's back is on the far
    side, so from the camera one sees its seat and back, which hide the legs behind it. A chair
    (``centre_xy`` the seat's centre, ``yaw`` the way a seated person faces) is a closed seat
    block ``seat_height_m`` high, 0.44 m square, with a back 0.45 m above the seat.
    """
    fabrics = [(0.35, 0.36, 0.40), (0.25, 0.32, 0.45), (0.40, 0.30, 0.22), (0.30, 0.40, 0.30)]
    c = np.asarray(centre_xy, float)
    f = np.array([math.cos(yaw), math.sin(yaw)])
    side = np.array([-f[1], f[0]])
    boxes: list[Box] = []
    if kind == "sofa":
        col = fabrics[int(rng.integers(len(fabrics)))]
        seat = tuple(c)
        boxes.append(Box((*seat, 0.0), (0.9, 2.0, 0.44), yaw, col))
        back = c - 0.35 * f
        boxes.append(Box((*back, 0.0), (0.2, 2.0, 0.86), yaw, tuple(0.9 * x for x in col)))
        for sgn in (-1, 1):
            arm = c + sgn * 0.9 * side
            boxes.append(Box((*arm, 0.0), (0.9, 0.2, 0.62), yaw, tuple(0.95 * x for x in col)))
    elif kind == "table":
        wood = (0.45, 0.30, 0.18)
        boxes.append(Box((*c, 0.72), (0.8, 1.4, 0.04), yaw, wood))
        for sx in (-1, 1):
            for sy in (-1, 1):
                p = c + sx * 0.34 * f + sy * 0.64 * side
                boxes.append(Box((*p, 0.0), (0.05, 0.05, 0.72), yaw, wood))
        # a closed sideboard-like apron under the near edge keeps it a real occluder
        apron = c + 0.38 * f
        boxes.append(Box((*apron, 0.42), (0.03, 1.3, 0.30), yaw, wood))
    elif kind == "chair":
        wood = [(0.45, 0.30, 0.18), (0.30, 0.22, 0.15), (0.55, 0.45, 0.32)]
        col = wood[int(rng.integers(len(wood)))]
        boxes.append(Box((*c, 0.0), (0.44, 0.44, seat_height_m), yaw, col))
        back = c - 0.2 * f
        size = (0.04, 0.44, seat_height_m + 0.45)
        boxes.append(Box((*back, 0.0), size, yaw, tuple(0.9 * x for x in col)))
    elif kind != "none":
        raise ValueError(f"unknown furniture {kind!r}")
    return boxes


@dataclass
class RoomScene:
    """A room box (metres), its textures, furniture and lights."""

    xmin: float
    xmax: float
    ymin: float
    ymax: float
    height: float
    lights: LightRig
    rng: np.random.Generator
    floor_kind: str = "wood"
    furniture: list[Box] = field(default_factory=list)

    def __post_init__(self) -> None:
        r = self.rng
        self.noise = ValueNoise(r)
        self.noise2 = ValueNoise(r)
        if self.floor_kind == "wood":
            self.plank_w = float(r.uniform(0.12, 0.2))
            self.plank_l = float(r.uniform(0.9, 1.8))
            self.plank_along_x = bool(r.integers(2))
            base = np.array(
                [(0.62, 0.45, 0.30), (0.50, 0.34, 0.22), (0.72, 0.58, 0.42), (0.40, 0.27, 0.18)][
                    int(r.integers(4))
                ]
            )
            self.plank_offsets = r.random(256)
            self.plank_cols = np.clip(base * (1 + 0.12 * r.standard_normal((256, 1))), 0, 1)
        else:
            self.tile = float(r.uniform(0.3, 0.5))
            base = np.array(
                [(0.80, 0.78, 0.72), (0.55, 0.55, 0.56), (0.70, 0.60, 0.50), (0.85, 0.85, 0.85)][
                    int(r.integers(4))
                ]
            )
            self.tile_cols = np.clip(base * (1 + 0.05 * r.standard_normal((256, 1))), 0, 1)
        walls = [(0.85, 0.83, 0.78), (0.75, 0.80, 0.82), (0.86, 0.80, 0.70), (0.72, 0.76, 0.68)]
        self.wall_col = np.array(walls[int(r.integers(len(walls)))])
        # pictures and a door: (wall, u0, u1, z0, z1, colour)
        self.decor: list[tuple[int, float, float, float, float, np.ndarray]] = []
        for wall in (WALL_X0, WALL_X1, WALL_Y0, WALL_Y1):
            lo, hi = (
                (self.ymin, self.ymax) if wall in (WALL_X0, WALL_X1) else (self.xmin, self.xmax)
            )
            if hi - lo < 1.2:
                continue
            for _ in range(int(r.integers(1, 4))):
                w = float(r.uniform(0.3, 1.0))
                u0 = float(r.uniform(lo + 0.1, max(lo + 0.1, hi - w - 0.1)))
                z0 = float(r.uniform(1.1, 1.5))
                self.decor.append((wall, u0, u0 + w, z0, z0 + float(r.uniform(0.25, 0.7)),
                                   r.random(3) * 0.7 + 0.15))  # fmt: skip
            if r.random() < 0.5:
                u0 = float(r.uniform(lo + 0.2, max(lo + 0.2, hi - 1.1)))
                self.decor.append((wall, u0, u0 + 0.9, 0.0, 2.0, np.array([0.55, 0.40, 0.28])))

    # -- geometry ---------------------------------------------------------------------------
    def contains(self, p: np.ndarray, margin: float = 0.0) -> bool:
        return bool(
            self.xmin + margin < p[0] < self.xmax - margin
            and self.ymin + margin < p[1] < self.ymax - margin
            and margin < p[2] < self.height - margin
        )

    def cast(self, origin: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance along unit rays (N, 3) from ``origin`` (inside) to the room's surface, and
        the surface id (N,)."""
        lo = np.array([self.xmin, self.ymin, 0.0])
        hi = np.array([self.xmax, self.ymax, self.height])
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(
                dirs > 0, (hi - origin) / dirs, np.where(dirs < 0, (lo - origin) / dirs, np.inf)
            )
        axis = np.argmin(t, axis=1)
        dist = t[np.arange(len(t)), axis]
        positive = dirs[np.arange(len(t)), axis] > 0
        surface = np.select(
            [axis == 2, axis == 0, axis == 1],
            [np.where(positive, CEILING, FLOOR), np.where(positive, WALL_X1, WALL_X0),
             np.where(positive, WALL_Y1, WALL_Y0)],
        )  # fmt: skip
        return dist, surface

    # -- textures ---------------------------------------------------------------------------
    def albedo(self, p: np.ndarray, surface: np.ndarray) -> np.ndarray:
        """Reflectance (N, 3) at surface points (N, 3)."""
        out = np.zeros((len(p), 3))
        m = surface == FLOOR
        if m.any():
            out[m] = self._floor(p[m, 0], p[m, 1])
        m = surface == CEILING
        out[m] = 0.9
        m = surface >= WALL_X0
        if m.any():
            out[m] = self._walls(p[m], surface[m])
        return out

    def _floor(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        if self.floor_kind == "wood":
            a, b = (y, x) if self.plank_along_x else (x, y)
            row = np.floor(a / self.plank_w).astype(np.int64)
            bb = b / self.plank_l + self.plank_offsets[row % 256]
            col = np.floor(bb).astype(np.int64)
            idx = (row * 31 + col * 17) % 256
            c = self.plank_cols[idx]
            grain = self.noise.fractal(b * 0.8 + idx * 3.7, a * 25.0, 3)
            c = c * (1 + 0.35 * grain)[:, None]
            fa = a / self.plank_w - row
            fb = bb - col
            gap = (fa < 0.03) | (fb < 0.004)
            c[gap] *= 0.45
            return np.clip(c, 0, 1)
        i = np.floor(x / self.tile).astype(np.int64)
        j = np.floor(y / self.tile).astype(np.int64)
        c = self.tile_cols[(i * 13 + j * 29) % 256]
        c = c * (1 + 0.12 * self.noise.fractal(x * 6, y * 6, 3))[:, None]
        fx, fy = x / self.tile - i, y / self.tile - j
        g = 0.012 / self.tile
        grout = (fx < g) | (fy < g)
        c[grout] = c[grout] * 0.5 + 0.15
        return np.clip(c, 0, 1)

    def _walls(self, p: np.ndarray, surface: np.ndarray) -> np.ndarray:
        u = np.where((surface == WALL_X0) | (surface == WALL_X1), p[:, 1], p[:, 0])
        z = p[:, 2]
        mottle = self.noise2.fractal(u * 1.5 + surface * 7.0, z * 1.5, 4)
        c = self.wall_col * (1 + 0.12 * mottle)[:, None]
        for wall, u0, u1, z0, z1, colour in self.decor:
            m = (surface == wall) & (u >= u0) & (u <= u1) & (z >= z0) & (z <= z1)
            if m.any():
                frame = (
                    (u[m] - u0 < 0.03)
                    | (u1 - u[m] < 0.03)
                    | (z[m] - z0 < 0.03)
                    | (z1 - z[m] < 0.03)
                )
                pat = colour * (1 + 0.4 * self.noise.fractal(u[m] * 8, z[m] * 8, 2))[:, None]
                pat[frame] = 0.2
                c[m] = pat
        skirting = z < 0.08
        c[skirting] = 0.92
        return np.clip(c, 0, 1)

    def normals(self, surface: np.ndarray) -> np.ndarray:
        table = np.array(
            [[0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], dtype=float
        )
        return table[surface]


@dataclass
class Backdrop:
    """The empty room seen by one camera.

    Attributes
    ----------
    ambient, lamp : ndarray (H, W, 3)
        Linear RGB radiance from the ambient light and from the lamp.
    depth : ndarray (H, W)
        Depth along the optical axis of the nearest surface, metres.
    labels : ndarray (H, W), uint8
        ``LABEL_ROOM``, ``LABEL_FLOOR`` or ``LABEL_FURNITURE``.
    """

    ambient: np.ndarray
    lamp: np.ndarray
    depth: np.ndarray
    labels: np.ndarray


def _pixel_rays(camera: Camera, pixels: np.ndarray) -> np.ndarray:
    """Unit world-frame ray directions (N, 3) through pixels (N, 2); fast path without
    distortion, ``Camera.pixel_rays`` (OpenCV undistortion) otherwise."""
    if camera.dist.size and np.any(camera.dist):
        return camera.pixel_rays(pixels)
    a = camera.R.T @ np.linalg.inv(camera.K)
    d = pixels[:, :1] * a[:, 0] + pixels[:, 1:2] * a[:, 1] + a[:, 2]
    return d / np.sqrt(np.sum(d * d, axis=1, keepdims=True))


def render_backdrop(room: RoomScene, camera: Camera, supersample: int = 2) -> Backdrop:
    """Ray-cast the room and rasterise its furniture for one camera."""
    w, h = camera.width, camera.height
    c = camera.center
    if not room.contains(c):
        raise ValueError(f"camera {camera.name} at {c.round(2)} is outside the room")
    ss = supersample
    u = (np.arange(w * ss) + 0.5) / ss - 0.5
    v = (np.arange(h * ss) + 0.5) / ss - 0.5
    uu, vv = np.meshgrid(u, v)
    rays = _pixel_rays(camera, np.stack([uu, vv], -1).reshape(-1, 2))
    dist, surf = room.cast(c, rays)
    pts = c + dist[:, None] * rays
    alb = room.albedo(pts, surf)
    nrm = room.normals(surf)
    amb = alb * room.lights.ambient_term(nrm)[:, None]
    lamp = alb * room.lights.lamp_term(pts, nrm)[:, None]

    def down(a: np.ndarray) -> np.ndarray:
        return a.reshape(h, ss, w, ss, -1).mean(axis=(1, 3))

    amb_img, lamp_img = down(amb.reshape(h * ss, w * ss, 3)), down(lamp.reshape(h * ss, w * ss, 3))
    # depth and labels at the pixel centres
    uu1, vv1 = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    rays1 = _pixel_rays(camera, np.stack([uu1, vv1], -1).reshape(-1, 2))
    d1, s1 = room.cast(c, rays1)
    depth = (d1 * np.sum(rays1 * camera.R[2], axis=1)).reshape(h, w)
    labels = np.where(s1 == FLOOR, LABEL_FLOOR, LABEL_ROOM).astype(np.uint8).reshape(h, w)
    img = np.concatenate([amb_img, lamp_img], axis=2)
    for box in room.furniture:
        bv, bn, bt = box.mesh()
        col = np.asarray(box.colour)
        a = col * room.lights.ambient_term(bn)[:, None]
        lmp = col * room.lights.lamp_term(bv, bn)[:, None]
        vc = np.concatenate([a, lmp], axis=1)
        xy, z = project_mesh(camera, bv, bt)
        rasterize(xy, z, vc[bt], LABEL_FURNITURE, depth, img, labels)
    return Backdrop(
        np.ascontiguousarray(img[..., :3], dtype=np.float32),
        np.ascontiguousarray(img[..., 3:], dtype=np.float32),
        depth,
        labels,
    )
