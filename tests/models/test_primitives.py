"""Tests of inkarm.models.primitives: the factorial HMM of seed 004 against exact inference."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.models.primitives import (
    Batch,
    PrimitiveModel,
    PrimitivesConfig,
    e_step,
    fit,
    initial_model,
    lower_bound,
    m_step,
)
from inkarm.models.primitives.exact import exact_log_likelihood, exact_posterior
from inkarm.models.primitives.features import first_differences, normalise
from inkarm.models.primitives.generate import pen_path, sample, scribble
from inkarm.models.primitives.inference import (
    forward_backward,
    log_domain_pass,
    log_forward_backward,
)
from inkarm.models.primitives.learning import em_iterations, log_prior
from inkarm.models.primitives.reference import (
    chain_forward_backward,
    em_iteration_loops,
    scaled_forward_backward,
)
from inkarm.plans.primitives_data import letter_training_set


def small_model(rng, M=2, K=3, D=2, noise=0.3, amplitude=1.5) -> PrimitiveModel:
    W = rng.normal(size=(M, K, D)) * amplitude
    advance = rng.uniform(0.5, 0.9, size=(M, K))
    advance[:, 0] = rng.uniform(0.05, 0.2, size=M)
    start = np.zeros((M, K))
    start[:, 0], start[:, 1] = 0.8, 0.2
    return PrimitiveModel(W=W, advance=advance, start=start, C=np.eye(D) * noise**2)


def generated(model, rng, n=6, lengths=(12, 30)):
    return [sample(model, int(rng.integers(*lengths)), rng)[0] for _ in range(n)]


def test_variational_marginals_close_to_exact_on_2x3():
    """On data each 2 x 3 model generated, the structured posterior is the exact one on most
    models and stays close (same most likely state at >= 75% of samples) where the exact
    posterior is ambiguous; F never exceeds log p(Y)."""
    per_model = []
    for seed in range(8):
        rng = np.random.default_rng(seed)
        model = small_model(rng)
        seqs = generated(model, rng)
        post = e_step(model, Batch.of(seqs), max_sweeps=50, tol=1e-10)
        errors = []
        for b, Y in enumerate(seqs):
            exact = exact_posterior(model, Y).marginals
            approx = post.expectations[:, : len(Y), b]
            errors.append(np.abs(approx - exact).mean())
            assert (approx.argmax(-1) == exact.argmax(-1)).mean() >= 0.75
        per_model.append(np.mean(errors))
        exact_f = exact_log_likelihood(model, seqs)   # F = log p(Y) where q is exact: rounding
        assert lower_bound(model, Batch.of(seqs), post) <= exact_f + 1e-9 * abs(exact_f)
    per_model = np.array(per_model)
    assert per_model.max() < 0.06
    assert (per_model < 0.005).sum() >= 5


def test_one_chain_is_exact():
    """With M = 1 the structured approximation is the exact posterior: F = log p(Y)."""
    rng = np.random.default_rng(5)
    model = small_model(rng, M=1, K=4)
    seqs = generated(model, rng, n=4, lengths=(3, 25))
    batch = Batch.of(seqs)
    post = e_step(model, batch, max_sweeps=2, tol=0.0)
    assert lower_bound(model, batch, post) == pytest.approx(exact_log_likelihood(model, seqs),
                                                            abs=1e-8)
    for b, Y in enumerate(seqs):
        np.testing.assert_allclose(post.expectations[:, : len(Y), b],
                                   exact_posterior(model, Y).marginals, atol=1e-10)
    assert np.all(post.expectations[:, len(seqs[0]):, 0] == 0)  # padding carries no weight


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
@pytest.mark.parametrize("self_loops", [True, False])
def test_bound_never_decreases_and_exact_likelihood_rises(seed, self_loops):
    rng = np.random.default_rng(seed)
    truth = small_model(rng)
    seqs = generated(truth, rng, n=8)
    config = PrimitivesConfig(n_chains=2, n_states=3, max_outer=25, tol_outer=0.0,
                              self_loops=self_loops)
    start = initial_model(Batch.of(seqs), config, np.random.default_rng(seed))
    result = fit(seqs, config, seed=seed)
    assert len(result.history) == 25
    bounds = result.bounds + [it.log_prior for it in result.history]   # F + log p(W)
    assert np.all(np.diff(bounds) >= -1e-8 * np.abs(bounds[:-1]))
    final = result.final_bound + log_prior(result.model, config)
    assert final >= bounds[-1] - 1e-8 * abs(bounds[-1])
    before = exact_log_likelihood(start, seqs)
    after = exact_log_likelihood(result.model, seqs)
    assert after > before + 10.0
    assert result.final_bound <= after + 1e-9
    if not self_loops:
        assert np.all(result.model.advance[:, 1:] == 1.0)


def test_vectorised_em_iteration_equals_the_plain_loops():
    rng = np.random.default_rng(3)
    truth = small_model(rng, M=3, K=4, D=3)
    seqs = generated(truth, rng, n=5, lengths=(4, 20))
    config = PrimitivesConfig(n_chains=3, n_states=4)
    batch = Batch.of(seqs)
    model = initial_model(batch, config, rng)
    new = m_step(model, batch, e_step(model, batch, max_sweeps=3, tol=0.0), config)
    silent = [[np.eye(4)[np.zeros(len(Y), int)] for _ in range(3)] for Y in seqs]
    ref, _ = em_iteration_loops(model, seqs, silent, config, sweeps=3)
    for name in ("W", "C", "start", "advance"):
        np.testing.assert_allclose(getattr(new, name), getattr(ref, name), atol=1e-10,
                                   err_msg=name)


def test_fast_and_log_domain_em_learn_the_same_model_where_states_are_rarely_visited():
    """4 chains of 8 states on 5 letters: after the first E-step some states have tiny
    occupancies, where the paper's pseudo-inverse (prior_samples = 0) makes W a ratio of tiny
    sums that the forward-backward's rounding decides (the two parted by 7.4 in W at the second
    iteration); the prior on W (eq. 10') makes the learned model a function of the data."""
    data = letter_training_set("a", 5, ("faithful", "cursive", "loose", "italic", "hurried"),
                               seed=0)
    batch = Batch.of(data.sequences)
    config = PrimitivesConfig(n_chains=4, n_states=8, max_outer=2, self_loops=False)
    model = initial_model(batch, config, np.random.default_rng(0))
    runs = [list(em_iterations(model, batch, config, chain_pass))
            for chain_pass in (None, log_domain_pass)]
    assert len(runs[0]) == len(runs[1]) == 2
    for (fast_it, fast, _), (ref_it, ref, _) in zip(*runs):
        assert fast_it.sweeps == ref_it.sweeps
        for name in ("W", "C", "start", "advance"):
            np.testing.assert_allclose(getattr(fast, name), getattr(ref, name), rtol=0,
                                       atol=1e-6, err_msg=f"{name}, iteration {fast_it.number}")


@pytest.mark.parametrize("self_loops", [True, False])
def test_scaled_forward_backward_equals_the_log_domain_one(self_loops):
    """The E-step's scaled forward-backward (and the benchmark's textbook one) give the log-domain
    posteriors, normalisers and transition counts to 1e-10, with log h spread over hundreds (the
    scaling's range) and sequences of different lengths (padding)."""
    rng = np.random.default_rng(7)
    K, lengths = 5, [1, 2, 9, 40]
    advance = rng.uniform(0.1, 0.9, size=K) if self_loops else np.r_[0.2, np.ones(K - 1)]
    model = PrimitiveModel(W=np.zeros((1, K, 1)), advance=advance[None],
                           start=rng.dirichlet(np.ones(K))[None], C=np.eye(1))
    T, B = max(lengths), len(lengths)
    mask = np.arange(T)[:, None] < np.array(lengths)[None]
    log_h = rng.normal(scale=100.0, size=(T, B, K)) * mask[..., None]
    with np.errstate(divide="ignore"):
        log_stay, log_adv = (x[0] for x in model.log_transitions())
        log_start = np.log(model.start[0])
    P = model.transition_matrix(0)
    post = forward_backward(log_h, P, model.start[0], mask)
    in_logs = log_forward_backward(log_h, log_stay, log_adv, log_start, mask)
    for name in ("gamma", "log_z", "advance_counts", "occupancy"):
        np.testing.assert_allclose(getattr(post, name), getattr(in_logs, name), rtol=1e-12,
                                   atol=1e-10, err_msg=name)
    gamma, log_z, counts = scaled_forward_backward(log_h, P, model.start[0], mask)
    np.testing.assert_allclose(gamma, post.gamma, atol=1e-10)
    np.testing.assert_allclose(log_z, post.log_z, rtol=1e-12)
    np.testing.assert_allclose(counts[np.arange(K), (np.arange(K) + 1) % K],
                               post.advance_counts, atol=1e-10)
    advances, occupancy = np.zeros(K), np.zeros(K)
    for b, n in enumerate(lengths):
        g, adv, occ, z = chain_forward_backward(log_h[:n, b], log_stay, log_adv, log_start)
        np.testing.assert_allclose(post.gamma[:n, b], g, atol=1e-10)
        assert np.all(post.gamma[n:, b] == 0)
        assert post.log_z[b] == pytest.approx(z, rel=1e-12, abs=1e-10)
        advances += adv
        occupancy += occ
    np.testing.assert_allclose(post.advance_counts, advances, atol=1e-10)
    np.testing.assert_allclose(post.occupancy, occupancy, atol=1e-10)


def test_scaled_forward_backward_falls_back_to_logs_where_it_underflows():
    """A chain that cannot leave state 0 meets log h = -1000 there: every scaled alpha is 0 at
    that step, and the log-domain pass takes over (log Z = -1000, <S> stays in state 0)."""
    model = PrimitiveModel(W=np.zeros((1, 3, 1)), advance=np.array([[0.0, 1.0, 1.0]]),
                           start=np.array([[1.0, 0.0, 0.0]]), C=np.eye(1))
    log_h = np.zeros((4, 1, 3))
    log_h[2, 0, 0] = -1000.0
    mask = np.ones((4, 1), dtype=bool)
    post = forward_backward(log_h, model.transition_matrix(0), model.start[0], mask)
    assert post.log_z[0] == pytest.approx(-1000.0)
    np.testing.assert_allclose(post.gamma[:, 0], np.eye(3)[[0, 0, 0, 0]], atol=1e-12)


def test_silent_state_and_band_are_kept():
    rng = np.random.default_rng(4)
    truth = small_model(rng, M=2, K=4)
    result = fit(generated(truth, rng, n=6), PrimitivesConfig(n_chains=2, n_states=4,
                                                               max_outer=5), seed=1)
    assert np.all(result.model.W[:, 0] == 0)
    S = result.posterior.expectations
    np.testing.assert_allclose(S.sum(axis=-1), np.broadcast_to(result.batch.mask, S.shape[:-1]),
                               atol=1e-9)
    P = result.model.transition_matrix(0)
    K = 4
    allowed = np.eye(K, dtype=bool) | np.roll(np.eye(K, dtype=bool), 1, axis=1)
    assert np.all(P[~allowed] == 0)
    np.testing.assert_allclose(P.sum(axis=1), 1.0)


def test_restarts_keep_the_best_bound():
    rng = np.random.default_rng(6)
    seqs = generated(small_model(rng), rng, n=5)
    config = PrimitivesConfig(n_chains=2, n_states=3, max_outer=8)
    best = fit(seqs, config, seed=10, restarts=3)
    singles = [fit(seqs, config, seed=10 + r).objective for r in range(3)]
    assert best.objective == pytest.approx(max(singles))
    seen = []
    fit(seqs, config, seed=10, restarts=2, progress=lambda r, it: seen.append((r, it.number)))
    assert seen[0] == (0, 1) and seen[-1][0] == 1
    with pytest.raises(InputError, match="restarts: expected an integer >= 1"):
        fit(seqs, config, restarts=0)


def test_seeded():
    rng = np.random.default_rng(7)
    seqs = generated(small_model(rng), rng, n=4)
    config = PrimitivesConfig(n_chains=2, n_states=3, max_outer=3)
    a, b = fit(seqs, config, seed=3), fit(seqs, config, seed=3)
    np.testing.assert_array_equal(a.model.W, b.model.W)
    assert not np.array_equal(a.model.W, fit(seqs, config, seed=4).model.W)


def test_generation_follows_the_band():
    rng = np.random.default_rng(8)
    model = small_model(rng, M=3, K=5)
    Y, states = sample(model, 400, rng, noise=False)
    steps = (states[1:] - states[:-1]) % 5
    assert set(np.unique(steps)) <= {0, 1}
    np.testing.assert_allclose(Y, model.W[np.arange(3), states].sum(axis=1))
    onsets = ((states[:-1] == 0) & (states[1:] == 1)).sum(axis=0)
    assert np.all(onsets > 0)


def test_features_round_trip_through_pen_path():
    t = np.linspace(0.0, 0.5, 41)
    pos = np.column_stack([10 * np.sin(4 * t), 5 * t**2])
    raw = first_differences(t, pos, rate_hz=200.0)
    assert raw.shape == (102, 3)  # 101 samples at 200 Hz, pen up after
    assert raw[0, 2] == 1.0 and raw[-1, 2] == -1.0 and np.all(raw[1:-1, 2] == 0)
    (Y,), scale = normalise([raw])
    np.testing.assert_allclose(np.sqrt(np.mean(Y**2, axis=0)), 1.0)
    model = PrimitiveModel(W=np.zeros((1, 2, 3)), advance=np.full((1, 2), 0.5),
                           start=[[1.0, 0.0]], C=np.eye(3), scale=scale,
                           channels=("dx", "dy", "dp"))
    path = pen_path(model, Y, start=pos[0])
    np.testing.assert_allclose(path.pos[-1], pos[-1], atol=1e-9)
    np.testing.assert_allclose(path.pos[1:-1], np.column_stack(
        [np.interp(np.arange(101) / 200, t, pos[:, 0]), np.interp(np.arange(101) / 200, t,
                                                                   pos[:, 1])]), atol=1e-9)
    assert path.pressure[1:-1].min() == 1.0 and path.pressure[-1] == 0.0
    assert path.t[1] == pytest.approx(1 / 200)


def test_scribble_is_seeded():
    rng = np.random.default_rng(9)
    model = small_model(rng, M=3, K=5)
    a, _ = scribble(model, 1.0, seed=2)
    b, _ = scribble(model, 1.0, seed=2)
    assert a == b and a.n == 201
    with pytest.raises(InputError, match="duration_s: expected a positive duration"):
        scribble(model, 0.0)
    with pytest.raises(InputError, match="duration_s: samples of a 1e\\+06 s scribble"):
        scribble(model, 1e6)


def test_save_load_round_trip(tmp_path):
    model = small_model(np.random.default_rng(10))
    path = tmp_path / "m.npz"
    model.save(path)
    back = PrimitiveModel.load(path)
    for name in ("W", "advance", "start", "C", "scale"):
        np.testing.assert_array_equal(getattr(back, name), getattr(model, name))
    assert back.channels == model.channels and back.rate_hz == model.rate_hz


def _saved(tmp_path, **changes):
    model = small_model(np.random.default_rng(11))
    fields = {"version": np.array(1), "W": model.W, "advance": model.advance,
              "start": model.start, "C": model.C, "scale": model.scale,
              "rate_hz": np.array(200.0), "channels": np.array(model.channels)}
    fields.update(changes)
    fields = {k: v for k, v in fields.items() if v is not None}
    path = tmp_path / "bad.npz"
    np.savez(path, **fields)
    return path


@pytest.mark.parametrize(("changes", "message"), [
    ({"version": np.array(7)}, "version: unsupported version"),
    ({"version": None}, "version: missing field"),
    ({"C": None}, "C: missing field"),
    ({"C": -np.eye(2)}, "C: expected a symmetric positive definite"),
    ({"advance": np.full((2, 3), 1.5)}, "advance: expected probabilities"),
    ({"start": np.full((2, 3), 0.1)}, "start: each chain's initial distribution"),
    ({"W": np.zeros((2, 3))}, "W: expected W of shape"),
    ({"rate_hz": np.array([1.0, 2.0])}, "rate_hz: expected a number"),
    ({"channels": np.array([1, 2])}, "channels: expected text"),
    ({"scale": np.array(["a", "b"])}, "scale: expected numbers"),
    ({"W": np.full((2, 3, 2), np.nan)}, "W: holds non-finite values"),
])
def test_bad_model_files_name_file_and_field(tmp_path, changes, message):
    path = _saved(tmp_path, **changes)
    with pytest.raises(InputError, match=message) as info:
        PrimitiveModel.load(path)
    assert info.value.file == str(path)


def test_unreadable_model_files(tmp_path):
    with pytest.raises(InputError, match="no such primitives model file"):
        PrimitiveModel.load(tmp_path / "missing.npz")
    junk = tmp_path / "junk.npz"
    junk.write_text("not a zip")
    with pytest.raises(InputError, match="junk.npz: not a primitives model"):
        PrimitiveModel.load(junk)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"n_chains": 0}, "n_chains: expected an integer in 1..200"),
    ({"n_states": 1}, "n_states: expected an integer in 2..100"),
    ({"max_outer": 1_000_000_000}, "max_outer: expected an integer in 0..10000, got 1000000000"),
    ({"max_inner": 10**6}, "max_inner: expected an integer in 1..1000"),
    ({"max_inner": 2.5}, "max_inner: expected an integer"),
    ({"stay_init": 1.0}, "stay_init: expected a number in"),
    ({"tol_outer": -1.0}, "tol_outer: expected a number in"),
    ({"prior_samples": -1.0}, r"prior_samples: expected a number in \[0.0, inf\), got -1.0"),
    ({"prior_samples": 1e-300}, (r"prior_samples: expected 0 \(the paper's pseudo-inverse\) or "
                                r">= 1e-6 samples, got 1e-300")),
])
def test_config_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        PrimitivesConfig(**kwargs)


def test_batch_errors():
    with pytest.raises(InputError, match="no sequences"):
        Batch.of([])
    with pytest.raises(InputError, match="one D"):
        Batch.of([np.zeros((3, 2)), np.zeros((3, 3))])
    with pytest.raises(InputError, match=r"sequences\[1\]: holds non-finite"):
        Batch.of([np.zeros((3, 2)), np.full((3, 2), np.inf)])
    with pytest.raises(InputError, match=r"sequences\[0\]: empty sequence"):
        Batch.of([np.zeros((0, 2))])


def test_memory_is_budgeted_before_any_work(monkeypatch):
    from inkarm.core.budget import BudgetError

    monkeypatch.setenv("INKARM_MAX_MEMORY_MB", "1")
    seqs = [np.zeros((2000, 3))] * 10
    with pytest.raises(BudgetError, match="memory of EM on 10 sequences of up to 2000 samples"):
        fit(seqs, PrimitivesConfig(n_chains=10, n_states=10))
