"""tracker.swing: the way the raised feet move relative to the sacrum."""

from __future__ import annotations

import numpy as np
import pytest

from tracker.dof import wrap_angle
from tracker.swing import swing_direction

FPS = 20.0


def _gait(
    heading: float, speed: float, belt: bool, n: int = 30, period_s: float = 1.1
) -> tuple[np.ndarray, ...]:
    """Times, sacrum and ankles of a schematic gait along ``heading`` (radians): each foot
    stands for 60 % of the period and swings, lifted by up to 8 cm, for 40 %, half a period
    out of phase with the other. Overground (``belt`` False) the sacrum travels at ``speed``
    and a standing foot stays; on a treadmill the sacrum stays and a standing foot is carried
    back at ``speed``."""
    t = np.arange(n) / FPS
    fwd = np.array([np.cos(heading), np.sin(heading)])
    stride = speed * 0.6 * period_s  # a foot's reach, back in stance at speed, forward in swing
    sacrum = np.zeros((n, 3))
    sacrum[:, 2] = 0.95
    if not belt:
        sacrum[:, :2] = (speed * t)[:, None] * fwd
    ankles = []
    for phase0 in (0.0, 0.5):
        ph = (t / period_s + phase0) % 1.0
        stance = ph < 0.6
        # position along fwd relative to the sacrum: back at speed in stance, forward in swing
        rel = np.where(
            stance, 0.5 * stride - stride * ph / 0.6, -0.5 * stride + stride * (ph - 0.6) / 0.4
        )
        z = np.where(stance, 0.08, 0.08 + 0.08 * np.sin(np.pi * (ph - 0.6) / 0.4))
        a = np.zeros((n, 3))
        a[:, :2] = sacrum[:, :2] + rel[:, None] * fwd
        a[:, 2] = z
        ankles.append(a)
    return t, sacrum, ankles[0], ankles[1]


@pytest.mark.parametrize("heading", [0.0, 1.2, -2.5, np.pi])
@pytest.mark.parametrize("belt", [False, True])
def test_the_raised_feet_swing_the_way_the_walker_faces(heading: float, belt: bool) -> None:
    found = swing_direction(*_gait(heading, 1.0, belt))
    assert found is not None
    direction, consistency = found
    assert abs(np.degrees(wrap_angle(direction - heading))) < 1.0
    assert consistency > 0.99  # the schematic feet move only along the walk


def test_played_backwards_the_feet_swing_back() -> None:
    t, s, left, right = _gait(0.7, 1.0, True)
    direction, _ = swing_direction(t, s[::-1], left[::-1], right[::-1])
    assert abs(np.degrees(wrap_angle(direction - 0.7 - np.pi))) < 1.0


def test_noise_lowers_the_consistency_not_the_direction() -> None:
    rng = np.random.default_rng(3)
    t, s, left, right = _gait(0.3, 1.0, True, n=40)
    noisy = [x + rng.normal(0.0, 0.02, x.shape) for x in (s, left, right)]
    direction, consistency = swing_direction(t, *noisy)
    assert abs(np.degrees(wrap_angle(direction - 0.3))) < 30.0
    assert 0.05 < consistency < 0.9


def test_no_answer_without_a_swing() -> None:
    t, s, left, right = _gait(0.0, 1.0, True)
    flat = [a.copy() for a in (left, right)]
    for a in flat:
        a[:, 2] = 0.08  # never lifted
    assert swing_direction(t, s, *flat) is None
    assert swing_direction(t[:2], s[:2], left[:2], right[:2]) is None  # two frames
    assert swing_direction(t[::-1], s, left, right) is None  # time running back
    bad = left.copy()
    bad[3, 0] = np.nan
    assert swing_direction(t, s, bad, right) is None
    with pytest.raises(ValueError, match="must be"):
        swing_direction(t, s[:-1], left, right)
