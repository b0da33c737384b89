"""numba kernels of the silhouette likelihood: project capsules, rasterise row spans into
bit-packed rows, count with popcount.

Image masks are bit-packed rows: ``mask[y, w]`` (uint64) holds pixels ``x = 64 w + bit`` of row
``y`` (bit 0 = the leftmost), the layout of ``np.packbits(..., bitorder="little")`` viewed as
little-endian uint64.

Geometry (the same in :mod:`tracker.render_ref`):

* A capsule end (sphere centre ``X``, radius ``r`` metres) projects to the disc centred on the
  distorted projection of ``X`` with radius ``r * (fx + fy) / 2 / z * s`` pixels, ``z`` the depth
  and ``s = sqrt(|det J|)`` the local scale of the lens distortion at ``X`` (``J`` the Jacobian
  of OpenCV's distortion in normalised coordinates, by forward differences with step 1e-6; s = 1
  without distortion). A capsule is drawn as the convex hull of its two end discs.
* A capsule with an end closer to the camera plane than :data:`Z_NEAR` is not drawn.
* A pixel is covered when its centre (integer coordinates, OpenCV's convention) lies in the hull.

Every kernel keeps a row/word bounding box per mask, so clearing and counting touch only the
rows and words the model covers. Masks live in 3-D arrays ``(slots, H, W64)`` addressed by slot,
and the kernels index the arrays they are given rather than slicing them: in numba every array
view costs an atomic reference-count update, which parallel threads would fight over.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Final

import numba as nb
import numpy as np
from numba.core import types
from numba.extending import intrinsic


def prefer_passive_openmp() -> bool:
    """Let idle OpenMP threads sleep instead of spinning (``OMP_WAIT_POLICY=PASSIVE``).

    numba's default threading layer here is GNU OpenMP, whose idle threads spin (busy-wait)
    after every parallel kernel. The tracker calls many short kernels per frame, with Python
    work in between: the spinning worker thread uses up its share of the CPU, so on a busy
    machine the scheduler runs it late when the next parallel kernel needs it, and each launch
    waits milliseconds (measured: 2 threads 3-8 times slower than 1 under load). Sleeping
    threads are woken within microseconds. Only effective before numba starts its threads (the
    first parallel kernel, ``numba.set_num_threads`` or ``numba.get_num_threads``); an
    ``OMP_WAIT_POLICY`` set by the user is kept.

    Returns
    -------
    bool
        True when the policy is in force for this process's OpenMP threads (set here or by the
        user before they started).
    """
    import os

    from numba.np.ufunc import parallel

    if getattr(parallel, "_is_initialized", False):
        return os.environ.get("OMP_WAIT_POLICY", "").upper() == "PASSIVE"
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    return os.environ["OMP_WAIT_POLICY"].upper() == "PASSIVE"


prefer_passive_openmp()


@contextmanager
def numba_threads(n: int) -> Iterator[None]:
    """Run the numba kernels inside the block on ``n`` threads (restored afterwards).

    ``n`` is capped to ``[1, numba.config.NUMBA_NUM_THREADS]``.
    """
    old = nb.get_num_threads()
    n = max(1, min(int(n), nb.config.NUMBA_NUM_THREADS))
    if n == old:
        yield
        return
    nb.set_num_threads(n)
    try:
        yield
    finally:
        nb.set_num_threads(old)


Z_NEAR: Final[float] = 0.05  # metres
FD_STEP: Final[float] = 1e-6  # forward-difference step of the distortion Jacobian
_ALL = np.uint64(0xFFFFFFFFFFFFFFFF)
_BIG = 1 << 40


@intrinsic
def popcount64(typingctx, x):  # type: ignore[no-untyped-def]
    """Number of set bits of a uint64, as int64 (LLVM ``ctpop``: one POPCNT instruction)."""
    sig = types.int64(types.uint64)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.ctpop(args[0])

    return sig, codegen


# Packed camera: one float64 row of CAM_FIELDS values per camera.
CAM_R: Final = slice(0, 9)  # world -> camera rotation, row-major
CAM_T: Final = slice(9, 12)  # translation
CAM_INTR: Final = slice(12, 17)  # fx, fy, cx, cy, skew
CAM_DIST: Final = slice(17, 31)  # 14 OpenCV distortion coefficients, zero padded
CAM_HAS_DIST: Final = 31  # 1.0 when any coefficient is non-zero
CAM_FIELDS: Final = 32


def pack_camera(R: np.ndarray, t: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """One camera's parameters as the (32,) float64 row the kernels read."""
    row = np.zeros(CAM_FIELDS)
    row[CAM_R] = np.asarray(R, dtype=np.float64).ravel()
    row[CAM_T] = t
    row[CAM_INTR] = (K[0, 0], K[1, 1], K[0, 2], K[1, 2], K[0, 1])
    d = np.asarray(dist, dtype=np.float64).ravel()
    if d.size > 12 and np.any(d[12:] != 0):
        raise ValueError("tilted-sensor distortion (tauX, tauY) is not supported")
    row[17 : 17 + min(d.size, 12)] = d[:12]
    row[CAM_HAS_DIST] = 1.0 if np.any(d != 0) else 0.0
    return row


