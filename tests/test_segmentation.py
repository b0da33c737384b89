"""Segmentation on synthetic frames with a known silhouette."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from tracker.segmentation import (
    Segmentation,
    SegmentationConfig,
    SegmentationError,
    Segmenter,
    downscale_mask,
    keep_blobs,
)

W, H = 320, 240


def _background(rng: np.random.Generator) -> np.ndarray:
    """A textured, colourful scene: smooth random colour field plus a few 'furniture' shapes."""
    coarse = rng.uniform(60, 200, (12, 16, 3)).astype(np.float32)
    bg = cv2.resize(coarse, (W, H), interpolation=cv2.INTER_CUBIC)
    bg += rng.normal(0, 6, bg.shape).astype(np.float32)  # fine texture
    img = np.clip(bg, 0, 255).astype(np.uint8)
    cv2.rectangle(img, (10, 150), (70, 230), (30, 60, 140), -1)
    cv2.circle(img, (270, 60), 25, (180, 180, 40), -1)
    return img


def _person_mask(cx: int = 150, top: int = 40) -> np.ndarray:
    """A person-like silhouette: head, trunk, two arms, two legs (bool H x W)."""
    m = np.zeros((H, W), np.uint8)
    cv2.circle(m, (cx, top + 14), 13, 1, -1)  # head
    cv2.rectangle(m, (cx - 18, top + 28), (cx + 18, top + 100), 1, -1)  # trunk
    cv2.line(m, (cx - 20, top + 32), (cx - 34, top + 95), 1, 9)  # arms
    cv2.line(m, (cx + 20, top + 32), (cx + 36, top + 92), 1, 9)
    cv2.line(m, (cx - 9, top + 100), (cx - 22, top + 180), 1, 13)  # legs
    cv2.line(m, (cx + 9, top + 100), (cx + 16, top + 180), 1, 13)
    return m.astype(bool)


def _frame(
    bg: np.ndarray,
    person: np.ndarray | None,
    rng: np.random.Generator,
    *,
    shadow: bool = False,
    speckles: bool = False,
    noise: float = 4.0,
) -> np.ndarray:
    f = bg.astype(np.float32)
    if shadow:
        sh = np.zeros((H, W), np.uint8)
        cv2.ellipse(sh, (210, 215), (60, 16), 0, 0, 360, 1, -1)  # cast on the floor
        f[sh.astype(bool)] *= 0.6
    if person is not None:
        # Clothes: a colour unlike the scene, with some shading so it is not flat.
        shade = np.linspace(0.8, 1.1, H, dtype=np.float32)[:, None, None]
        clothes = np.broadcast_to(np.array([200, 40, 230], np.float32) * shade, f.shape)
        f[person] = clothes[person]
    f += rng.normal(0, noise, f.shape).astype(np.float32)
    img = np.clip(f, 0, 255).astype(np.uint8)
    if speckles:
        for x, y in rng.integers([5, 5], [W - 5, H - 5], (12, 2)):
            img[y : y + 2, x : x + 2] = (255, 255, 255)
    return img


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(7)


def test_static_finds_the_person_and_not_the_shadow(rng: np.random.Generator) -> None:
    bg = _background(rng)
    person = _person_mask()
    frame = _frame(bg, person, rng, shadow=True, speckles=True)
    seg = Segmenter(SegmentationConfig(mode="static", output_size=(160, 120)), bg).apply(frame)
    assert isinstance(seg, Segmentation)
    assert not seg.empty
    assert _iou(seg.mask_full, person) > 0.9
    # The shadow region is not foreground.
    sh = np.zeros((H, W), np.uint8)
    cv2.ellipse(sh, (210, 215), (60, 16), 0, 0, 360, 1, -1)
    sh = sh.astype(bool) & ~person
    assert seg.mask_full[sh].mean() < 0.02
    # Speckles are gone: one blob, the person, its centroid near the true one.
    assert len(seg.blobs) == 1
    ys, xs = np.nonzero(person)
    assert abs(seg.blobs[0].centroid[0] - xs.mean()) < 2
    assert abs(seg.blobs[0].centroid[1] - ys.mean()) < 2
    assert seg.blobs[0].area == seg.mask_full.sum()
    # Low-resolution mask: majority downscale of the truth agrees.
    assert seg.mask.shape == (120, 160)
    assert _iou(seg.mask, downscale_mask(person, (160, 120))) > 0.88


def test_shadow_is_foreground_without_suppression(rng: np.random.Generator) -> None:
    bg = _background(rng)
    frame = _frame(bg, None, rng, shadow=True)
    on = Segmenter(SegmentationConfig(), bg).apply(frame)
    off = Segmenter(SegmentationConfig(shadow_suppression=False), bg).apply(frame)
    assert on.empty
    assert not off.empty  # the same darkening is detected when not suppressed


def test_empty_scene_is_empty(rng: np.random.Generator) -> None:
    bg = _background(rng)
    seg = Segmenter(SegmentationConfig(), bg).apply(_frame(bg, None, rng, speckles=True))
    assert seg.empty
    assert seg.blobs == []
    assert not seg.mask.any() and not seg.mask_full.any()


def test_small_person_below_minimum_area_counts_as_empty(rng: np.random.Generator) -> None:
    bg = _background(rng)
    person = _person_mask()
    frame = _frame(bg, person, rng)
    big = person.sum() / (H * W)
    seg = Segmenter(SegmentationConfig(min_blob_fraction=big * 1.5), bg).apply(frame)
    assert seg.empty
    seg = Segmenter(SegmentationConfig(min_blob_pixels=int(person.sum() * 0.5)), bg).apply(frame)
    assert not seg.empty


def test_global_gain_compensates_uniform_light_change(rng: np.random.Generator) -> None:
    bg = _background(rng)
    person = _person_mask()
    frame = np.clip(_frame(bg, person, rng).astype(np.float32) * 1.25, 0, 255).astype(np.uint8)
    plain = Segmenter(SegmentationConfig(), bg).apply(frame)
    gain = Segmenter(SegmentationConfig(global_gain=True), bg).apply(frame)
    assert _iou(plain.mask_full, person) < 0.6  # the whole room changed
    assert _iou(gain.mask_full, person) > 0.85


@pytest.mark.parametrize("mode", ["mog2", "knn"])
def test_adaptive_learns_background_then_finds_person(rng: np.random.Generator, mode: str) -> None:
    bg = _background(rng)
    seg = Segmenter(SegmentationConfig(mode=mode, history=50))
    for _ in range(40):  # the empty room, with sensor noise
        seg.apply(_frame(bg, None, rng))
    person = _person_mask(cx=120)
    out = seg.apply(_frame(bg, person, rng, shadow=True))
    assert not out.empty
    assert _iou(out.mask_full, person) > 0.8
    assert len(out.blobs) == 1


def test_keep_blobs_restricts_to_one_person(rng: np.random.Generator) -> None:
    bg = _background(rng)
    a = _person_mask(cx=70)
    b = _person_mask(cx=230, top=20)
    both = a | b
    seg = Segmenter(SegmentationConfig(), bg).apply(_frame(bg, both, rng))
    assert len(seg.blobs) == 2
    right = max(seg.blobs, key=lambda bl: bl.centroid[0])
    only = keep_blobs(seg, [right])
    assert [bl.label for bl in only.blobs] == [right.label]
    assert _iou(only.mask_full, b) > 0.9
    assert not (only.mask_full & a).any()
    assert only.mask.shape == seg.mask.shape
    assert only.mask.sum() < seg.mask.sum()
    assert not (only.mask & downscale_mask(a, (160, 120))).any()
    none = keep_blobs(seg, [])
    assert none.empty and not none.mask.any()
    with pytest.raises(ValueError):
        keep_blobs(seg, [99])


def test_downscale_is_majority() -> None:
    m = np.zeros((8, 8), bool)
    m[0:4, 0:4] = True  # a full 4x4 block -> one pixel at 2x2
    m[4:8, 4:6] = True  # exactly half of a block -> counts
    m[0:1, 4:8] = True  # a quarter -> does not
    small = downscale_mask(m, (2, 2))
    assert small.tolist() == [[True, False], [False, True]]


def test_bad_config_and_inputs(rng: np.random.Generator) -> None:
    with pytest.raises(ValidationError):
        SegmentationConfig(mode="magic")
    with pytest.raises(ValidationError):
        SegmentationConfig(thresh=3)  # unknown key
    with pytest.raises(ValidationError):
        SegmentationConfig(open_kernel=4)
    with pytest.raises(SegmentationError, match="background"):
        Segmenter(SegmentationConfig(mode="static"))
    bg = _background(rng)
    s = Segmenter(SegmentationConfig(), bg)
    with pytest.raises(SegmentationError, match="differs"):
        s.apply(bg[:100])
    with pytest.raises(SegmentationError, match="uint8"):
        s.apply(bg.astype(np.float32))


def test_grey_frames_work(rng: np.random.Generator) -> None:
    bg = cv2.cvtColor(_background(rng), cv2.COLOR_BGR2GRAY)
    person = _person_mask()
    frame = bg.copy()
    frame[person] = 250
    seg = Segmenter(SegmentationConfig(shadow_suppression=False), bg).apply(frame)
    assert _iou(seg.mask_full, person) > 0.9


@pytest.mark.parametrize("mode", ["mog2", "knn"])
def test_seeded_adaptive_keeps_a_person_standing_still(rng: np.random.Generator, mode: str) -> None:
    bg = _background(rng)
    person = _person_mask()
    seg = Segmenter(SegmentationConfig(mode=mode, history=300), bg)
    ious = [_iou(seg.apply(_frame(bg, person, rng)).mask_full, person) for _ in range(30)]
    assert min(ious) > 0.8
    # ... and the room without the person is empty again.
    assert seg.apply(_frame(bg, None, rng)).empty


@pytest.mark.parametrize(("mode", "scale"), [("static", 0.5), ("mog2", 0.5), ("static", 0.4)])
def test_work_scale_gives_full_resolution_results(
    rng: np.random.Generator, mode: str, scale: float
) -> None:
    bg = _background(rng)
    a = _person_mask(cx=70)
    b = _person_mask(cx=230, top=20)
    tol = 1 / scale + 0.5  # one working pixel
    cfg = SegmentationConfig(mode=mode, work_scale=scale, blur=0)
    seg = Segmenter(cfg, bg).apply(_frame(bg, a | b, rng, shadow=True))
    assert seg.mask_full.shape == (H, W) and seg.labels.shape == (H, W)
    assert seg.mask.shape == (120, 160)
    assert _iou(seg.mask_full, a | b) > 0.82
    assert len(seg.blobs) == 2
    for blob in seg.blobs:
        truth = a if blob.centroid[0] < W / 2 else b
        ys, xs = np.nonzero(truth)
        assert abs(blob.centroid[0] - xs.mean()) < tol and abs(blob.centroid[1] - ys.mean()) < tol
        lab = seg.labels == blob.label
        assert blob.area == lab.sum()
        ly, lx = np.nonzero(lab)  # the bbox is exactly that of the blob's labelled pixels
        assert blob.bbox == (lx.min(), ly.min(), lx.max() - lx.min() + 1, ly.max() - ly.min() + 1)
        x, y, w, h = blob.bbox
        assert abs(x - xs.min()) <= tol and abs(x + w - 1 - xs.max()) <= tol
        assert abs(y - ys.min()) <= tol and abs(y + h - 1 - ys.max()) <= tol
    only = keep_blobs(seg, [seg.blobs[0]])
    assert only.mask_full.sum() == seg.blobs[0].area


def _clean_whole_frame(seg: Segmenter, fg: np.ndarray) -> tuple[np.ndarray, list[tuple]]:
    """The reference for Segmenter.clean: morphology and labelling over the whole frame."""
    c = seg.config
    m = fg.astype(np.uint8)
    for op, size in ((cv2.MORPH_OPEN, c.open_kernel), (cv2.MORPH_CLOSE, c.close_kernel)):
        if size > 1:
            m = cv2.morphologyEx(m, op, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)))
    n, labels, stats, cents = cv2.connectedComponentsWithStats(m, connectivity=8)
    min_area = max(c.min_blob_fraction * m.size, float(c.min_blob_pixels), 1.0)
    keep = [k for k in range(1, n) if stats[k, cv2.CC_STAT_AREA] >= min_area]
    keep.sort(key=lambda k: -stats[k, cv2.CC_STAT_AREA])  # stable: ties by label
    relabel = np.zeros(n, np.int32)
    relabel[keep] = np.arange(1, len(keep) + 1)
    blobs = [
        (int(stats[k, 4]), tuple(int(v) for v in stats[k, :4]), (cents[k, 0], cents[k, 1]))
        for k in keep
    ]
    return relabel[labels], blobs


@pytest.mark.parametrize("kernels", [(3, 5), (1, 1), (5, 9)])
def test_clean_inside_the_foreground_box_equals_the_whole_frame(kernels: tuple[int, int]) -> None:
    """clean() works inside the foreground's box plus a margin: the same labels, areas, boxes
    and centroids (bit for bit) as over the whole frame, blobs at the borders and noise too."""
    rng = np.random.default_rng(8)
    cfg = SegmentationConfig(open_kernel=kernels[0], close_kernel=kernels[1], min_blob_fraction=0)
    for trial in range(150):
        h, w = int(rng.integers(3, 130)), int(rng.integers(3, 170))
        fg = np.zeros((h, w), bool)
        for _ in range(int(rng.integers(0, 6))):
            y0, x0 = int(rng.integers(0, h)), int(rng.integers(0, w))
            y1, x1 = y0 + int(rng.integers(1, 40)), x0 + int(rng.integers(1, 40))
            fg[max(0, y0 - 20) : y1, max(0, x0 - 20) : x1] = True
        fg |= rng.random((h, w)) < rng.choice([0.0, 0.002, 0.03])
        seg = Segmenter(cfg, background=np.zeros((h, w, 3), np.uint8))
        mask, labels, blobs = seg.clean(fg)
        ref_labels, ref_blobs = _clean_whole_frame(seg, fg)
        assert np.array_equal(labels, ref_labels), trial
        assert np.array_equal(mask, ref_labels > 0), trial
        assert [(b.area, b.bbox, b.centroid) for b in blobs] == ref_blobs, trial


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_from_foreground_is_apply_after_the_raw_foreground(
    rng: np.random.Generator, scale: float
) -> None:
    """A given foreground goes through apply's clean-up, labelling and downscale: the same
    Segmentation as apply() on the frame whose raw foreground it is."""
    bg = _background(rng)
    frame = _frame(bg, _person_mask(cx=70) | _person_mask(cx=230, top=20), rng, speckles=True)
    seg = Segmenter(SegmentationConfig(work_scale=scale), bg)
    a = seg.apply(frame)
    b = seg.from_foreground(seg.raw_foreground(frame))
    assert np.array_equal(a.mask_full, b.mask_full) and np.array_equal(a.mask, b.mask)
    assert np.array_equal(a.labels, b.labels) and a.blobs == b.blobs
    assert len(b.blobs) == 2


def test_from_foreground_of_a_person_mask(rng: np.random.Generator) -> None:
    """A true person mask (the benchmark's oracle) gives that person's blob and mask."""
    bg = _background(rng)
    person = _person_mask()
    seg = Segmenter(SegmentationConfig(), bg).from_foreground(person)
    assert len(seg.blobs) == 1 and _iou(seg.mask_full, person) > 0.97
    assert seg.mask.shape == (120, 160)
    assert np.array_equal(seg.mask, downscale_mask(seg.mask_full, (160, 120)))
    empty = Segmenter(SegmentationConfig(), bg).from_foreground(np.zeros((H, W), bool))
    assert empty.empty and not empty.mask.any()


def test_from_foreground_rejects_a_mask_of_another_size(rng: np.random.Generator) -> None:
    seg = Segmenter(SegmentationConfig(work_scale=0.5), _background(rng))
    with pytest.raises(SegmentationError, match="neither the frame's 320x240"):
        seg.from_foreground(np.zeros((100, 100), bool))
    adaptive = Segmenter(SegmentationConfig(mode="mog2"))
    with pytest.raises(SegmentationError, match="no frame size yet"):
        adaptive.from_foreground(np.zeros((H, W), bool))


def _dark_trousers_frame(
    bg: np.ndarray, person: np.ndarray, legs: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """``_frame`` with the legs in grey trousers: the scene behind them darkened to 0.6 of its
    brightness, its colour kept (what the shadow test takes for a shadow), and the floor
    shadow."""
    f = _frame(bg, person, rng, shadow=True).astype(np.float32)
    f[legs] = bg[legs].astype(np.float32) * 0.6 + rng.normal(0, 2.0, (int(legs.sum()), 3))
    return np.clip(f, 0, 255).astype(np.uint8)


def _legs(person: np.ndarray, top: int = 40) -> np.ndarray:
    legs = person.copy()
    legs[: top + 104] = False
    return legs


def _floor_shadow() -> np.ndarray:
    sh = np.zeros((H, W), np.uint8)
    cv2.ellipse(sh, (210, 215), (60, 16), 0, 0, 360, 1, -1)
    return sh.astype(bool)


@pytest.mark.parametrize("mode", ["static", "mog2"])
def test_the_segmentation_keeps_what_the_shadow_test_removed(
    rng: np.random.Generator, mode: str
) -> None:
    """The raw foreground and the shadow pixels travel with the result; none without a shadow
    test, none after keep_blobs."""
    bg = _background(rng)
    person = _person_mask()
    frame = _frame(bg, person, rng, shadow=True)
    seg = Segmenter(SegmentationConfig(mode=mode), bg)
    out = seg.apply(frame)
    assert out.foreground is not None and out.shadow is not None
    assert out.foreground.shape == out.shadow.shape == (H, W)
    assert not (out.foreground & out.shadow).any()
    assert np.array_equal(out.foreground, seg.raw_foreground(frame)) or mode == "mog2"
    floor = _floor_shadow() & ~person
    assert out.shadow[floor].mean() > 0.8  # the floor shadow is the test's
    assert out.shadow[person].mean() < 0.02  # the purple clothes are not
    off = Segmenter(SegmentationConfig(mode=mode, shadow_suppression=False), bg).apply(frame)
    assert off.shadow is None and off.foreground is not None
    kept = keep_blobs(out, out.blobs)
    assert kept.foreground is None and kept.shadow is None


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_shadow_pixels_are_given_back_under_the_person(
    rng: np.random.Generator, scale: float
) -> None:
    """Grey trousers are lost to the shadow test; given a person mask over the body, they come
    back, and the floor's shadow outside the mask stays out."""
    bg = _background(rng)
    person, legs = _person_mask(), _legs(_person_mask())
    frame = _dark_trousers_frame(bg, person, legs, rng)
    sg = Segmenter(SegmentationConfig(work_scale=scale), bg)
    seg = sg.apply(frame)
    assert seg.mask_full[legs].mean() < 0.2  # the trousers taken for a shadow
    assert _iou(seg.mask_full, person) < 0.75
    # The person mask, as a detector gives it: the body grown by two pixels, in its box.
    grown = cv2.dilate(person.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    ys, xs = np.nonzero(grown)
    x0, y0 = int(xs.min()), int(ys.min())
    box = grown[y0 : ys.max() + 1, x0 : xs.max() + 1]
    back = sg.with_shadow_given_back(seg, (x0, y0, box))
    assert back is not seg
    assert _iou(back.mask_full, person) > 0.85
    assert back.mask_full[legs].mean() > 0.9
    assert back.mask_full[_floor_shadow() & ~grown].mean() < 0.02  # the floor's stays out
    assert len(back.blobs) == 1
    assert np.array_equal(back.mask, downscale_mask(back.mask_full, (160, 120)))
    # The pixels given back are no longer shadow; the floor's still are.
    assert back.shadow is not None and not (back.shadow & back.foreground).any()
    assert back.shadow.sum() < seg.shadow.sum()
    # Nothing under the mask, or the mask outside the frame: the segmentation itself.
    far = np.ones((20, 20), bool)
    assert sg.with_shadow_given_back(seg, (0, 0, far)) is seg
    assert sg.with_shadow_given_back(seg, (W + 5, 10, far)) is seg
    assert sg.with_shadow_given_back(keep_blobs(seg, seg.blobs), (x0, y0, box)).shadow is None


def test_shadow_pixels_given_back_by_a_mask_past_the_frame_edge(rng: np.random.Generator) -> None:
    """A person mask running past the frame's edges is clipped to it."""
    bg = _background(rng)
    person, legs = _person_mask(cx=150), _legs(_person_mask(cx=150))
    frame = _dark_trousers_frame(bg, person, legs, rng)
    sg = Segmenter(SegmentationConfig(), bg)
    seg = sg.apply(frame)
    whole = np.ones((H + 40, W + 40), bool)  # everything, from (-20, -20)
    back = sg.with_shadow_given_back(seg, (-20, -20, whole))
    assert back.mask_full[legs].mean() > 0.9
    assert back.mask_full[_floor_shadow() & ~person].mean() > 0.8  # the floor's came back too


def test_from_foreground_rejects_a_shadow_of_another_size(rng: np.random.Generator) -> None:
    seg = Segmenter(SegmentationConfig(), _background(rng))
    with pytest.raises(SegmentationError, match="shadow mask 100x100"):
        seg.from_foreground(np.zeros((H, W), bool), shadow=np.zeros((100, 100), bool))


@pytest.mark.parametrize("mode", ["static", "mog2"])
def test_a_segmenter_may_spare_the_shadow_bookkeeping(rng: np.random.Generator, mode: str) -> None:
    """``keep_shadow=False`` (a tracker that gives no shadow back): the same silhouette, no
    shadow pixels kept."""
    bg = _background(rng)
    frame = _frame(bg, _person_mask(), rng, shadow=True)
    kept = Segmenter(SegmentationConfig(mode=mode), bg).apply(frame)
    spared = Segmenter(SegmentationConfig(mode=mode), bg, keep_shadow=False).apply(frame)
    assert kept.shadow is not None and spared.shadow is None
    assert np.array_equal(kept.mask_full, spared.mask_full) and kept.blobs == spared.blobs
