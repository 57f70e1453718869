"""Typed configs of the intended-goal estimator, one dataclass per kind (thesis 3.1).

A scenario's `intention` field is `NoIntention` or `GmmBayesIntention`;
`intention.systems.apply_intention_config` builds the system. The defaults reproduce the
estimator of `diagrams/box_usb.yaml` (method M3 with the shipped model, threshold 0.8).
No pydrake here, and real annotations (pydrake's typed YAML loader reads them).
"""

import math
from dataclasses import dataclass, field

from hrc_drake.errors import check

#: Methods of Table 3.1.
METHODS = ("M1", "M2", "M3")
#: How a perceived action ends (`detector.GoalRegionDetector.end_rule`).
END_RULES = ("exit", "next", "next_merging_reentries")
#: Hands whose goals the feedback may announce.
HANDS = ("left", "right")
#: Highest update rate of a Python system (DESIGN.md, performance rules).
MAX_RATE = 50.0
#: How the segmenter makes Phi_OjY of eq. (4.1) (`segmentation.OBSERVATION_POTENTIALS`).
OBSERVATION_POTENTIALS = ("counts", "per_action_frequencies")


def _unit(value, path: str, name: str, low_open: bool = False) -> None:
    ok = math.isfinite(value) and (0.0 < value if low_open else 0.0 <= value) and value <= 1.0
    check(ok, f"{path}.{name}", f"must be in {'(' if low_open else '['}0, 1], got {value!r}")


@dataclass
class NoIntention:
    """No intention estimator in the cell."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class GmmBayesIntention:
    """Per-hand goal probabilities by recursive Bayes over learned GMM likelihoods (thesis 3.1.2,
    eq. 3.2) and the "robot understood" feedback of Fig. 3.6."""

    #: Method of Table 3.1: "M1" ([135], angle to a minimum-jerk reach, eq. 3.1), "M2" (GMM2d on
    #: Psi only) or "M3" (GMM4d on Phi while the gaze flag F holds, GMM2d otherwise).
    method: str = "M3"
    #: Probability a goal must reach for the feedback "the robot understood" (Fig. 3.6).
    threshold: float = 0.8
    #: Probability below which a goal's feedback is re-armed (no feedback sequence only).
    release: float = 0.5
    #: Update rate of the estimator (Hz), at most 50.
    rate: float = 30.0
    #: Learned `IntentionModel` (JSON) relative to the scenario file; "" for the shipped model.
    model: str = ""
    #: Goal names of the cyclic feedback machine of Fig. 3.6 (e.g. [G4, G1]); empty: feedback
    #: at every rise of a goal's probability to `threshold`.
    feedback_sequence: list[str] = field(default_factory=list)
    #: Hands whose goals the feedback announces ("left", "right").
    feedback_hands: list[str] = field(default_factory=lambda: ["left", "right"])
    #: Standard deviation of each goal centre C_i (m); with n_goal_samples > 0 the likelihood is
    #: averaged over sampled centres, eq. (3.12).
    goal_std: float = 0.0
    #: Np, sampled centres per goal of eq. (3.12); 0 uses the centres themselves.
    n_goal_samples: int = 0
    #: Probability per update that the intended goal changes (Markov prediction step).
    switch_probability: float = 0.02
    #: The same probability at the first update of a motion after a pause of restart_after s.
    restart_switch: float = 0.5
    #: Pause (s) after which a hand's next motion is a new reach.
    restart_after: float = 0.25
    #: Exponent w of the likelihoods in eq. (3.2), in (0, 1]; 0: the model's own (learned with it).
    evidence_weight: float = 0.0
    #: sigma of the angle likelihood of M1, eq. (3.1) (rad).
    m1_sigma: float = 0.6
    #: Mean hand speed of M1's nominal reach duration |C_i - p_s| / speed (m/s).
    m1_mean_speed: float = 0.4

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the estimator cannot use."""
        check(self.method in METHODS, f"{path}.method", f"must be one of {METHODS}, got {self.method!r}")
        _unit(self.threshold, path, "threshold", low_open=True)
        check(math.isfinite(self.release) and 0.0 <= self.release < self.threshold, f"{path}.release",
              f"must be in [0, threshold), got {self.release!r}")
        check(math.isfinite(self.rate) and 0.0 < self.rate <= MAX_RATE, f"{path}.rate",
              f"must be in (0, {MAX_RATE:g}] Hz, got {self.rate!r}")
        check(isinstance(self.model, str), f"{path}.model", "must be a file path (a string)")
        for k, goal in enumerate(self.feedback_sequence):
            check(isinstance(goal, str) and goal != "", f"{path}.feedback_sequence[{k}]",
                  f"must be a goal name, got {goal!r}")
        check(len(self.feedback_hands) > 0, f"{path}.feedback_hands", "needs at least one hand")
        for k, hand in enumerate(self.feedback_hands):
            check(hand in HANDS, f"{path}.feedback_hands[{k}]", f"must be one of {HANDS}, got {hand!r}")
        check(math.isfinite(self.goal_std) and self.goal_std >= 0, f"{path}.goal_std",
              f"must be a finite number >= 0, got {self.goal_std!r}")
        check(isinstance(self.n_goal_samples, int) and 0 <= self.n_goal_samples <= 10000,
              f"{path}.n_goal_samples", f"must be an integer in [0, 10000], got {self.n_goal_samples!r}")
        _unit(self.switch_probability, path, "switch_probability")
        _unit(self.restart_switch, path, "restart_switch")
        check(math.isfinite(self.restart_after) and self.restart_after >= 0, f"{path}.restart_after",
              f"must be a finite number >= 0, got {self.restart_after!r}")
        _unit(self.evidence_weight, path, "evidence_weight")
        for name in ("m1_sigma", "m1_mean_speed"):
            value = getattr(self, name)
            check(math.isfinite(value) and value > 0, f"{path}.{name}", f"must be > 0, got {value!r}")