def pack_cameras(cameras) -> tuple[np.ndarray, np.ndarray]:
    """Cameras (objects with ``R, t, K, dist, height, width, name``) as the kernels read them:
    the packed rows ``(K, 32)`` (:func:`pack_camera`) and the image sizes ``(K, 2)`` int64
    ``(height, width)``. A camera the kernels cannot use raises ValueError naming it."""
    rows = []
    for c in cameras:
        try:
            rows.append(pack_camera(c.R, c.t, c.K, c.dist))
        except ValueError as err:
            raise ValueError(f"camera {c.name}: {err}") from None
    cam_hw = np.array([[c.height, c.width] for c in cameras], dtype=np.int64)
    return np.ascontiguousarray(np.stack(rows)), cam_hw


@nb.njit(cache=True, inline="always")
def _distort(x: float, y: float, cams: np.ndarray, k: int) -> tuple[float, float]:
    """OpenCV distortion of normalised coordinates with the coefficients of camera k."""
    k1 = cams[k, 17]
    k2 = cams[k, 18]
    p1 = cams[k, 19]
    p2 = cams[k, 20]
    k3 = cams[k, 21]
    r2 = x * x + y * y
    r4 = r2 * r2
    r6 = r4 * r2
    radial = (1.0 + k1 * r2 + k2 * r4 + k3 * r6) / (
        1.0 + cams[k, 22] * r2 + cams[k, 23] * r4 + cams[k, 24] * r6
    )
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + cams[k, 25] * r2
    xd += cams[k, 26] * r4
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + cams[k, 27] * r2
    yd += cams[k, 28] * r4
    return xd, yd


@nb.njit(cache=True, inline="always")
def _to_camera(px: float, py: float, pz: float, cams: np.ndarray, k: int):
    """World point (px, py, pz) in packed camera k's coordinates ``(xc, yc, zc)``."""
    xc = cams[k, 0] * px + cams[k, 1] * py + cams[k, 2] * pz + cams[k, 9]
    yc = cams[k, 3] * px + cams[k, 4] * py + cams[k, 5] * pz + cams[k, 10]
    zc = cams[k, 6] * px + cams[k, 7] * py + cams[k, 8] * pz + cams[k, 11]
    return xc, yc, zc


@nb.njit(cache=True, inline="always")
def _to_pixel(x: float, y: float, cams: np.ndarray, k: int) -> tuple[float, float]:
    """Distorted normalised coordinates -> pixel ``(u, v)`` with camera k's intrinsics."""
    return cams[k, 12] * x + cams[k, 16] * y + cams[k, 14], cams[k, 13] * y + cams[k, 15]


@nb.njit(cache=True, inline="always")
def project_point(
    px: float, py: float, pz: float, cams: np.ndarray, k: int
) -> tuple[float, float, float, bool]:
    """Project world point (px, py, pz) with packed camera k (:func:`pack_camera`).

    Returns (u, v, pixels per metre at that depth, in front of the camera?).
    """
    xc, yc, zc = _to_camera(px, py, pz, cams, k)
    if not zc >= Z_NEAR:
        return 0.0, 0.0, 0.0, False
    x = xc / zc
    y = yc / zc
    scale = 0.5 * (cams[k, 12] + cams[k, 13]) / zc
    if cams[k, 31] != 0.0:
        xd, yd = _distort(x, y, cams, k)
        x1, y1 = _distort(x + FD_STEP, y, cams, k)
        x2, y2 = _distort(x, y + FD_STEP, cams, k)
        det = ((x1 - xd) * (y2 - yd) - (x2 - xd) * (y1 - yd)) / (FD_STEP * FD_STEP)
        scale *= np.sqrt(abs(det))
        x = xd
        y = yd
    u, v = _to_pixel(x, y, cams, k)
    return u, v, scale, True


