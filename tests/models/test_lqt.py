"""Tests of inkarm.models.lqt: the banded solvers against the batch oracle (eq. 13) and an
extended-precision oracle, closed forms (Flash-Hogan), sampling statistics, the papers' claims,
and every error path."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.analysis.kinematics import speed_peaks
from inkarm.core.plan import GaussianTarget, StrokePlan, bezier_keypoints
from inkarm.errors import InputError, PlanError, SolverError
from inkarm.models import lqt
from inkarm.models.lqt import (
    LQTConfig,
    Reference,
    covariance,
    sample,
    semi_tied_covariances,
    solve,
    system_matrices,
    velocity_direction_reference,
)


def _random_plan(rng, m, dim, spread=60.0, var_range=(1.0, 100.0), segment_time=0.2):
    means = rng.uniform(0, spread, (m, dim))
    covs = []
    for _ in range(m):
        q, _ = np.linalg.qr(rng.normal(size=(dim, dim)))
        covs.append(q @ np.diag(rng.uniform(*var_range, dim)) @ q.T)
    return StrokePlan.from_arrays(means, covs, segment_time=segment_time)


def _extent(pos):
    return float(np.max(np.ptp(pos, axis=0)))


def _speed_peaks(traj):
    return speed_peaks(traj, 0.1)


# ---------------------------------------------------------------------------------------------
# solver equivalence


@settings(max_examples=25, deadline=None)
@given(
    order=st.integers(1, 5),
    dim=st.sampled_from([2, 3]),
    m=st.integers(1, 4),
    seed=st.integers(0, 2**31),
    d=st.floats(1.0, 20.0),
    zoh=st.booleans(),
    end_at_rest=st.booleans(),
)
def test_fast_solvers_match_batch_oracle(order, dim, m, seed, d, zoh, end_at_rest):
    rng = np.random.default_rng(seed)
    plan = _random_plan(rng, m, dim, segment_time=0.1 * rng.integers(1, 4))
    disc = "zoh" if zoh else "euler"
    oracle = solve(
        plan,
        LQTConfig(order, 0.01, d=d, discretisation=disc, end_at_rest=end_at_rest, solver="batch"),
    )
    scale = max(_extent(oracle.pos), 1.0)
    for solver in ("auto", "cholesky", "augmented"):
        cfg = LQTConfig(
            order, 0.01, d=d, discretisation=disc, end_at_rest=end_at_rest, solver=solver
        )
        fast = solve(plan, cfg)
        np.testing.assert_array_equal(fast.t, oracle.t)
        assert np.max(np.abs(fast.pos - oracle.pos)) <= 1e-6 * scale, solver
        if order > 1:
            vel_scale = max(np.max(np.abs(oracle.vel)), 1.0)
            assert np.max(np.abs(fast.vel - oracle.vel)) <= 1e-6 * vel_scale, solver


@pytest.mark.parametrize("order", [6, 7])
def test_high_orders_stay_accurate(order):
    """Where the normal equations lose all precision the augmented solver (auto) does not."""
    rng = np.random.default_rng(order)
    plan = StrokePlan.from_arrays(rng.uniform(0, 100, (3, 2)), 100.0, segment_time=0.5)
    cfg = LQTConfig(order, 0.01, d=5.0)
    prob = lqt._problem(plan, cfg)
    assert lqt._precision_loss(prob, lqt._obs_band(prob)) > 1e-2  # eps * cond(normal matrix)
    fast = solve(plan, cfg)
    oracle = solve(plan, LQTConfig(order, 0.01, d=5.0, solver="batch"))
    assert np.max(np.abs(fast.pos - oracle.pos)) <= 1e-6 * _extent(oracle.pos)
    assert lqt._Factor(prob, "auto").method == "augmented"


def _mp_oracle(plan, cfg, dps=110):
    """Eq. 13 (normal equations in control space) in extended precision; end at rest as a
    precision of 1e30 on the last state's derivatives. D = 1."""
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = dps
    n, dt = cfg.order, mp.mpf(cfg.dt)
    per = round(plan.segment_time / cfg.dt)
    n_steps = per * len(plan.targets)
    omega = 2 * mp.pi / mp.mpf(plan.segment_time)
    r = 1 / (omega**n * mp.mpf(cfg.d)) ** 2
    a = mp.eye(n)
    for i in range(n - 1):
        a[i, i + 1] = dt
    b = mp.zeros(n, 1)
    b[n - 1] = dt
    blocks = [b]  # A^k B
    for _ in range(n_steps):
        blocks.append(a * blocks[-1])
    mu = [mp.mpf(float(plan.means[t // per, 0] - plan.means[0, 0])) for t in range(n_steps)]
    w = [1 / mp.mpf(float(plan.covs[t // per, 0, 0])) for t in range(n_steps)]
    size = n_steps - 1
    h = mp.zeros(size, size)
    g = mp.zeros(size, 1)

    def row(t, k):  # component k of xi_t as a function of u_0 .. u_{N-2}
        return [blocks[t - 1 - s][k] if s < t else mp.mpf(0) for s in range(size)]

    terms = [(row(t, 0), w[t], mu[t]) for t in range(n_steps)]
    for k in range(1, n):
        rk = row(n_steps - 1, k)
        terms.append((rk, mp.mpf(10) ** 30 / sum(x * x for x in rk), mp.mpf(0)))
    for rt, wt, yt in terms:
        for i in range(size):
            if rt[i] == 0:
                continue
            g[i] += rt[i] * wt * yt
            for j in range(size):
                h[i, j] += rt[i] * wt * rt[j]
    for i in range(size):
        h[i, i] += r
    u = mp.lu_solve(h, g)
    x = [sum(row(t, 0)[s] * u[s] for s in range(size)) for t in range(n_steps)]
    return np.array([float(v) for v in x]) + plan.means[0, 0]


@pytest.mark.parametrize("order", [3, 7])
def test_fast_solver_matches_extended_precision_oracle(order):
    plan = StrokePlan.from_arrays([[0.0], [80.0], [30.0]], [100.0, 50.0, 100.0], segment_time=0.2)
    cfg = LQTConfig(order, 0.01, d=5.0)
    truth = _mp_oracle(plan, cfg)
    scale = _extent(truth[:, None])
    assert np.max(np.abs(solve(plan, cfg).pos[:, 0] - truth)) <= 1e-7 * scale
    batch = solve(plan, LQTConfig(order, 0.01, d=5.0, solver="batch")).pos[:, 0]
    assert np.max(np.abs(batch - truth)) <= 1e-6 * scale


# ---------------------------------------------------------------------------------------------
# behaviour


def test_starts_on_first_mean_and_ends_at_rest():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [50.0, 20.0], [90.0, -10.0]], 25.0, segment_time=0.3)
    for disc in ("euler", "zoh"):
        traj = solve(plan, LQTConfig(4, 0.01, d=5.0, discretisation=disc))
        assert traj.n == 90 and traj.t[0] == 0.0 and traj.t[1] == pytest.approx(0.01)
        np.testing.assert_allclose(traj.pos[0], [0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(traj.vel[0], 0.0, atol=1e-9)
        np.testing.assert_allclose(traj.vel[-1], 0.0, atol=1e-6)
        states, _ = lqt._batch(lqt._problem(plan, LQTConfig(4, 0.01, d=5.0, discretisation=disc)))
        np.testing.assert_allclose(states[-1, 2:], 0.0, atol=1e-6)  # all derivatives at rest
    free = solve(plan, LQTConfig(4, 0.01, d=5.0, end_at_rest=False))
    assert np.linalg.norm(free.vel[-1]) > 1.0


def test_tight_covariance_is_a_via_point():
    plan = StrokePlan.from_arrays(
        [[0.0, 0.0], [40.0, 70.0], [100.0, 10.0]], [100.0, 1e-6, 100.0], segment_time=0.5
    )
    traj = solve(plan, LQTConfig(4, 0.01, d=5.0))
    held = traj.pos[50:100]
    assert np.max(np.linalg.norm(held - [40.0, 70.0], axis=1)) <= 0.01


def test_control_weight_from_displacement():
    cfg = LQTConfig(order=3, dt=0.01, d=4.0)
    omega = 2 * np.pi / 0.25
    assert cfg.control_weight(0.25) == pytest.approx(1.0 / (omega**3 * 4.0) ** 2)
    assert LQTConfig(order=3, d=None, r=2e-9).control_weight(0.25) == 2e-9
    # a smaller d smooths: the path passes farther from the middle target
    plan = StrokePlan.from_arrays([[0.0, 0.0], [50.0, 50.0], [100.0, 0.0]], 10.0, segment_time=0.5)
    miss = [
        np.min(np.linalg.norm(solve(plan, LQTConfig(4, 0.01, d=d)).pos - [50, 50], axis=1))
        for d in (1, 20)
    ]
    assert miss[0] > 5 * miss[1]


def test_flash_hogan_minimum_jerk():
    """Order 3, key-points at start and end, at rest: the discrete Euler chain converges to the
    quintic delayed by (n - 1) / 2 steps (positions c_0 = c_1 = c_2 pin the start, centred at
    t = dt; the tied tail ends it at T + dt)."""
    amplitude, duration, n_steps = 100.0, 1.0, 201
    dt = duration / (n_steps - 1)
    plan = StrokePlan.from_arrays(
        [[5.0], [5.0 + amplitude]], 1e-6, segment_time=duration, keypoints=True
    )
    traj = solve(plan, LQTConfig(order=3, dt=dt, d=None, r=1e-15))
    assert traj.n == n_steps
    s = np.clip((traj.t - dt) / duration, 0.0, 1.0)
    quintic = 5.0 + amplitude * (10 * s**3 - 15 * s**4 + 6 * s**5)
    assert np.max(np.abs(traj.pos[:, 0] - quintic)) <= 1e-3 * amplitude
    vmax = np.max(np.abs(traj.vel[:, 0]))
    assert vmax / (amplitude / duration) == pytest.approx(1.875, abs=1e-3)


def test_keypoint_velocities_mimic_bezier():
    """Order 2 with key-points and Bezier end tangents reproduces the cubic Bezier (GI 4.3)."""
    cps = np.array([[0.0, 0.0], [30.0, 60.0], [70.0, 60.0], [100.0, 0.0]])
    plan = bezier_keypoints(cps, segment_time=1.0)
    traj = solve(plan, LQTConfig(order=2, dt=0.002, d=None, r=1e-12, end_at_rest=False))
    s = traj.t / 1.0
    bez = ((1 - s) ** 3)[:, None] * cps[0] + (3 * s * (1 - s) ** 2)[:, None] * cps[1]
    bez += (3 * s**2 * (1 - s))[:, None] * cps[2] + (s**3)[:, None] * cps[3]
    assert np.max(np.linalg.norm(traj.pos - bez, axis=1)) <= 0.01 * 100
    np.testing.assert_allclose(traj.vel[0], 3 * (cps[1] - cps[0]), rtol=0.02)
    for disc in ("euler", "zoh"):  # the moving start state agrees with the batch oracle
        coarse = {
            "order": 3,
            "dt": 0.02,
            "d": None,
            "r": 1e-9,
            "end_at_rest": False,
            "discretisation": disc,
        }
        fast = solve(plan, LQTConfig(**coarse))
        oracle = solve(plan, LQTConfig(**coarse, solver="batch"))
        assert np.max(np.abs(fast.pos - oracle.pos)) <= 1e-6 * _extent(oracle.pos)
        np.testing.assert_allclose(fast.vel[0], 3 * (cps[1] - cps[0]), rtol=1e-9)


def test_speed_profile_has_one_peak_per_segment_when_smoothing():
    """Seed 000 sec. 4: m targets give m - 1 speed peaks (targets 50-100 mm apart, variance
    100 mm^2, d = 5 mm, order 4, segments of 0.5 s)."""
    rng = np.random.default_rng(3)
    for m in range(2, 9):
        turns = np.cumsum(rng.uniform(-2.5, 2.5, m - 1))
        steps = np.stack([np.cos(turns), np.sin(turns)], 1) * rng.uniform(50, 100, (m - 1, 1))
        plan = StrokePlan.from_arrays(
            np.vstack([[0, 0], np.cumsum(steps, 0)]), 100.0, segment_time=0.5
        )
        assert _speed_peaks(solve(plan, LQTConfig(4, 0.01, d=5.0))) == m - 1


def test_velocity_reference_changes_direction():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [60.0, 0.0], [60.0, 60.0]], 200.0, segment_time=0.4)
    cfg = LQTConfig(3, 0.01, d=5.0)
    base = solve(plan, cfg)
    ref = velocity_direction_reference([0.0, 1.0], weight=1e-2)  # penalises vertical speed
    damped = solve(plan, cfg, references=[ref])
    assert np.abs(damped.vel[:, 1]).max() < 0.8 * np.abs(base.vel[:, 1]).max()
    oracle = solve(plan, LQTConfig(3, 0.01, d=5.0, solver="batch"), references=[ref])
    assert np.max(np.abs(damped.pos - oracle.pos)) <= 1e-6 * _extent(oracle.pos)


def test_zoh_matches_its_state_space_definition():
    a, b = system_matrices(3, 2, 0.1, "zoh")
    np.testing.assert_allclose(a[:2, 4:], 0.005 * np.eye(2))
    np.testing.assert_allclose(b[:2], (0.1**3 / 6) * np.eye(2))
    a, b = system_matrices(3, 1, 0.1, "euler")
    np.testing.assert_allclose(a, [[1, 0.1, 0], [0, 1, 0.1], [0, 0, 1]])


# ---------------------------------------------------------------------------------------------
# sampling


def test_exact_samples_match_analytic_covariance():
    plan = StrokePlan.from_arrays(
        [[0.0, 0.0], [8.0, 5.0], [15.0, 2.0]],
        [1.0, np.diag([2.0, 0.5]), [[1.0, 0.3], [0.3, 0.4]]],
        segment_time=0.1,
    )
    steps = np.arange(8, 18)  # 10 time steps
    for solver in ("cholesky", "augmented"):
        cfg = LQTConfig(3, 0.01, d=5.0, solver=solver)
        cov = covariance(plan, cfg)[steps][:, :, steps].reshape(20, 20)  # batch oracle, eq. 15
        draws = sample(plan, cfg, k=20000, seed=7)
        assert draws.shape == (20000, 30, 2)
        emp = np.cov(draws[:, steps].reshape(20000, -1).T)
        assert np.linalg.norm(emp - cov) / np.linalg.norm(cov) <= 0.03
        mean = solve(plan, cfg).pos
        assert np.max(np.abs(draws.mean(axis=0) - mean)) <= 0.05


@pytest.mark.parametrize("disc", ["euler", "zoh"])
def test_perturbation_samples_of_keypoints_with_velocities(disc):
    """Key-points (sparse observations), a moving start and ZOH go through the augmented solver's
    perturbation sampler; its covariance is the batch one within 3 standard errors."""
    plan = StrokePlan.from_arrays(
        [[0.0, 0.0], [8.0, 5.0], [15.0, 2.0]],
        [1.0, np.diag([2.0, 0.5]), [[1.0, 0.3], [0.3, 0.4]]],
        segment_time=0.1,
        keypoints=True,
    )
    vel = [[50.0, 0.0], [np.nan, np.nan], [0.0, -20.0]]
    plan = StrokePlan(plan.targets, 0.1, True, velocities=vel, velocity_var=100.0)
    cfg = LQTConfig(3, 0.01, d=None, r=1e-7, discretisation=disc)
    cov = covariance(plan, cfg).reshape(42, 42)
    draws = sample(plan, cfg, k=20000, seed=2).reshape(20000, -1)
    stderr = np.sqrt((np.linalg.norm(cov) ** 2 + np.trace(cov) ** 2) / 20000)
    assert np.linalg.norm(np.cov(draws.T) - cov) <= 3 * stderr
    assert np.max(np.abs(draws.mean(axis=0) - solve(plan, cfg).pos.reshape(-1))) <= 0.01


def test_samples_are_seeded_and_start_on_the_first_mean():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [40.0, 30.0]], 50.0, segment_time=0.3)
    cfg = LQTConfig(4, 0.01, d=5.0)
    a = sample(plan, cfg, k=5, seed=3)
    np.testing.assert_array_equal(a, sample(plan, cfg, k=5, seed=3))
    assert not np.allclose(a, sample(plan, cfg, k=5, seed=4))
    np.testing.assert_allclose(a[:, :4], 0.0, atol=1e-9)  # xi_1 = (mu_1, 0, 0, 0) is not random
    assert np.all(np.std(a[:, -1], axis=0) > 0.1)


def test_eigen_sampler_with_all_components_matches_covariance():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 4.0]], [2.0, 1.0], segment_time=0.1)
    cfg = LQTConfig(2, 0.01, d=5.0)
    cov = covariance(plan, cfg).reshape(40, 40)
    full = sample(plan, cfg, k=20000, seed=1, method="eigen", components=None)
    emp = np.cov(full.reshape(20000, -1).T)
    # standard error of a sample covariance in Frobenius norm: sqrt((|C|^2 + tr(C)^2) / K)
    stderr = np.sqrt((np.linalg.norm(cov) ** 2 + np.trace(cov) ** 2) / 20000)
    assert np.linalg.norm(emp - cov) <= 3 * stderr
    few = sample(plan, cfg, k=4000, seed=1, method="eigen", components=3)
    assert np.trace(np.cov(few.reshape(4000, -1).T)) < np.trace(cov)  # truncation drops variance


# ---------------------------------------------------------------------------------------------
# semi-tied covariances (eq. 22)


def test_semi_tied_covariances():
    basis = np.array([[1.0, 0.6], [0.0, 1.0]])
    covs = semi_tied_covariances(4, basis, 9.0)
    np.testing.assert_allclose(covs, np.broadcast_to(9.0 * basis @ basis.T, (4, 2, 2)))
    a = semi_tied_covariances(50, basis, 9.0, rho=4.0, seed=2)
    np.testing.assert_array_equal(a, semi_tied_covariances(50, basis, 9.0, rho=4.0, seed=2))
    mags = a[:, 1, 1] / (basis @ basis.T)[1, 1]
    assert abs(mags.mean() - 9.0) < 1.0 and 1.0 < mags.std() < 3.0
    assert np.all(np.linalg.eigvalsh(a) > 0)
    shape = a[:, 0, 1] / a[:, 1, 1]  # shared orientation
    np.testing.assert_allclose(shape, shape[0])


# ---------------------------------------------------------------------------------------------
# errors


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"order": 0}, "order: expected 1..7, got 0"),
        ({"order": 8}, "order: expected 1..7, got 8"),
        ({"order": 2.5}, "order: expected an integer"),
        ({"dt": 0.0}, "dt: must be a positive number"),
        ({"dt": float("nan")}, "dt: must be a positive number"),
        ({"d": None}, "exactly one of d .* and r"),
        ({"d": 5.0, "r": 1e-6}, "exactly one of d .* and r"),
        ({"d": -1.0}, "d: must be a positive number"),
        ({"d": None, "r": float("inf")}, "r: must be a positive number"),
        ({"discretisation": "rk4"}, "discretisation: expected 'euler' or 'zoh'"),
        ({"solver": "magic"}, "solver: expected one of"),
    ],
)
def test_config_errors(kwargs, match):
    with pytest.raises(InputError, match=match):
        LQTConfig(**kwargs)


