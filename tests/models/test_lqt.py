"""Tests of inkarm.models.lqt: the banded solvers against the dense oracle (eq. 13) and an
extended-precision oracle, the oracle against eq. 13 as printed, closed forms (Flash-Hogan),
the papers' claims, Bezier ends and the timing of the two discretisations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from inkarm.analysis.kinematics import speed_peaks
from inkarm.core.plan import StrokePlan, bezier_keypoints
from inkarm.models.lqt import (
    LQTConfig,
    oracle,
    solve,
    system_matrices,
    velocity_direction_reference,
)
from inkarm.models.lqt.normal import obs_band, precision_loss
from inkarm.models.lqt.problem import build_problem
from inkarm.models.lqt.solvers import Factor


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
    prob = build_problem(plan, cfg)
    assert precision_loss(prob, obs_band(prob)) > 1e-2  # eps * cond(normal matrix)
    fast = solve(plan, cfg)
    oracle = solve(plan, LQTConfig(order, 0.01, d=5.0, solver="batch"))
    assert np.max(np.abs(fast.pos - oracle.pos)) <= 1e-6 * _extent(oracle.pos)
    assert Factor(prob, "auto").method == "augmented"


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
        states, _ = oracle.batch(plan, LQTConfig(4, 0.01, d=5.0, discretisation=disc))
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




def test_oracle_is_eq_13_as_printed():
    """On a small well-conditioned plan the oracle's square-root form equals
    u = (S_u^T Q S_u + R)^-1 S_u^T Q (xi_hat - S_xi xi_1) evaluated literally (eq. 10-13)."""
    plan = StrokePlan.from_arrays([[0.0, 0.0], [8.0, 5.0]], [2.0, [[1.0, 0.3], [0.3, 0.5]]],
                                  segment_time=0.1)
    cfg = LQTConfig(2, 0.01, d=5.0, end_at_rest=False)
    n, dim, n_steps = 2, 2, 20
    a, b = system_matrices(n, dim, cfg.dt)
    s_xi, s_u = oracle.transfer_matrices(a, b, n_steps)
    c = np.hstack([np.eye(dim), np.zeros((dim, dim))])  # sensor matrix, eq. 5 (GI)
    target = np.repeat(np.arange(2), 10)  # s = {1, ..., 1, 2, ..., 2}
    q = np.zeros((n_steps * n * dim, n_steps * n * dim))
    xi_hat = np.zeros(n_steps * n * dim)
    for t, i in enumerate(target):
        block = slice(t * n * dim, (t + 1) * n * dim)
        q[block, block] = c.T @ plan.precisions[i] @ c  # Q_t = C^T Sigma^-1 C
        xi_hat[block] = c.T @ plan.means[i]
    r = cfg.control_weight(plan.segment_time) * np.eye(s_u.shape[1])
    xi1 = oracle.initial_state(plan, n)
    u = np.linalg.solve(s_u.T @ q @ s_u + r, s_u.T @ q @ (xi_hat - s_xi @ xi1))  # eq. 13
    states = (s_xi @ xi1 + s_u @ u).reshape(n_steps, n * dim)  # eq. 10
    np.testing.assert_allclose(oracle.batch(plan, cfg)[0], states, rtol=1e-9, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# Bezier mimicking: a prescribed final velocity frees the end


def _bezier_with_final_speed(speed, variance=1.0, segment_time=1.0):
    p2, direction = np.array([70.0, 60.0]), np.array([0.6, -0.8])
    end = p2 + direction * speed * segment_time / 3.0  # tangent 3 (P3 - P2) / T
    cps = np.array([[0.0, 0.0], [30.0, 60.0], p2, end])
    return bezier_keypoints(cps, segment_time=segment_time, variance=variance), end


@pytest.mark.parametrize("disc", ["euler", "zoh"])
def test_bezier_end_with_a_prescribed_velocity_reaches_its_key_point(disc):
    """A 190 mm/s final tangent with the default end_at_rest: resting there braked the path
    14.8 mm short of a key-point of variance 1 mm^2; the prescribed velocity now frees the end."""
    plan, end = _bezier_with_final_speed(190.0)
    traj = solve(plan, LQTConfig(discretisation=disc))
    assert np.linalg.norm(traj.pos[-1] - end) < 1.5  # about the key-point's 1 mm std
    np.testing.assert_allclose(traj.vel[-1], plan.velocities[-1], atol=1e-3)
    free = solve(plan, LQTConfig(discretisation=disc, end_at_rest=False))
    np.testing.assert_array_equal(traj.pos, free.pos)
    batch = solve(plan, LQTConfig(discretisation=disc, solver="batch"))  # same rule
    # the hard velocity term (precision 1e6) enters the banded system squared: ~1e-6 relative
    assert np.max(np.abs(batch.pos - traj.pos)) <= 1e-5 * _extent(traj.pos)


def test_bezier_end_with_zero_or_free_velocity_stays_at_rest():
    plan, _ = _bezier_with_final_speed(190.0)
    for last in ([0.0, 0.0], [np.nan, np.nan]):
        vel = plan.velocities.copy()
        vel[-1] = last
        still = StrokePlan(plan.targets, plan.segment_time, True, velocities=vel,
                           velocity_var=plan.velocity_var)
        traj = solve(still, LQTConfig())
        np.testing.assert_allclose(traj.vel[-1], 0.0, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# timing of the discretisations against a 20x finer grid


def _lag(coarse, fine) -> float:
    """Best shift tau [steps of coarse] with coarse(t) ~ fine(t - tau dt), least squares."""
    dt = coarse.t[1]

    def misfit(tau: float) -> float:
        shifted = [np.interp(coarse.t - tau * dt, fine.t, fine.pos[:, d]) for d in range(2)]
        return float(np.sum((coarse.pos - np.stack(shifted, 1)) ** 2))

    return minimize_scalar(misfit, bounds=(-4.0, 4.0), method="bounded",
                           options={"xatol": 1e-6}).x


def _lags(plan, order, **kw) -> tuple[float, float]:
    """(Euler lag, ZOH lag) in steps against ZOH on a 20x finer grid (continuous stand-in)."""
    fine = solve(plan, LQTConfig(order, 0.01 / 20, discretisation="zoh", **kw))
    return tuple(
        _lag(solve(plan, LQTConfig(order, 0.01, discretisation=disc, **kw)), fine)
        for disc in ("euler", "zoh")
    )


@pytest.mark.parametrize("order", [1, 2, 3, 4, 5])
def test_euler_lag_against_a_finer_grid(order):
    """What lqt's docstring states: with stepwise Gaussian targets Euler does not lag ZOH by
    (n - 1) / 2 steps; both lead the finer solve by (1 - 1/20) / 2 steps. Point to point between
    key-points at rest, Euler lags by (n - 1) / 2 steps and ZOH not at all."""
    gauss = StrokePlan.from_arrays([[0, 0], [50, 20], [90, -10]], 25.0, segment_time=0.3)
    euler, zoh = _lags(gauss, order)
    assert abs(euler - zoh) <= (0.01 if order <= 3 else 0.1)
    assert zoh == pytest.approx(-0.475, abs=0.005)
    p2p = StrokePlan.from_arrays([[0, 0], [100, 40]], 1e-6, segment_time=1.0, keypoints=True)
    euler, zoh = _lags(p2p, order)
    assert euler == pytest.approx((order - 1) / 2, abs=0.01)
    assert zoh == pytest.approx(0.0, abs=0.01)
