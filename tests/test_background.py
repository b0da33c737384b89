"""The empty scene estimated from footage: the frame sampler, the median, and the pass over the
videos that ``gaitwatch track`` makes without ``--background``."""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import numpy as np
import pytest

from service.background import footage_backgrounds
from tracker.background import (
    FrameSampler,
    LightingStates,
    LightingSwitch,
    PersonMask,
    brightness_gain,
    median_background,
    people_in_samples,
)
from tracker.camera import save_camera
from tracker.synthetic import side_cameras, textured_background

SIZE = (96, 72)


# -- FrameSampler ----------------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 5, 7, 8, 9, 31, 100, 1000])
def test_sampler_keeps_evenly_spaced_frames_within_capacity(n: int) -> None:
    s = FrameSampler(capacity=8, max_bytes=None)
    for i in range(n):
        s.offer(np.full((2, 3), i % 256, np.uint8))
    idx = s.indices
    assert len(idx) <= 8
    assert len(idx) == n if n < 8 else len(idx) >= 4
    assert idx[0] == 0 and all(i % s.stride == 0 for i in idx)
    assert np.all(np.diff(idx) == s.stride)  # evenly spaced ...
    assert idx[-1] + 2 * s.stride > n - 1  # ... up to the end of the stream
    assert [int(f[0, 0]) for f in s.frames] == [i % 256 for i in idx]
    assert s.offered == n


def test_sampler_copies_and_checks_shapes() -> None:
    s = FrameSampler(capacity=4, max_bytes=None)
    f = np.zeros((2, 2), np.uint8)
    s.offer(f)
    f[:] = 9  # the caller's buffer reused
    assert s.frames[0].max() == 0
    with pytest.raises(ValueError, match="shape"):
        s.offer(np.zeros((3, 2), np.uint8))


def test_sampler_memory_budget_lowers_capacity() -> None:
    frame = np.zeros((10, 10, 3), np.uint8)  # 300 bytes
    s = FrameSampler(capacity=64, max_bytes=3000)
    for _ in range(100):
        s.offer(frame)
    assert s.capacity == 10 and len(s.frames) <= 10
    assert FrameSampler(capacity=64, max_bytes=1).capacity == 64  # lowered at the first frame
    tiny = FrameSampler(capacity=64, max_bytes=1)
    tiny.offer(frame)
    assert tiny.capacity == 2


@pytest.mark.parametrize("kw", [{"capacity": 1}, {"max_bytes": 0}])
def test_sampler_rejects_bad_settings(kw: dict) -> None:
    with pytest.raises(ValueError):
        FrameSampler(**kw)


# -- median_background ---------------------------------------------------------------------------
def _walk_frames(bg: np.ndarray, n: int, rng: np.random.Generator, noise: float = 2.0):
    """``n`` noisy frames of ``bg`` with a person-sized box crossing from left to right."""
    h, w = bg.shape[:2]
    out = []
    for k in range(n):
        f = bg.astype(np.float32) + rng.normal(0, noise, bg.shape)
        x = int(round((w - 12) * k / max(1, n - 1)))
        f[h // 4 : h // 4 + 40, x : x + 12] = (30, 200, 60)
        out.append(np.clip(f, 0, 255).astype(np.uint8))
    return out


def test_median_of_a_walk_is_the_empty_scene() -> None:
    rng = np.random.default_rng(0)
    bg = textured_background(*SIZE, rng)
    est = median_background(_walk_frames(bg, 21, rng))
    diff = np.abs(est.image.astype(int) - bg.astype(int)).max(axis=2)
    assert est.image.dtype == np.uint8 and est.image.shape == bg.shape
    assert est.n_samples == 21
    assert diff.max() <= 8  # the box covers each pixel in at most 3 of 21 frames
    assert est.unsure_fraction == 0.0


def test_median_in_bands_equals_the_whole() -> None:
    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, (SIZE[1], SIZE[0], 3), dtype=np.uint8) for _ in range(6)]
    whole = median_background(frames, band_bytes=1 << 30)
    bands = median_background(frames, band_bytes=1)  # one row at a time
    assert np.array_equal(whole.image, bands.image)
    stack = np.stack(frames).astype(np.float64)
    assert np.abs(whole.image - np.round(np.median(stack, axis=0) + 1e-9)).max() <= 1
    grey = median_background([f[..., 0] for f in frames])
    assert grey.image.shape == (SIZE[1], SIZE[0])


