"""Occluders learned from silhouettes (tracker.occlusion): regions of the empty scene that the
silhouette's lower ends lie on, frame after frame, without entering them."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tracker.config import OcclusionConfig
from tracker.occlusion import OcclusionLearner, background_regions

W, H = 160, 120


def _room(rng: np.random.Generator) -> np.ndarray:
    """A 320x240 BGR empty scene: a wall, a floor of 40-pixel tiles with dark grout, a flat
    brown table top (rows 150-200, columns 100-220) and a thin dark floorboard seam."""
    img = np.empty((240, 320, 3), np.uint8)
    img[:90] = (200, 205, 210)  # wall
    img[90:] = (170, 175, 180)  # floor
    for x in range(0, 320, 40):
        img[90:, x : x + 2] = (90, 90, 90)
    for y in range(90, 240, 40):
        img[y : y + 2] = (90, 90, 90)
    img[150:200, 100:220] = (40, 80, 140)  # table top
    img += rng.integers(0, 3, img.shape, dtype=np.uint8)
    return img


@pytest.fixture(scope="module")
def labels() -> np.ndarray:
    return background_regions(_room(np.random.default_rng(0)), (W, H))


def _person(x0: int, top: int, bottom: int, width: int = 10) -> np.ndarray:
    """A standing person's silhouette at likelihood resolution: a block and two legs."""
    s = np.zeros((H, W), bool)
    s[top : top + (bottom - top) // 2, x0 : x0 + width] = True
    s[top : bottom + 1, x0 : x0 + 3] = True
    s[top : bottom + 1, x0 + width - 3 : x0 + width] = True
    return s


def test_regions_of_the_empty_scene(labels: np.ndarray) -> None:
    assert labels.shape == (H, W) and labels.dtype == np.int32
    table = labels[75:100, 50:110]
    # the table top is one region of its own, not shared with the floor around it
    inner = table[2:-2, 2:-2]
    assert np.unique(inner).size == 1 and inner[0, 0] > 0
    r = inner[0, 0]
    assert (labels == r).sum() == pytest.approx(25 * 60, rel=0.15)
    # the wall is one large region; the tiles are regions of their own
    assert np.unique(labels[5:40, 5:150]).size == 1
    grey = cv2.cvtColor(_room(np.random.default_rng(0)), cv2.COLOR_BGR2GRAY)
    assert background_regions(grey, (W, H)).shape == (H, W)
    with pytest.raises(ValueError, match="uint8"):
        background_regions(np.zeros((240, 320, 3), np.float32), (W, H))


def test_legs_ending_on_the_table_make_it_an_occluder(labels: np.ndarray) -> None:
    learner = OcclusionLearner(labels, OcclusionConfig())
    table = labels[85, 80]
    changed = []
    # the person walks behind the table: the legs end on its top edge (row 74, edge at 75)
    for k in range(6):
        changed.append(learner.update(_person(60 + 3 * k, 20, 73)))
    assert changed.index(True) == OcclusionConfig().min_frames - 1
    assert np.flatnonzero(learner.occluders).tolist() == [table]
    # the mask: the table and, in its columns, everything below it; nothing above or beside
    m = learner.mask
    assert m[80:, 55:105].all() and not m[:74].any()
    assert not m[:, :45].any() and not m[:, 115:].any()
    # the person then walks in front of the table: it stops being an occluder
    for _ in range(3):
        learner.update(_person(70, 50, 110))
    assert not learner.occluders.any() and not learner.mask.any()


def test_feet_on_the_floor_make_no_occluder(labels: np.ndarray) -> None:
    learner = OcclusionLearner(labels, OcclusionConfig())
    # walking across the tiles, feet inside them: every lower end lies on the tile it stands in
    for k in range(30):
        learner.update(_person(10 + 4 * k, 40, 100 + (k % 3)))
    assert not learner.occluders.any()
    # a thin region (a seam, a floorboard) the feet stop on is not furniture either
    seam = np.zeros((H, W), np.int32)
    seam[:60] = 1
    seam[60:62] = 2
    seam[62:] = 3
    thin = OcclusionLearner(seam, OcclusionConfig(min_region_px=10))
    for _ in range(10):
        thin.update(_person(40, 10, 59))
    assert thin.support[2] >= 4 and not thin.occluders.any()
    # an empty silhouette is no evidence
    assert not learner.update(np.zeros((H, W), bool))
    with pytest.raises(ValueError, match="must match"):
        learner.update(np.zeros((10, 10), bool))


def test_ends_above_the_floor_support_a_region_on_their_own() -> None:
    """With the camera and the stature, lower ends that lie above the floor (a silhouette cut by
    a table top) support the region they end on even when other lower ends (hands, the crotch)
    outnumber them; a silhouette ending on the floor gains nothing from it."""
    from tracker.camera import Camera

    cam = Camera.look_at(
        name="corner", position=[0.0, 0.0, 2.4], target=[4.0, 0.0, 0.6], image_size=(W, H)
    )
    stature = 1.70
    head = cam.project(np.array([4.0, 0.0, stature]))
    feet = cam.project(np.array([4.0, 0.0, 0.0]))
    cut = cam.project(np.array([3.6, 0.0, 0.75]))  # the far edge of a table 0.4 m in front
    top, bottom, cut_row = (int(round(p[1])) for p in (head, feet, cut))
    assert top < cut_row < bottom - 5
    labels = np.ones((H, W), np.int32)
    labels[cut_row + 1 : cut_row + 20] = 2  # the table top, below the cut
    labels[bottom + 1 : bottom + 20] = 3  # the floor in front of the feet
    x0 = int(round(head[0])) - 5

    def cut_person() -> np.ndarray:
        s = _person(x0, top, cut_row)
        s[cut_row - 6 : cut_row - 3, x0 - 8 : x0 - 1] = True  # a hand, ending on region 1
        return s

    common = {"min_region_px": 10, "min_depth": 0.0, "max_entered": 1.0}
    off = OcclusionLearner(labels, OcclusionConfig(floor_margin_m=None, **common), cam, stature)
    on = OcclusionLearner(labels, OcclusionConfig(floor_margin_m=0.25, **common), cam, stature)
    for _ in range(6):
        off.update(cut_person())
        on.update(cut_person())
    assert off.support[2] == 0  # 6 leg ends against 7 hand ends: under half
    assert on.support[2] == 6 and on.occluders[2]
    # feet on the floor: the floor in front of them is supported by the share rule alone (in
    # both), never by ends above the floor
    a = OcclusionLearner(labels, OcclusionConfig(floor_margin_m=None, **common), cam, stature)
    b = OcclusionLearner(labels, OcclusionConfig(floor_margin_m=0.25, **common), cam, stature)
    for _ in range(6):
        a.update(_person(x0, top, bottom))
        b.update(_person(x0, top, bottom))
    np.testing.assert_array_equal(a.support, b.support)
    high = b._above_floor(_person(x0, top, bottom), top)
    assert not high[bottom, x0] and high[cut_row, x0]
    with pytest.raises(ValueError, match="regions"):
        OcclusionLearner(labels[:, :100], OcclusionConfig(), cam, stature)