#: Every intention kind a scenario can choose.
IntentionConfig = NoIntention | GmmBayesIntention


@dataclass
class NoActionDetector:
    """No action detector in the cell: nothing perceives the operator's actions."""

    def validate(self, path: str) -> None:
        """Nothing to check."""


@dataclass
class GoalRegionActionDetector:
    """Actions perceived from the hands entering and leaving their goal regions G_a (thesis Ch. 2
    preamble: spheres of centre C_a and radius r_a), with the hysteresis, minimum dwell and
    lost-point rules of `intention.detector.GoalRegionDetector`."""

    #: A wrist enters G_a within entry_scale * r_a of C_a.
    entry_scale: float = 1.0
    #: It leaves only beyond exit_scale * r_a (>= entry_scale): the hysteresis band.
    exit_scale: float = 1.3
    #: Seconds a wrist must stay before an entry is an action (a hand passing through is not).
    min_dwell: float = 0.2
    #: Largest spread (m) of a wrist estimate still used; a larger one is a lost point.
    max_spread: float = 0.1
    #: Seconds a wrist may stay lost inside a region before its action ends (at the loss).
    lost_timeout: float = 2.0
    #: Update rate (Hz), at most 50: the camera's, normally.
    rate: float = 30.0
    #: How an action ends: "exit" (the last hand leaves its region) or "next" (the next action
    #: begins, a new entry into the same region included: for actions that take a part at their
    #: region and go on elsewhere); "next_merging_reentries", our earlier variant, lets a
    #: re-entry continue the action (it misses consecutive repeats of one action).
    end_rule: str = "exit"

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the detector cannot use."""
        check(self.end_rule in END_RULES, f"{path}.end_rule",
              f"must be one of {', '.join(END_RULES)}, got {self.end_rule!r}")
        check(math.isfinite(self.entry_scale) and 0.0 < self.entry_scale <= 10.0, f"{path}.entry_scale",
              f"must be in (0, 10], got {self.entry_scale!r}")
        check(math.isfinite(self.exit_scale) and self.entry_scale <= self.exit_scale <= 10.0,
              f"{path}.exit_scale", f"must be in [entry_scale, 10], got {self.exit_scale!r}")
        check(math.isfinite(self.min_dwell) and 0.0 <= self.min_dwell <= 60.0, f"{path}.min_dwell",
              f"must be in [0, 60] s, got {self.min_dwell!r}")
        check(math.isfinite(self.max_spread) and 0.0 < self.max_spread <= 10.0, f"{path}.max_spread",
              f"must be in (0, 10] m, got {self.max_spread!r}")
        check(math.isfinite(self.lost_timeout) and 0.0 < self.lost_timeout <= 600.0,
              f"{path}.lost_timeout", f"must be in (0, 600] s, got {self.lost_timeout!r}")
        check(math.isfinite(self.rate) and 0.0 < self.rate <= MAX_RATE, f"{path}.rate",
              f"must be in (0, {MAX_RATE:g}] Hz, got {self.rate!r}")


@dataclass
class SegmenterActionDetector:
    """Actions perceived by the segmenter of thesis 4.1 (`intention.segmentation.Segmenter`):
    windows of the skeleton estimate, a variable-structure MRF per segmentation hypothesis, a
    genetic algorithm, the sliding window of 4.1.4. Before the run it learns from a library of
    the operator's own actions: `training_cycles` cycles of the scenario's pattern performed by a
    synthetic operator of its own seed and anthropometrics, recorded at `rate` with the camera's
    noise (4.1.5's "library of recorded human motions"); the precedence constraints are the
    pattern's order."""

    #: l_w, the length of an observation window (s; 400 ms in 4.2).
    window: float = 0.4
    #: L, observation windows per segmentation (30 in 4.2).
    batch_windows: int = 30
    #: o, the order of the sequence potentials (4.2); 1 keeps the chain a tree (exact MAP).
    order: int = 1
    #: Values of each discretised feature (the ECDF bins of Fig. 4.3).
    n_bins: int = 5
    #: Genetic algorithm (4.1.3): individuals per generation and generations per segmentation.
    population: int = 24
    generations: int = 20
    #: Cycles of the operator's pattern recorded for the library before the run.
    training_cycles: int = 8
    #: The library's operator is another person: arms (upper arm, forearm) and shoulder width
    #: scaled by these factors from the scenario's operator (4.2 trains on other volunteers).
    library_arm_scale: float = 1.08
    library_shoulder_scale: float = 1.05
    #: Rate at which skeleton estimates are sampled (Hz), at most 50: 25 Hz is the 40 ms sampling
    #: time of 4.2, so a window of 400 ms holds 10 samples.
    rate: float = 25.0
    #: Phi_OjY of eq. (4.1): "counts", the times the pair (Ô_j, Y) occurs in the library (4.1.1),
    #: or "per_action_frequencies", our variant: the counts divided by the action's library windows
    #: (every action's potentials on one scale, however long or often it was recorded).
    observation_potential: str = "counts"

    def validate(self, path: str) -> None:
        """Raise `ConfigError` naming `path.field` for a value the segmenter cannot use."""
        check(math.isfinite(self.rate) and 0.0 < self.rate <= MAX_RATE, f"{path}.rate",
              f"must be in (0, {MAX_RATE:g}] Hz, got {self.rate!r}")
        check(math.isfinite(self.window) and 1.0 / self.rate <= self.window <= 10.0, f"{path}.window",
              f"must be in [1 / rate, 10] s, got {self.window!r}")
        check(self.observation_potential in OBSERVATION_POTENTIALS, f"{path}.observation_potential",
              f"must be one of {', '.join(OBSERVATION_POTENTIALS)}, got {self.observation_potential!r}")
        for name in ("library_arm_scale", "library_shoulder_scale"):
            value = getattr(self, name)
            check(math.isfinite(value) and 0.5 <= value <= 2.0, f"{path}.{name}",
                  f"must be in [0.5, 2], got {value!r}")
        for name, low, high in (("batch_windows", 2, 1000), ("order", 1, 5), ("n_bins", 2, 50),
                                ("population", 2, 1000), ("generations", 1, 1000),
                                ("training_cycles", 1, 1000)):
            value = getattr(self, name)
            check(isinstance(value, int) and not isinstance(value, bool) and low <= value <= high,
                  f"{path}.{name}", f"must be an integer in [{low}, {high}], got {value!r}")


#: Every action-detector kind a scenario can choose.
ActionDetectorConfig = NoActionDetector | GoalRegionActionDetector | SegmenterActionDetector
