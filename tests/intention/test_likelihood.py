import numpy as np
import pytest
from scipy.stats import multivariate_normal
from sklearn.mixture import GaussianMixture

from hrc_drake.intention.likelihood import GaussianMixtureDensity, IntentionLikelihoodLearner, IntentionModel
from tests.intention.intention_reaches import reach_samples


def test_density_matches_scipy_and_sklearn():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, 3)) @ np.diag([1.0, 0.3, 2.0])
    gmm = GaussianMixture(3, covariance_type="full", random_state=0).fit(x)
    density = GaussianMixtureDensity.from_sklearn(gmm)
    query = rng.normal(size=(5, 4, 3))
    np.testing.assert_allclose(
        density.log_density(query), gmm.score_samples(query.reshape(-1, 3)).reshape(5, 4)
    )
    by_hand = sum(
        w * multivariate_normal(m, c).pdf(query[0])
        for w, m, c in zip(gmm.weights_, gmm.means_, gmm.covariances_, strict=True)
    )
    np.testing.assert_allclose(np.exp(density.log_density(query[0])), by_hand)


def test_far_samples_give_finite_log_density():
    density = GaussianMixtureDensity([1.0], [[0.0, 0.0]], [np.eye(2) * 1e-4])
    value = density.log_density(np.array([1e3, 1e3]))
    assert np.isfinite(value) and value < -1e9


def test_bad_parameters_raise():
    with pytest.raises(ValueError, match="sum to 1"):
        GaussianMixtureDensity([0.5, 0.2], np.zeros((2, 2)), np.stack([np.eye(2)] * 2))
    with pytest.raises(ValueError, match="positive definite"):
        GaussianMixtureDensity([1.0], np.zeros((1, 2)), -np.eye(2)[None])
    with pytest.raises(ValueError, match="NaN"):
        IntentionLikelihoodLearner().fit(np.full((50, 4), np.nan))


def test_learner_selects_clusters_by_heldout_likelihood_and_round_trips_json(tmp_path):
    phi = reach_samples(40, seed=1)
    learner = IntentionLikelihoodLearner(candidates=(1, 2, 3, 4), random_state=0).fit(phi)
    scores = learner.heldout_scores_4d_
    assert set(scores) == {1, 2, 3, 4}
    assert scores[learner.n_components_4d_] >= max(scores.values()) - learner.tolerance
    assert learner.gmm4d_.n_components == learner.n_components_4d_
    path = tmp_path / "model.json"
    learner.model_.save(path)
    loaded = IntentionModel.load(path)
    np.testing.assert_allclose(loaded.gmm4d.log_density(phi[:20]), learner.score_samples(phi[:20]))
    np.testing.assert_allclose(
        loaded.gmm2d.log_density(phi[:20, [0, 3]]), learner.gmm2d_.score_samples(phi[:20, [0, 3]])
    )
    assert "pickle" not in path.read_text()
    before = learner.gmm4d_.means_.copy()
    learner.partial_fit(reach_samples(10, seed=2))
    assert learner.gmm4d_.means_.shape == before.shape
    assert learner.n_samples_seen_ > len(phi)


def test_learned_likelihood_prefers_the_true_direction(small_model):
    # moving straight at a goal 0.3 m away is likelier than moving away from it
    toward = small_model.gmm2d.log_density(np.array([0.05, 0.3]))
    away = small_model.gmm2d.log_density(np.array([2.5, 0.3]))
    assert toward > away + 3.0


def test_load_reports_the_file(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"gmm4d": {}}')
    with pytest.raises(ValueError, match="broken.json"):
        IntentionModel.load(path)


def test_gmm4d_learns_only_from_samples_with_a_valid_gaze_flag():
    rng = np.random.default_rng(0)
    columns = [(0.3, 0.1), (1.5, 0.2), (0.2, 0.05), (0.25, 0.1)]
    phi = np.column_stack([rng.normal(mean, std, 400) for mean, std in columns])
    valid = np.arange(400) < 300
    phi[~valid, 2] = rng.normal(2.5, 0.05, 100)  # unreliable gaze estimates: far from the goal
    learner = IntentionLikelihoodLearner(candidates=(1,), random_state=0).fit(phi, valid)
    assert learner.gmm4d_.means_[0, 2] == pytest.approx(phi[valid, 2].mean(), abs=1e-6)
    assert learner.gmm2d_.means_[0] == pytest.approx(phi[:, [0, 3]].mean(axis=0), abs=1e-6)
    with pytest.raises(ValueError, match="gaze_valid"):
        learner.fit(phi, valid[:10])
    with pytest.raises(ValueError, match="valid gaze flag"):
        learner.fit(phi, np.zeros(400, bool))