@nb.njit(cache=True, inline="always")
def project_uv(
    px: float, py: float, pz: float, cams: np.ndarray, k: int
) -> tuple[float, float, bool]:
    """Pixel ``(u, v)`` of world point (px, py, pz) through packed camera k, as
    :meth:`tracker.camera.Camera.project` gives it, and whether it lies in front of the camera
    (``z > 0``; Camera.project gives NaN otherwise)."""
    xc, yc, zc = _to_camera(px, py, pz, cams, k)
    if not zc > 0.0:
        return 0.0, 0.0, False
    x = xc / zc
    y = yc / zc
    if cams[k, 31] != 0.0:
        x, y = _distort(x, y, cams, k)
    u, v = _to_pixel(x, y, cams, k)
    return u, v, True


@nb.njit(cache=True, inline="always")
def project_capsule(
    pts: np.ndarray, i: int, cap_ab: np.ndarray, c: int, cams: np.ndarray, k: int
) -> tuple[float, float, float, float, float, float, bool]:
    """Project both ends of capsule c of pose i (``pts`` (N, P, 3), ``cap_ab`` (C, 2) point
    indices) with packed camera k: ``(ua, va, pixels per metre at a, ub, vb, at b, ok)``,
    ``ok`` False when either end is behind the camera (the rest is then meaningless)."""
    ia = cap_ab[c, 0]
    ib = cap_ab[c, 1]
    ua, va, sa, oka = project_point(pts[i, ia, 0], pts[i, ia, 1], pts[i, ia, 2], cams, k)
    if not oka:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False
    ub, vb, sb, okb = project_point(pts[i, ib, 0], pts[i, ib, 1], pts[i, ib, 2], cams, k)
    return ua, va, sa, ub, vb, sb, okb


@nb.njit(cache=True, inline="always")
def _emit_span(mask: np.ndarray, slot: int, y: int, xl: float, xr: float, wmax: float) -> None:
    """Set the pixels of row y of mask[slot] whose centres lie in [xl, xr] (wmax = W - 1)."""
    if xl > xr or xr < 0.0 or xl > wmax:
        return
    j0 = int(np.ceil(max(xl, 0.0)))
    j1 = int(np.floor(min(xr, wmax)))
    if j0 > j1:
        return
    wa = j0 >> 6
    wb = j1 >> 6
    lo = _ALL << np.uint64(j0 & 63)
    hi = _ALL >> np.uint64(63 - (j1 & 63))
    if wa == wb:
        mask[slot, y, wa] |= lo & hi
    else:
        mask[slot, y, wa] |= lo
        for w in range(wa + 1, wb):
            mask[slot, y, w] = _ALL
        mask[slot, y, wb] |= hi


