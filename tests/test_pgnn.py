"""PGNN building blocks: R1 estimator, physics penalty, physical part, switch-off, save/load."""

import numpy as np
import pytest
import torch

from lcgym import systems
from lcgym.data import Trial
from lcgym.methods.pgnn import PGNN, PGNNConfig
from lcgym.methods.pgnn.method import PGNNFeedforward
from lcgym.methods.pgnn.network import PGNNModule, min_eigenvalue, physical_constraints, physics_penalty
from lcgym.methods.pgnn.objective import batch_projection, nonzero_columns, projected_norm2, projection_basis
from lcgym.methods.pgnn.training import network_inputs
from lcgym.physics.model import PhysicalModel
from lcgym.systems.flexarm import motor
from lcgym.systems.ix import IX
from lcgym.systems.ix import dynamics as ix
from lcgym.systems.ix.references import random_moves


def test_minibatch_r1_estimates_the_full_projection():
    """R1 / N = ||U^T g||^2 / N over the data (projection by least squares, independent of the
    SVD); the mean of per-batch ||U_b^T g_b||^2 / B matches it."""
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.normal(size=(3, 40_000, 2))
    X = ix.regressor(ix.IXParameters().to_vector()[ix.N_LINEAR :], q, qd, qdd)
    g = np.tanh(q @ rng.normal(size=(2, 2))) + 0.3 * qdd  # partly inside, partly outside the span
    full = 0.0
    for i in range(2):
        coef, *_ = np.linalg.lstsq(X[:, i, :], g[:, i], rcond=None)
        full += np.sum((X[:, i, :] @ coef) ** 2)
    full /= len(g)
    perm = np.random.default_rng(1).permutation(len(g))
    batches = [batch_projection(X[perm[s : s + 10_000]], g[perm[s : s + 10_000]]) for s in range(0, len(g), 10_000)]
    assert np.mean(batches) == pytest.approx(full, rel=0.02)


def test_projection_without_the_zero_columns_and_with_a_known_basis_is_the_same():
    """What training saves (``pgnn.training.train``): dropping columns that are zero everywhere, and
    reusing a batch's basis, change the projection only by round-off."""
    rng = np.random.default_rng(5)
    q, qd, qdd = rng.normal(size=(3, 3000, 6))
    X = motor.regressor(None, q, qd, qdd)
    g = rng.normal(size=(3000, 6))
    columns = nonzero_columns(X)
    assert min(len(c) for c in columns) < X.shape[2]  # the arm's joint 6 sees only its own link and drive
    known = [(X[:, i, c], projection_basis(X[:, i, c])) for i, c in enumerate(columns)]
    full = batch_projection(X, g)
    assert batch_projection(X, g, columns) == pytest.approx(full, rel=1e-12)
    assert batch_projection(X, g, columns, known) == pytest.approx(full, rel=1e-12)


@pytest.mark.parametrize("machine", ["ix", "flexarm"])
def test_physics_penalty_skips_only_a_zero_term(machine):
    """R2 with the positive-definite shortcut (``physics_penalty``) has the value and gradient of
    eq. (30) evaluated in full, both where M(theta) is positive definite and where it is not."""
    system = systems.get(machine)
    zeta0 = system.nominal_params().to_vector()
    q = torch.tensor(np.random.default_rng(6).uniform(-1.5, 1.5, (64, system.n_axes)), dtype=torch.float32)
    indefinite = zeta0.copy()
    indefinite[list(system.positive)[:2]] *= -3.0  # masses or inertias of the wrong sign
    for z in (zeta0, indefinite):
        zeta = torch.tensor(z, requires_grad=True)
        fast, grad = physics_penalty(system, z, q.numpy())
        full = torch.clamp(torch.exp(-physical_constraints(system, zeta, q.double())) - 1.0, min=0.0).sum()
        full.backward()
        assert fast == pytest.approx(float(full.detach()), rel=1e-12)
        np.testing.assert_allclose(grad, zeta.grad.numpy(), rtol=1e-12, atol=0)
    assert float(full.detach()) > 0 and bool(zeta.grad.abs().max() > 0)


