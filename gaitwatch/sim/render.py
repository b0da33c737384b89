"""Triangle rasteriser with a z-buffer, and Lambert shading under a ceiling lamp.

:func:`rasterize` draws triangles given in pixel coordinates with per-vertex camera depths and
per-vertex colours (any number of channels) into a depth buffer, a colour buffer and a label
buffer: pixel centres at integer coordinates (OpenCV's convention), barycentric coverage,
perspective-correct interpolation of depth and colour, nearest surface wins. It is a plain
numba loop over triangles and the pixels of each triangle's bounding box (``cache=True``).

Lights (:class:`LightRig`): an ambient term that is brighter on upward-facing surfaces, plus a
point lamp with cosine and inverse-square fall-off. The lamp and the ambient parts are kept
apart so that the lamp can be switched off and its shadow drawn.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from gaitwatch.sim.person import Mesh
from tracker.camera import Camera

NEAR = 0.05  # metres: triangles with a vertex nearer than this to the camera are dropped

LABEL_NONE, LABEL_ROOM, LABEL_FLOOR, LABEL_FURNITURE, LABEL_PERSON = 0, 1, 2, 3, 4


@numba.njit(cache=True)
def _raster(xy, z, col, label, zbuf, img, labels):  # pragma: no cover - compiled
    h, w = zbuf.shape
    nc = img.shape[2]
    for t in range(xy.shape[0]):
        x0, y0 = xy[t, 0, 0], xy[t, 0, 1]
        x1, y1 = xy[t, 1, 0], xy[t, 1, 1]
        x2, y2 = xy[t, 2, 0], xy[t, 2, 1]
        z0, z1, z2 = z[t, 0], z[t, 1], z[t, 2]
        if not (z0 > NEAR and z1 > NEAR and z2 > NEAR):  # also rejects NaN
            continue
        if not (
            np.isfinite(x0)
            and np.isfinite(y0)
            and np.isfinite(x1)
            and np.isfinite(y1)
            and np.isfinite(x2)
            and np.isfinite(y2)
        ):
            continue
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if abs(area) < 1e-12:
            continue
        xmin = max(int(np.ceil(min(x0, x1, x2))), 0)
        xmax = min(int(np.floor(max(x0, x1, x2))), w - 1)
        ymin = max(int(np.ceil(min(y0, y1, y2))), 0)
        ymax = min(int(np.floor(max(y0, y1, y2))), h - 1)
        if xmin > xmax or ymin > ymax:
            continue
        inv = 1.0 / area
        iz0, iz1, iz2 = 1.0 / z0, 1.0 / z1, 1.0 / z2
        lab = label[t]
        for py in range(ymin, ymax + 1):
            for px in range(xmin, xmax + 1):
                w0 = ((x1 - px) * (y2 - py) - (x2 - px) * (y1 - py)) * inv
                w1 = ((x2 - px) * (y0 - py) - (x0 - px) * (y2 - py)) * inv
                w2 = 1.0 - w0 - w1
                if w0 < -1e-9 or w1 < -1e-9 or w2 < -1e-9:
                    continue
                iz = w0 * iz0 + w1 * iz1 + w2 * iz2
                zz = 1.0 / iz
                if zz < zbuf[py, px]:
                    zbuf[py, px] = zz
                    labels[py, px] = lab
                    a0, a1, a2 = w0 * iz0 * zz, w1 * iz1 * zz, w2 * iz2 * zz
                    for c in range(nc):
                        img[py, px, c] = a0 * col[t, 0, c] + a1 * col[t, 1, c] + a2 * col[t, 2, c]


def rasterize(
    xy: np.ndarray,
    z: np.ndarray,
    colours: np.ndarray,
    labels_per_tri: np.ndarray | int,
    zbuf: np.ndarray,
    img: np.ndarray,
    labels: np.ndarray,
) -> None:
    """Draw triangles into the buffers, in place.

    Parameters
    ----------
    xy : ndarray (F, 3, 2)
        Vertex pixel coordinates (pixel centres at integers); NaN drops the triangle.
    z : ndarray (F, 3)
        Vertex depths along the optical axis, metres.
    colours : ndarray (F, 3, C)
        Vertex colours, any number of channels C.
    labels_per_tri : ndarray (F,) of uint8, or int
        Label written where a triangle is nearest.
    zbuf : ndarray (H, W), float64
        Depth buffer (``inf`` where empty), updated.
    img : ndarray (H, W, C), float32 or float64
        Colour buffer, updated.
    labels : ndarray (H, W), uint8
        Label buffer, updated.
    """
    f = xy.shape[0]
    if np.isscalar(labels_per_tri) or np.ndim(labels_per_tri) == 0:
        labels_per_tri = np.full(f, int(labels_per_tri), dtype=np.uint8)
    _raster(
        np.ascontiguousarray(xy, dtype=np.float64),
        np.ascontiguousarray(z, dtype=np.float64),
        np.ascontiguousarray(colours, dtype=np.float64),
        np.ascontiguousarray(labels_per_tri, dtype=np.uint8),
        zbuf,
        img,
        labels,
    )


@dataclass(frozen=True)
class LightRig:
    """Ambient light plus one point lamp (world position, metres)."""

    lamp: np.ndarray
    ambient: float = 0.55
    lamp_power: float = 1.0

    def ambient_term(self, normals: np.ndarray) -> np.ndarray:
        """Ambient irradiance (...,): brighter for upward-facing surfaces (sky/ceiling fill)."""
        return self.ambient * (0.8 + 0.2 * normals[..., 2])

    def lamp_term(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Lamp irradiance (...,) at points with unit normals; 1.0 straight under at 2 m."""
        d = self.lamp - points
        r2 = np.sum(d * d, axis=-1)
        cos = np.sum(d * normals, axis=-1) / np.sqrt(np.maximum(r2, 1e-12))
        return self.lamp_power * np.clip(cos, 0.0, None) * (4.0 / np.maximum(r2, 0.25))