@nb.njit(cache=True, inline="always")
def raster_capsule(
    ax: float,
    ay: float,
    ra: float,
    bx: float,
    by: float,
    rb: float,
    mask: np.ndarray,
    slot: int,
    height: int,
    width: int,
    bbox: np.ndarray,
) -> None:
    """OR the convex hull of discs (a, ra) and (b, rb) (pixels) into bit-packed mask[slot].

    ``bbox[slot]`` = [row_min, row_max, word_min, word_max] is widened to cover the capsule's
    clipped bounding box (rows and words in it that the capsule misses stay zero). Rows
    crossed by both outer tangent segments take their span from the segments alone; only the
    rows near the ends look at the discs.
    """
    if not (
        np.isfinite(ax)
        and np.isfinite(ay)
        and np.isfinite(bx)
        and np.isfinite(by)
        and np.isfinite(ra)
        and np.isfinite(rb)
    ):
        return
    ymin = min(ay - ra, by - rb)
    ymax = max(ay + ra, by + rb)
    xmin = min(ax - ra, bx - rb)
    xmax = max(ax + ra, bx + rb)
    wmax = width - 1.0
    if ymax < 0.0 or ymin > height - 1.0 or xmax < 0.0 or xmin > wmax:
        return
    r0 = int(np.ceil(max(ymin, 0.0)))
    r1 = int(np.floor(min(ymax, height - 1.0)))
    if r0 > r1:
        return
    if r0 < bbox[slot, 0]:
        bbox[slot, 0] = r0
    if r1 > bbox[slot, 1]:
        bbox[slot, 1] = r1
    c0 = int(np.ceil(max(xmin, 0.0))) >> 6
    c1 = int(np.floor(min(xmax, wmax))) >> 6
    if c0 < bbox[slot, 2]:
        bbox[slot, 2] = c0
    if c1 > bbox[slot, 3]:
        bbox[slot, 3] = c1
    dx = bx - ax
    dy = by - ay
    d = np.sqrt(dx * dx + dy * dy)
    if not d > abs(ra - rb) + 1e-9:  # one disc contains the other: draw the larger
        if rb > ra:
            ax, ay, ra = bx, by, rb
        ra2 = ra * ra
        for y in range(r0, r1 + 1):
            e = y - ay
            if e * e <= ra2:
                h = np.sqrt(ra2 - e * e)
                _emit_span(mask, slot, y, ax - h, ax + h, wmax)
        return
    # the two outer tangent segments p -> q of the hull
    inv_d = 1.0 / d
    ux = dx * inv_d
    uy = dy * inv_d
    c = (ra - rb) * inv_d
    s = np.sqrt(max(0.0, 1.0 - c * c))
    n1x = c * ux - s * uy
    n1y = c * uy + s * ux
    n2x = c * ux + s * uy
    n2y = c * uy - s * ux
    p1x = ax + ra * n1x
    p1y = ay + ra * n1y
    q1y = by + rb * n1y
    p2x = ax + ra * n2x
    p2y = ay + ra * n2y
    q2y = by + rb * n2y
    k1 = (bx + rb * n1x - p1x) / (q1y - p1y) if q1y != p1y else 0.0
    k2 = (bx + rb * n2x - p2x) / (q2y - p2y) if q2y != p2y else 0.0
    # rows crossed by both tangent segments: [i0, i1]
    i0 = r1 + 1
    i1 = r1
    if q1y != p1y and q2y != p2y:
        i0 = max(int(np.ceil(max(min(p1y, q1y), min(p2y, q2y)))), r0)
        i1 = min(int(np.floor(min(max(p1y, q1y), max(p2y, q2y)))), r1)
        if i0 > i1:
            i0 = r1 + 1
            i1 = r1
    ra2 = ra * ra
    rb2 = rb * rb
    _rows_ends(
        mask,
        slot,
        r0,
        min(i0 - 1, r1),
        ax,
        ay,
        ra2,
        bx,
        by,
        rb2,
        p1x,
        p1y,
        q1y,
        k1,
        p2x,
        p2y,
        q2y,
        k2,
        wmax,
    )
    if i0 <= i1:
        for y in range(i0, i1 + 1):
            fy = float(y)
            x1 = p1x + (fy - p1y) * k1
            x2 = p2x + (fy - p2y) * k2
            if x1 <= x2:
                _emit_span(mask, slot, y, x1, x2, wmax)
            else:
                _emit_span(mask, slot, y, x2, x1, wmax)
        _rows_ends(
            mask,
            slot,
            i1 + 1,
            r1,
            ax,
            ay,
            ra2,
            bx,
            by,
            rb2,
            p1x,
            p1y,
            q1y,
            k1,
            p2x,
            p2y,
            q2y,
            k2,
            wmax,
        )


@nb.njit(cache=True, inline="always")
def _rows_ends(
    mask: np.ndarray,
    slot: int,
    y0: int,
    y1: int,
    ax: float,
    ay: float,
    ra2: float,
    bx: float,
    by: float,
    rb2: float,
    p1x: float,
    p1y: float,
    q1y: float,
    k1: float,
    p2x: float,
    p2y: float,
    q2y: float,
    k2: float,
    wmax: float,
) -> None:
    """Rows y0..y1 of a hull: the span of both discs and of whichever tangents cross the row."""
    for y in range(y0, y1 + 1):
        fy = float(y)
        xl = np.inf
        xr = -np.inf
        e = fy - ay
        if e * e <= ra2:
            h = np.sqrt(ra2 - e * e)
            xl = ax - h
            xr = ax + h
        e = fy - by
        if e * e <= rb2:
            h = np.sqrt(rb2 - e * e)
            xl = min(xl, bx - h)
            xr = max(xr, bx + h)
        if (fy - p1y) * (fy - q1y) <= 0.0 and q1y != p1y:
            x = p1x + (fy - p1y) * k1
            xl = min(xl, x)
            xr = max(xr, x)
        if (fy - p2y) * (fy - q2y) <= 0.0 and q2y != p2y:
            x = p2x + (fy - p2y) * k2
            xl = min(xl, x)
            xr = max(xr, x)
        _emit_span(mask, slot, y, xl, xr, wmax)