def test_projection_has_the_rank_of_the_regressor():
    """Zero columns (parameters absent from an axis) and the dependent J2yy column add no
    directions: ||U^T g||^2 equals the least-squares projection, g inside the span is kept whole."""
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.normal(size=(3, 500, 2))
    X = ix.regressor(ix.IXParameters().to_vector()[ix.N_LINEAR :], q, qd, qdd)
    for i in range(2):
        assert np.linalg.matrix_rank(X[:, i, :]) < ix.N_LINEAR
        g = rng.normal(size=500)
        coef, *_ = np.linalg.lstsq(X[:, i, :], g, rcond=None)
        inside = X[:, i, :] @ coef
        assert projected_norm2(X[:, i, :], g) == pytest.approx(inside @ inside, rel=1e-9)
        assert projected_norm2(X[:, i, :], inside) == pytest.approx(inside @ inside, rel=1e-9)


def test_physics_penalty_and_constraints():
    zeta = torch.tensor(ix.IXParameters().to_vector())
    q = torch.tensor(np.random.default_rng(1).uniform(-2, 2, (100, 2)))
    h = physical_constraints(IX, zeta, q)
    assert h.shape == (9,) and bool((h > 0).all())
    M = ix.mass_matrix(zeta.numpy(), q.numpy())
    assert float(h[-1]) == pytest.approx(min(np.linalg.eigvalsh(M).min(axis=1)), rel=1e-9)
    assert physics_penalty(IX, zeta.numpy(), q.numpy())[0] == 0.0
    S = torch.tensor(np.random.default_rng(2).normal(size=(50, 3, 3)))
    S = S @ S.transpose(1, 2)
    torch.testing.assert_close(min_eigenvalue(S), torch.linalg.eigvalsh(S)[:, 0])
    bad = zeta.clone()
    bad[ix.M3] = -0.5
    assert physics_penalty(IX, bad.numpy(), q.numpy())[0] == pytest.approx(np.exp(0.5) - 1, rel=1e-6)


def _trials(n=2, duration=6.0):
    model = PhysicalModel(IX)
    rng = np.random.default_rng(3)
    out = []
    for i in range(n):
        r = random_moves(f"s{i}", rng, duration=duration)
        u = model.predict(r) + 0.05 * np.sin(r.positions * 7)  # a smooth extra the physics lacks
        out.append(Trial(t=r.t, ref=r.positions, pos=r.positions, u=u, axes=ix.AXES))
    return out


@pytest.fixture(scope="module")
def small_pgnn():
    return PGNN(PGNNConfig(max_epochs=3, batch_size=2000, threads=1, history=(0.1,), periods=((0, 0.1),)), system=IX).fit(
        _trials())


def test_physical_part_is_the_shared_model(small_pgnn):
    ref = random_moves("new", np.random.default_rng(9), duration=3.0)
    small_pgnn.use_network = False
    phys = small_pgnn.predict(ref)
    small_pgnn.use_network = True
    expected = PhysicalModel(IX, params=small_pgnn.params_).predict(ref)
    np.testing.assert_allclose(phys, expected, atol=2e-5)  # float32 network vs float64 model
    both = small_pgnn.predict(ref)
    np.testing.assert_allclose(both - phys, small_pgnn.nn_contribution(ref), atol=1e-6)
    assert small_pgnn.info_["epochs"] == 3


def test_save_and_load_round_trip(small_pgnn, tmp_path):
    path = small_pgnn.save(tmp_path / "pgnn.pt")
    loaded = PGNN.load(path)
    ref = random_moves("new", np.random.default_rng(9), duration=3.0)
    np.testing.assert_array_equal(loaded.predict(ref), small_pgnn.predict(ref))
    assert loaded.config_ == small_pgnn.config_
    torch.load(path, weights_only=True)  # tensors only: loadable without trusting pickled objects


