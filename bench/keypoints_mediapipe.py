"""2D key points of frames by MediaPipe Pose, in the CONVENTIONS order (for the key-point cue).

This script runs in an interpreter of its own, not gaitwatch's: MediaPipe needs NumPy < 2 and
its own OpenCV build. It imports nothing of gaitwatch. Set it up once (offline: the wheel of
0.10.21 carries its pose models, ``model_complexity`` 1 only; 0 and 2 download theirs)::

    python3 -m venv /tmp/mediapipe && /tmp/mediapipe/bin/pip install mediapipe==0.10.21

Usage (``bench/keypoint_cue.py`` calls it)::

    /tmp/mediapipe/bin/python bench/keypoints_mediapipe.py FRAMES.npy OUT.npy

``FRAMES.npy``: uint8 ``(T, H, W, 3)`` BGR frames of one camera, in time order (tracked as a
video). ``OUT.npy``: float64 ``(T, 19, 3)`` ``(u, v, visibility)`` in pixels; NaN for the key
points MediaPipe does not have (neck, sacrum) and in frames where it found nobody. ``head`` is
MediaPipe's nose (only used for the person's extent in the image).
"""

from __future__ import annotations

import sys

import numpy as np

#: CONVENTIONS key-point index -> MediaPipe Pose landmark index.
TO_MEDIAPIPE = {
    0: 0,  # head <- nose
    3: 11, 4: 12, 5: 13, 6: 14, 7: 15, 8: 16,  # shoulders, elbows, wrists
    9: 23, 10: 24, 11: 25, 12: 26, 13: 27, 14: 28,  # hips, knees, ankles
    15: 29, 16: 30, 17: 31, 18: 32,  # heels, toes <- foot index
}  # fmt: skip


def detect(frames: np.ndarray) -> np.ndarray:
    import cv2
    import mediapipe as mp

    out = np.full((len(frames), 19, 3), np.nan)
    h, w = frames.shape[1:3]
    with mp.solutions.pose.Pose(static_image_mode=False, model_complexity=1) as pose:
        for t, image in enumerate(frames):
            res = pose.process(cv2.cvtColor(image, cv2.COLOR_BGR2RGB))
            if res.pose_landmarks is None:
                continue
            marks = res.pose_landmarks.landmark
            for ours, theirs in TO_MEDIAPIPE.items():
                m = marks[theirs]
                out[t, ours] = (m.x * w, m.y * h, m.visibility)
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("\n\n")[0] + "\nusage: keypoints_mediapipe.py FRAMES.npy OUT.npy")
        return 2
    frames = np.load(argv[0])
    if frames.ndim != 4 or frames.shape[3] != 3 or frames.dtype != np.uint8:
        print(f"keypoints_mediapipe: {argv[0]}: expected uint8 (T, H, W, 3) BGR frames")
        return 2
    np.save(argv[1], detect(frames))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