@nb.njit(cache=True, inline="always")
def _reset_bbox(bbox: np.ndarray, slot: int) -> None:
    bbox[slot, 0] = _BIG
    bbox[slot, 1] = -1
    bbox[slot, 2] = _BIG
    bbox[slot, 3] = -1


@nb.njit(cache=True, nogil=True)
def render_capsules(
    pts: np.ndarray,
    i: int,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    k: int,
    height: int,
    width: int,
    mask: np.ndarray,
    slot: int,
    bbox: np.ndarray,
) -> None:
    """Rasterise capsules ``sel`` of pose i in camera k into mask[slot] (widening bbox[slot]).

    ``pts`` (N, P, 3) model points; ``cap_ab`` (C, 2) point indices of the capsule ends;
    ``radii`` (C, 2) metres; ``cams`` packed cameras (K, 32).
    """
    for ci in range(sel.shape[0]):
        c = sel[ci]
        ua, va, sa, ub, vb, sb, ok = project_capsule(pts, i, cap_ab, c, cams, k)
        if not ok:
            continue
        raster_capsule(
            ua, va, radii[c, 0] * sa, ub, vb, radii[c, 1] * sb, mask, slot, height, width, bbox
        )


@nb.njit(cache=True, inline="always")
def _count_clear(
    mask: np.ndarray,
    slot: int,
    sil: np.ndarray,
    vis: np.ndarray,
    vis_on: np.ndarray,
    k: int,
    bbox: np.ndarray,
) -> tuple[int, int]:
    """(counted model pixels, common pixels) of mask[slot] against sil[k] within bbox[slot];
    clears. Model pixels count where ``vis[k]`` is set (not behind a known occluder) when
    ``vis_on[k]``, everywhere otherwise."""
    tot = 0
    com = 0
    use = vis_on[k]
    for y in range(bbox[slot, 0], bbox[slot, 1] + 1):
        for w in range(bbox[slot, 2], bbox[slot, 3] + 1):
            m = mask[slot, y, w]
            if m:
                tot += popcount64(m & vis[k, y, w]) if use else popcount64(m)
                com += popcount64(m & sil[k, y, w])
                mask[slot, y, w] = 0
    return tot, com


@nb.njit(cache=True, nogil=True)
def _counts_range(
    lo: int,
    hi: int,
    pts: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    vis: np.ndarray,
    vis_on: np.ndarray,
    sil_total: np.ndarray,
    out: np.ndarray,
) -> None:
    """Counts of poses lo..hi-1 (all capsules) into ``out`` with one scratch mask."""
    mask = np.zeros((1, sil.shape[1], sil.shape[2]), dtype=np.uint64)
    bbox = np.empty((1, 4), dtype=np.int64)
    sel = np.arange(cap_ab.shape[0])
    for i in range(lo, hi):
        for k in range(cams.shape[0]):
            _reset_bbox(bbox, 0)
            render_capsules(
                pts, i, sel, cap_ab, radii, cams, k, cam_hw[k, 0], cam_hw[k, 1], mask, 0, bbox
            )
            tot, com = _count_clear(mask, 0, sil, vis, vis_on, k, bbox)
            out[i, k, 0] = com
            out[i, k, 1] = sil_total[k] - com
            out[i, k, 2] = tot - com