def project_mesh(
    camera: Camera, vertices: np.ndarray, triangles: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per-triangle pixel coordinates (F, 3, 2) and depths (F, 3) of a mesh in a camera."""
    px = camera.project(vertices)
    z = camera.depth(vertices)
    return px[triangles], z[triangles]


def draw_person(
    camera: Camera,
    mesh: Mesh,
    lights: LightRig,
    lamp_on: float,
    zbuf: np.ndarray,
    img: np.ndarray,
    labels: np.ndarray,
    pattern: Callable[[np.ndarray], np.ndarray] | None = None,
) -> None:
    """Shade (Lambert, ambient + lamp) and draw the person's mesh into RGB buffers, in place.

    With ``pattern`` (texcoords (N, 3) -> reflectance factor (N,)) and the mesh's texcoords,
    the cloth pattern is applied per pixel where ``mesh.patterned``.
    """
    shade = lights.ambient_term(mesh.normals) + lamp_on * lights.lamp_term(
        mesh.vertices, mesh.normals
    )
    colour = mesh.albedo * shade[:, None]
    xy, z = project_mesh(camera, mesh.vertices, mesh.triangles)
    if pattern is None or mesh.texcoords is None or mesh.patterned is None:
        rasterize(xy, z, colour[mesh.triangles], LABEL_PERSON, zbuf, img, labels)
        return
    attrs = np.concatenate([colour, mesh.texcoords, mesh.patterned[:, None]], axis=1)
    buf = np.zeros(img.shape[:2] + (attrs.shape[1],), dtype=np.float32)
    lab = np.zeros_like(labels)
    rasterize(xy, z, attrs[mesh.triangles], LABEL_PERSON, zbuf, buf, lab)
    drawn = lab == LABEL_PERSON
    px = buf[drawn]
    factor = np.where(px[:, 6] > 0.5, pattern(px[:, 3:6].astype(np.float64)), 1.0)
    img[drawn] = px[:, :3] * factor[:, None].astype(np.float32)
    labels[drawn] = LABEL_PERSON


def shadow_coverage(
    camera: Camera, mesh: Mesh, lamp: np.ndarray, floor_depth: np.ndarray
) -> np.ndarray:
    """Where the person's shadow from the lamp falls on visible floor: float mask (H, W) in 0/1.

    The mesh is projected onto the floor (z = 0) from the lamp; the floor copy is drawn with a
    1 cm depth tolerance against ``floor_depth`` (the empty scene's depth, so furniture in front
    hides the shadow).
    """
    v = mesh.vertices
    h = lamp[2]
    below = v[:, 2] < h - 1e-3
    s = np.where(below, h / np.maximum(h - v[:, 2], 1e-3), np.nan)
    shadow = lamp + (v - lamp) * s[:, None]
    shadow[:, 2] = 0.0
    xy, z = project_mesh(camera, shadow, mesh.triangles)
    zb = floor_depth + 0.01
    cov = np.zeros(floor_depth.shape + (1,), dtype=np.float32)
    lab = np.zeros(floor_depth.shape, dtype=np.uint8)
    rasterize(xy, z, np.ones(z.shape + (1,)), 1, zb, cov, lab)
    return (lab == 1).astype(np.float32)
