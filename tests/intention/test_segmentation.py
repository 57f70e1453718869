"""The action segmenter of thesis 4.1 against hand computations, brute force and synthetic ground truth.

Every check is computed independently of the module: features by hand, fitness by enumerating the
hidden actions, the sliding-window message by summing out the deleted chain, the segmentation of a
synthetic recording against the frames it was built from.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from hrc_drake.intention import segmentation as seg
from hrc_drake.messages import L_ELBOW, L_SHOULDER, L_WRIST, R_ELBOW, R_SHOULDER, R_WRIST, THORAX

# ---------------------------------------------------------------------------------------------
# synthetic skeletons: the right wrist reaches the goal centre of the action being performed

CENTRES = np.array([[0.5, 0.5, 1.0], [0.0, 0.6, 1.0], [-0.5, 0.5, 1.0]])
PRECEDENCE = [(0, 1), (0, 2)]  # action 0 first, then 1 and 2 in any order
WINDOW = 5


def base_pose() -> np.ndarray:
    pose = np.zeros((8, 3))
    pose[THORAX] = (0.0, 0.0, 1.3)
    pose[1] = (0.0, 0.0, 1.6)  # head
    pose[L_SHOULDER], pose[R_SHOULDER] = (-0.2, 0.0, 1.45), (0.2, 0.0, 1.45)
    pose[L_ELBOW], pose[L_WRIST] = (-0.25, 0.1, 1.2), (-0.25, 0.3, 1.1)
    return pose


def recording(action: int, n_frames: int, rng: np.random.Generator) -> np.ndarray:
    pose = base_pose()
    frames = pose[None] + rng.normal(0.0, 0.01, (n_frames, 8, 3))
    wrist = CENTRES[action] + rng.normal(0.0, 0.05, (n_frames, 3))
    frames[:, R_WRIST] = wrist
    frames[:, R_ELBOW] = 0.5 * (pose[R_SHOULDER] + wrist) + rng.normal(0.0, 0.01, (n_frames, 3))
    return frames


def stream(actions, lengths, rng):
    parts, truth, start = [], [], 0
    for action, n in zip(actions, lengths, strict=True):
        parts.append(recording(action, int(n), rng))
        truth.append((start, start + int(n), action))
        start += int(n)
    return np.concatenate(parts), truth


@pytest.fixture(scope="module")
def library():
    rng = np.random.default_rng(1)
    return [(a, recording(a, int(rng.integers(40, 80)), rng)) for a in range(3) for _ in range(6)]


@pytest.fixture(scope="module")
def segmenter(library):
    genetic = seg.GeneticSettings(population=16, generations=12)
    out = seg.Segmenter(WINDOW, batch_windows=10, centres=CENTRES, genetic=genetic, seed=0)
    return out.fit(library, PRECEDENCE, n_sequences=60, seed=3)


def small_model(order: int = 1) -> seg.SegmentationModel:
    """2 features of 3 bins, 2 actions, fixed random potentials."""
    rng = np.random.default_rng(5)
    return seg.SegmentationModel(
        actions=("a", "b"),
        edges=np.array([[0.0, 1.0], [0.0, 1.0]]),
        phi_obs=rng.uniform(0.0, 1.0, (2, 3, 2)),
        phi_seq=rng.uniform(0.0, 1.0, (order, 2, 2)),
        w_obs=np.array([0.7, 1.3]),
        w_seq=0.9,
        mean_action_windows=2.0,
    )


def is_valid_hypothesis(rho, n_windows: int) -> bool:
    scaled = np.asarray(rho) * n_windows
    return bool(
        np.all(rho > 0)
        and abs(np.sum(rho) - 1.0) < 1e-12
        and np.allclose(scaled, np.rint(scaled))
        and len(rho) <= n_windows
    )


# ---------------------------------------------------------------------------------------------
# windows and features (4.1, Fig. 4.1)


def test_window_bounds_cut_at_most_lw_samples():
    assert seg.window_bounds(12, 5).tolist() == [[0, 5], [5, 10], [10, 12]]
    assert seg.window_bounds(12, 5, keep_partial=False).tolist() == [[0, 5], [5, 10]]
    assert seg.window_bounds(10, 5).tolist() == [[0, 5], [5, 10]]


def test_features_match_a_hand_computation():
    # every point at the origin but the right wrist, which goes (0,0,0) -> (3,0,0); centre at (0,4,0)
    frames = np.zeros((2, 8, 3))
    frames[1, R_WRIST] = (3.0, 0.0, 0.0)
    values, bounds = seg.window_features(frames, 2, centres=[[0.0, 4.0, 0.0]])
    names = seg.feature_names(1)
    assert values.shape == (1, 2 * (28 + 2)) and len(names) == values.shape[1]
    assert bounds.tolist() == [[0, 2]]
    row = dict(zip(names, values[0], strict=True))
    assert row["mean(left_wrist-right_wrist)"] == pytest.approx(1.5)  # distances 0 and 3
    assert row["var(left_wrist-right_wrist)"] == pytest.approx(2.25)
    assert row["mean(right_wrist-centre0)"] == pytest.approx(4.5)  # distances 4 and 5
    assert row["var(right_wrist-centre0)"] == pytest.approx(0.25)
    assert row["mean(left_wrist-centre0)"] == pytest.approx(4.0)
    assert row["var(left_wrist-centre0)"] == pytest.approx(0.0)
    assert row["mean(thorax-head)"] == pytest.approx(0.0)


def test_features_of_many_windows_equal_those_of_each_window():
    frames = recording(1, 23, np.random.default_rng(0))
    values, bounds = seg.window_features(frames, 5, CENTRES)
    assert len(values) == 5
    for row, (start, end) in zip(values, bounds, strict=True):
        alone, _ = seg.window_features(frames[start:end], end - start, CENTRES)
        np.testing.assert_allclose(alone[0], row, rtol=1e-12, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# ECDF bins (Fig. 4.3)


def test_ecdf_bins_hold_equal_shares():
    ramp = np.arange(100.0)[:, None]
    assert np.bincount(seg.discretise(ramp, seg.fit_ecdf_edges(ramp, 4))[:, 0]).tolist() == [25] * 4
    rng = np.random.default_rng(2)
    values = np.column_stack([rng.exponential(1.0, 1000), rng.normal(0.0, 3.0, 1000), rng.uniform(size=1000)])
    edges = seg.fit_ecdf_edges(values, 5)
    codes = seg.discretise(values, edges)
    for j in range(3):
        counts = np.bincount(codes[:, j], minlength=5)
        assert np.all(np.abs(counts - 200) <= 1), counts
    # non-equispaced on skewed data: the exponential's bins widen to the right
    widths = np.diff(edges[0])
    assert np.all(np.diff(widths) > 0)


def test_discretise_new_values():
    edges = np.array([[1.0, 2.0, 3.0]])
    codes = seg.discretise(np.array([[-5.0], [1.0], [1.5], [2.5], [99.0]]), edges)
    assert codes[:, 0].tolist() == [0, 1, 1, 2, 3]


# ---------------------------------------------------------------------------------------------
# potentials (4.1.1, 4.1.2)


def test_observation_phi_counts_and_per_action_frequencies():
    """4.1.1: Phi_OjY(ô, y) is the number of library windows with Ô_j = ô and Y = y (the default);
    the variant divides by the windows of y."""
    codes = np.array([[0], [0], [1], [1], [1]])
    labels = np.array([0, 0, 0, 1, 1])
    phi = seg.observation_phi(codes, labels, n_bins=2, n_actions=2)
    # action 0: bins (0, 0, 1); action 1: bins (1, 1)
    np.testing.assert_allclose(phi[0], [[2.0, 0.0], [1.0, 2.0]])
    frequencies = seg.observation_phi(codes, labels, n_bins=2, n_actions=2, kind="per_action_frequencies")
    np.testing.assert_allclose(frequencies[0], [[2 / 3, 0.0], [1 / 3, 1.0]])
    with pytest.raises(ValueError, match="kind"):
        seg.observation_phi(codes, labels, n_bins=2, n_actions=2, kind="normalised")


def test_fitted_phi_is_the_library_counts_unless_the_variant_is_chosen(library):
    """The segmenter learns the literal Phi_OjY of 4.1.1 by default: every action's column sums to
    its number of library windows; "per_action_frequencies" sums to 1."""
    labels, features, _ = seg.library_windows(library, WINDOW, CENTRES)
    windows = {a: sum(len(f) for lab, f in zip(labels, features, strict=True) if lab == a) for a in range(3)}
    genetic = seg.GeneticSettings(population=4, generations=1)
    fitted = {}
    for kind in seg.OBSERVATION_POTENTIALS:
        segmenter = seg.Segmenter(
            WINDOW, centres=CENTRES, genetic=genetic, seed=0, observation_potential=kind
        ).fit(library, PRECEDENCE, n_sequences=10, max_iter=5, seed=3)
        fitted[kind] = segmenter.model_.phi_obs
    for code, action in enumerate(segmenter.model_.actions):
        np.testing.assert_allclose(fitted["counts"][:, :, code].sum(axis=1), windows[action])
        np.testing.assert_allclose(fitted["per_action_frequencies"][:, :, code].sum(axis=1), 1.0)
    with pytest.raises(ValueError, match="observation_potential"):
        seg.Segmenter(WINDOW, observation_potential="normalised")


def test_sequence_phi_is_lambda_q_of_the_homm():
    cycle = [0, 1, 2] * 10
    phi = seg.sequence_phi(cycle, 3, order=1)
    expected = np.zeros((3, 3))
    expected[1, 0] = expected[2, 1] = expected[0, 2] = 1.0  # row: Y_k, column: Y_k-1
    np.testing.assert_allclose(phi[0], expected)
    phi2 = seg.sequence_phi(cycle, 3, order=2)
    assert phi2.shape == (2, 3, 3)
    # both lags are deterministic here; lambda sums to 1
    lag2 = np.zeros((3, 3))
    lag2[2, 0] = lag2[0, 1] = lag2[1, 2] = 1.0
    assert phi2[0].sum() + phi2[1].sum() == pytest.approx(3.0)
    for lag, step in enumerate((expected, lag2)):
        np.testing.assert_allclose(phi2[lag], phi2[lag].max() * step)


# ---------------------------------------------------------------------------------------------
# the MRF of a hypothesis (Fig. 4.2)


def test_segment_counts_round_the_cumulative_shares():
    assert seg.segment_counts([0.25, 0.5, 0.25], 4).tolist() == [1, 2, 1]
    assert seg.segment_counts([1 / 3, 1 / 3, 1 / 3], 10).tolist() == [3, 4, 3]
    assert seg.segment_counts([0.01, 0.99], 10).tolist() == [10]  # rounded to nothing: dropped
    assert seg.canonical_hypothesis([0.33, 0.67], 3).tolist() == pytest.approx([1 / 3, 2 / 3])


def test_mrf_has_the_expected_variables_and_factors():
    model = small_model(order=2)
    codes = np.array([[0, 1], [2, 2], [1, 0], [0, 0]])
    mrf = seg.build_segmentation_graph(model, codes, [0.25, 0.5, 0.25])
    hidden = [("Y", 0), ("Y", 1), ("Y", 2)]
    observed = [("O", l, j) for l in range(4) for j in range(2)]
    assert mrf.hidden == hidden
    assert mrf.graph.variables == {**dict.fromkeys(hidden, 2), **dict.fromkeys(observed, 3)}
    assert mrf.evidence == {("O", l, j): int(codes[l, j]) for l in range(4) for j in range(2)}
    owner = [0, 1, 1, 2]  # counts 1, 2, 1
    expected = [((("O", l, j), ("Y", owner[l])), f"w_O{j}") for l in range(4) for j in range(2)]
    expected += [((("Y", 1), ("Y", 0)), "w_Y"), ((("Y", 2), ("Y", 1)), "w_Y"), ((("Y", 2), ("Y", 0)), "w_Y")]
    assert sorted(mrf.factors) == sorted(expected)
    assert mrf.graph.weights() == {"w_O0": 0.7, "w_O1": 1.3, "w_Y": 0.9}


def test_mrf_log_energy_matches_hand_computation():
    model = small_model(order=2)
    codes = np.array([[0, 1], [2, 2], [1, 0], [0, 0]])
    mrf = seg.build_segmentation_graph(model, codes, [0.25, 0.5, 0.25])
    y = [1, 0, 1]
    owner = [0, 1, 1, 2]
    assignment = {**mrf.evidence, ("Y", 0): y[0], ("Y", 1): y[1], ("Y", 2): y[2]}
    hand = sum(
        model.w_obs[j] * model.phi_obs[j, codes[l, j], y[owner[l]]] for l in range(4) for j in range(2)
    )
    hand += model.w_seq * (model.phi_seq[0, y[1], y[0]] + model.phi_seq[0, y[2], y[1]])
    hand += model.w_seq * model.phi_seq[1, y[2], y[0]]
    assert mrf.graph.log_energy(assignment) == pytest.approx(hand, rel=1e-12)


@pytest.mark.parametrize("rho", [[1.0], [0.25, 0.5, 0.25], [0.5, 0.25, 0.25], [0.25] * 4])
def test_fitness_matches_brute_force_and_the_full_graph(rho):
    model = small_model(order=2)
    codes = np.array([[0, 1], [2, 2], [1, 0], [0, 0]])
    counts = seg.segment_counts(rho, 4)
    owner = np.repeat(np.arange(len(counts)), counts)
    pairs = seg.chain_pairs(len(counts), 2)

    def log_e(y):
        total = sum(
            model.w_obs[j] * model.phi_obs[j, codes[l, j], y[owner[l]]] for l in range(4) for j in range(2)
        )
        return total + sum(model.w_seq * model.phi_seq[lag - 1, y[k], y[p]] for k, p, lag in pairs)

    best = max(log_e(y) for y in itertools.product(range(2), repeat=len(counts)))
    log_sup = 4 * sum(np.max(w * phi) for w, phi in zip(model.w_obs, model.phi_obs, strict=True))
    log_sup += sum(np.max(model.w_seq * model.phi_seq[lag - 1]) for _, _, lag in pairs)
    rate = 1.0 + 4 / 2.0  # 1 + L / mean action length
    log_prior = -rate + len(counts) * np.log(rate) - np.log(float(np.prod(np.arange(1, len(counts) + 1))))
    expected = best - log_sup + log_prior
    assert seg.log_fitness(model, codes, rho) == pytest.approx(expected, rel=1e-10)
    mrf = seg.build_segmentation_graph(model, codes, rho)  # the MAP of the full MRF, evidence sliced by BP
    full = mrf.graph.log_energy(mrf.graph.map(mrf.evidence)) - log_sup + log_prior
    assert full == pytest.approx(expected, rel=1e-10)


def test_poisson_prior_values():
    assert seg.poisson_prior(3, 2.0, 10) == pytest.approx(np.exp(-2.0) * 8.0 / 6.0)
    assert seg.poisson_prior(1, 0.5, 10) == pytest.approx(0.5 * np.exp(-0.5))
    assert seg.poisson_prior(11, 2.0, 10) == 0.0  # |rho| > L
    assert sum(seg.poisson_prior(n, 3.0, 200) for n in range(1, 200)) == pytest.approx(1 - np.exp(-3.0))
    assert seg.window_prior_rate(30, 10.0) == pytest.approx(4.0)


# ---------------------------------------------------------------------------------------------
# genetic operators (4.1.3, Fig. 4.4)


def random_parent(rng, n_windows):
    return seg.random_hypothesis(n_windows, 4.0, rng)


def inner(rho, n_windows):
    """Inner segment boundaries of rho, in windows."""
    return set(np.rint(np.cumsum(rho)[:-1] * n_windows).astype(int).tolist())


def test_crossover_keeps_the_parents_boundaries_around_the_cut():
    rng = np.random.default_rng(0)
    for _ in range(200):
        a, b = random_parent(rng, 20), random_parent(rng, 20)
        seed = int(rng.integers(1 << 30))
        cut = np.random.default_rng(seed).uniform()  # the one draw crossover makes
        child = seg.crossover(a, b, 20, np.random.default_rng(seed))
        assert is_valid_hypothesis(child, 20)
        below = {x for x in inner(a, 20) if x < cut * 20}
        above = {x for x in inner(b, 20) if x > cut * 20}
        assert inner(child, 20) == below | above


def test_genetic_operators_are_seed_deterministic_and_valid():
    rng = np.random.default_rng(1)
    a, b = random_parent(rng, 30), random_parent(rng, 30)
    children = [seg.crossover(a, b, 30, np.random.default_rng(7)) for _ in range(2)]
    np.testing.assert_array_equal(children[0], children[1])
    mutants = [seg.mutate(a, 30, np.random.default_rng(7)) for _ in range(2)]
    np.testing.assert_array_equal(mutants[0], mutants[1])
    different = {tuple(seg.mutate(a, 30, np.random.default_rng(s))) for s in range(20)}
    assert len(different) > 5
    for s in range(100):
        r = np.random.default_rng(s)
        inserted = seg.mutate(a, 30, r, insertion_share=1.0)
        changed = seg.mutate(a, 30, r, insertion_share=0.0)
        assert is_valid_hypothesis(inserted, 30) and is_valid_hypothesis(changed, 30)
        assert len(a) <= len(inserted) <= len(a) + 1  # the new value may round away
        assert len(changed) <= len(a)


def test_value_change_rescales_one_value_and_renormalises():
    # scaling one value of [0.5, 0.5] by u gives [u, 1] / (1 + u): reproduce the draws of mutate
    rho = np.array([0.5, 0.5])
    r = np.random.default_rng(3)
    r.uniform()  # the insertion test, not taken with insertion_share=0
    index, factor = r.integers(2), r.uniform(0.0, 2.0)
    values = rho.copy()
    values[index] *= factor
    expected = seg.canonical_hypothesis(values / values.sum(), 100)
    np.testing.assert_allclose(seg.mutate(rho, 100, np.random.default_rng(3), insertion_share=0.0), expected)


def test_roulette_is_proportional_to_fitness():
    picks = seg.roulette(np.log([1.0, 3.0]), 20000, np.random.default_rng(0))
    assert np.mean(picks == 1) == pytest.approx(0.75, abs=0.015)


def test_genetic_algorithm_finds_the_exhaustive_optimum():
    rng = np.random.default_rng(4)
    model = small_model(order=1)
    # 8 windows, first half evidence for one action, second for the other
    codes = np.array([[0, 0]] * 4 + [[2, 2]] * 4)
    problem = seg.WindowProblem(model, codes, np.stack([np.arange(8), np.arange(1, 9)], axis=1))
    compositions = []
    for cuts in itertools.product([0, 1], repeat=7):
        boundaries = [i + 1 for i, c in enumerate(cuts) if c]
        compositions.append(np.diff([0, *boundaries, 8]) / 8)
    best = max(problem.log_fitness(rho) for rho in compositions)
    result = seg.evolve(problem.log_fitness, 8, problem.prior_rate, seg.GeneticSettings(20, 15), rng)
    assert result.log_fitness == pytest.approx(best)
    assert result.best_per_generation == sorted(result.best_per_generation)  # the elite is kept


# ---------------------------------------------------------------------------------------------
# sliding window (4.1.4)


def test_survivor_message_equals_the_summed_out_deleted_chain(segmenter):
    model = segmenter.model_
    frames, _ = stream([0, 1, 2], [20, 15, 25], np.random.default_rng(9))
    values, bounds = seg.window_features(frames, WINDOW, CENTRES)
    codes = seg.discretise(values, model.edges)
    sliding = seg.SlidingWindowSegmenter(model, batch_windows=12, genetic=segmenter.genetic, seed=0)
    closed = []
    for row, b in zip(codes, bounds, strict=True):
        closed += sliding.push(row, b)
    counts = seg.segment_counts(sliding.last_result.rho, 12)
    assert len(counts) >= 2 and len(sliding.survivors) == 1 and len(closed) == len(counts) - 1
    unary = model.window_log_potentials(codes)
    cut = np.concatenate([[0], np.cumsum(counts)])
    evidence = [unary[a:b].sum(axis=0) for a, b in itertools.pairwise(cut)]
    survivor = sliding.survivors[0]
    np.testing.assert_allclose(survivor.log_evidence, evidence[-1])
    # message into Y_last: sum over the deleted actions of their evidence and sequence potentials
    deleted, m = len(counts) - 1, model.n_actions
    message = np.full(m, -np.inf)
    for ys in itertools.product(range(m), repeat=deleted):
        score = sum(evidence[k][y] for k, y in enumerate(ys))
        score += sum(model.w_seq * model.phi_seq[0, ys[k], ys[k - 1]] for k in range(1, deleted))
        message = np.logaddexp(message, score + model.w_seq * model.phi_seq[0, :, ys[-1]])
    message -= np.logaddexp.reduce(message)
    np.testing.assert_allclose(survivor.log_message, message, atol=1e-9)
    # closed segments tile the frames before the survivor
    assert closed[0].start == 0 and all(x.end == y.start for x, y in itertools.pairwise(closed))
    assert closed[-1].end == survivor.start


def test_online_updates_equal_the_offline_segmentation(segmenter):
    frames, _ = stream([0, 2, 1], [33, 41, 27], np.random.default_rng(11))
    online = []
    segmenter.reset()
    for frame in frames:
        online += segmenter.update(frame)
    online += segmenter.flush()
    assert online == segmenter.segment(frames, merge=False)
    assert online[0].start == 0 and online[-1].end == len(frames)
    assert all(x.end == y.start for x, y in itertools.pairwise(online))


def test_order_two_segmenter_runs_through_the_sliding_window(library):
    genetic = seg.GeneticSettings(population=10, generations=6)
    out = seg.Segmenter(WINDOW, batch_windows=8, order=2, centres=CENTRES, genetic=genetic, seed=0)
    out.fit(library, PRECEDENCE, n_sequences=15, max_iter=30, seed=3)
    frames, truth = stream([0, 1, 2], [40, 40, 40], np.random.default_rng(12))
    assert out.model_.order == 2 and out.model_.w_seq > 0
    assert seg.segmentation_error(out.segment(frames), truth) < 0.15


# ---------------------------------------------------------------------------------------------
# the segmenter on synthetic recordings


def test_segmenter_recovers_a_synthetic_segmentation(segmenter):
    rng = np.random.default_rng(100)
    order = [0, 2, 1, 0, 1, 2]  # two precedence-valid cycles
    frames, truth = stream(order, rng.integers(30, 90, len(order)), rng)
    predicted = segmenter.segment(frames)
    error = seg.segmentation_error(predicted, truth)
    assert error < 0.08
    assert [s.action for s in predicted] == order
    # random segmentations (5 random cuts, random actions) are far worse
    random_errors = []
    for _ in range(20):
        cuts = np.concatenate(
            [[0], np.sort(rng.choice(np.arange(1, len(frames)), 5, replace=False)), [len(frames)]]
        )
        guess = [(int(a), int(b), int(rng.integers(3))) for a, b in itertools.pairwise(cuts)]
        random_errors.append(seg.segmentation_error(guess, truth))
    assert np.mean(random_errors) > 0.45
    # a model whose observation potentials are given to the wrong actions fails
    model = segmenter.model_
    wrong = seg.SegmentationModel(
        model.actions, model.edges, model.phi_obs[:, :, [1, 2, 0]], model.phi_seq,
        model.w_obs, model.w_seq, model.mean_action_windows,
    )  # fmt: skip
    wrong_segmenter = seg.Segmenter(
        WINDOW, batch_windows=10, centres=CENTRES, genetic=segmenter.genetic, seed=0, model=wrong
    )
    assert seg.segmentation_error(wrong_segmenter.segment(frames), truth) > 0.9


def test_same_seed_same_segmentation(segmenter, library):
    frames, _ = stream([0, 1, 2], [37, 29, 44], np.random.default_rng(13))
    first = segmenter.segment(frames, merge=False)
    assert segmenter.segment(frames, merge=False) == first
    twin = seg.Segmenter(WINDOW, batch_windows=10, centres=CENTRES, genetic=segmenter.genetic, seed=0)
    twin.fit(library, PRECEDENCE, n_sequences=60, seed=3)
    np.testing.assert_array_equal(twin.model_.w_obs, segmenter.model_.w_obs)
    assert twin.segment(frames, merge=False) == first


# ---------------------------------------------------------------------------------------------
# training (4.1.5)


def test_training_learns_the_sign_of_w_y_from_the_sequences(segmenter, library):
    labels, features, _ = seg.library_windows(library, WINDOW, CENTRES)
    window_labels = np.concatenate([np.full(len(f), a) for a, f in zip(labels, features, strict=True)])
    codes = seg.discretise(np.vstack(features), segmenter.model_.edges)
    # a strict chain 0 -> 1 -> 2: Q puts all its mass on the successor, none on the predecessor
    series = seg.artificial_sequence(3, seg.precedence_pairs([(0, 1), (1, 2)], (0, 1, 2)), 30, seed=0)
    phi_seq = seg.sequence_phi(series, 3, order=1)
    windows = np.lib.stride_tricks.sliding_window_view(series, 3)[::2]
    noise = np.random.default_rng(0).integers(0, 3, windows.shape)

    def w_y(sequences):
        trained = seg.learn_weights(
            segmenter.model_.phi_obs, phi_seq, codes, window_labels, sequences, seed=0
        )
        assert trained.report.converged
        return trained.w_seq

    assert w_y(windows) > 1.0  # sequences that follow the precedence
    assert w_y(windows[:, ::-1]) < 0.0  # the same sequences reversed break it
    assert abs(w_y(noise)) < 1.0  # random sequences: the sequence model is worth little
    assert segmenter.model_.w_seq > 1.0  # Segmenter.fit on the (weaker) precedence of the fixture


def test_precedence_orders_are_valid_and_seeded():
    pairs = seg.precedence_pairs({"a": ["b", "c"], "b": ["d"]}, ("a", "b", "c", "d"))
    assert sorted(pairs) == [(0, 1), (0, 2), (1, 3)]
    series = seg.artificial_sequence(4, pairs, 50, seed=2)
    cycles = series.reshape(50, 4)
    for cycle in cycles:
        position = {a: i for i, a in enumerate(cycle)}
        assert sorted(cycle) == [0, 1, 2, 3]
        assert all(position[x] < position[y] for x, y in pairs)
    assert len({tuple(c) for c in cycles}) >= 2  # several valid orders drawn
    np.testing.assert_array_equal(series, seg.artificial_sequence(4, pairs, 50, seed=2))


# ---------------------------------------------------------------------------------------------
# segmentation error (4.2.1)


def test_segmentation_error_by_hand():
    truth = [(0, 10, "a"), (10, 20, "b")]
    assert seg.segmentation_error([(0, 12, "a"), (12, 20, "b")], truth) == pytest.approx(0.1)
    assert seg.segmentation_error([(0, 15, "a")], truth) == pytest.approx(0.5)  # 5 wrong, 5 missing
    assert seg.segmentation_error(["a"] * 10 + ["b"] * 10, truth) == 0.0
    assert seg.merge_segments([(0, 5, "a"), (5, 9, "a"), (9, 12, "b")]) == [(0, 9, "a"), (9, 12, "b")]


# ---------------------------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: seg.window_features(np.zeros((4, 7, 3)), 2), r"shape \(T >= 1, 8, 3\)"),
        (lambda: seg.window_features(np.full((4, 8, 3), np.nan), 2), r"sample 0, point 'thorax'"),
        (lambda: seg.window_features(np.zeros((4, 8, 3)), 0), "window_length"),
        (lambda: seg.window_features(np.zeros((4, 8, 3)), 2, centres=[1.0, 2.0]), "centres"),
        (lambda: seg.fit_ecdf_edges(np.zeros((5, 2)), 1), "n_bins"),
        (lambda: seg.segment_counts([0.5, 0.6], 10), "sum to 1"),
        (lambda: seg.segment_counts([1.5, -0.5], 10), "positive"),
        (lambda: seg.poisson_log_prior(0, 1.0, 10), r"n_segments \(\|rho\|\)"),
        (lambda: seg.poisson_log_prior(2, -1.0, 10), "rate"),
        (lambda: seg.precedence_pairs([("a", "b"), ("b", "a")], ("a", "b")), "cycle"),
        (lambda: seg.precedence_pairs([("a", "z")], ("a", "b")), "unknown action 'z'"),
        (lambda: seg.Segmenter(5).segment(np.zeros((10, 8, 3))), "call fit"),
        (lambda: seg.Segmenter(5).fit([("a", np.zeros((3, 8)))], []), r"library\[0\] frames"),
        (lambda: seg.segmentation_error([(0, 5, "a"), (3, 8, "b")], [(0, 8, "a")]), "overlaps"),
        (lambda: seg.GeneticSettings(population=4, elite=4), "elite"),
        (
            lambda: seg.Segmenter(5).fit([("a", np.zeros((6, 8, 3)))], [], actions=("a", "b")),
            r"\['b'\] have no",
        ),
        (
            lambda: seg.SegmentationModel(
                ("a",), np.zeros((2, 2)), np.zeros((2, 3, 2)), np.zeros((1, 1, 1)), np.ones(2), 1.0, 1.0
            ),
            "phi_obs has shape",
        ),
        (lambda: seg.log_fitness(small_model(), np.array([[0, 3]]), [1.0]), "out of range"),
    ],
)
def test_bad_input_raises_value_error_naming_the_problem(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_update_rejects_a_bad_frame(segmenter):
    segmenter.reset()
    segmenter.update(base_pose())
    with pytest.raises(ValueError, match="frame 1"):
        segmenter.update(np.full((8, 3), np.inf))
    segmenter.reset()


# ---------------------------------------------------------------------------------------------
# the scenario config (4.2)


def test_segmenter_config_defaults_follow_4_2():
    """4.2: a camera sample every 40 ms and l_w = 400 ms, so 10 samples a window; L = 30; the
    literal Phi_OjY; a bad variant name is a ConfigError naming the field."""
    from hrc_drake.errors import ConfigError
    from hrc_drake.intention.config import SegmenterActionDetector

    config = SegmenterActionDetector()
    config.validate("action_detector")
    assert 1.0 / config.rate == pytest.approx(0.040)
    assert round(config.window * config.rate) == 10 and config.batch_windows == 30
    assert config.observation_potential == "counts"
    assert set(seg.OBSERVATION_POTENTIALS) == {"counts", "per_action_frequencies"}
    with pytest.raises(ConfigError, match="action_detector.observation_potential"):
        SegmenterActionDetector(observation_potential="normalised").validate("action_detector")
