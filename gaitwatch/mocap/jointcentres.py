"""Joint centres and foot points from skin markers: published regressions and simple geometry.

All functions work on whole recordings at once: inputs are marker trajectories of shape
(T, 3) in metres in a z-up world frame (NaN where a marker is missing) and outputs have the
same shape. Missing inputs give NaN in the frames concerned, never an exception.

References
----------
Harrington ME, Zavatsky AB, Lawson SEM, Yuan Z, Theologis TN (2007). Prediction of the hip
joint centre in adults, children, and patients with cerebral palsy based on magnetic resonance
imaging. J Biomech 40(3):595-602. doi:10.1016/j.jbiomech.2006.02.003

Sangeux M (2015). On the implementation of predictive methods to locate the hip joint centres.
Gait Posture 42(3):402-405. doi:10.1016/j.gaitpost.2015.07.004 (the pelvis-width-only form).

Davis RB, Ounpuu S, Tyburski D, Gage JR (1991). A gait analysis data collection and reduction
technique. Hum Mov Sci 10:575-587 (knee and ankle centres offset medially from the lateral
markers by half the joint width plus the marker radius, as in Vicon Plug-in Gait).
"""

from __future__ import annotations

import numpy as np

Z = np.array([0.0, 0.0, 1.0])


def unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the last axis; NaN where the norm is zero or NaN."""
    v = np.asarray(v, float)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 1e-12, v / n, np.nan)


def nanmid(*points: np.ndarray) -> np.ndarray:
    """Mean of several (T, 3) trajectories; NaN in a frame where any of them is NaN."""
    return np.mean(np.stack([np.asarray(p, float) for p in points]), axis=0)


def nanmedian_scalar(x: np.ndarray) -> float:
    """Median of the finite values (NaN if there are none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else float("nan")


def pelvis_frame(
    lasi: np.ndarray, rasi: np.ndarray, posterior: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The ISB pelvis frame from the anterior superior iliac spines and a posterior point.

    Parameters
    ----------
    lasi, rasi : ndarray, shape (T, 3)
        Left and right ASIS markers.
    posterior : ndarray, shape (T, 3) or None
        Mid-point of the PSIS markers, or the sacrum marker. When None the pelvis is assumed
        level: the superior axis is the world z made orthogonal to the inter-ASIS axis.

    Returns
    -------
    origin, x, y, z : ndarray, each shape (T, 3)
        Origin at the mid-ASIS point; x anterior, y superior, z to the subject's right, unit
        vectors (a right-handed frame, ``x = y cross z``).
    """
    origin = nanmid(lasi, rasi)
    z = unit(rasi - lasi)
    if posterior is not None:
        a = origin - posterior
        x = unit(a - np.sum(a * z, axis=-1, keepdims=True) * z)
        y = np.cross(z, x)
    else:
        y = unit(Z - np.sum(Z * z, axis=-1, keepdims=True) * z)
        x = np.cross(y, z)
    return origin, x, y, z


def harrington_hip_centres(
    lasi: np.ndarray,
    rasi: np.ndarray,
    posterior: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Hip joint centres by the regression of Harrington et al. (2007).

    With a posterior marker (mid-PSIS or sacrum), pelvic depth PD = |mid-ASIS - posterior| and
    pelvic width PW = |RASI - LASI| (recording medians, in mm) give, in the pelvis frame of
    :func:`pelvis_frame` (mm)::

        x = -0.24 PD - 9.9      y = -0.30 PW - 10.9      z = +-(0.33 PW + 7.3)

    Without one, the width-only form (Harrington et al. 2007, as implemented by Sangeux 2015)
    is used with a level pelvis: ``x = -0.138 PW - 10.4, y = -0.305 PW - 10.9``.

    Parameters
    ----------
    lasi, rasi : ndarray, shape (T, 3)
        ASIS markers, metres.
    posterior : ndarray, shape (T, 3) or None
        Mid-PSIS or sacrum marker, metres.

    Returns
    -------
    left, right : ndarray, each shape (T, 3)
        Hip joint centres, metres.
    info : dict
        ``{"pw_m", "pd_m", "method"}`` for documentation and tests.
    """
    origin, x, y, z = pelvis_frame(lasi, rasi, posterior)
    pw = nanmedian_scalar(np.linalg.norm(rasi - lasi, axis=-1)) * 1000.0
    if posterior is not None:
        pd = nanmedian_scalar(np.linalg.norm(nanmid(lasi, rasi) - posterior, axis=-1)) * 1000.0
        hx, hy, hz = -0.24 * pd - 9.9, -0.30 * pw - 10.9, 0.33 * pw + 7.3
        method = "harrington2007"
    else:
        pd = float("nan")
        hx, hy, hz = -0.138 * pw - 10.4, -0.305 * pw - 10.9, 0.33 * pw + 7.3
        method = "harrington2007-width-only"
    base = origin + (hx * x + hy * y) / 1000.0
    right = base + hz / 1000.0 * z
    left = base - hz / 1000.0 * z
    return left, right, {"pw_m": pw / 1000.0, "pd_m": pd / 1000.0, "method": method}


def hip_centres_from_trochanters(
    ltroch: np.ndarray, rtroch: np.ndarray, medial_fraction: float = 0.25
) -> tuple[np.ndarray, np.ndarray]:
    """Approximate hip centres from greater-trochanter markers (no pelvis markers).

    Each centre lies on the inter-trochanter line, moved medially by ``medial_fraction`` of the
    inter-trochanter distance (0.25 puts the centres half the trochanter width apart, about
    17-18 cm for an adult with a 35 cm trochanter width). A rough estimate: the trochanter also
    sits slightly posterior to the head of the femur; documented in docs/mocap-readers.md.
    """
    d = rtroch - ltroch
    return ltroch + medial_fraction * d, rtroch - medial_fraction * d


def offset_medially(
    lateral: np.ndarray, right_axis: np.ndarray, side: str, offset_m: float
) -> np.ndarray:
    """A joint centre from a lateral marker, moved medially along the horizontal right axis.

    Parameters
    ----------
    lateral : ndarray, shape (T, 3)
        Lateral marker (epicondyle, malleolus).
    right_axis : ndarray, shape (T, 3)
        The subject's right direction (e.g. the pelvis z axis); only its horizontal part is used.
    side : {"left", "right"}
    offset_m : float
        Half the joint width plus the marker radius (metres).
    """
    h = np.array(right_axis, float)
    h[..., 2] = 0.0
    h = unit(h)
    medial = h if side == "left" else -h
    return lateral + offset_m * medial


def sole_down(back: np.ndarray, front: np.ndarray | None) -> np.ndarray:
    """Unit "down" direction of the foot: -z made orthogonal to the heel-to-toe line.

    Parameters
    ----------
    back, front : ndarray, shape (T, 3)
        A rear and a front foot point (e.g. heel and toe markers). With ``front`` None (or NaN in
        a frame) the direction is the world's -z.

    Returns
    -------
    ndarray, shape (T, 3)
    """
    down = np.broadcast_to(-Z, np.shape(back)).copy()
    if front is None:
        return down
    e1 = unit(front - back)
    v = unit(-Z - np.sum(-Z * e1, axis=-1, keepdims=True) * e1)
    ok = np.isfinite(v).all(axis=-1)
    down[ok] = v[ok]
    return down


def lower_to_sole(
    marker: np.ndarray, down: np.ndarray, percentile: float = 2.0, max_drop_m: float = 0.08
) -> tuple[np.ndarray, float]:
    """Move a foot marker to the sole: by its own low-percentile height, along ``down``.

    The marker's height when the foot is flat on the floor (the ``percentile`` of its heights
    over the recording, floor at z = 0) is the distance from its centre to the sole: marker
    radius plus the foot or shoe below it. Moving it by that distance puts the point on the sole.

    Returns
    -------
    point : ndarray, shape (T, 3)
    drop_m : float
        The distance used, clipped to [0, max_drop_m].
    """
    z = marker[..., 2]
    z = z[np.isfinite(z)]
    dz = -down[..., 2][np.isfinite(down[..., 2])]
    # Along a slightly tilted "down" the height falls by drop * |down_z|.
    tilt = float(np.clip(np.median(dz), 0.5, 1.0)) if dz.size else 1.0
    drop = float(np.clip(np.percentile(z, percentile) / tilt, 0.0, max_drop_m)) if z.size else 0.0
    return marker + drop * down, drop


def _sagittal_basis(
    a: np.ndarray, b: np.ndarray, right: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """e1 = unit(b - a) and the unit vector perpendicular to it in the sagittal plane, pointing
    down when e1 is near horizontal (NaN where undefined).

    With ``right`` (the subject's right direction, shape (T, 3)) the sagittal plane is the
    plane normal to it, which stays defined when the foot points straight down (toe off and
    swing); without it the vertical plane through e1 is used.
    """
    if right is not None:
        r = unit(right)
        ok = np.isfinite(r).all(axis=-1)
        if ok.any():
            v = b - a
            v = v - np.sum(v * r, axis=-1, keepdims=True) * r
            e1 = unit(v)
            p = unit(np.cross(e1, r))
            e1f, pf = _sagittal_basis(a, b)
            e1 = np.where(ok[..., None], e1, e1f)
            p = np.where(ok[..., None], p, pf)
            return e1, p
    e1 = unit(b - a)
    p = unit(-Z - np.sum(-Z * e1, axis=-1, keepdims=True) * e1)
    return e1, p


def heel_from_ankle_toe(
    ankle: np.ndarray,
    toe: np.ndarray,
    back_ratio: float = 0.45,
    right: np.ndarray | None = None,
) -> np.ndarray:
    """The back of the heel at the sole, from the ankle centre and the toe point on the sole.

    A sagittal foot model: with the foot flat, the ankle centre is ``h`` above the floor and
    ``d`` behind the toe point (2nd metatarsal head, on the sole); the heel is on the floor
    ``back_ratio * d`` behind the ankle (heel-to-ankle about 0.22 and ankle-to-metatarsal-head
    about 0.5 of foot length). ``h`` and ``d`` come from the recording (low-percentile ankle
    height, median ankle-toe distance); the heel then moves rigidly with the ankle-toe line,
    within the vertical plane that contains it.

    Parameters
    ----------
    ankle, toe : ndarray, shape (T, 3)
        Ankle centre and toe point (on the sole), metres, floor at z = 0.
    back_ratio : float
    right : ndarray, shape (T, 3), optional
        The subject's right direction (e.g. left hip -> right hip): the foot then moves in the
        plane normal to it (see ``_sagittal_basis``); the vertical plane otherwise.
    right : ndarray, shape (T, 3), optional
        The subject's right direction (e.g. left hip -> right hip): the foot then moves in the
        plane normal to it (see ``_sagittal_basis``); the vertical plane otherwise.

    Returns
    -------
    ndarray, shape (T, 3)
    """
    n = nanmedian_scalar(np.linalg.norm(toe - ankle, axis=-1))
    az = ankle[..., 2]
    az = az[np.isfinite(az)]
    if not np.isfinite(n) or az.size == 0:
        return np.full_like(ankle, np.nan)
    h = float(np.clip(np.percentile(az, 2.0), 0.02, 0.9 * n))
    d = float(np.sqrt(n * n - h * h))
    b = back_ratio * d
    c1 = (-b * d + h * h) / n
    c2 = (b * h + h * d) / n
    e1, p = _sagittal_basis(ankle, toe, right)
    heel = ankle + c1 * e1 + c2 * p
    # The ankle's lowest height is reached with the heel on the floor but not exactly with the
    # foot flat; correct c2 once so the heel's own low percentile sits on the floor.
    hz = heel[..., 2][np.isfinite(heel[..., 2])]
    pz = -p[..., 2][np.isfinite(p[..., 2])]
    if hz.size and pz.size:
        heel = heel + (np.percentile(hz, 2.0) / max(float(np.median(pz)), 0.5)) * p
    return heel


def ankle_from_heel_toe(
    heel: np.ndarray,
    toe: np.ndarray,
    forward_ratio: float = 0.3,
    height_ratio: float = 0.4,
    right: np.ndarray | None = None,
) -> np.ndarray:
    """Approximate ankle centre from heel and toe points on the sole (no malleolus markers).

    The centre is ``forward_ratio`` of the heel-to-toe distance in front of the heel and
    ``height_ratio`` of it above the sole line, in the vertical plane containing that line.
    """
    n = nanmedian_scalar(np.linalg.norm(toe - heel, axis=-1))
    e1, p = _sagittal_basis(heel, toe, right)
    return heel + forward_ratio * n * e1 - height_ratio * n * p


def segment_poses(cluster: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rigid poses of a marker cluster over time (least-squares fit, Kabsch/SVD, all frames at
    once), relative to its shape in the first frame where every marker is present.

    Parameters
    ----------
    cluster : ndarray, shape (T, M, 3)
        M >= 3 markers on one segment, NaN where missing.

    Returns
    -------
    R : ndarray, shape (T, 3, 3)
    t : ndarray, shape (T, 3)
        ``x_world = R @ x_ref + t`` for a point ``x_ref`` in the reference frame (the cluster
        centred on its centroid in the reference frame). NaN in frames with fewer than three
        markers.
    ok : ndarray of bool, shape (T,)
    """
    cluster = np.asarray(cluster, float)
    T, M, _ = cluster.shape
    seen = np.isfinite(cluster).all(axis=-1)  # (T, M)
    full = np.flatnonzero(seen.all(axis=1))
    R = np.full((T, 3, 3), np.nan)
    t = np.full((T, 3), np.nan)
    if M < 3 or full.size == 0:
        return R, t, np.zeros(T, bool)
    ref = cluster[full[0]] - cluster[full[0]].mean(axis=0)  # (M, 3)
    w = seen.astype(float)
    n = w.sum(axis=1)
    ok = n >= 3
    X = np.where(seen[..., None], cluster, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        cur_c = (w[..., None] * X).sum(axis=1) / n[:, None]
        ref_c = (w[..., None] * ref[None]).sum(axis=1) / n[:, None]
    A = ref[None] - ref_c[:, None]
    B = X - cur_c[:, None]
    H = np.einsum("tm,tmi,tmj->tij", w, A, B)
    H[~ok] = np.eye(3)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, 1, 2) @ np.swapaxes(U, 1, 2)))
    D = np.zeros((T, 3, 3))
    D[:, 0, 0] = 1.0
    D[:, 1, 1] = 1.0
    D[:, 2, 2] = d
    Rt = np.swapaxes(Vt, 1, 2) @ D @ np.swapaxes(U, 1, 2)
    R[ok] = Rt[ok]
    t[ok] = cur_c[ok] - np.einsum("tij,tj->ti", Rt[ok], ref_c[ok])
    return R, t, ok


def score_centre(
    R1: np.ndarray, t1: np.ndarray, R2: np.ndarray, t2: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre of rotation between two segments by SCoRE (Ehrig et al. 2006, J Biomech 39:2798).

    Solves ``R1 c1 + t1 = R2 c2 + t2`` in the least-squares sense over all frames where both
    poses are known, for the constant local points c1, c2.

    Returns
    -------
    c1, c2 : ndarray, shape (3,)
        The centre in each segment's reference frame (minimum-norm solution: for a hinge the
        position along the axis is not determined by the motion).
    sv : ndarray, shape (6,)
        Singular values of the system, descending; ``sv[5] / sv[4]`` small means a hinge, whose
        axis is the last right singular vector (see :func:`hinge_centre`).
    """
    ok = np.isfinite(R1).all(axis=(1, 2)) & np.isfinite(R2).all(axis=(1, 2))
    A = np.concatenate([R1[ok], -R2[ok]], axis=2).reshape(-1, 6)
    b = (t2[ok] - t1[ok]).reshape(-1)
    if A.shape[0] < 12:
        return np.full(3, np.nan), np.full(3, np.nan), np.full(6, np.nan)
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    sv = np.linalg.svd(A, compute_uv=False)
    return x[:3], x[3:], sv


def hinge_centre(
    R1: np.ndarray,
    t1: np.ndarray,
    R2: np.ndarray,
    t2: np.ndarray,
    proximal: np.ndarray,
    distal: np.ndarray,
) -> np.ndarray:
    """Centre of a hinge joint (the knee) from two marker clusters, in world coordinates.

    SCoRE gives a point on the flexion axis and the axis (SARA-like: the null direction of the
    SCoRE system, Ehrig et al. 2007); the position along the axis, which the motion does not
    determine, is chosen where the axis passes closest to the line from the proximal to the
    distal joint centre (hip to ankle: the mechanical axis of the leg), median over frames.

    Parameters
    ----------
    R1, t1, R2, t2 : ndarrays
        Poses of the proximal (thigh) and distal (shank) clusters, see :func:`segment_poses`.
    proximal, distal : ndarray, shape (T, 3)
        Hip and ankle centres.

    Returns
    -------
    ndarray, shape (T, 3)
        NaN where the thigh pose is unknown.
    """
    ok = np.isfinite(R1).all(axis=(1, 2)) & np.isfinite(R2).all(axis=(1, 2))
    A = np.concatenate([R1[ok], -R2[ok]], axis=2).reshape(-1, 6)
    b = (t2[ok] - t1[ok]).reshape(-1)
    T = len(R1)
    if A.shape[0] < 12:
        return np.full((T, 3), np.nan)
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    _, _, Vt = np.linalg.svd(A, full_matrices=False)
    u1 = Vt[-1, :3]
    u1 = u1 / np.linalg.norm(u1)
    c1 = x[:3]
    k0 = np.einsum("tij,j->ti", R1, c1) + t1  # a point on the axis, per frame
    u = np.einsum("tij,j->ti", R1, u1)  # axis direction
    d = unit(distal - proximal)
    # Closest point on the axis line to the hip-ankle line: minimise |k0 + s u - (p + r d)|.
    w0 = k0 - proximal
    a, bb, c = np.sum(u * u, -1), np.sum(u * d, -1), np.sum(d * d, -1)
    dd, e = np.sum(u * w0, -1), np.sum(d * w0, -1)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (bb * e - c * dd) / (a * c - bb * bb)
    s_med = nanmedian_scalar(s)
    if not np.isfinite(s_med):
        return np.full((T, 3), np.nan)
    return np.einsum("tij,j->ti", R1, c1 + s_med * u1) + t1
