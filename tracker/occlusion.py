"""Furniture in front of the walk, learned from the silhouettes (config ``occlusion``).

Behind a table or a sofa the legs vanish from the silhouette. The likelihood then counts the
model's hidden legs as "model only" pixels and the colour cue finds the furniture's colour along
them, so the tracker bends, shrinks and moves the body to hide its legs and drifts in depth.
Given the furniture's pixels (``Tracker(occluders=...)``, ``gaitwatch track --occluder``) the
tracker discounts them; this module finds them when nobody marked them.

What gives furniture away is its image in the empty scene (the background) and what the
silhouette does at its outline, not what the person looks like:

Regions
    The background is cut into regions of even colour (:func:`background_regions`): Canny edges
    on each Lab channel of a bilateral-filtered copy at twice the likelihood resolution, dilated
    by one pixel; the 4-connected components of the rest. A wall is one large region, a tiled or
    planked floor many small ones, a table top or a sofa's back one each.

Evidence, per frame (:meth:`OcclusionLearner.update`)
    The silhouette's *lower ends* (silhouette pixels whose pixel below is not silhouette) in the
    lower ``lower_fraction`` of its height, and the region just below each (within 3 rows:
    outlines are 1-2 pixels wide). Walking in the open, the lower ends are the soles, spread over
    the floor regions the feet stand in; behind a table, they all lie on the table top's outline.
    A region *supports* the frame when at least ``min_ends_px`` lower ends and ``min_share`` of
    them lie on it. The silhouette pixels *inside* a region (away from its outline) are counted
    too, over the whole track.

Occluders
    A region of at least ``min_region_px`` pixels is an occluder once ``min_frames`` frames
    supported it, the silhouette entered it at most ``max_entered`` times as many pixels as
    ended on it (a hand over a table top is allowed; a floor region the feet stand in is not),
    and it is thick below the lower ends: their mean run of the region downwards is at least
    ``min_depth`` of the image height (a floorboard a foot stops on is not). It
    stops being one when the silhouette enters it later. Furniture stands on the floor and the
    cameras look down at it, so what lies below an occluder's outline in its columns is the
    furniture's front or the floor in front of it: the occluded pixels are, per column of the
    region, its top pixel and everything below.

Above the floor (``floor_margin_m``)
    With the camera and the person's height, a lower end lies *above the floor* when its
    pixel's ray meets the floor more than ``floor_margin_m`` beyond the person, whose distance
    is that of the silhouette's top at the stature's height (give or take what two pixels change
    it): the silhouette does not end on the floor there. A frame also supports a region when at
    least ``min_ends_px`` such ends lie on it, whatever share of all the ends that is: when a
    table starts to hide the legs, the hands and the crotch still hold most of the lower ends.
    Soles on the floor never count this way, whatever the floor looks like.
"""

from __future__ import annotations

import cv2
import numpy as np

from tracker.config import OcclusionConfig


