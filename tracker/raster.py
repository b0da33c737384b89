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
rows and words the model covers.
"""

from __future__ import annotations

from typing import Final

import numba as nb
import numpy as np
from numba.core import types
from numba.extending import intrinsic

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


@nb.njit(cache=True)
def _distort(x: float, y: float, d: np.ndarray) -> tuple[float, float]:
    """OpenCV distortion of normalised coordinates; ``d`` holds 14 coefficients (zero padded)."""
    r2 = x * x + y * y
    r4 = r2 * r2
    r6 = r4 * r2
    radial = (1.0 + d[0] * r2 + d[1] * r4 + d[4] * r6) / (1.0 + d[5] * r2 + d[6] * r4 + d[7] * r6)
    xd = x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x) + d[8] * r2 + d[9] * r4
    yd = y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y + d[10] * r2 + d[11] * r4
    return xd, yd


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


@nb.njit(cache=True)
def project_point(X: np.ndarray, cam: np.ndarray) -> tuple[float, float, float, bool]:
    """Project world point ``X`` (3,) -> (u, v, pixels per metre at that depth, in front?).

    ``cam`` is a packed camera row (:func:`pack_camera`).
    """
    xc = cam[0] * X[0] + cam[1] * X[1] + cam[2] * X[2] + cam[9]
    yc = cam[3] * X[0] + cam[4] * X[1] + cam[5] * X[2] + cam[10]
    zc = cam[6] * X[0] + cam[7] * X[1] + cam[8] * X[2] + cam[11]
    if not zc >= Z_NEAR:
        return 0.0, 0.0, 0.0, False
    x = xc / zc
    y = yc / zc
    fx = cam[12]
    fy = cam[13]
    scale = 0.5 * (fx + fy) / zc
    if cam[31] != 0.0:
        d = cam[17:31]
        xd, yd = _distort(x, y, d)
        x1, y1 = _distort(x + FD_STEP, y, d)
        x2, y2 = _distort(x, y + FD_STEP, d)
        det = ((x1 - xd) * (y2 - yd) - (x2 - xd) * (y1 - yd)) / (FD_STEP * FD_STEP)
        scale *= np.sqrt(abs(det))
        x = xd
        y = yd
    u = fx * x + cam[16] * y + cam[14]
    v = fy * y + cam[15]
    return u, v, scale, True


@nb.njit(cache=True)
def _emit_span(mask: np.ndarray, y: int, xl: float, xr: float, wmax: float) -> None:
    """Set the pixels of row y whose centres lie in [xl, xr] (wmax = width - 1)."""
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
        mask[y, wa] |= lo & hi
    else:
        mask[y, wa] |= lo
        for w in range(wa + 1, wb):
            mask[y, w] = _ALL
        mask[y, wb] |= hi


@nb.njit(cache=True)
def raster_capsule(
    ax: float,
    ay: float,
    ra: float,
    bx: float,
    by: float,
    rb: float,
    mask: np.ndarray,
    height: int,
    width: int,
    bbox: np.ndarray,
) -> None:
    """OR the convex hull of discs (a, ra) and (b, rb) (pixels) into bit-packed ``mask``.

    ``bbox`` (4,) int64 = [row_min, row_max, word_min, word_max] is widened to cover the
    capsule's clipped bounding box (rows and words in it that the capsule misses stay zero).
    Rows crossed by both outer tangent segments take their span from the segments alone
    (incrementally); only the rows near the ends look at the discs.
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
    if r0 < bbox[0]:
        bbox[0] = r0
    if r1 > bbox[1]:
        bbox[1] = r1
    c0 = int(np.ceil(max(xmin, 0.0))) >> 6
    c1 = int(np.floor(min(xmax, wmax))) >> 6
    if c0 < bbox[2]:
        bbox[2] = c0
    if c1 > bbox[3]:
        bbox[3] = c1
    dx = bx - ax
    dy = by - ay
    d = np.sqrt(dx * dx + dy * dy)
    hull = d > abs(ra - rb) + 1e-9
    if not hull:  # one disc contains the other: draw the larger
        if rb > ra:
            ax, ay, ra = bx, by, rb
        ra2 = ra * ra
        for y in range(r0, r1 + 1):
            e = y - ay
            if e * e <= ra2:
                h = np.sqrt(ra2 - e * e)
                _emit_span(mask, y, ax - h, ax + h, wmax)
        return
    ra2 = ra * ra
    rb2 = rb * rb
    # the two outer tangent segments p -> q of the hull
    ux = dx / d
    uy = dy / d
    c = (ra - rb) / d
    s = np.sqrt(max(0.0, 1.0 - c * c))
    n1x = c * ux - s * uy
    n1y = c * uy + s * ux
    n2x = c * ux + s * uy
    n2y = c * uy - s * ux
    p1x = ax + ra * n1x
    p1y = ay + ra * n1y
    q1x = bx + rb * n1x
    q1y = by + rb * n1y
    p2x = ax + ra * n2x
    p2y = ay + ra * n2y
    q2x = bx + rb * n2x
    q2y = by + rb * n2y
    k1 = (q1x - p1x) / (q1y - p1y) if q1y != p1y else 0.0
    k2 = (q2x - p2x) / (q2y - p2y) if q2y != p2y else 0.0
    # rows crossed by both tangent segments: [i0, i1]
    i0 = int(np.ceil(max(min(p1y, q1y), min(p2y, q2y))))
    i1 = int(np.floor(min(max(p1y, q1y), max(p2y, q2y))))
    if q1y == p1y or q2y == p2y:
        i0 = r1 + 1
        i1 = r1
    i0 = max(i0, r0)
    i1 = min(i1, r1)
    if i0 > i1:
        i0 = r1 + 1
        i1 = r1
    _rows_ends(
        mask,
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
        _rows_middle(mask, i0, i1, p1x, p1y, k1, p2x, p2y, k2, wmax)
        _rows_ends(
            mask, i1 + 1, r1, ax, ay, ra2, bx, by, rb2, p1x, p1y, q1y, k1, p2x, p2y, q2y, k2, wmax
        )


@nb.njit(cache=True)
def _rows_middle(
    mask: np.ndarray,
    y0: int,
    y1: int,
    p1x: float,
    p1y: float,
    k1: float,
    p2x: float,
    p2y: float,
    k2: float,
    wmax: float,
) -> None:
    """Rows y0..y1, all crossed by both tangent segments: the span lies between them."""
    for y in range(y0, y1 + 1):
        fy = float(y)
        x1 = p1x + (fy - p1y) * k1
        x2 = p2x + (fy - p2y) * k2
        if x1 <= x2:
            _emit_span(mask, y, x1, x2, wmax)
        else:
            _emit_span(mask, y, x2, x1, wmax)


@nb.njit(cache=True)
def _rows_ends(
    mask: np.ndarray,
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
        _emit_span(mask, y, xl, xr, wmax)


@nb.njit(cache=True)
def _reset_bbox(bbox: np.ndarray) -> None:
    bbox[0] = _BIG
    bbox[1] = -1
    bbox[2] = _BIG
    bbox[3] = -1


@nb.njit(cache=True)
def render_capsules(
    pts: np.ndarray,
    sel: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cam: np.ndarray,
    height: int,
    width: int,
    mask: np.ndarray,
    bbox: np.ndarray,
) -> None:
    """Rasterise capsules ``sel`` of one pose into ``mask`` (height rows, width pixels).

    ``pts`` (P, 3) model points; ``cap_ab`` (C, 2) point indices of capsule ends; ``radii``
    (C, 2) metres; ``cam`` a packed camera row.
    """
    for ci in range(sel.shape[0]):
        c = sel[ci]
        ua, va, sa, oka = project_point(pts[cap_ab[c, 0]], cam)
        if not oka:
            continue
        ub, vb, sb, okb = project_point(pts[cap_ab[c, 1]], cam)
        if not okb:
            continue
        raster_capsule(
            ua, va, radii[c, 0] * sa, ub, vb, radii[c, 1] * sb, mask, height, width, bbox
        )


@nb.njit(cache=True)
def _count_clear(mask: np.ndarray, sil: np.ndarray, bbox: np.ndarray) -> tuple[int, int]:
    """(model pixels, common pixels) within bbox; clears those mask words."""
    tot = 0
    com = 0
    for y in range(bbox[0], bbox[1] + 1):
        for w in range(bbox[2], bbox[3] + 1):
            m = mask[y, w]
            if m:
                tot += popcount64(m)
                com += popcount64(m & sil[y, w])
                mask[y, w] = 0
    return tot, com


@nb.njit(cache=True)
def _counts_range(
    lo: int,
    hi: int,
    pts: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    sil_total: np.ndarray,
    out: np.ndarray,
) -> None:
    """Counts of poses lo..hi-1 (all capsules) into ``out`` with one scratch mask."""
    mask = np.zeros((sil.shape[1], sil.shape[2]), dtype=np.uint64)
    bbox = np.empty(4, dtype=np.int64)
    sel = np.arange(cap_ab.shape[0])
    for i in range(lo, hi):
        for k in range(cams.shape[0]):
            _reset_bbox(bbox)
            render_capsules(
                pts[i], sel, cap_ab, radii, cams[k], cam_hw[k, 0], cam_hw[k, 1], mask, bbox
            )
            tot, com = _count_clear(mask, sil[k], bbox)
            out[i, k, 0] = com
            out[i, k, 1] = sil_total[k] - com
            out[i, k, 2] = tot - com


@nb.njit(cache=True, parallel=True)
def counts_kernel(
    pts: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
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
            sil_total,
            out,
        )
    return out


@nb.njit(cache=True)
def _factored_one(
    m: int,
    pts_base: np.ndarray,
    pts_left: np.ndarray,
    pts_right: np.ndarray,
    groups: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    sil_total: np.ndarray,
    out: np.ndarray,
) -> None:
    """All A*B leg combinations of base pose m into ``out[m]``."""
    base_sel = np.flatnonzero(groups == 0)
    left_sel = np.flatnonzero(groups == 1)
    right_sel = np.flatnonzero(groups == 2)
    na = pts_left.shape[1]
    nb_ = pts_right.shape[1]
    ncam = cams.shape[0]
    hh = sil.shape[1]
    ww = sil.shape[2]
    base = np.zeros((ncam, hh, ww), dtype=np.uint64)
    left = np.zeros((na, ncam, hh, ww), dtype=np.uint64)
    right = np.zeros((nb_, ncam, hh, ww), dtype=np.uint64)
    bb = np.empty((ncam, 4), dtype=np.int64)
    lb = np.empty((na, ncam, 4), dtype=np.int64)
    rb = np.empty((nb_, ncam, 4), dtype=np.int64)
    for k in range(ncam):
        h = cam_hw[k, 0]
        w = cam_hw[k, 1]
        _reset_bbox(bb[k])
        render_capsules(pts_base[m], base_sel, cap_ab, radii, cams[k], h, w, base[k], bb[k])
        for a in range(na):
            _reset_bbox(lb[a, k])
            render_capsules(
                pts_left[m, a], left_sel, cap_ab, radii, cams[k], h, w, left[a, k], lb[a, k]
            )
        for b in range(nb_):
            _reset_bbox(rb[b, k])
            render_capsules(
                pts_right[m, b], right_sel, cap_ab, radii, cams[k], h, w, right[b, k], rb[b, k]
            )
    for k in range(ncam):
        sk = sil[k]
        bk = base[k]
        for a in range(na):
            lk = left[a, k]
            y0a = min(bb[k, 0], lb[a, k, 0])
            y1a = max(bb[k, 1], lb[a, k, 1])
            w0a = min(bb[k, 2], lb[a, k, 2])
            w1a = max(bb[k, 3], lb[a, k, 3])
            for b in range(nb_):
                rk = right[b, k]
                y0 = min(y0a, rb[b, k, 0])
                y1 = max(y1a, rb[b, k, 1])
                w0 = min(w0a, rb[b, k, 2])
                w1 = max(w1a, rb[b, k, 3])
                tot = 0
                com = 0
                for y in range(y0, y1 + 1):
                    for x in range(w0, w1 + 1):
                        v = bk[y, x] | lk[y, x] | rk[y, x]
                        tot += popcount64(v)
                        com += popcount64(v & sk[y, x])
                out[m, a, b, k, 0] = com
                out[m, a, b, k, 1] = sil_total[k] - com
                out[m, a, b, k, 2] = tot - com


@nb.njit(cache=True, parallel=True)
def counts_factored_kernel(
    pts_base: np.ndarray,
    pts_left: np.ndarray,
    pts_right: np.ndarray,
    groups: np.ndarray,
    cap_ab: np.ndarray,
    radii: np.ndarray,
    cams: np.ndarray,
    cam_hw: np.ndarray,
    sil: np.ndarray,
    sil_total: np.ndarray,
) -> np.ndarray:
    """Counts of every (base m, left variant a, right variant b): (M, A, B, K, 3) int64.

    ``pts_base`` (M, P, 3), ``pts_left`` (M, A, P, 3), ``pts_right`` (M, B, P, 3): model points;
    ``groups`` (C,) int64 tells which capsules each supplies (0 base, 1 left leg, 2 right leg).
    Each part is rendered once; the A*B combinations are OR-ed and counted inside the union
    bounding box. Other arguments as in :func:`counts_kernel`.
    """
    m_n = pts_base.shape[0]
    out = np.zeros((m_n, pts_left.shape[1], pts_right.shape[1], cams.shape[0], 3), dtype=np.int64)
    for m in nb.prange(m_n):
        _factored_one(
            m,
            pts_base,
            pts_left,
            pts_right,
            groups,
            cap_ab,
            radii,
            cams,
            cam_hw,
            sil,
            sil_total,
            out,
        )
    return out


@nb.njit(cache=True)
def render_one_kernel(
    pts: np.ndarray, cap_ab: np.ndarray, radii: np.ndarray, cam: np.ndarray, height: int, width: int
) -> np.ndarray:
    """The bit-packed mask (height, ceil(width / 64)) of one pose (P, 3) in one camera."""
    mask = np.zeros((height, (width + 63) // 64), dtype=np.uint64)
    bbox = np.empty(4, dtype=np.int64)
    _reset_bbox(bbox)
    render_capsules(pts, np.arange(cap_ab.shape[0]), cap_ab, radii, cam, height, width, mask, bbox)
    return mask


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