@nb.njit(cache=True, parallel=True, nogil=True)
def counts_kernel(
    pts: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    vis: np.ndarray,
    vis_on: np.ndarray,
    sil_total: np.ndarray,
    nchunks: int,
) -> np.ndarray:
    """(Nc, Ns, Nm) per pose and camera -> (N, K, 3) int64.

    Parameters
    ----------
    pts : (N, P, 3) model points of the poses (``BodyModel.points``).
    cap_ab : (C, 2) int64 point indices of the capsule ends; radii : (C, 2) metres.
    cams : (K, 32) packed cameras; cam_hw : (K, 2) int64 image height and width.
    sil : (K, H, W64) uint64 bit-packed silhouettes; sil_total : (K,) their pixel counts.
    vis : (K, H, W64) uint64 bit-packed pixels where model pixels count (Nm): all set but
    behind a known occluder, silhouette pixels always set (so Nc <= the counted model pixels);
    vis_on : (K,) bool, False: camera k has no occluder (``vis[k]`` is not read).
    nchunks : work units (a multiple of the thread count) that share the batch.
    """
    n = pts.shape[0]
    out = np.zeros((n, cams.shape[0], 3), dtype=np.int64)
    nchunks = max(1, min(n, nchunks))
    for ch in nb.prange(nchunks):
        _counts_range(
            ch * n // nchunks,
            (ch + 1) * n // nchunks,
            pts,
            cap_ab,
            radii,
            cams,
            cam_hw,
            sil,
            vis,
            vis_on,
            sil_total,
            out,
        )
    return out


@nb.njit(cache=True, nogil=True)
def _factored_range(
    lo: int,
    hi: int,
    pts_base: np.ndarray,
    pts_left: np.ndarray,
    pts_right: np.ndarray,
    na: int,
    nb_: int,
    groups: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    vis: np.ndarray,
    vis_on: np.ndarray,
    sil_total: np.ndarray,
    out: np.ndarray,
) -> None:
    """All A*B leg combinations of base poses lo..hi-1 into ``out`` (M, A, B, K, 3).

    Mask slots: base camera k -> k; left variant a -> K + a K + k; right b -> K + A K + b K + k.
    """
    base_sel = np.flatnonzero(groups == 0)
    left_sel = np.flatnonzero(groups == 1)
    right_sel = np.flatnonzero(groups == 2)
    ncam = cams.shape[0]
    nslots = ncam * (1 + na + nb_)
    mask = np.zeros((nslots, sil.shape[1], sil.shape[2]), dtype=np.uint64)
    bbox = np.empty((nslots, 4), dtype=np.int64)
    lofs = ncam
    rofs = ncam + na * ncam
    # cum[y] = (model, common) pixels of the base in rows < y, from its first row on
    cum = np.zeros((sil.shape[1] + 1, 2), dtype=np.int64)
    for m in range(lo, hi):
        for k in range(ncam):
            h = cam_hw[k, 0]
            w = cam_hw[k, 1]
            _reset_bbox(bbox, k)
            render_capsules(pts_base, m, base_sel, cap_ab, radii, cams, k, h, w, mask, k, bbox)
            for a in range(na):
                sl = lofs + a * ncam + k
                _reset_bbox(bbox, sl)
                render_capsules(
                    pts_left, m * na + a, left_sel, cap_ab, radii, cams, k, h, w, mask, sl, bbox
                )
            for b in range(nb_):
                sr = rofs + b * ncam + k
                _reset_bbox(bbox, sr)
                render_capsules(
                    pts_right,
                    m * nb_ + b,
                    right_sel,
                    cap_ab,
                    radii,
                    cams,
                    k,
                    h,
                    w,
                    mask,
                    sr,
                    bbox,
                )
        for k in range(ncam):
            # per-row prefix sums of the base alone: rows without leg pixels need no OR
            b_tot = 0
            b_com = 0
            if bbox[k, 0] <= bbox[k, 1]:
                cum[bbox[k, 0], 0] = 0
                cum[bbox[k, 0], 1] = 0
            use = vis_on[k]
            for y in range(bbox[k, 0], bbox[k, 1] + 1):
                for x in range(bbox[k, 2], bbox[k, 3] + 1):
                    v = mask[k, y, x]
                    b_tot += popcount64(v & vis[k, y, x]) if use else popcount64(v)
                    b_com += popcount64(v & sil[k, y, x])
                cum[y + 1, 0] = b_tot
                cum[y + 1, 1] = b_com
            for a in range(na):
                sl = lofs + a * ncam + k
                for b in range(nb_):
                    sr = rofs + b * ncam + k
                    tot = b_tot
                    com = b_com
                    y0 = min(bbox[sl, 0], bbox[sr, 0])
                    y1 = max(bbox[sl, 1], bbox[sr, 1])
                    if y0 <= y1:
                        # replace the base's count over the legs' rows by the OR-ed count
                        ya = min(max(y0, bbox[k, 0]), bbox[k, 1] + 1)
                        yb = min(max(y1 + 1, bbox[k, 0]), bbox[k, 1] + 1)
                        if yb > ya:
                            tot -= cum[yb, 0] - cum[ya, 0]
                            com -= cum[yb, 1] - cum[ya, 1]
                        w0 = min(bbox[k, 2], bbox[sl, 2], bbox[sr, 2])
                        w1 = max(bbox[k, 3], bbox[sl, 3], bbox[sr, 3])
                        if use:
                            for y in range(y0, y1 + 1):
                                for x in range(w0, w1 + 1):
                                    v = mask[k, y, x] | mask[sl, y, x] | mask[sr, y, x]
                                    tot += popcount64(v & vis[k, y, x])
                                    com += popcount64(v & sil[k, y, x])
                        else:
                            for y in range(y0, y1 + 1):
                                for x in range(w0, w1 + 1):
                                    v = mask[k, y, x] | mask[sl, y, x] | mask[sr, y, x]
                                    tot += popcount64(v)
                                    com += popcount64(v & sil[k, y, x])
                    out[m, a, b, k, 0] = com
                    out[m, a, b, k, 1] = sil_total[k] - com
                    out[m, a, b, k, 2] = tot - com
        # clear what was drawn for the next base pose
        for sl in range(nslots):
            for y in range(bbox[sl, 0], bbox[sl, 1] + 1):
                for x in range(bbox[sl, 2], bbox[sl, 3] + 1):
                    mask[sl, y, x] = 0