def test_segment_time_must_be_a_whole_number_of_steps():
    stroke = StrokePlan.from_arrays([[0, 0], [10, 0]], 1.0, segment_time=0.025)
    with pytest.raises(PlanError, match=r"segment_time: 0.025 s is not a whole number of dt = 0.01 s steps \(2.5\)"):
        solve(stroke, LQTConfig(dt=0.01))
    assert solve(stroke, LQTConfig(dt=0.005)).n == 10


def test_plan_errors_name_the_target():
    with pytest.raises(PlanError, match="stroke target 1: covariance is not symmetric"):
        StrokePlan.from_arrays([[0, 0], [1, 1]], [1.0, [[1.0, 0.5], [0.0, 1.0]]])
    with pytest.raises(PlanError, match="stroke target 0: covariance is not positive definite"):
        StrokePlan.from_arrays([[0, 0], [1, 1]], [[[1.0, 2.0], [2.0, 1.0]], 1.0])
    with pytest.raises(PlanError, match="NaN or inf"):
        StrokePlan.from_arrays([[0, np.nan], [1, 1]], 1.0)
    with pytest.raises(PlanError, match="stroke target 1: covariance contains NaN"):
        StrokePlan.from_arrays([[0, 0], [1, 1]], [1.0, [[np.inf, 0], [0, 1]]])
    with pytest.raises(PlanError, match="no targets"):
        StrokePlan(())
    with pytest.raises(PlanError, match="stroke target 1: has 3 dimensions but target 0 has 2"):
        StrokePlan((GaussianTarget(np.zeros(2), 1.0), GaussianTarget(np.zeros(3), 1.0)))


