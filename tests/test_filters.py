"""The body-part filters (IPF, APF, Condensation) behind one interface, on a toy likelihood.

The toy likelihood is a smooth function of the distance to a hidden true pose, so these tests
exercise the filters alone; tests/test_track.py runs them on rendered silhouettes.
"""

from __future__ import annotations

import numpy as np
import pytest

from tracker.config import IPFConfig, OriginSearchConfig, TrackerConfig
from tracker.dof import DOF, LEFT_LEG, N_DOF, RIGHT_LEG, ROOT_DOFS, JointLimits
from tracker.filters import (
    FILTERS,
    IntervalParticleFilter,
    make_filter,
    resample_systematic,
    select_distinct,
    split_budget,
)
from tracker.filters.apf import annealed, annealing_exponent, survival_rate
from tracker.origin import search_origin

LIMITS = JointLimits.profile("walking").arrays()
LEGS = [DOF[n] for n in ("l_hip_flexion", "r_hip_flexion", "l_knee_flexion", "r_knee_flexion")]


class ToyLikelihood:
    """exp(-d^2 / 2): d the scaled distance to a hidden pose; counts evaluations."""

    def __init__(self, truth: np.ndarray, *, factored: bool = True) -> None:
        self.truth = truth.copy()
        self.scale = np.full(N_DOF, np.radians(8.0))
        self.scale[list(ROOT_DOFS[:3])] = 0.05
        self.evaluations = 0
        if not factored:
            self.weights_factored = None  # type: ignore[assignment]

    def weights(self, poses: np.ndarray) -> np.ndarray:
        self.evaluations += poses.shape[0]
        d = (poses - self.truth) / self.scale
        return np.exp(-0.5 * np.sum(d * d, axis=1) / 4.0)

    def weights_factored(self, base, left, right) -> np.ndarray:  # noqa: D102
        m, a, b = base.shape[0], left.shape[1], right.shape[1]
        p = np.repeat(base[:, None, None, :], a, axis=1).repeat(b, axis=2)
        p[..., list(LEFT_LEG)] = left[:, :, None, :]
        p[..., list(RIGHT_LEG)] = right[:, None, :, :]
        return self.weights(p.reshape(-1, N_DOF)).reshape(m, a, b)


def _standing() -> np.ndarray:
    p = np.zeros(N_DOF)
    p[DOF["root_z"]] = 0.9
    p[DOF["l_knee_flexion"]] = p[DOF["r_knee_flexion"]] = np.radians(5.0)
    return p


def _truth(t: float) -> np.ndarray:
    """A walking-like motion of the legs at 1 Hz; the root stays put."""
    p = _standing()
    w = 2 * np.pi * t
    p[DOF["l_hip_flexion"]] = np.radians(10 + 20 * np.sin(w))
    p[DOF["r_hip_flexion"]] = np.radians(10 - 20 * np.sin(w))
    p[DOF["l_knee_flexion"]] = np.radians(30 + 25 * np.sin(w + 1.0))
    p[DOF["r_knee_flexion"]] = np.radians(30 - 25 * np.sin(w + 1.0))
    return p


def _small_config(name: str) -> TrackerConfig:
    return TrackerConfig(filter=name, ipf=IPFConfig(kept=9))  # 9 * 81 = 729 evaluations


# -- shared steps -----------------------------------------------------------------------------
def test_select_distinct_keeps_heaviest_distinct() -> None:
    poses = np.array([[0.0, 1], [2, 3], [0, 1], [4, 5], [2, 3]])
    w = np.array([0.1, 0.9, 0.5, 0.2, 0.3])
    idx = select_distinct(poses, w, 10)
    assert idx.tolist() == [1, 2, 3]  # (2,3) heaviest at 1; (0,1) heaviest at 2; then (4,5)
    assert select_distinct(poses, w, 2).tolist() == [1, 2]


