"""Learned likelihoods L_GMM(Phi) and L_GMM(Psi) of thesis 3.1.2 (GMM4d and GMM2d).

The mixtures are fitted with scikit-learn's `GaussianMixture` (EM, Appendix B); the number of
clusters is chosen by held-out log-likelihood, as Fig. 3.8 does. For on-line use they are
evaluated by `GaussianMixtureDensity`, a small numpy evaluator of eq. (3.10) that is saved and
loaded as JSON (weights, means, covariances), never pickled.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hrc_drake.intention.features import DEFAULT_MIN_SPEED, DEFAULT_SIGNIFICANCE, DEFAULT_WINDOW, PSI_COLUMNS

#: An intention model is two small mixtures: a file larger than this is not one.
MAX_MODEL_BYTES = 20_000_000
DEFAULT_MODEL_PATH = Path(__file__).resolve().parents[1] / "data" / "intention_default.json"
_LOG_2PI = np.log(2.0 * np.pi)


class GaussianMixtureDensity:
    """Density of a Gaussian mixture, f(x) = sum_k lambda_k N(x; mu_k, Sigma_k) (eq. 3.10).

    weights: (K,) summing to 1; means: (K, D); covariances: (K, D, D) symmetric positive definite.
    """

    def __init__(self, weights, means, covariances):
        weights = np.asarray(weights, dtype=float)
        means = np.asarray(means, dtype=float)
        covariances = np.asarray(covariances, dtype=float)
        if weights.ndim != 1 or means.ndim != 2 or covariances.ndim != 3:
            raise ValueError(
                "GaussianMixtureDensity: weights (K,), means (K, D), covariances (K, D, D) "
                f"expected, got {weights.shape}, {means.shape}, {covariances.shape}"
            )
        k, d = means.shape
        if weights.shape[0] != k or covariances.shape != (k, d, d) or k == 0:
            raise ValueError(
                f"GaussianMixtureDensity: inconsistent shapes {weights.shape}, {means.shape}, "
                f"{covariances.shape}"
            )
        if not (
            np.all(np.isfinite(weights)) and np.all(np.isfinite(means)) and np.all(np.isfinite(covariances))
        ):
            raise ValueError("GaussianMixtureDensity: parameters contain NaN or inf")
        if np.any(weights < 0) or abs(weights.sum() - 1.0) > 1e-6:
            raise ValueError(
                f"GaussianMixtureDensity: weights must be >= 0 and sum to 1 (eq. 3.6), "
                f"sum is {weights.sum():.6g}"
            )
        try:
            chol = np.linalg.cholesky(covariances)
        except np.linalg.LinAlgError as err:
            raise ValueError("GaussianMixtureDensity: a covariance is not positive definite") from err
        self.weights = weights
        self.means = means
        self.covariances = covariances
        # (x - mu)^T Sigma^-1 (x - mu) = |(x - mu) @ P|^2 with P = inv(L)^T, Sigma = L L^T.
        self._precision_chol = np.transpose(np.linalg.inv(chol), (0, 2, 1))  # (K, D, D)
        self._mean_proj = np.einsum("kd,kde->ke", means, self._precision_chol)  # (K, D)
        with np.errstate(divide="ignore"):
            log_weights = np.log(weights)
        self._log_norm = (
            log_weights - 0.5 * d * _LOG_2PI - np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(axis=1)
        )  # (K,)

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(precision Cholesky factors (K, D, D), projected means (K, D), log normalisers (K,)):
        what `log_density` evaluates, for `_kernels.goal_log_likelihoods`."""
        return self._precision_chol, self._mean_proj, self._log_norm

    @property
    def n_components(self) -> int:
        return self.weights.shape[0]

    @property
    def n_features(self) -> int:
        return self.means.shape[1]

    def log_density(self, x: np.ndarray) -> np.ndarray:
        """log f(x) for samples x (..., D); one batched expression for all samples."""
        x = np.asarray(x, dtype=float)
        if x.shape[-1] != self.n_features:
            raise ValueError(
                f"GaussianMixtureDensity.log_density: last axis must be {self.n_features}, got {x.shape}"
            )
        y = np.einsum("...d,kde->...ke", x, self._precision_chol) - self._mean_proj
        log_comp = self._log_norm - 0.5 * np.einsum("...ke,...ke->...k", y, y)
        top = np.max(log_comp, axis=-1, keepdims=True)
        top = np.where(np.isfinite(top), top, 0.0)
        return top[..., 0] + np.log(np.sum(np.exp(log_comp - top), axis=-1))

    def to_dict(self) -> dict:
        return {
            "weights": self.weights.tolist(),
            "means": self.means.tolist(),
            "covariances": self.covariances.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> GaussianMixtureDensity:
        missing = {"weights", "means", "covariances"} - set(data)
        if missing:
            raise ValueError(f"GaussianMixtureDensity.from_dict: missing keys {sorted(missing)}")
        return cls(data["weights"], data["means"], data["covariances"])

    @classmethod
    def from_sklearn(cls, gmm) -> GaussianMixtureDensity:
        """From a fitted `sklearn.mixture.GaussianMixture` with covariance_type 'full'."""
        if gmm.covariance_type != "full":
            raise ValueError(
                f"GaussianMixtureDensity.from_sklearn: covariance_type 'full' needed, "
                f"got {gmm.covariance_type!r}"
            )
        return cls(gmm.weights_, gmm.means_, gmm.covariances_)


@dataclass
class IntentionModel:
    """The two likelihoods of thesis 3.1.2 and the feature settings they were learned with.

    gmm4d: density of Phi = (delta_W1, delta_W2, delta_H, d); gmm2d: density of Psi = (delta_W1, d).
    window, min_speed, significance: the velocity estimator used for the features (see `features`).
    """

    gmm4d: GaussianMixtureDensity
    gmm2d: GaussianMixtureDensity
    window: int = DEFAULT_WINDOW
    min_speed: float = DEFAULT_MIN_SPEED
    info: dict = field(default_factory=dict)
    significance: float = DEFAULT_SIGNIFICANCE
    evidence_weight: float = 1.0

    def __post_init__(self):
        if self.gmm4d.n_features != 4 or self.gmm2d.n_features != 2:
            raise ValueError(
                f"IntentionModel: GMM4d needs 4 features and GMM2d 2, got "
                f"{self.gmm4d.n_features} and {self.gmm2d.n_features}"
            )
        # The velocity estimator's settings: a line needs 2 samples, a speed and a test level.
        if not 2 <= self.window <= 1000:
            raise ValueError(f"IntentionModel: window must be in [2, 1000] samples, got {self.window}")
        if not (math.isfinite(self.min_speed) and self.min_speed >= 0):
            raise ValueError(f"IntentionModel: min_speed must be a finite speed >= 0, got {self.min_speed}")
        if not 0 <= self.significance <= 100:
            raise ValueError(f"IntentionModel: significance must be in [0, 100] standard errors, got "
                             f"{self.significance}")
        if not 0 < self.evidence_weight <= 1:
            raise ValueError(f"IntentionModel: evidence_weight must be in (0, 1], got {self.evidence_weight}")

    def to_dict(self) -> dict:
        return {
            "format": "hrc_drake.intention.IntentionModel/1",
            "gmm4d": self.gmm4d.to_dict(),
            "gmm2d": self.gmm2d.to_dict(),
            "window": int(self.window),
            "min_speed": float(self.min_speed),
            "significance": float(self.significance),
            "evidence_weight": float(self.evidence_weight),
            "info": self.info,
        }

    @classmethod
    def from_dict(cls, data: dict) -> IntentionModel:
        for key in ("gmm4d", "gmm2d"):
            if not isinstance(data.get(key), dict):
                raise ValueError(f"IntentionModel.from_dict: {key!r} must be an object of weights, means, "
                                 "covariances")
        return cls(
            GaussianMixtureDensity.from_dict(data["gmm4d"]),
            GaussianMixtureDensity.from_dict(data["gmm2d"]),
            int(data.get("window", DEFAULT_WINDOW)),
            float(data.get("min_speed", DEFAULT_MIN_SPEED)),
            dict(data.get("info", {})),
            # models saved before the significance test existed gated motion on speed only
            float(data.get("significance", 0.0)),
            float(data.get("evidence_weight", 1.0)),
        )

    def save(self, path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=1))

    @classmethod
    def load(cls, path) -> IntentionModel:
        """Read a model saved by `save`; ValueError naming the file for anything it cannot use."""
        path = Path(path)
        try:
            size = path.stat().st_size
            if size > MAX_MODEL_BYTES:
                raise ValueError(f"{size / 1e6:.1f} MB is too large for an intention model "
                                 f"(at most {MAX_MODEL_BYTES / 1e6:g} MB)")
            data = json.loads(path.read_bytes().decode("utf-8"))
            if not isinstance(data, dict):
                raise ValueError(f"the top level must be an object with 'gmm4d' and 'gmm2d', got "
                                 f"{type(data).__name__}")
            return cls.from_dict(data)
        except OSError as err:
            raise ValueError(f"IntentionModel.load: cannot read {path}: {err.strerror or err}") from None
        except UnicodeDecodeError as err:
            raise ValueError(f"IntentionModel.load: {path}: not UTF-8 text (byte {err.start})") from None
        except json.JSONDecodeError as err:
            raise ValueError(f"IntentionModel.load: {path}: not valid JSON: {err}") from None
        except RecursionError:
            raise ValueError(f"IntentionModel.load: {path}: nested too deeply to be a model") from None
        except (ValueError, TypeError, KeyError, AttributeError) as err:
            raise ValueError(f"IntentionModel.load: {path}: {err}") from None