def test_solve_errors():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.02)
    with pytest.raises(PlanError, match="order 4 needs at least 5"):
        solve(plan, LQTConfig(4, 0.01))
    with pytest.raises(PlanError, match="shorter than dt"):
        solve(plan, LQTConfig(1, 0.05))
    single = StrokePlan.from_arrays([[0.0, 0.0]], 1.0, keypoints=True)
    with pytest.raises(PlanError, match="at least 2 key-points"):
        solve(single, LQTConfig(2, 0.01))
    with pytest.raises(InputError, match="expected a StrokePlan"):
        solve([[0, 0]], LQTConfig())
    ok = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.2)
    with pytest.raises(InputError, match="reference 0 derivative: expected an integer 0..2"):
        solve(ok, LQTConfig(3, 0.01), references=[Reference(3, np.eye(2))])
    with pytest.raises(InputError, match="reference 0 precision: not symmetric"):
        solve(ok, LQTConfig(3, 0.01), references=[Reference(1, [[1.0, 1.0], [0.0, 1.0]])])
    with pytest.raises(InputError, match=r"reference 0 precision: expected shape \(2, 2\)"):
        solve(ok, LQTConfig(3, 0.01), references=[Reference(1, np.eye(3))])
    with pytest.raises(InputError, match="reference 0 steps: must lie in 0..39"):
        solve(ok, LQTConfig(3, 0.01), references=[Reference(1, np.eye(2), steps=np.array([40]))])
    with pytest.raises(SolverError, match="not positive definite"):
        lqt._Factor(lqt._problem(ok, LQTConfig(7, 0.001, d=100.0, solver="cholesky")), "cholesky")