@pytest.mark.bad_input
def test_module_rejects_unknown_activation():
    with pytest.raises(ValueError, match="activation"):
        PGNNModule(IX, ix.IXParameters().to_vector(), 8, activation="swish")


def test_wall_time_cap_stops_after_one_epoch():
    m = PGNN(PGNNConfig(max_epochs=50, max_seconds=0.0, batch_size=2000, threads=1), system=IX).fit(_trials(n=1, duration=3.0))
    assert m.info_["epochs"] == 1


def test_network_inputs_and_options():
    """Eq. (11) per axis, relay carried across samples and 0 before the first move; the optional
    history is the velocity d seconds earlier (0 before the run), periods add sin and cos."""
    qd = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.0], [-0.2, 0.3], [0.0, 0.0]])
    q, qdd = np.cumsum(qd, axis=0), np.zeros_like(qd)
    x = network_inputs(q, qd, qdd, PGNNConfig(), fs=1.0)
    assert x.shape == (5, 8)
    np.testing.assert_array_equal(x[:, 3], [0, 1, 1, -1, -1])
    np.testing.assert_array_equal(x[:, 7], [0, 0, 0, 1, 1])
    np.testing.assert_array_equal(x[:, 4:7], np.column_stack([q[:, 1], qd[:, 1], qdd[:, 1]]))
    y = network_inputs(q, qd, qdd, PGNNConfig(history=(2.0,), periods=((1, 0.5),)), fs=1.0)
    assert y.shape == (5, 12)
    np.testing.assert_array_equal(y[:, 8:10], np.vstack([np.zeros((2, 2)), qd[:3]]))
    np.testing.assert_allclose(y[:, 10:12], np.column_stack([np.sin(4 * np.pi * q[:, 1]), np.cos(4 * np.pi * q[:, 1])]))


