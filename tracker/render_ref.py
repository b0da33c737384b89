"""The slow, simple reference renderer of the body model: OpenCV drawing plus numpy counting.

It implements the geometry of :mod:`tracker.raster` independently: capsule ends are projected
with :meth:`Camera.project` (OpenCV's model), the disc radii use the same rule (``r * (fx + fy)
/ 2 / z`` times the local scale ``sqrt(|det J|)`` of the lens distortion, here by central
differences of :func:`tracker.camera.distort`), and each capsule is drawn as the convex hull of
points sampled on its two end circles with ``cv2.fillConvexPoly`` (sub-pixel vertices, 4 bits).
Capsules with an end closer to the camera plane than ``Z_NEAR`` are not drawn.

OpenCV also fills the pixels its polygon edges pass through, so a plain drawing is about half a
pixel wider on each side of every row than the fast path's pixel-centre rule. By default the
reference therefore draws at ``supersample`` (7) times the resolution and keeps the sample at
each pixel centre, which implements the pixel-centre rule to ~1/14 pixel; ``supersample=1`` is
the plain (faster) drawing the benchmark times.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from tracker.body import BodyModel
from tracker.camera import Camera, distort
from tracker.raster import Z_NEAR

_SHIFT = 4
_SAMPLES = 48  # points per end circle
_ANG = np.linspace(0, 2 * np.pi, _SAMPLES, endpoint=False)
_CIRCLE = np.stack([np.cos(_ANG), np.sin(_ANG)], axis=1)


def capsule_discs(
    camera: Camera, a: np.ndarray, b: np.ndarray, radii: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Project capsule ends to image discs.

    Parameters
    ----------
    camera : Camera
    a, b : np.ndarray
        ``(..., C, 3)`` world centres of the end spheres, metres.
    radii : np.ndarray
        ``(C, 2)`` sphere radii, metres.

    Returns
    -------
    ca, cb : np.ndarray
        ``(..., C, 2)`` disc centres in pixels.
    ra, rb : np.ndarray
        ``(..., C)`` disc radii in pixels.
    valid : np.ndarray
        ``(..., C)`` bool: both ends at least ``Z_NEAR`` in front of the camera.
    """
    out = []
    fbar = 0.5 * (camera.K[0, 0] + camera.K[1, 1])
    h = 1e-6
    for pts, r in ((a, radii[:, 0]), (b, radii[:, 1])):
        pc = camera.to_camera(pts)
        z = pc[..., 2]
        ok = z >= Z_NEAR
        zs = np.where(ok, z, 1.0)
        x, y = pc[..., 0] / zs, pc[..., 1] / zs
        scale = fbar / zs
        if camera.dist.size and np.any(camera.dist):
            dxp = distort(x + h, y, camera.dist)
            dxm = distort(x - h, y, camera.dist)
            dyp = distort(x, y + h, camera.dist)
            dym = distort(x, y - h, camera.dist)
            j00 = (dxp[0] - dxm[0]) / (2 * h)
            j10 = (dxp[1] - dxm[1]) / (2 * h)
            j01 = (dyp[0] - dym[0]) / (2 * h)
            j11 = (dyp[1] - dym[1]) / (2 * h)
            scale = scale * np.sqrt(np.abs(j00 * j11 - j01 * j10))
        uv = camera.project(np.where(ok[..., None], pts, np.nan))
        out.append((uv, r * scale, ok))
    (ca, ra, oka), (cb, rb, okb) = out
    return ca, cb, ra, rb, oka & okb


def _draw(
    ca: np.ndarray,
    cb: np.ndarray,
    ra: np.ndarray,
    rb: np.ndarray,
    valid: np.ndarray,
    width: int,
    height: int,
    supersample: int,
) -> np.ndarray:
    """Fill the hulls of the discs of one pose (C capsules) -> bool (height, width)."""
    s = int(supersample)
    if s < 1 or s % 2 == 0:
        raise ValueError(f"supersample must be a positive odd integer, not {supersample}")
    img = np.zeros((height * s, width * s), dtype=np.uint8)
    circ = _CIRCLE
    lim = 4.0 * max(width, height)
    for c in np.flatnonzero(valid):
        pts = np.concatenate([ca[c] + ra[c] * circ, cb[c] + rb[c] * circ])
        if not np.all(np.isfinite(pts)):
            continue
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        if hi[0] < 0 or hi[1] < 0 or lo[0] > width - 1 or lo[1] > height - 1:
            continue
        # low-res pixel centre j sits at high-res pixel centre s*j + (s-1)/2
        pts = np.clip(pts, -lim, lim) * s + (s - 1) / 2
        fixed = np.round(pts * (1 << _SHIFT)).astype(np.int32)
        hull = cv2.convexHull(fixed.reshape(-1, 1, 2))
        cv2.fillConvexPoly(img, hull, 1, lineType=cv2.LINE_8, shift=_SHIFT)
    h0 = (s - 1) // 2
    return img[h0::s, h0::s].astype(bool)


def render_reference(
    body: BodyModel, pose: np.ndarray, camera: Camera, supersample: int = 7
) -> np.ndarray:
    """The body model's silhouette of one pose (31,) in one camera, bool ``(H, W)``.

    ``supersample`` (odd): draw at that many times the resolution and keep the sample at each
    pixel centre, so that OpenCV's inclusive polygon edges cost ~1/supersample pixel instead of
    ~1/2; ``supersample=1`` is the plain OpenCV drawing.
    """
    a, b = body.capsules(np.asarray(pose, dtype=np.float64)[None])
    ca, cb, ra, rb, valid = capsule_discs(camera, a[0], b[0], body.radii)
    return _draw(ca, cb, ra, rb, valid, camera.width, camera.height, supersample)


def counts_reference(
    body: BodyModel,
    cameras: Sequence[Camera],
    silhouettes: Sequence[np.ndarray],
    poses: np.ndarray,
    supersample: int = 7,
) -> np.ndarray:
    """(Nc, Ns, Nm) of poses ``(N, 31)`` in every camera -> ``(N, K, 3)`` int64.

    Each pose and camera is drawn on its own (OpenCV) and counted with numpy.
    """
    poses = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    out = np.zeros((poses.shape[0], len(cameras), 3), dtype=np.int64)
    a, b = body.capsules(poses)
    for k, (cam, sil) in enumerate(zip(cameras, silhouettes, strict=True)):
        sil = np.asarray(sil, dtype=bool)
        ns_total = int(np.count_nonzero(sil))
        ca, cb, ra, rb, valid = capsule_discs(cam, a, b, body.radii)
        for i in range(poses.shape[0]):
            m = _draw(ca[i], cb[i], ra[i], rb[i], valid[i], cam.width, cam.height, supersample)
            nc = int(np.count_nonzero(m & sil))
            out[i, k] = (nc, ns_total - nc, int(np.count_nonzero(m)) - nc)
    return out