def test_select_distinct_matches_a_full_sort_with_ties_and_duplicates() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        poses = rng.normal(size=(2000, N_DOF))
        poses[rng.integers(0, 2000, 900)] = poses[rng.integers(0, 5)]  # many duplicates
        w = rng.random(2000).round(1)  # many ties
        order = np.argsort(-w, kind="stable")
        seen, expect = set(), []
        for i in order:
            key = poses[i].tobytes()
            if key not in seen:
                seen.add(key)
                expect.append(i)
        for m in (1, 7, 81, 5000):
            assert select_distinct(poses, w, m).tolist() == expect[:m]


@pytest.mark.parametrize("collide", [False, True])
def test_row_groups_are_exact_even_when_hashes_collide(
    collide: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Rows are grouped by a hash of their bytes, and by the bytes when two hashes collide
    (here every hash is forced to 0); -0.0 and 0.0 differ in their bytes, so stay apart."""
    from tracker.filters import base

    if collide:
        monkeypatch.setattr(base, "_row_hashes", lambda rows: np.zeros(len(rows), np.uint64))
    rng = np.random.default_rng(5)
    rows = rng.normal(size=(6, N_DOF))[rng.integers(0, 6, 300)]
    rows[:40, 3] = 0.0
    rows[40:80, 3] = -0.0
    first, group = base.row_groups(rows)
    keys = [r.tobytes() for r in rows]
    assert len(first) == len(set(keys))
    for i, g in enumerate(group):
        assert keys[first[g]] == keys[i]
        assert first[g] == keys.index(keys[i])  # the first occurrence
    assert select_distinct(rows, np.ones(300), 500).tolist() == sorted(
        keys.index(k) for k in set(keys)
    )


def test_resample_systematic_is_proportional() -> None:
    rng = np.random.default_rng(1)
    w = np.array([0.0, 1.0, 3.0, 0.0])
    idx = resample_systematic(w, 4000, rng)
    counts = np.bincount(idx, minlength=4)
    assert counts[0] == counts[3] == 0
    assert abs(counts[2] / counts[1] - 3.0) < 0.01
    assert set(resample_systematic(np.zeros(3), 30, rng)) == {0, 1, 2}


def test_split_budget_sums_exactly() -> None:
    for total, parts in [(6561, 5), (6561, 9), (10, 3), (2, 5)]:
        s = split_budget(total, parts)
        assert sum(s) == total and max(s) - min(s) <= 1 and min(s) >= 1


def test_annealing_exponent_hits_survival_rate() -> None:
    w = np.random.default_rng(2).random(500) ** 3
    for alpha in (0.2, 0.5, 0.8):
        beta = annealing_exponent(w, alpha)
        log_w = np.log(w)
        assert survival_rate(log_w, beta) == pytest.approx(alpha, abs=1e-3)
    pi = annealed(w, annealing_exponent(w, 0.5))
    assert pi.sum() == pytest.approx(1.0)


# -- IPF --------------------------------------------------------------------------------------
def test_ipf_makes_exactly_q_pow_n_neighbours_inside_limits() -> None:
    cfg = IPFConfig(kept=5, q=3)
    f = IntervalParticleFilter(cfg, limits=LIMITS, rng=np.random.default_rng(0))
    kept = np.repeat(_standing()[None], 5, axis=0)
    kept[:, DOF["root_x"]] = np.arange(5.0)  # distinct groups
    kept[0, DOF["l_knee_flexion"]] = 0.0  # at the lower limit: interval shifted inside
    kept[1, DOF["r_hip_flexion"]] = LIMITS[1][DOF["r_hip_flexion"]]  # at the upper limit
    out = f.predict(kept.copy(), dt=0.05)
    n, q = len(cfg.interesting), cfg.q
    assert out.shape == (5 * q**n, N_DOF)
    assert np.all(out >= LIMITS[0] - 1e-12) and np.all(out <= LIMITS[1] + 1e-12)
    groups = out.reshape(5, q**n, N_DOF)
    L = [DOF[d] for d in cfg.interesting]
    R = [i for i in range(N_DOF) if i not in L]
    for g in groups:
        # R shared inside a group, L takes q^n distinct combinations of q values per DOF
        assert np.all(g[:, R] == g[0, R])
        assert len({tuple(r) for r in g[:, L].round(12)}) == q**n
        for j in L:
            vals = np.unique(g[:, j])
            assert vals.size == q
            assert vals.max() - vals.min() == pytest.approx(np.radians(10.0))
    # interval scales with the frame interval: 10 deg at 20 Hz -> 5 deg at 40 Hz
    half = f.predict(kept.copy(), dt=0.025).reshape(5, q**n, N_DOF)
    j = DOF["l_hip_flexion"]
    assert np.ptp(half[2, :, j]) == pytest.approx(np.radians(5.0))


def test_ipf_default_is_6561_particles_and_factored_equals_plain() -> None:
    cfg = TrackerConfig()
    assert cfg.ipf.evaluations == 6561 == cfg.evaluations_per_frame
    truth = _truth(0.1)
    results = []
    for factored in (True, False):
        f = make_filter("ipf", cfg, rng=np.random.default_rng(5))
        f.initialise(_standing()[None])
        lik = ToyLikelihood(truth, factored=factored)
        est = f.step(lik, 0.05)
        assert f.used_factored is factored
        assert f.particles.shape == (6561, N_DOF) and lik.evaluations == 6561
        results.append((f.particles.copy(), f.weights.copy(), est.weight))
    assert np.array_equal(results[0][0], results[1][0])
    assert np.allclose(results[0][1], results[1][1], rtol=0, atol=1e-15)


def test_ipf_keeps_m_groups_even_with_few_distinct_particles() -> None:
    f = make_filter("ipf", _small_config("ipf"), rng=np.random.default_rng(0))
    f.initialise(_standing()[None])  # one distinct particle
    lik = ToyLikelihood(_truth(0.0))
    f.step(lik, 0.05)
    assert f.particles.shape[0] == 9 * 81
    assert np.unique(f.particles, axis=0).shape[0] == 9 * 81  # noise on R separates the groups


def test_ipf_anneal_stage_takes_its_groups_budget_and_moves_every_dof() -> None:
    """The annealing stage spends a share of the kept groups' evaluations on layers diffused on
    every DOF, the root included; the frame's total stays kept * q^n."""
    cfg = IPFConfig(kept=9, anneal={"share": 0.34, "layers": 2})
    assert cfg.anneal_groups == 3 and cfg.evaluations == 729
    f = IntervalParticleFilter(cfg, limits=LIMITS, rng=np.random.default_rng(0))
    assert f.M == 6 and f.anneal_sizes == [122, 121] and f.evaluations_per_step == 729
    f.initialise(_standing()[None])
    lik = ToyLikelihood(_truth(0.0))
    est = f.step(lik, 0.05)
    assert lik.evaluations == f.last_evaluations == 729
    assert f.particles.shape == (729, N_DOF)
    grid, layers = f.particles[: 6 * 81], f.particles[6 * 81 :]
    root = list(ROOT_DOFS)
    assert np.all(grid[:, root] == grid[0, root])  # the grid passes leave the root as set
    assert np.all(np.ptp(layers, axis=0) > 0)  # the layers move every DOF, the root too
    assert np.all(layers >= LIMITS[0] - 1e-12) and np.all(layers <= LIMITS[1] + 1e-12)
    assert est.weight == f.weights.max()  # the estimate is the heaviest of all
    # move_interesting false: the layers keep the grid's values of the interesting DOFs
    still = IPFConfig(kept=9, anneal={"share": 0.34, "move_interesting": False})
    g = IntervalParticleFilter(still, limits=LIMITS, rng=np.random.default_rng(0))
    g.initialise(_standing()[None])
    g.step(ToyLikelihood(_truth(0.0)), 0.05)
    grid_vals = {tuple(r) for r in g.particles[: 6 * 81][:, LEGS]}
    assert all(tuple(r) in grid_vals for r in g.particles[6 * 81 :][:, LEGS])
    assert np.all(np.ptp(g.particles[6 * 81 :][:, list(ROOT_DOFS)], axis=0) > 0)
    # share 0 (the default): the M groups of the grid, no stage
    off = IntervalParticleFilter(
        IPFConfig(kept=9, anneal={"share": 0.0}), limits=LIMITS, rng=np.random.default_rng(0)
    )
    assert off.M == 9 and off.anneal_sizes == [] and off.evaluations_per_step == 729


def test_ipf_anneal_stage_moves_the_root_towards_the_truth() -> None:
    """The grid and the noise on R never move the root (the origin search sets it); the
    annealing stage does, at the same evaluations."""
    truth = _standing()
    truth[DOF["root_x"]] = 0.05
    truth[DOF["root_yaw"]] = np.radians(6.0)
    errors = {}
    for share in (0.0, 0.34):
        cfg = IPFConfig(kept=9, anneal={"share": share})
        f = IntervalParticleFilter(cfg, limits=LIMITS, rng=np.random.default_rng(0))
        f.initialise(_standing()[None])
        lik = ToyLikelihood(truth)
        for _ in range(5):
            est = f.step(lik, 0.05)
        assert lik.evaluations == 5 * 729
        errors[share] = (
            abs(est.pose[DOF["root_x"]] - 0.05),
            abs(est.pose[DOF["root_yaw"]] - truth[DOF["root_yaw"]]),
        )
    assert errors[0.0] == pytest.approx((0.05, np.radians(6.0)), abs=1e-12)
    assert errors[0.34][0] < 0.04 and errors[0.34][1] < np.radians(5.0)


# -- the interface suite, run on every filter --------------------------------------------------
@pytest.mark.parametrize("name", sorted(FILTERS))
def test_same_evaluations_per_frame(name: str) -> None:
    cfg = _small_config(name)
    f = make_filter(name, cfg, rng=np.random.default_rng(0))
    assert f.name == name
    f.initialise(np.repeat(_standing()[None], 3, axis=0), np.array([1.0, 0.5, 0.2]))
    for k in range(3):
        lik = ToyLikelihood(_truth(0.05 * k))
        f.step(lik, 0.05)
        assert lik.evaluations == cfg.evaluations_per_frame == f.evaluations_per_step == 729
        assert f.last_evaluations == 729


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_limits_respected(name: str) -> None:
    f = make_filter(name, _small_config(name), rng=np.random.default_rng(3))
    wild = np.random.default_rng(4).uniform(-4, 4, (20, N_DOF))
    f.initialise(wild)
    assert np.all(f.particles >= LIMITS[0] - 1e-12) and np.all(f.particles <= LIMITS[1] + 1e-12)
    far = _truth(0.0)
    far[DOF["l_knee_flexion"]] = LIMITS[0][DOF["l_knee_flexion"]] - 1.0  # outside: pulls to limit
    for _ in range(3):
        f.step(ToyLikelihood(far), 0.05)
        assert np.all(f.particles >= LIMITS[0] - 1e-12)
        assert np.all(f.particles <= LIMITS[1] + 1e-12)


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_deterministic_with_seed(name: str) -> None:
    def run(seed: int) -> np.ndarray:
        f = make_filter(name, _small_config(name), rng=np.random.default_rng(seed))
        f.initialise(_standing()[None])
        return np.stack([f.step(ToyLikelihood(_truth(0.05 * k)), 0.05).pose for k in range(4)])

    a, b, c = run(11), run(11), run(12)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_follows_a_moving_target(name: str) -> None:
    """Over one walking cycle (20 frames at 20 Hz) the estimate follows hips and knees."""
    f = make_filter(
        name, TrackerConfig(filter=name, ipf=IPFConfig(kept=27)), rng=np.random.default_rng(7)
    )
    f.initialise(_truth(0.0)[None])
    errs = []
    for k in range(1, 21):
        truth = _truth(k * 0.05)
        f.set_root(truth[list(ROOT_DOFS)])
        est = f.step(ToyLikelihood(truth), 0.05)
        errs.append(np.degrees(np.abs(est.pose[LEGS] - truth[LEGS])).mean())
    # Measured mean errors (deg, seed 7): IPF 3.4, APF 2.5, Condensation 4.4; bound with margin.
    assert np.mean(errs) < 8.0, errs


def test_origin_search_recovers_offset_root() -> None:
    truth = _truth(0.0)
    truth[DOF["root_x"]], truth[DOF["root_y"]] = 0.8, -0.4
    truth[DOF["root_yaw"]] = np.radians(30.0)
    start = truth.copy()
    start[DOF["root_x"]] += 0.07
    start[DOF["root_y"]] -= 0.05
    start[DOF["root_yaw"]] += np.radians(8.0)
    lik = ToyLikelihood(truth)
    res = search_origin(lik, start, OriginSearchConfig(), limits=LIMITS)
    # 12 grids of 7; each grid after the first reuses the weight of its zero offset (best)
    assert res.evaluations == 6 * 2 * 7 - 11 == lik.evaluations
    assert abs(res.pose[DOF["root_x"]] - 0.8) < 0.02
    assert abs(res.pose[DOF["root_y"]] + 0.4) < 0.02
    assert abs(np.degrees(res.pose[DOF["root_yaw"]]) - 30.0) < 2.0
    # body parts held fixed
    assert np.array_equal(res.pose[6:], start[6:])


def _origin_search_weighing_everything(lik, pose, config, dt, velocity_xy):
    """The origin search as first written: every grid value weighed (the reference)."""
    from tracker.dof import clamp
    from tracker.origin import ORIGIN_ORDER, _ranges

    low, high = LIMITS
    best = pose.copy()
    best[[0, 1]] += config.velocity_damping * velocity_xy * dt
    clamp(best[None], low, high)
    offsets = np.linspace(-1.0, 1.0, config.steps)
    offsets = offsets[np.argsort(np.abs(offsets), kind="stable")]
    ranges = _ranges(config, dt / 0.05)
    weight = None
    for _ in range(config.passes):
        for name in ORIGIN_ORDER:
            r = ranges[name]
            for _level in range(config.levels):
                cand = np.repeat(best[None], offsets.size, axis=0)
                cand[:, DOF[name]] = best[DOF[name]] + offsets * r
                clamp(cand, low, high)
                w = lik.weights(cand)
                k = int(np.argmax(w))
                best, weight = cand[k].copy(), float(w[k])
                r *= config.shrink
    return best, weight


@pytest.mark.parametrize("known", [False, True])
def test_origin_search_reusing_weights_is_bit_identical(known: bool) -> None:
    """Reusing the zero offset's weight (and the caller's) changes nothing but the count."""
    truth = _truth(0.0)
    truth[DOF["root_x"]], truth[DOF["root_yaw"]] = 0.5, np.radians(-20.0)
    # coarse toy weights: ties between grid values, the case where reuse could pick another
    coarse = ToyLikelihood(truth)
    coarse.weights = lambda p: np.round(ToyLikelihood.weights(coarse, p), 2)  # type: ignore[method-assign]
    rng = np.random.default_rng(3)
    for trial in range(6):
        start = truth.copy()
        start[list(ROOT_DOFS)] += rng.normal(0.0, [0.05, 0.05, 0.02, 0.1, 0.05, 0.05])
        start = np.clip(start, *LIMITS)  # a start outside the limits is moved: weight unknown
        cfg = OriginSearchConfig(levels=1 + trial % 3, passes=1 + trial % 2)
        vel = np.zeros(2) if known else rng.normal(0.0, 0.3, 2)
        ref_pose, ref_w = _origin_search_weighing_everything(coarse, start, cfg, 0.05, vel)
        w0 = float(coarse.weights(start[None])[0]) if known else None
        coarse.evaluations = 0
        res = search_origin(coarse, start, cfg, limits=LIMITS, velocity_xy=vel, weight=w0)
        grids = 6 * cfg.levels * cfg.passes
        assert np.array_equal(res.pose, ref_pose) and res.weight == ref_w
        assert res.evaluations == coarse.evaluations
        # at most one reuse per grid; most grids reuse (the heading's wrap may move it by a bit)
        assert grids * 6 <= res.evaluations <= grids * 7 - grids // 2


# -- IPF extensions (defaults beyond the published method; docs/tracker.md) -------------------
METHOD = IPFConfig(
    kept=9,
    interval_centre="value",
    adaptive_width=0,
    refine_share=0,
    max_per_group=0,
    anneal={"share": 0.0},
)
#: The grid passes alone (no annealing stage), for the tests of the other extensions.
NO_ANNEAL = {"anneal": {"share": 0.0}}


def test_ipf_coarse_to_fine_spends_the_same_budget() -> None:
    cfg = IPFConfig(kept=9, refine_share=0.5, coarse_factor=2.0, **NO_ANNEAL)
    f = IntervalParticleFilter(cfg, limits=LIMITS, rng=np.random.default_rng(0))
    assert f.pass_sizes() == (5, 4)  # M2 = round(4.5) = 4
    f.initialise(_standing()[None])
    lik = ToyLikelihood(_truth(0.1))
    f.step(lik, 0.05)
    assert lik.evaluations == f.last_evaluations == 9 * 81 == f.particles.shape[0]
    groups = f.particles.reshape(9, 81, N_DOF)
    j = DOF["l_hip_flexion"]
    # coarse groups span 2 x 10 deg (unless shifted at a limit), fine groups one coarse step
    assert np.ptp(groups[0, :, j]) == pytest.approx(np.radians(20.0))
    assert np.ptp(groups[-1, :, j]) == pytest.approx(np.radians(10.0))
    # every fine group surrounds a particle of the coarse pass (its interval holds its L values)
    coarse_l = f.particles[: 5 * 81][:, LEGS]
    for g in groups[5:]:
        lo, hi = g[:, LEGS].min(axis=0), g[:, LEGS].max(axis=0)
        assert np.any(np.all((coarse_l >= lo - 1e-12) & (coarse_l <= hi + 1e-12), axis=1))
    assert np.unique(f.particles, axis=0).shape[0] == 9 * 81


def test_a_partial_sigma_table_keeps_the_other_defaults(tmp_path) -> None:
    """``[ipf.sigma] l_ankle_flexion = 8`` in a settings file changes that DOF's noise only
    (it used to zero every other DOF's)."""
    from tracker.config import load_tracker_config

    default = TrackerConfig()
    path = tmp_path / "t.toml"
    path.write_text("[ipf.sigma]\nl_ankle_flexion = 8.0\n[apf.sigma]\nroot_x = 0.05\n")
    cfg = load_tracker_config(path)
    for name, value in default.ipf.sigma.items():
        assert cfg.ipf.sigma[name] == (8.0 if name == "l_ankle_flexion" else value)
    assert cfg.ipf.sigma["root_yaw"] == 0.0  # the IPF's root stays the origin search's
    assert cfg.apf.sigma == {**default.apf.sigma, "root_x": 0.05}
    assert cfg.condensation.sigma == default.condensation.sigma
    # a round trip through model_dump is the identity; unknown DOFs are still refused
    assert TrackerConfig.model_validate(cfg.model_dump()) == cfg
    with pytest.raises(ValueError, match="unknown DOF"):
        IPFConfig(sigma={"l_ankel_flexion": 8.0})


def test_ipf_method_settings_make_one_pass() -> None:
    f = IntervalParticleFilter(METHOD, limits=LIMITS, rng=np.random.default_rng(0))
    assert f.pass_sizes() == (9, 0)


def test_ipf_adaptive_width_follows_the_joint_speed() -> None:
    cfg = IPFConfig(kept=9, adaptive_width=2.0, max_interval_deg=60.0)
    f = IntervalParticleFilter(cfg, limits=LIMITS, rng=np.random.default_rng(0))
    n = len(cfg.interesting)
    base = np.radians(10.0)
    assert np.allclose(f.interval_widths(0.05), base)  # no history yet
    f._history = [np.zeros(n), np.radians([1.0, 8.0, 20.0, 40.0])]
    f._last_dt = 0.05
    w = np.degrees(f.interval_widths(0.05))
    # at least 10 deg, twice the last change, at most 60 deg
    assert w == pytest.approx([10.0, 16.0, 40.0, 60.0])
    assert np.degrees(f.interval_widths(0.025)) == pytest.approx([5.0, 8.0, 20.0, 30.0])


def test_ipf_selection_caps_particles_per_group() -> None:
    f = IntervalParticleFilter(
        IPFConfig(kept=9, max_per_group=3, **NO_ANNEAL), limits=LIMITS, rng=np.random.default_rng(0)
    )
    f.initialise(np.repeat(_standing()[None], 2, axis=0))
    lik = ToyLikelihood(_truth(0.05))
    f.step(lik, 0.05)
    kept = f.select()
    r = [i for i in range(N_DOF) if i not in LEGS]
    _, counts = np.unique(kept[:, r], axis=0, return_counts=True)
    assert kept.shape == (9, N_DOF)
    assert counts.max() <= 3
    # without the cap the heaviest nine come from fewer groups
    f.config = f.config.model_copy(update={"max_per_group": 0})
    _, counts0 = np.unique(f.select()[:, r], axis=0, return_counts=True)
    assert counts0.max() > 3


def test_inject_keeps_the_motion_history() -> None:
    f = make_filter("ipf", _small_config("ipf"), rng=np.random.default_rng(0))
    f.initialise(_truth(0.0)[None])
    for k in range(1, 3):
        f.step(ToyLikelihood(_truth(0.05 * k)), 0.05)
    assert len(f._history) == 2
    better = _truth(0.1)
    f.inject(better[None], np.array([10.0]))
    assert len(f._history) == 2 and np.allclose(f._history[-1], better[f.L])
    assert np.array_equal(f.estimate().pose, better)
    f.inject(better[None], np.array([11.0]), reset_motion=True)
    assert len(f._history) == 1


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_a_share_of_the_budget_shrinks_every_filter_alike(name: str) -> None:
    """``share`` keeps a third of the IPF's groups and weighs a third as many poses in the
    baselines: 243 of 729 evaluations, whatever the filter."""
    cfg = _small_config(name)
    f = make_filter(name, cfg, rng=np.random.default_rng(0), share=1 / 3)
    assert f.evaluations_per_step == 243
    f.initialise(_standing()[None])
    lik = ToyLikelihood(_truth(0.0))
    f.step(lik, 0.05)
    assert lik.evaluations == 243
    whole = make_filter(name, cfg, rng=np.random.default_rng(0), share=1.0)
    assert whole.evaluations_per_step == 729
    for bad in (0.0, -0.5, 1.5):
        with pytest.raises(ValueError, match="share"):
            make_filter(name, cfg, rng=np.random.default_rng(0), share=bad)


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_load_state_continues_as_the_other_filter_would(name: str) -> None:
    """A filter that loads another's state steps on exactly as that one would have."""
    cfg = _small_config(name)
    small = make_filter(name, cfg, rng=np.random.default_rng(5), share=1 / 3)
    small.initialise(_standing()[None])
    for k in range(2):
        small.step(ToyLikelihood(_truth(0.05 * k)), 0.05)
    big = make_filter(name, cfg, rng=np.random.default_rng(5))
    big.initialise(np.repeat(_truth(0.3)[None], 4, axis=0))
    big.load_state(small)
    assert np.array_equal(big.particles, small.particles)
    assert big.particles is not small.particles  # copies: the two go on separately
    twin = make_filter(name, cfg, rng=np.random.default_rng(9))
    twin.load_state(small)
    big.rng, twin.rng = np.random.default_rng(1), np.random.default_rng(1)
    a = big.step(ToyLikelihood(_truth(0.1)), 0.05)
    b = twin.step(ToyLikelihood(_truth(0.1)), 0.05)
    assert np.array_equal(a.pose, b.pose) and a.weight == b.weight
    assert big.evaluations_per_step == 729  # its own budget, not the loaded filter's
    other_name = "ipf" if name != "ipf" else "condensation"
    other = make_filter(other_name, cfg, rng=np.random.default_rng(0))
    with pytest.raises(TypeError):
        big.load_state(other)