def test_jerk_and_snap_inputs_are_the_derivatives_of_a_known_motion():
    """``derivatives = 4`` adds the reference's jerk and snap per axis; on q = t^4 (qdd = 12 t^2) they
    are 24 t and 24 (checked away from the ends, where one-sided differences take over), and the
    low-pass they share with u (``filter_hz``) leaves a constant snap as it is."""
    fs = 100.0
    t = np.arange(400) / fs
    q = np.column_stack([t**4, -2 * t**4])
    qd, qdd = 4 * t[:, None] ** 3 * [1, -2], 12 * t[:, None] ** 2 * [1, -2]
    x = network_inputs(q, qd, qdd, PGNNConfig(derivatives=4, filter_hz=None), fs)
    assert x.shape == (400, 12)
    inner = slice(2, -2)
    np.testing.assert_allclose(x[inner, 8:10], (24 * t[:, None] * [1, -2])[inner], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(x[inner, 10:12], np.full((396, 2), [24.0, -48.0]), rtol=1e-9)
    filtered = network_inputs(q, qd, qdd, PGNNConfig(derivatives=4, filter_hz=5.0), fs)
    np.testing.assert_allclose(filtered[100:300, 10:12], np.full((200, 2), [24.0, -48.0]), rtol=1e-6)
    assert network_inputs(q, qd, qdd, PGNNConfig(derivatives=3, filter_hz=None), fs).shape == (400, 10)
    with pytest.raises(ValueError, match="derivatives must be 2"):
        network_inputs(q, qd, qdd, PGNNConfig(derivatives=5), fs)


class FastPGNN(PGNNFeedforward):
    """The leaderboard's ``pgnn`` with a short training (the cell's plumbing is what is tested)."""

    def __init__(self, system=None):  # the runner hands it the cell's machine
        super().__init__(PGNNConfig(max_epochs=2, batch_size=1000, threads=1, steps_per_iteration=5), system=system)

    gate = False  # the network's contribution is reported whatever the safeguard would keep


class FastPGNNLS(FastPGNN):
    regularize = False


def test_leaderboard_methods_report_the_network_contribution():
    from lcgym.leaderboard.runner import BenchConfig, run_cell
    from lcgym.methods import CONTROLLERS

    assert {"pgnn", "pgnn-ls"} <= set(CONTROLLERS) and CONTROLLERS["pgnn"] is PGNNFeedforward
    config = BenchConfig(methods=("test_pgnn:FastPGNN",), seeds=(0,), n_train=1, n_validation=1, duration=4.0)
    for method in ("test_pgnn:FastPGNN", "test_pgnn:FastPGNNLS"):
        rows, trace = run_cell("ix", method, 0, config)
        assert trace is not None and all(r["status"] == "ok" for r in rows), rows[0].get("error")
        assert all(np.isfinite(r["RMS"]) and r["nn_rms"] > 0 for r in rows)
        assert all(r["plant_trials"] == 2 for r in rows)  # the shared run and its own with the physical feedforward


@pytest.mark.bad_input
def test_sample_rate_mismatch_and_ls_variant_config():
    with pytest.raises(ValueError, match="physical model samples at 1000"):
        PGNN(PGNNConfig(max_epochs=1, threads=1), fs=500.0, physical=PhysicalModel(IX, fs=1000.0)).fit(_trials(n=1))
    from lcgym.methods.pgnn.method import PGNNLSFeedforward

    ls = PGNNLSFeedforward(PGNNConfig(max_epochs=1, batch_size=2000, threads=1), collect="feedback",
                           system=IX).fit(_trials(n=1, duration=3.0))
    assert ls.pgnn_.config_.regularize is False  # a given config keeps the method's meaning


def test_an_iteration_is_a_number_of_adam_steps():
    """The patience counts iterations of ``steps_per_iteration`` Adam steps (None: one epoch)."""
    trials = _trials(n=1, duration=3.0)
    m = PGNN(PGNNConfig(max_epochs=2, batch_size=200, threads=1, steps_per_iteration=7), system=IX).fit(trials)
    assert [h["steps"] for h in m.info_["history"]] == [7, 14]
    m = PGNN(PGNNConfig(max_epochs=2, batch_size=200, threads=1, steps_per_iteration=None), system=IX).fit(trials)
    per_epoch = -(-int(0.8 * m.info_["n_samples"]) // 200)
    assert [h["steps"] for h in m.info_["history"]] == [per_epoch, 2 * per_epoch]
    with pytest.raises(ValueError, match="steps_per_iteration must be >= 1"):
        PGNN(PGNNConfig(max_epochs=1, threads=1, steps_per_iteration=0), system=IX).fit(trials)


def test_fixed_minibatches_learn_too():
    """``reshuffle=False`` (fixed minibatches, their order reshuffled) trains on the same samples
    along another path: the validation cost falls in both, and the two fits differ."""
    trials = _trials(n=1, duration=3.0)
    fits = {r: PGNN(PGNNConfig(max_epochs=3, batch_size=200, threads=1, steps_per_iteration=10, patience=5,
                               reshuffle=r), system=IX).fit(trials) for r in (True, False)}
    for m in fits.values():
        j = [h["J_validation"] for h in m.info_["history"]]
        assert np.all(np.isfinite(j)) and j[-1] < j[0]
    assert fits[True].info_["history"][-1]["J_validation"] != fits[False].info_["history"][-1]["J_validation"]


def test_zeta_steps_absolute_or_relative():
    trials = _trials(n=1, duration=3.0)
    absolute = PGNN(PGNNConfig(max_epochs=1, batch_size=500, threads=1, steps_per_iteration=3), system=IX).fit(trials)
    assert torch.all(absolute.module_.zeta_scale == 1)  # the paper's: Adam on zeta itself
    relative = PGNN(PGNNConfig(max_epochs=1, batch_size=500, threads=1, steps_per_iteration=3,
                               zeta_steps="relative"), system=IX).fit(trials)
    zeta0 = relative.module_.zeta0
    torch.testing.assert_close(relative.module_.zeta_scale, torch.clamp(zeta0.abs(), min=1e-3))
    with pytest.raises(ValueError, match="zeta_steps must be 'absolute' or 'relative'"):
        PGNN(PGNNConfig(max_epochs=1, threads=1, zeta_steps="log"), system=IX).fit(trials)


def test_pgnn_method_records_its_training_data_with_the_physical_feedforward():
    """On the IX the leaderboard's PGNN trains on a run of the training references with the physical
    model's feedforward on (one plant trial per reference, counted), not on the feedback-only runs."""
    from lcgym.methods.pgnn.method import PaperPGNN, PGNNFeedforward
    from lcgym.methods.physical import PhysicalFeedforward
    from lcgym.references import references_of
    from lcgym.systems.ix.plant import IXPlant
    from lcgym.systems.ix.references import reference_set

    plant = IXPlant.of_version("v1")
    train = plant.run(reference_set("train", 0, 1, 3.0))
    method = PGNNFeedforward(PGNNConfig(max_epochs=1, batch_size=2000, threads=1, steps_per_iteration=2),
                             system="ix").fit(train)
    with pytest.raises(RuntimeError, match="learn"):
        method.feedforward(train[0].ref)
    method.gate = False  # the runs of the safeguard are counted too: see test_the_pgnn_never_ends_worse_than_its_physical_model
    method.learn(plant, None)
    physical = PhysicalFeedforward(system="ix").fit(train)
    np.testing.assert_array_equal(method.data_[0].ff, physical.feedforward(references_of(train)[0]))
    assert method.cost_.plant_trials == 1
    assert method.feedforward(train[0].ref).shape == train[0].ref.shape
    default = PGNNFeedforward()
    default.system_ = method.system_
    assert default.training_config().filter_hz is None and default.training_config().threads == 1  # u as measured
    paper = PaperPGNN()
    paper.system_ = method.system_
    assert paper.training_config().filter_hz == 5.0  # paper000-pgnn: the IX's protocol of before


def test_iteration_cap_in_proportion_to_the_training_runs():
    """The protocol's cap: 100 iterations on the benchmark's 8 training runs (unchanged), a quarter on
    --quick's 2, never none."""
    from lcgym.methods.pgnn.method import MAX_ITERATIONS, REFERENCE_TRIALS, PGNNFeedforward, max_iterations

    assert max_iterations(REFERENCE_TRIALS) == MAX_ITERATIONS == 100
    assert [max_iterations(n) for n in (1, 2, 3, 16)] == [13, 25, 38, 200]
    method = PGNNFeedforward()
    method.system_ = IX
    assert method.training_config(2).max_epochs == 25 and method.training_config().max_epochs == 100


def test_a_training_whose_validation_cost_is_never_finite_says_so():
    """NaN in the targets: no iteration improves, and ``train`` names the divergence instead of
    restoring parameters it never kept."""
    from lcgym.methods.pgnn.training import TrainingData, train

    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, (3, 3000, 2))
    zeta0 = IX.nominal_params().to_vector()
    config = PGNNConfig(max_epochs=2, patience=1, steps_per_iteration=2, batch_size=1000)
    inputs = network_inputs(q, qd, qdd, config, 500.0)
    u = np.full((3000, 2), np.nan)
    data = TrainingData(q, qd, qdd, inputs, u, IX.regressor(zeta0[IX.n_linear:], q, qd, qdd))
    with pytest.raises(RuntimeError, match="not finite in any of 1 iteration"):
        train(PGNNModule(IX, zeta0, inputs.shape[1]), data, config)