def default_model() -> IntentionModel:
    """The model shipped in hrc_drake/data/intention_default.json (tools/train_intention.py)."""
    if not DEFAULT_MODEL_PATH.exists():
        raise FileNotFoundError(
            f"the default intention model {DEFAULT_MODEL_PATH} is missing; run tools/train_intention.py"
        )
    return IntentionModel.load(DEFAULT_MODEL_PATH)


def _check_samples(x, n_features: int, where: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != n_features:
        raise ValueError(f"{where}: samples must be (M, {n_features}), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{where}: samples contain NaN or inf (drop still hands and lost wrists first)")
    return x


class IntentionLikelihoodLearner:
    """Learns GMM4d (on Phi) and GMM2d (on Psi) from labelled samples (thesis 3.1.2, Fig. 3.8).

    Samples are Phi^i rows computed for the goal i the hand was really going to. The number of
    clusters is the smallest candidate whose mean held-out log-likelihood per sample is within
    `tolerance` of the best ("a greater number does not improve significantly").

    Learned: `gmm4d_`, `gmm2d_` (sklearn GaussianMixture), `n_components_4d_`, `n_components_2d_`,
    `heldout_scores_4d_`, `heldout_scores_2d_` (dict n_components -> nats per sample), `model_`.
    """

    def __init__(
        self,
        candidates=tuple(range(1, 13)),
        heldout_fraction: float = 0.25,
        tolerance: float = 0.05,
        reg_covar: float = 1e-3,
        max_samples: int = 40000,
        window: int = DEFAULT_WINDOW,
        min_speed: float = DEFAULT_MIN_SPEED,
        random_state: int = 0,
        significance: float = DEFAULT_SIGNIFICANCE,
    ):
        self.candidates = tuple(int(c) for c in candidates)
        self.heldout_fraction = heldout_fraction
        self.tolerance = tolerance
        self.reg_covar = reg_covar
        self.max_samples = max_samples
        self.window = window
        self.min_speed = min_speed
        self.random_state = random_state
        self.significance = significance

    def _select_and_fit(self, x: np.ndarray, rng: np.random.Generator):
        from sklearn.mixture import GaussianMixture

        if len(x) > self.max_samples:
            x = x[rng.choice(len(x), self.max_samples, replace=False)]
        order = rng.permutation(len(x))
        n_test = max(1, int(round(self.heldout_fraction * len(x))))
        test, train = x[order[:n_test]], x[order[n_test:]]
        scores = {}
        for k in self.candidates:
            if k > len(train):
                break
            gmm = GaussianMixture(
                k, covariance_type="full", reg_covar=self.reg_covar, n_init=1, random_state=self.random_state
            ).fit(train)
            scores[k] = float(gmm.score(test))
        best = max(scores.values())
        chosen = min(k for k, s in scores.items() if s >= best - self.tolerance)
        gmm = GaussianMixture(
            chosen, covariance_type="full", reg_covar=self.reg_covar, n_init=2, random_state=self.random_state
        ).fit(x)
        return gmm, chosen, scores

    def fit(self, phi: np.ndarray, gaze_valid: np.ndarray | None = None) -> IntentionLikelihoodLearner:
        """Fit GMM4d to the samples Phi (M, 4) of the true goals whose gaze flag F is valid, GMM2d to all.

        gaze_valid (M,) bool: flag F of each sample (default: all valid). GMM4d is used on line
        only when F is valid (3.1.2), so it learns delta_H only from trustworthy gaze estimates.
        """
        phi = _check_samples(phi, 4, "IntentionLikelihoodLearner.fit")
        valid = np.ones(len(phi), dtype=bool) if gaze_valid is None else np.asarray(gaze_valid, dtype=bool)
        if valid.shape != (len(phi),):
            raise ValueError(
                f"IntentionLikelihoodLearner.fit: gaze_valid must be ({len(phi)},), got {valid.shape}"
            )
        minimum = 2 * max(self.candidates[0], 2)
        if len(phi) < minimum or valid.sum() < minimum:
            raise ValueError(
                f"IntentionLikelihoodLearner.fit: too few samples ({len(phi)}, {int(valid.sum())} with a "
                f"valid gaze flag; at least {minimum} each)"
            )
        rng = np.random.default_rng(self.random_state)
        self.gmm4d_, self.n_components_4d_, self.heldout_scores_4d_ = self._select_and_fit(phi[valid], rng)
        psi = phi[:, list(PSI_COLUMNS)]
        self.gmm2d_, self.n_components_2d_, self.heldout_scores_2d_ = self._select_and_fit(psi, rng)
        self.n_samples_seen_ = len(phi)
        self._make_model()
        return self

    def partial_fit(self, phi: np.ndarray) -> IntentionLikelihoodLearner:
        """Refine the fitted mixtures with new samples: a few EM steps started from the current ones."""
        if not hasattr(self, "gmm4d_"):
            return self.fit(phi)
        from sklearn.mixture import GaussianMixture

        phi = _check_samples(phi, 4, "IntentionLikelihoodLearner.partial_fit")
        updated = []
        for old, x in ((self.gmm4d_, phi), (self.gmm2d_, phi[:, list(PSI_COLUMNS)])):
            if len(x) < old.n_components:
                raise ValueError(
                    f"IntentionLikelihoodLearner.partial_fit: need at least {old.n_components} "
                    f"samples, got {len(x)}"
                )
            gmm = GaussianMixture(
                old.n_components,
                covariance_type="full",
                reg_covar=self.reg_covar,
                max_iter=5,
                weights_init=old.weights_,
                means_init=old.means_,
                precisions_init=old.precisions_,
                random_state=self.random_state,
            )
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # few EM steps on purpose: not converged is fine
                updated.append(gmm.fit(x))
        self.gmm4d_, self.gmm2d_ = updated
        self.n_samples_seen_ += len(phi)
        self._make_model()
        return self

    def _make_model(self) -> None:
        self.model_ = IntentionModel(
            GaussianMixtureDensity.from_sklearn(self.gmm4d_),
            GaussianMixtureDensity.from_sklearn(self.gmm2d_),
            self.window,
            self.min_speed,
            {
                "n_components_4d": self.n_components_4d_,
                "n_components_2d": self.n_components_2d_,
                "heldout_scores_4d": {str(k): v for k, v in self.heldout_scores_4d_.items()},
                "heldout_scores_2d": {str(k): v for k, v in self.heldout_scores_2d_.items()},
                "n_samples": int(self.n_samples_seen_),
            },
            self.significance,
        )

    def score_samples(self, phi: np.ndarray) -> np.ndarray:
        """log L_GMM4d(Phi) per sample (M,)."""
        return self.model_.gmm4d.log_density(
            _check_samples(phi, 4, "IntentionLikelihoodLearner.score_samples")
        )