def background_regions(
    background: np.ndarray, size: tuple[int, int], *, work_factor: int = 2
) -> np.ndarray:
    """Regions of even colour of an image of the empty scene -> int32 ``(h, w)`` labels.

    Parameters
    ----------
    background : ndarray (H, W, 3) uint8 BGR, or (H, W) uint8 grey
        The empty scene.
    size : (w, h)
        The output (likelihood) resolution.
    work_factor : int
        Edges are found at ``work_factor`` times ``size``.

    Returns
    -------
    ndarray (h, w) int32: 0 on edges, 1..n the regions.
    """
    bg = np.asarray(background)
    if bg.dtype != np.uint8 or not (bg.ndim == 2 or (bg.ndim == 3 and bg.shape[2] == 3)):
        raise ValueError(
            f"background must be an (H, W, 3) or (H, W) uint8 image, got {bg.shape} {bg.dtype}"
        )
    if bg.ndim == 2:
        bg = cv2.cvtColor(bg, cv2.COLOR_GRAY2BGR)
    w, h = size
    work = (w * work_factor, h * work_factor)
    img = cv2.resize(bg, work, interpolation=cv2.INTER_AREA)
    img = cv2.bilateralFilter(img, 7, 30, 5)
    lab = cv2.cvtColor(img, cv2.COLOR_BGR2Lab)
    edges = np.zeros(work[::-1], dtype=bool)
    for ch in range(3):
        edges |= cv2.Canny(np.ascontiguousarray(lab[..., ch]), 20, 50) > 0
    edges = cv2.dilate(edges.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    _, labels = cv2.connectedComponents((~edges).astype(np.uint8), connectivity=4)
    labels[edges] = 0
    small = cv2.resize(labels.astype(np.float32), size, interpolation=cv2.INTER_NEAREST)
    return small.astype(np.int32)


class OcclusionLearner:
    """Occluders of one camera, learned from its silhouettes (module docstring).

    Parameters
    ----------
    labels : ndarray (h, w) int
        Regions of the empty scene (:func:`background_regions`), 0 = none.
    config : OcclusionConfig
    camera : tracker.camera.Camera, optional
        The camera at the labels' resolution; with ``stature_m`` and
        ``config.floor_margin_m``, lower ends above the floor support a region on their own
        (module docstring). Otherwise only the share rule applies.
    stature_m : float, optional
        The person's height, metres.
    """

    def __init__(
        self,
        labels: np.ndarray,
        config: OcclusionConfig,
        camera=None,
        stature_m: float | None = None,
    ) -> None:
        lab = np.asarray(labels, dtype=np.int32)
        if lab.ndim != 2:
            raise ValueError(f"labels must be 2-D, got shape {lab.shape}")
        self.labels = lab
        self.config = config
        self.camera = camera
        self.stature_m = stature_m
        #: Horizontal distance (m) from the camera to where each pixel's ray meets the floor
        #: (inf: it does not), or None without a camera.
        self._floor_dist: np.ndarray | None = None
        if camera is not None and stature_m is not None and config.floor_margin_m is not None:
            if (camera.width, camera.height) != (lab.shape[1], lab.shape[0]):
                raise ValueError(
                    f"camera {camera.name!r} is {camera.width}x{camera.height}, the regions "
                    f"{lab.shape[1]}x{lab.shape[0]}"
                )
            vv, uu = np.mgrid[0 : lab.shape[0], 0 : lab.shape[1]].astype(np.float64)
            pts = camera.pixel_to_floor(np.stack([uu, vv], axis=-1), 0.0)
            d = np.linalg.norm(pts[..., :2] - camera.center[:2], axis=-1)
            self._floor_dist = np.where(np.isfinite(d), d, np.inf)
        n = int(lab.max()) + 1
        self.area = np.bincount(lab.ravel(), minlength=n)
        # inner pixels: the whole 3x3 neighbourhood in the same region
        pad = np.pad(lab, 1, mode="edge")
        same = np.ones(lab.shape, dtype=bool)
        for dy in range(3):
            for dx in range(3):
                same &= pad[dy : dy + lab.shape[0], dx : dx + lab.shape[1]] == lab
        self._inner = np.where(same, lab, 0)
        # run[y, x]: pixels of y's region from y down in column x (0 on outlines)
        run = np.zeros(lab.shape, dtype=np.int32)
        run[-1] = lab[-1] > 0
        for y in range(lab.shape[0] - 2, -1, -1):
            run[y] = np.where(lab[y] > 0, 1 + np.where(lab[y + 1] == lab[y], run[y + 1], 0), 0)
        # the first region below each pixel, within 3 rows, and its run down from there
        below = np.zeros_like(lab)
        below_run = np.zeros_like(run)
        for d in (3, 2, 1):
            shifted = np.zeros_like(lab)
            shifted[:-d] = lab[d:]
            srun = np.zeros_like(run)
            srun[:-d] = run[d:]
            below = np.where(shifted > 0, shifted, below)
            below_run = np.where(shifted > 0, srun, below_run)
        self._below = below
        self._below_run = below_run
        self.ends = np.zeros(n, dtype=np.int64)
        self.depth = np.zeros(n)
        self.entered = np.zeros(n, dtype=np.int64)
        self.support = np.zeros(n, dtype=np.int64)
        self.occluders = np.zeros(n, dtype=bool)
        #: bool (h, w): the occluded pixels (module docstring).
        self.mask = np.zeros(lab.shape, dtype=bool)

    def update(self, silhouette: np.ndarray) -> bool:
        """Add one frame's silhouette (bool (h, w)); True when the occluders changed."""
        sil = np.asarray(silhouette, dtype=bool)
        if sil.shape != self.labels.shape:
            raise ValueError(f"silhouette {sil.shape} must match the regions {self.labels.shape}")
        rows = np.flatnonzero(sil.any(axis=1))
        if rows.size == 0:
            return False
        c = self.config
        n = self.area.size
        top, bottom = int(rows[0]), int(rows[-1])
        first = int(np.ceil(bottom - c.lower_fraction * (bottom - top + 1)))
        ends = np.zeros_like(sil)
        ends[:-1] = sil[:-1] & ~sil[1:]
        ends[: max(first, 0)] = False
        on = np.bincount(self._below[ends], minlength=n)
        on[0] = 0
        self.depth += np.bincount(self._below[ends], weights=self._below_run[ends], minlength=n)
        total = int(on.sum())
        self.ends += on
        self.entered += np.bincount(self._inner[sil], minlength=n)
        supported = (on >= c.min_ends_px) & (on >= c.min_share * total)
        if self._floor_dist is not None:
            # or: enough of the ends that lie above the floor, whatever the others do
            high = ends & self._above_floor(sil, top)
            on_high = np.bincount(self._below[high], minlength=n)
            on_high[0] = 0
            supported |= on_high >= c.min_ends_px
        if total >= c.min_ends_px:
            self.support += supported
        deep = self.depth >= c.min_depth * self.labels.shape[0] * self.ends
        occ = (
            (self.support >= c.min_frames)
            & (self.entered <= c.max_entered * self.ends)
            & (self.area >= c.min_region_px)
            & deep
        )
        occ[0] = False
        if np.array_equal(occ, self.occluders):
            return False
        self.occluders = occ
        self.mask = self._shadow(occ[self.labels])
        return True

    def _above_floor(self, sil: np.ndarray, top: int) -> np.ndarray:
        """Pixels whose ray meets the floor more than ``floor_margin_m`` beyond the person:
        where the silhouette ends there, it does not end on the floor. The person's distance is
        that of the silhouette's top at the stature's height (an upright person; someone
        bending or sitting seems farther, which only makes this stricter), give or take what
        two pixels up or down change it (a camera at head height cannot tell)."""
        cam = self.camera
        x = float(np.flatnonzero(sil[top]).mean())
        px = np.array([[x, top - 2.0], [x, float(top)], [x, top + 2.0]])
        heads = cam.pixel_to_floor(px, self.stature_m)
        if not np.all(np.isfinite(heads)):
            return np.zeros_like(sil)
        d = np.linalg.norm(heads[:, :2] - cam.center[:2], axis=1)
        slack = 0.5 * abs(float(d[2] - d[0]))
        return self._floor_dist > d[1] + slack + float(self.config.floor_margin_m or 0.0)

    @staticmethod
    def _shadow(regions: np.ndarray) -> np.ndarray:
        """Per column, from the regions' top pixel to the image's bottom."""
        out = np.zeros_like(regions)
        cols = np.flatnonzero(regions.any(axis=0))
        if cols.size:
            tops = regions[:, cols].argmax(axis=0)
            rows = np.arange(regions.shape[0])[:, None]
            out[:, cols] = rows >= tops[None, :]
        return out


__all__ = ["OcclusionLearner", "background_regions"]
