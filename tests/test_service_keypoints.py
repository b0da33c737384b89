"""service.keypoints: the 2D key-point files of ``gaitwatch track --keypoints``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from service.keypoints import COLUMNS, KeypointFileError, read_keypoints


def _points(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(0, 640, 19), rng.uniform(0, 480, 19), rng.uniform(0, 1, 19)])
    pts[[1, 2]] = np.nan  # neck and sacrum: not detected
    return pts


def _csv(path: Path, rows: dict[int, np.ndarray], header=COLUMNS) -> Path:
    lines = [",".join(header)]
    for frame, pts in rows.items():
        cells = ["" if np.isnan(x) else repr(float(x)) for x in pts.ravel()]
        lines.append(",".join([str(frame), *cells]))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_csv_and_npy_give_the_same_frames(tmp_path: Path) -> None:
    a, b = _points(0), _points(1)
    f = read_keypoints(_csv(tmp_path / "k.csv", {0: a, 3: b}))
    assert len(f) == 2 and f.get(1) is None and f.get(2) is None
    np.testing.assert_array_equal(f.get(0), a)
    np.testing.assert_array_equal(f.get(3), b)
    arr = np.full((4, 19, 3), np.nan)
    arr[0], arr[3] = a, b
    np.save(tmp_path / "k.npy", arr)
    g = read_keypoints(tmp_path / "k.npy")
    assert sorted(g.frames) == [0, 3]
    np.testing.assert_array_equal(g.get(3), f.get(3))
    assert COLUMNS[:4] == ("frame", "head_u", "head_v", "head_conf") and len(COLUMNS) == 58


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda rows: (rows, ("frame", "x")), "the header must be"),
        (lambda rows: ({**rows, -1: rows[0]}, COLUMNS), "frame must be >= 0"),
        (lambda rows: ({0: np.where(np.arange(57).reshape(19, 3) == 2, 1.5, rows[0])}, COLUMNS),
         "conf must be within 0 and 1"),
        (lambda rows: ({0: np.where(np.arange(57).reshape(19, 3) == 0, np.nan, rows[0])}, COLUMNS),
         "u but no v"),
    ],
)  # fmt: skip
def test_bad_csv_files_are_refused_naming_the_line(tmp_path: Path, edit, match) -> None:
    rows, header = edit({0: _points(0)})
    with pytest.raises(KeypointFileError, match=match):
        read_keypoints(_csv(tmp_path / "bad.csv", rows, header))


def test_other_bad_files_are_refused(tmp_path: Path) -> None:
    good = _csv(tmp_path / "k.csv", {0: _points(0)})
    text = good.read_text().splitlines()
    (tmp_path / "twice.csv").write_text("\n".join([*text, text[1]]) + "\n")
    with pytest.raises(KeypointFileError, match="line 3: frame 0 given twice"):
        read_keypoints(tmp_path / "twice.csv")
    (tmp_path / "short.csv").write_text("\n".join([text[0], "0,1,2"]) + "\n")
    with pytest.raises(KeypointFileError, match="line 2: 3 values, expected 58"):
        read_keypoints(tmp_path / "short.csv")
    (tmp_path / "word.csv").write_text("\n".join([text[0], text[1].replace("0,", "x,", 1)]))
    with pytest.raises(KeypointFileError, match="line 2: not a number"):
        read_keypoints(tmp_path / "word.csv")
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(KeypointFileError, match="empty file"):
        read_keypoints(tmp_path / "empty.csv")
    np.save(tmp_path / "flat.npy", np.zeros((4, 57)))
    with pytest.raises(KeypointFileError, match=r"shape \(frames, 19, 3\)"):
        read_keypoints(tmp_path / "flat.npy")
    (tmp_path / "junk.npy").write_bytes(b"not numpy")
    with pytest.raises(KeypointFileError, match="not a NumPy array file"):
        read_keypoints(tmp_path / "junk.npy")
    with pytest.raises(KeypointFileError, match="must be .csv or .npy"):
        read_keypoints(good.with_suffix(".txt").write_text("") or good.with_suffix(".txt"))
    with pytest.raises(KeypointFileError, match="no such file"):
        read_keypoints(tmp_path / "missing.csv")
    inf = np.full((1, 19, 3), 0.5)
    inf[0, 4, 0] = np.inf
    np.save(tmp_path / "inf.npy", inf)
    with pytest.raises(KeypointFileError, match="frame 0: infinite value"):
        read_keypoints(tmp_path / "inf.npy")