def test_someone_who_stays_is_reported_unsure(caplog) -> None:
    """A box that stays in one place in most frames takes over the median there: those pixels
    are the unsure ones."""
    rng = np.random.default_rng(2)
    bg = textured_background(*SIZE, rng)
    frames = []
    for k in range(12):
        f = bg.copy()
        if k < 7:  # 7 of 12 frames
            f[10:40, 20:40] = (250, 250, 250)
        frames.append(f)
    est = median_background(frames)
    share = 30 * 20 / (SIZE[0] * SIZE[1])
    assert est.unsure_fraction == pytest.approx(share, abs=0.01)
    with caplog.at_level(logging.WARNING):
        few = median_background(frames[:3])
    assert few.n_samples == 3 and "3 frame(s) only" in caplog.text


@pytest.mark.parametrize(
    "frames, match",
    [
        ([], "no frames"),
        ([np.zeros((4, 4), np.float32)], "uint8"),
        ([np.zeros((4,), np.uint8)], "shape"),
        ([np.zeros((4, 4), np.uint8), np.zeros((4, 5), np.uint8)], "frame 1"),
    ],
)
def test_median_rejects_bad_frames(frames, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        median_background(frames)


# -- the person left out (masks) ------------------------------------------------------------------
def _staying_box(bg: np.ndarray, n: int, stay: int, box=(10, 40, 20, 40)):
    """``n`` frames of ``bg`` with a box over rows y0:y1, columns x0:x1 in the first ``stay``,
    and the masks that mark it there (one pixel wider than the box)."""
    y0, y1, x0, x1 = box
    frames, masks = [], []
    for k in range(n):
        f = bg.copy()
        if k < stay:
            f[y0:y1, x0:x1] = (250, 250, 250)
            masks.append(PersonMask(x0 - 1, y0 - 1, np.ones((y1 - y0 + 2, x1 - x0 + 2), bool)))
        else:
            masks.append(None)
        frames.append(f)
    return frames, masks


def test_the_person_left_out_of_the_median() -> None:
    """Someone who stays in one place in 9 of 12 frames takes over the plain median there; with
    their pixels masked, the median of the 3 other frames is the empty scene, and sure."""
    rng = np.random.default_rng(11)
    bg = textured_background(*SIZE, rng)
    frames, masks = _staying_box(bg, 12, 9)
    plain = median_background(frames)
    assert np.abs(plain.image.astype(int) - bg.astype(int)).max() > 100
    est = median_background(frames, masks=masks)
    assert np.array_equal(est.image, bg)
    assert est.unsure_fraction == 0.0 and est.filled_fraction == 0.0
    # no masks at all, or only None: the plain median
    assert np.array_equal(median_background(frames, masks=[None] * 12).image, plain.image)
    with pytest.raises(ValueError, match="11 person masks for 12 frames"):
        median_background(frames, masks=masks[:11])


def test_pixels_the_person_always_covers_are_filled_in() -> None:
    """Covered in 11 of 12 frames (fewer than min_valid left): filled in from around, counted
    as filled and unsure; the rest of the image is the median of the frames seen."""
    rng = np.random.default_rng(12)
    bg = np.full((SIZE[1], SIZE[0], 3), (90, 120, 150), np.uint8)
    bg = np.clip(bg + rng.normal(0, 2, bg.shape), 0, 255).astype(np.uint8)
    frames, masks = _staying_box(bg, 12, 11)
    est = median_background(frames, masks=masks)
    area = 32 * 22 / (SIZE[0] * SIZE[1])  # the masks' pixels
    assert est.filled_fraction == pytest.approx(area, rel=0.01)
    assert est.unsure_fraction == pytest.approx(area, abs=0.01)
    diff = np.abs(est.image.astype(int) - bg.astype(int)).max(axis=2)
    assert diff[10:40, 20:40].max() <= 12  # the plain scene around fills it
    assert diff.max() <= 12
    # with min_valid 1, the single frame that shows the scene gives it
    one = median_background(frames, masks=masks, min_valid=1)
    assert one.filled_fraction == 0.0 and np.array_equal(one.image, bg)


def test_masked_median_is_the_median_of_the_frames_seen() -> None:
    """Against numpy, pixel by pixel, on random frames and random masks (bands of one row too)."""
    rng = np.random.default_rng(13)
    n, h, w = 9, 12, 10
    frames = [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for _ in range(n)]
    frames[0][0, 0] = 255  # a real 255 among the masked ones
    cover = rng.random((n, h, w)) < 0.4
    masks = [PersonMask(0, 0, c) for c in cover]
    est = median_background(frames, masks=masks, min_valid=1)
    banded = median_background(frames, masks=masks, min_valid=1, band_bytes=1)
    assert np.array_equal(est.image, banded.image)
    stack = np.stack(frames).astype(np.float64)
    for y in range(h):
        for x in range(w):
            seen = ~cover[:, y, x]
            if not seen.any():
                continue
            want = np.floor(np.median(stack[seen, y, x], axis=0) + 0.5)
            assert np.array_equal(est.image[y, x], want), (y, x)


def test_person_mask_rows_are_clipped_to_the_frame() -> None:
    m = PersonMask(-2, 3, np.ones((4, 5), bool))  # 2 columns left of the frame
    rows = m.rows(0, 6, 8)
    assert rows.shape == (6, 8) and rows.sum() == 3 * 3
    assert rows[3:6, 0:3].all() and not rows[:3].any()
    assert m.rows(0, 3, 8) is None and m.rows(7, 9, 8) is None
    assert PersonMask(8, 0, np.ones((2, 2), bool)).rows(0, 2, 8) is None


def test_lighting_states_leave_the_person_out_of_each_state() -> None:
    """A lamp switched off half way and someone who stays in the same place in most frames of
    each half: each state's median, with the masks, is that light's empty scene."""
    rng = np.random.default_rng(14)
    bg = textured_background(*SIZE, rng)
    on, m_on = _staying_box(bg, 12, 9)
    off, m_off = _staying_box((bg * 0.5).astype(np.uint8), 12, 9)
    st = LightingStates(on + off, masks=m_on + m_off)
    assert len(st.states) == 2 and st.sample_states == [1] * 12 + [0] * 12
    assert np.abs(st.states[1].image.astype(int) - bg.astype(int)).max() <= 1
    assert np.abs(st.states[0].image.astype(int) - (bg * 0.5).astype(int)).max() <= 1
    plain = LightingStates(on + off)
    assert np.abs(plain.states[1].image.astype(int) - bg.astype(int)).max() > 100


class _FakeDetector:
    """Finds "the person" as the box it is given, widened by a pixel; nobody in ``blind``."""

    crop_scale = 1.5

    def __init__(self, blind: int | None = None) -> None:
        self.calls: list[tuple] = []
        self.blind = blind

    def person_mask(self, frame, box):
        self.calls.append(tuple(int(v) for v in box))
        if len(self.calls) - 1 == self.blind:
            return None
        x, y, w, h = box
        return x - 1, y - 1, np.ones((h + 2, w + 2), bool)


def test_people_in_samples_look_where_something_moved() -> None:
    """Each sample is segmented against its background; the detector looks at the
    foreground's box; a frame without foreground has no mask; where the detector sees nobody,
    the square crop around the box is left out."""
    rng = np.random.default_rng(15)
    bg = textured_background(*SIZE, rng)
    frames = _walk_frames(bg, 5, rng)
    frames.append(bg.copy())  # nobody
    det = _FakeDetector()
    masks = people_in_samples(frames, [bg] * 6, det)
    assert masks[5] is None and len(det.calls) == 5
    for k, (m, box) in enumerate(zip(masks[:5], det.calls, strict=True)):
        x, y, w, h = box
        assert 12 <= w <= 16 and 40 <= h <= 44  # the walking box, found by the segmentation
        assert (m.x, m.y, m.mask.shape) == (x - 1, y - 1, (h + 2, w + 2))
        truth = np.zeros(bg.shape[:2], bool)
        xk = int(round((SIZE[0] - 12) * k / 4))
        truth[SIZE[1] // 4 : SIZE[1] // 4 + 40, xk : xk + 12] = True
        assert m.rows(0, SIZE[1], SIZE[0])[truth].all()
    blind = people_in_samples(frames[:2], [bg] * 2, _FakeDetector(blind=1))
    x, y, w, h = det.calls[1]
    side = 1.5 * max(w, h)  # 60: the square around the box, clipped to the frame
    assert blind[1].mask.all() and blind[1].y == max(0, int(np.floor(y + h / 2 - side / 2)))
    assert blind[1].mask.shape[0] == min(SIZE[1], int(np.ceil(y + h / 2 + side / 2))) - blind[1].y
    with pytest.raises(ValueError, match="backgrounds"):
        people_in_samples(frames, [bg], det)


def test_people_in_samples_find_a_second_person() -> None:
    """Two people, far apart: the detector, looking at the box of all the foreground, finds one;
    the other's blob lies outside them, so it looks again there. A blob where it then finds
    nobody (a ghost) stays in; a speck under a quarter of the largest blob's area gets no look
    of its own."""
    rng = np.random.default_rng(17)
    bg = textured_background(*SIZE, rng)
    colours = [(30, 200, 60), (200, 30, 200)]
    frames = []
    for k in range(4):
        f = bg.copy()
        f[10:50, 5 + 3 * k : 17 + 3 * k] = colours[0]
        f[15:55, 75 - 3 * k : 87 - 3 * k] = colours[1]
        f[62:70, 20:28] = (255, 255, 255)  # a speck (64 pixels)
        f[20:60, 40:52] = (128, 128, 128)  # no person: a ghost, where the median held one
        frames.append(f)

    class ByColour:
        """Finds the first colour's pixels present in the box (a detector sees one person)."""

        crop_scale = 1.3
        looks = 0

        def person_mask(self, frame, box):
            self.looks += 1
            x, y, w, h = box
            crop = frame[y : y + h, x : x + w]
            for c in colours:
                hit = np.all(crop == c, axis=2)
                if hit.any():
                    return x, y, hit
            return None

    det = ByColour()
    masks = people_in_samples(frames, [bg] * 4, det, min_share=0.25)
    assert det.looks == 12  # three per frame: one person, the other, the ghost; not the speck
    for f, m in zip(frames, masks, strict=True):
        full = m.rows(0, SIZE[1], SIZE[0])
        for c in colours:
            person = np.all(f == c, axis=2)
            assert full[person].all()
        assert not full[62:70, 20:28].any() and not full[20:60, 40:52].any()
    one = people_in_samples(frames, [bg] * 4, ByColour(), max_people=1)
    assert all(not np.all(f == colours[1], axis=2)[m.rows(0, SIZE[1], SIZE[0])].any()
               for f, m in zip(frames, one, strict=True))  # fmt: skip


# -- footage_backgrounds (service) ---------------------------------------------------------------
def _write_footage(root: Path, n: int, rng: np.random.Generator):
    cams = side_cameras(2, image_size=SIZE, fps=20.0)
    bgs, folders, files = [], [], []
    for c, cam in enumerate(cams):
        bg = textured_background(*SIZE, rng)
        d = root / f"cam{c}"
        d.mkdir()
        for i, f in enumerate(_walk_frames(bg, n, rng)):
            cv2.imwrite(str(d / f"{i:04d}.png"), f)
        f = root / f"cam{c}.yaml"
        save_camera(cam, f)
        bgs.append(bg)
        folders.append(d)
        files.append(f)
    return cams, bgs, folders


def test_footage_backgrounds_per_camera(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    cams, bgs, folders = _write_footage(tmp_path, 20, rng)
    est = footage_backgrounds(folders, cams)
    assert len(est) == 2
    for e, bg in zip(est, bgs, strict=True):
        assert len(e.states) == 1 and e.first == 0
        assert np.abs(e.overall.image.astype(int) - bg.astype(int)).max() <= 8
    # --max-frames: at least min_span_s of footage (here the box's first 4 places in 4 frames
    # would take over the median)
    early = footage_backgrounds(folders, cams, max_frames=4, min_span_s=0.0)
    assert np.abs(early[0].overall.image.astype(int) - bgs[0].astype(int)).max() > 100
    spanned = footage_backgrounds(folders, cams, max_frames=4, min_span_s=1.0)  # 20 frames
    assert np.abs(spanned[0].overall.image.astype(int) - bgs[0].astype(int)).max() <= 8


def test_footage_backgrounds_stops_at_a_bad_frame(tmp_path: Path, caplog) -> None:
    """A frame that cannot be read ends the pass with a warning; the frames before it give the
    estimate (the tracking pass then raises its own error there)."""
    rng = np.random.default_rng(4)
    cams, bgs, folders = _write_footage(tmp_path, 20, rng)
    (folders[1] / "0012.png").write_bytes(b"not an image")
    with caplog.at_level(logging.WARNING):
        est = footage_backgrounds(folders, cams)
    assert "stopped after 12 frame(s)" in caplog.text
    assert est[1].overall.n_samples == 12
    assert np.abs(est[1].overall.image.astype(int) - bgs[1].astype(int)).max() <= 8


def test_footage_backgrounds_warns_when_unsure(tmp_path: Path, caplog) -> None:
    cams = side_cameras(1, image_size=SIZE, fps=20.0)
    rng = np.random.default_rng(5)
    bg = textured_background(*SIZE, rng)
    d = tmp_path / "cam0"
    d.mkdir()
    for i in range(10):
        f = bg.copy()
        if i < 6:
            f[5:60, 10:80] = (255, 0, 255)  # something large stays in 6 of 10 frames
        cv2.imwrite(str(d / f"{i:04d}.png"), f)
    with caplog.at_level(logging.WARNING):
        footage_backgrounds([d], cams)
    assert "unsure" in caplog.text and "--background" in caplog.text


def _lamp_footage(root: Path, rng: np.random.Generator, n: int = 24, switch: int = 10):
    """Camera 0's light dimmed to 60 % from frame ``switch`` on (a lamp switched off)."""
    cams, bgs, folders = _write_footage(root, n, rng)
    for i in range(switch, n):
        p = folders[0] / f"{i:04d}.png"
        cv2.imwrite(str(p), (cv2.imread(str(p)) * 0.6).astype(np.uint8))
    return cams, bgs, folders


def test_lighting_states_split_at_a_lamp_switch(tmp_path: Path) -> None:
    """The samples split into two states by brightness, each with its own empty scene; each
    frame is subtracted from its own state's; the overall median, half of each, is unsure."""
    rng = np.random.default_rng(6)
    cams, bgs, folders = _lamp_footage(tmp_path, rng)
    frames = [cv2.imread(str(p)) for p in sorted(folders[0].iterdir())]
    st = LightingStates(frames)
    assert len(st.states) == 2 and st.gains[0] < st.gains[1]
    assert st.gains[1] / st.gains[0] == pytest.approx(1 / 0.6, rel=0.05)
    assert st.first == 1  # the first frame: lamp on, the brighter state
    dark = (bgs[0] * 0.6).astype(np.uint8)
    assert np.abs(st.states[1].image.astype(int) - bgs[0].astype(int)).max() <= 8
    assert np.abs(st.states[0].image.astype(int) - dark.astype(int)).max() <= 8
    assert [st.state_of(f) for f in frames] == [1] * 10 + [0] * 14
    # the overall median is unsure nearly everywhere; a state only along the box's path
    assert st.unsure_fraction < 0.4 < 0.8 < st.overall.unsure_fraction
    assert brightness_gain(frames[-1], frames[0]) == pytest.approx(0.6, abs=0.02)
    # a change smaller than min_step, or groups smaller than min_samples: one state
    assert len(LightingStates(frames, min_step=0.8).states) == 1
    assert len(LightingStates(frames, min_samples=11).states) == 1
    with pytest.raises(ValueError):
        LightingStates(frames, min_step=0)


def test_lighting_switch_follows_the_frames() -> None:
    """The switch hands a camera its state's empty scene when the light changes, once."""
    rng = np.random.default_rng(7)
    bg = textured_background(*SIZE, rng)
    frames = _walk_frames(bg, 12, rng)
    frames = frames[:5] + [(f * 0.5).astype(np.uint8) for f in frames[5:]]
    st = LightingStates(frames, min_samples=3)
    assert len(st.states) == 2

    class Spy:
        calls: list = []

        def set_background(self, camera, image):
            self.calls.append((camera, image))

    switch = LightingSwitch([st, None])
    assert switch.initial()[0] is st.states[st.first].image and switch.initial()[1] is None
    spy = Spy()
    for f in frames:
        switch.apply(spy, [f, f])
    assert [c for c, _ in spy.calls] == [0] and spy.calls[0][1] is st.states[0].image
    assert switch.changes == [(5, 0, 0)]


def test_footage_backgrounds_follow_a_light_change(tmp_path: Path, caplog) -> None:
    """A lamp switched off half way: camera 0 gets two lighting states; camera 1 one."""
    rng = np.random.default_rng(8)
    cams, bgs, folders = _lamp_footage(tmp_path, rng)
    with caplog.at_level(logging.INFO):
        est = footage_backgrounds(folders, cams)
    assert len(est[0].states) == 2 and len(est[1].states) == 1
    assert "2 lighting state(s)" in caplog.text


def test_footage_backgrounds_give_way_when_unsure(tmp_path: Path, caplog) -> None:
    """Where most of the scene keeps changing (here: noise over most of the image), the
    estimate is not used: None, and the tracker learns that camera's background (MOG2)."""
    rng = np.random.default_rng(9)
    cams, bgs, folders = _write_footage(tmp_path, 12, rng)
    for p in sorted(folders[0].iterdir()):
        img = cv2.imread(str(p))
        img[:60] = rng.integers(0, 256, img[:60].shape, dtype=np.uint8)
        cv2.imwrite(str(p), img)
    with caplog.at_level(logging.WARNING):
        est = footage_backgrounds(folders, cams)
    assert est[0] is None and "learning the background" in caplog.text
    assert est[1] is not None
    assert footage_backgrounds(folders, cams, unsure_limit=1.0)[0] is not None


def test_someone_walking_towards_the_camera_is_left_out() -> None:
    """A rendered walk straight towards a frontal camera: the walker covers the middle of the
    view in most frames, and the plain median keeps them there. With the built-in detector
    finding them in each sample, the estimate is near the true empty scene."""
    from gaitwatch.sim.motion import procedural_walk
    from gaitwatch.sim.synth import SceneConfig, build_scene, render_background, render_frames
    from service.background import sampled_states
    from tracker.detector2d import PoseDetector

    walk = procedural_walk(distance_m=3.0, fps=20)
    cfg = SceneConfig(views=["frontal"], image_size=(320, 240), fps=20.0, seed=1, max_frames=30)
    scene = build_scene(walk, cfg)
    truth = cv2.cvtColor(render_background(scene, 0), cv2.COLOR_RGB2BGR)
    sampler = FrameSampler()
    for _, images, _ in render_frames(scene):
        sampler.offer(cv2.cvtColor(images[0], cv2.COLOR_RGB2BGR))

    def off(states) -> float:
        return float(np.mean(np.abs(states.overall.image.astype(int) - truth).max(axis=2) > 30))

    plain = sampled_states(sampler, "frontal")
    found = sampled_states(sampler, "frontal", detector=PoseDetector())
    # measured: 2.6 % of the pixels more than 30 grey levels off -> 0.7 %; 3.2 % filled in
    assert off(found) < 0.4 * off(plain), (off(found), off(plain))
    assert 0 < found.filled_fraction < 0.06


def test_a_detector_that_cannot_run_leaves_the_plain_median(caplog) -> None:
    from service.background import sampled_states
    from tracker.detector2d import DetectorUnavailableError

    class Broken:
        crop_scale = 1.3

        def person_mask(self, frame, box):
            raise DetectorUnavailableError("no runtime")

    rng = np.random.default_rng(16)
    bg = textured_background(*SIZE, rng)
    sampler = FrameSampler()
    for f in _walk_frames(bg, 10, rng):
        sampler.offer(f)
    with caplog.at_level(logging.WARNING):
        est = sampled_states(sampler, "cam0", detector=Broken())
    assert "not left out of the empty scene: no runtime" in caplog.text
    assert np.array_equal(est.overall.image, median_background(sampler.frames).image)
