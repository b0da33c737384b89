"""Detected 2D key points triangulated across cameras, and averaged into the written key points.

With two cameras or more, the 2D detector's points of one landmark seen by several cameras meet
in 3D (:func:`triangulate`: the point nearest every camera's ray through its detection, in
least squares). The tracker's written key points come from its body model fitted to the
silhouettes and cues; where the model's key points lie inside a volume the silhouettes do not
pin (the hip joints inside the pelvis, the shoulders at the trunk's edge), the triangulated
detections err about as much but largely independently: on the benchmark's two-camera walks
the estimate's hips erred 61 mm and the triangulated detections' 55 mm, their half-way point 44
mm (docs/tracker.md, "Session 48"). :func:`fuse_detections` writes that average for the chosen
pairs of points (``keypoints.fuse``; the hips along the vertical only by default, since moved
across they turn the thighs and the knee angles), and moves the sacrum (which the detector
does not give) with the triangulated hips; the tracker's own pose, particles and memory keep
the model's. Sides: each camera's detected left and right point are matched to the written
ones, kept or exchanged, whichever lies nearer their projections (the detector's labels are
not trusted, as in the key-point cue).

One camera cannot triangulate, but its detections still say where a point lies across its
line of sight, where the model's points often err more (the arms above all, which one camera's
tracker does not search). :func:`fuse_along_rays` moves the chosen written points towards the
rays through their detections, keeping the model's distance from the camera
(``keypoints.fuse_rays``; docs/tracker.md, "Session 49").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gaitwatch.conventions import KP, SACRUM
from tracker.camera import Camera

#: The pairs of points ``keypoints.fuse`` can name (the ones measured to gain: the legs' and
#: arms' detections triangulated err more than the model's points, docs/tracker.md "Session 48").
FUSE_PAIRS: dict[str, tuple[int, int]] = {
    "hips": (KP["left_hip"], KP["right_hip"]),
    "shoulders": (KP["left_shoulder"], KP["right_shoulder"]),
}

#: The pairs of points ``keypoints.fuse_rays`` can name (one camera).
RAY_PAIRS: dict[str, tuple[int, int]] = {
    name: (KP[f"left_{point}"], KP[f"right_{point}"])
    for name, point in (
        ("hips", "hip"),
        ("knees", "knee"),
        ("ankles", "ankle"),
        ("heels", "heel"),
        ("toes", "toe"),
        ("shoulders", "shoulder"),
        ("elbows", "elbow"),
        ("wrists", "wrist"),
    )
}

#: The limbs whose detected sides are matched as a whole (one camera): a leg with its hip, an
#: arm with its shoulder, as the key-point cue assigns them.
_LIMBS: tuple[tuple[str, ...], ...] = (
    ("hips", "knees", "ankles", "heels", "toes"),
    ("shoulders", "elbows", "wrists"),
)


def triangulate(cameras: Sequence[Camera], pixels: np.ndarray) -> np.ndarray | None:
    """The world point (3,) nearest the rays of ``cameras`` through ``pixels`` (N, 2) (least
    squares of the distances to the rays; lens distortion undone). None with fewer than two
    cameras, rays too nearly parallel to meet, or a point behind one of the cameras."""
    px = np.asarray(pixels, dtype=np.float64)
    if len(cameras) < 2 or px.shape != (len(cameras), 2) or not np.isfinite(px).all():
        return None
    a = np.zeros((3, 3))
    b = np.zeros(3)
    for cam, p in zip(cameras, px, strict=True):
        d = cam.pixel_rays(p[None])[0]
        m = np.eye(3) - np.outer(d, d)
        a += m
        b += m @ np.asarray(cam.center, dtype=np.float64)
    if np.linalg.cond(a) > 1e6:
        return None
    x = np.linalg.solve(a, b)
    if any(float(cam.depth(x[None])[0]) <= 0 for cam in cameras):
        return None
    return x


def side_distances(
    cam: Camera,
    det: np.ndarray,
    joints: np.ndarray,
    left: Sequence[int],
    right: Sequence[int],
    *,
    common_only: bool,
) -> tuple[float, float] | None:
    """How far the camera's detected pixels ``det`` (19, 2+) of the points ``left`` and
    ``right`` lie from the projections of ``joints`` (19, 3): the summed distances as labelled
    and with the two sides exchanged, over the points detected; with ``common_only`` only over
    those finite under both labellings (a point detected on both sides), and None when there
    are none."""
    proj_l, proj_r = cam.project(joints[list(left)]), cam.project(joints[list(right)])
    det_l, det_r = det[list(left), :2], det[list(right), :2]
    d_same = np.linalg.norm(np.concatenate([det_l - proj_l, det_r - proj_r]), axis=1)
    d_swap = np.linalg.norm(np.concatenate([det_r - proj_l, det_l - proj_r]), axis=1)
    if common_only:
        both = np.isfinite(d_same) & np.isfinite(d_swap)
        if not both.any():
            return None
        d_same, d_swap = d_same[both], d_swap[both]
    return float(np.nansum(d_same)), float(np.nansum(d_swap))


def _sides(
    cam: Camera,
    det: np.ndarray,
    joints: np.ndarray,
    left: Sequence[int],
    right: Sequence[int],
    *,
    common_only: bool,
) -> np.ndarray:
    """The camera's detected pixels ``(2, n, 2)`` of the points ``left`` and ``right`` (n each)
    for the written left and right side: as labelled or exchanged, whichever lies nearer the
    written points' projections (:func:`side_distances`; NaN: not detected; a tie, or with
    ``common_only`` no point detected on both sides: as labelled)."""
    det_l, det_r = det[list(left), :2], det[list(right), :2]
    dist = side_distances(cam, det, joints, left, right, common_only=common_only)
    swap = dist is not None and dist[1] < dist[0]
    return np.stack([det_r, det_l]) if swap else np.stack([det_l, det_r])


def fuse_detections(
    joints: np.ndarray,
    cameras: Sequence[Camera],
    detections: Sequence[np.ndarray | None],
    pairs: Sequence[str],
    *,
    weight: float = 0.5,
    max_gap_m: float = 0.15,
    vertical: Sequence[str] = (),
) -> np.ndarray:
    """``joints`` (19, 3) with each point of ``pairs`` (names of :data:`FUSE_PAIRS`) moved
    ``weight`` of the way to its triangulated detection, where at least two cameras detect it
    and the two lie within ``max_gap_m`` of each other (farther: the detections or the
    estimate are wrong, and the written point stays). The pairs named in ``vertical`` move
    along the vertical (z) only. With the hips, the sacrum moves by the mean of the two hips'
    steps towards their triangulations, along all three axes whatever ``vertical`` says (as a
    rigid pelvis would; the sacrum is in no knee angle, and the gait events read its place along
    the walk). ``detections``: per camera None or the detected pixels ``(19, 2)`` in the
    cameras' frame pixels, NaN where a point was not found or not confident enough. Returns a
    new array; ``joints`` is not changed."""
    out = np.array(joints, dtype=np.float64, copy=True)
    if len(detections) != len(cameras):
        raise ValueError(f"expected detections for {len(cameras)} cameras, got {len(detections)}")
    seen = [
        (c, np.asarray(d, dtype=np.float64))
        for c, d in zip(cameras, detections, strict=True)
        if d is not None
    ]
    if len(seen) < 2 or not np.isfinite(out).all():
        return out
    for name in pairs:
        pair = FUSE_PAIRS[name]
        steps = np.zeros((2, 3))
        matched = [_sides(c, d, out, pair[:1], pair[1:], common_only=True)[:, 0] for c, d in seen]
        for k, point in enumerate(pair):
            use = [
                (c, m[k])
                for (c, _), m in zip(seen, matched, strict=True)
                if np.isfinite(m[k]).all()
            ]
            if len(use) < 2:
                continue
            x = triangulate([c for c, _ in use], np.stack([p for _, p in use]))
            if x is None or np.linalg.norm(x - out[point]) > max_gap_m:
                continue
            steps[k] = weight * (x - out[point])
            out[point] = out[point] + (steps[k] * [0.0, 0.0, 1.0] if name in vertical else steps[k])
        if name == "hips":  # the sacrum follows the hips' mean step, along every axis
            out[SACRUM] += steps.mean(axis=0)
    return out


def fuse_along_rays(
    joints: np.ndarray,
    camera: Camera,
    detection: np.ndarray | None,
    pairs: Sequence[str],
    *,
    weight: float = 0.5,
    max_gap_m: float = 0.5,
    vertical: Sequence[str] = (),
    full: Sequence[str] = (),
) -> np.ndarray:
    """``joints`` (19, 3) with each point of ``pairs`` (names of :data:`RAY_PAIRS`) moved
    ``weight`` of the way across the camera's line of sight towards the ray through its
    detection: to the ray's point nearest it, so its distance from the camera, which one camera
    does not see, stays the model's. Farther than ``max_gap_m`` from the ray the point stays.
    The pairs named in ``full`` move all the way to the ray (weight 1), those in ``vertical``
    along the vertical (z) only. With the hips, the sacrum moves by the mean of the two hips'
    steps, along every axis whatever ``vertical`` says (as in :func:`fuse_detections`). The
    detected sides are matched to the written ones limb by limb (a leg with its hip, an arm with
    its shoulder), kept or exchanged, whichever lies nearer their projections. ``detection``:
    None or the detected pixels ``(19, 2)`` (further columns ignored), NaN where a point was not
    found or not confident enough. No point ends below the floor (z = 0) unless it was there
    already (then it goes no lower). Returns a new array; ``joints`` is not changed."""
    out = np.array(joints, dtype=np.float64, copy=True)
    if detection is None or not pairs or not np.isfinite(out).all():
        return out
    det = np.asarray(detection, dtype=np.float64)
    if det.ndim != 2 or det.shape[0] != out.shape[0] or det.shape[1] < 2:
        raise ValueError(f"expected detected pixels (19, 2), got {det.shape}")
    centre = np.asarray(camera.center, dtype=np.float64)
    for limb in _LIMBS:
        names = [n for n in limb if n in pairs]
        if not names:
            continue
        left = [RAY_PAIRS[n][0] for n in limb]
        right = [RAY_PAIRS[n][1] for n in limb]
        matched = _sides(camera, det, out, left, right, common_only=False)
        seen = np.isfinite(matched).all(axis=2)
        rays = np.full(matched.shape[:2] + (3,), np.nan)
        if seen.any():  # every detected point's ray at once
            rays[seen] = camera.pixel_rays(matched[seen])
        for name in names:
            k = limb.index(name)
            steps = np.zeros((2, 3))
            for side, point in enumerate(RAY_PAIRS[name]):
                if not seen[side, k]:
                    continue
                d = rays[side, k]
                along = float((out[point] - centre) @ d)
                if along <= 0:
                    continue
                step = centre + along * d - out[point]
                if np.linalg.norm(step) > max_gap_m:
                    continue
                steps[side] = (1.0 if name in full else weight) * step
            out[list(RAY_PAIRS[name])] += steps * [0.0, 0.0, 1.0] if name in vertical else steps
            if name == "hips":
                out[SACRUM] += steps.mean(axis=0)
    # No point is moved below the floor (z = 0), nor lower than it was when already below.
    floor = np.minimum(np.asarray(joints, dtype=np.float64)[:, 2], 0.0)
    np.maximum(out[:, 2], floor, out=out[:, 2])
    return out


__all__ = ["FUSE_PAIRS", "RAY_PAIRS", "fuse_along_rays", "fuse_detections", "triangulate"]