def test_sample_and_semi_tied_errors():
    plan = StrokePlan.from_arrays([[0.0, 0.0], [10.0, 0.0]], 1.0, segment_time=0.2)
    with pytest.raises(InputError, match="sample k: expected a positive integer"):
        sample(plan, LQTConfig(), k=0)
    with pytest.raises(InputError, match="sample components: expected a positive integer"):
        sample(plan, LQTConfig(), method="eigen", components=0)
    with pytest.raises(InputError, match="sample method: expected 'exact' or 'eigen'"):
        sample(plan, LQTConfig(), method="gibbs")
    with pytest.raises(InputError, match="H: singular basis"):
        semi_tied_covariances(3, [[1.0, 2.0], [0.5, 1.0]], 1.0)
    with pytest.raises(InputError, match="H: expected a square"):
        semi_tied_covariances(3, [[1.0, 2.0]], 1.0)
    with pytest.raises(InputError, match="h: must be a positive number"):
        semi_tied_covariances(3, np.eye(2), 0.0)
    with pytest.raises(InputError, match="rho: must be >= 0"):
        semi_tied_covariances(3, np.eye(2), 1.0, rho=-1.0)
    with pytest.raises(InputError, match="m: expected a positive integer"):
        semi_tied_covariances(0, np.eye(2), 1.0)
    with pytest.raises(InputError, match="velocity reference: expected a finite non-zero"):
        velocity_direction_reference([0.0, 0.0])