@nb.njit(cache=True, parallel=True, nogil=True)
def counts_factored_kernel(
    pts_base: np.ndarray,
    pts_left: np.ndarray,
    pts_right: np.ndarray,
    na: int,
    nb_: int,
    groups: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    vis: np.ndarray,
    vis_on: np.ndarray,
    sil_total: np.ndarray,
    nchunks: int,
) -> np.ndarray:
    """Counts of every (base m, left variant a, right variant b): (M, A, B, K, 3) int64.

    ``pts_base`` (M, P, 3), ``pts_left`` (M * A, P, 3), ``pts_right`` (M * B, P, 3): model
    points; ``groups`` (C,) int64 tells which capsules each supplies (0 base, 1 left leg,
    2 right leg). Each part is rendered once; the A*B combinations are OR-ed and counted inside
    the union bounding box. Other arguments as in :func:`counts_kernel`.
    """
    m_n = pts_base.shape[0]
    out = np.zeros((m_n, na, nb_, cams.shape[0], 3), dtype=np.int64)
    nchunks = max(1, min(m_n, nchunks))
    for ch in nb.prange(nchunks):
        _factored_range(
            ch * m_n // nchunks,
            (ch + 1) * m_n // nchunks,
            pts_base,
            pts_left,
            pts_right,
            na,
            nb_,
            groups,
            cap_ab,
            radii,
            cams,
            cam_hw,
            sil,
            vis,
            vis_on,
            sil_total,
            out,
        )
    return out


@nb.njit(cache=True, nogil=True)
def render_one_kernel(
    pts: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    k: int,
    height: int,
    width: int,
) -> np.ndarray:
    """The bit-packed mask (height, ceil(width / 64)) of pose 0 of ``pts`` in camera k."""
    mask = np.zeros((1, height, (width + 63) // 64), dtype=np.uint64)
    bbox = np.empty((1, 4), dtype=np.int64)
    _reset_bbox(bbox, 0)
    sel = np.arange(cap_ab.shape[0])
    render_capsules(pts, 0, sel, cap_ab, radii, cams, k, height, width, mask, 0, bbox)
    return mask[0]


def pack_rows(image: np.ndarray, words: int | None = None) -> np.ndarray:
    """Bool image (H, W) -> bit-packed rows (H, words) uint64 (default ceil(W / 64) words)."""
    img = np.asarray(image, dtype=bool)
    h, w = img.shape
    nw = (w + 63) // 64 if words is None else words
    padded = np.zeros((h, nw * 64), dtype=bool)
    padded[:, :w] = img
    packed = np.packbits(padded, axis=1, bitorder="little")
    return np.ascontiguousarray(packed).view("<u8").astype(np.uint64, copy=False)


def unpack_rows(mask: np.ndarray, width: int) -> np.ndarray:
    """Bit-packed rows (H, words) uint64 -> bool image (H, width)."""
    m = np.ascontiguousarray(mask, dtype="<u8")
    bits = np.unpackbits(m.view(np.uint8), axis=1, bitorder="little")
    return bits[:, :width].astype(bool)
