"""The old spelling of a scenario's optional systems (`kind` + a flat `params` dict), translated
to the typed configs for one purpose: a file in the old spelling is refused with an error that
shows its new spelling (`new_spelling`). Nothing builds a cell from the old spelling.
"""

from __future__ import annotations

import dataclasses

from hrc_drake.errors import ConfigError


def _typed(cls, params: dict, field: str, renames: dict | None = None):
    """A config of `cls` from a flat params dict of numbers, cast to the field types."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    values = {}
    for key, value in params.items():
        name = (renames or {}).get(key, key)
        if name not in fields:
            raise ConfigError(f"{field}.params.{key}", f"unknown parameter; known: {sorted(fields)}")
        kind = fields[name].type
        if kind in (bool, "bool"):
            values[name] = bool(value)
        elif kind in (int, "int"):
            if float(value) != int(float(value)):
                raise ConfigError(f"{field}.params.{key}", f"must be an integer, got {value!r}")
            values[name] = int(float(value))
        elif kind in (float, "float"):
            values[name] = float(value)
        else:
            values[name] = value
    return cls(**values)


def _tracker(kind: str, params: dict):
    from hrc_drake.perception.config import KalmanTracker, NoTracker, ParticleFilterTracker

    renames = {"threshold": "slow_down_threshold", "slow": "slow_factor"}
    if kind == "none":
        return [("tracker", NoTracker())]
    if kind == "kalman":
        # the old flat dict accepted the particle filter's keys for the Kalman filter; they did nothing
        for key in ("particles", "crown", "systematic", "bootstrap_tracked", "calibration_frames", "gate"):
            params.pop(key, None)
        return [("tracker", _typed(KalmanTracker, params, "tracker", renames))]
    if kind == "particle_filter":
        params.pop("confidence", None)
        return [("tracker", _typed(ParticleFilterTracker, params, "tracker", renames))]
    raise ConfigError("tracker.kind", f"unknown kind {kind!r}")


def _intention(kind: str, params: dict, raw: dict):
    from hrc_drake.intention.config import GmmBayesIntention, NoIntention

    if kind == "none":
        return [("intention", NoIntention())]
    if kind != "gmm":
        raise ConfigError("intention.kind", f"unknown kind {kind!r}")
    config = _typed(GmmBayesIntention, params, "intention")
    config.model = str(raw.get("model", "") or "")
    config.feedback_sequence = [str(n) for n in raw.get("names", []) or []]
    return [("intention", config)]


def _motion(kind: str, params: dict):
    from hrc_drake.motion.config import (
        GPMotionModel,
        NoMotionModel,
        SeparationSpeedScaling,
        WorstCaseMotionModel,
    )

    if kind == "none":
        return [("motion_model", NoMotionModel())]
    scaler_keys = {f.name for f in dataclasses.fields(SeparationSpeedScaling)}
    scaling = _typed(SeparationSpeedScaling, {k: v for k, v in params.items() if k in scaler_keys}, "speed")
    model = {k: v for k, v in params.items() if k not in scaler_keys}
    if kind == "worst_case":
        gp_only = {f.name for f in dataclasses.fields(GPMotionModel)} - {
            f.name for f in dataclasses.fields(WorstCaseMotionModel)
        }
        config = _typed(WorstCaseMotionModel, {k: v for k, v in model.items() if k not in gp_only}, "motion")
    elif kind in ("gp_a", "gp_b", "gp_c"):
        config = _typed(GPMotionModel, model, "motion_model")
        config.variant = kind[-1].upper()
    else:
        raise ConfigError("motion_model.kind", f"unknown kind {kind!r}")
    return [("motion_model", config), ("speed_scaling", scaling)]


def _kinds():
    """The old kind names of the predictor and scheduler -> their config classes."""
    from hrc_drake.prediction import config as prediction
    from hrc_drake.scheduling import config as scheduling

    predictors = {
        "none": prediction.NoPredictor,
        "homm": prediction.HigherOrderMarkovPredictor,
        "markov": prediction.MarkovChainPredictor,
        "ching": prediction.ChingPredictor,
        "vomm": prediction.VariableOrderMarkovPredictor,
        "suffix_tree": prediction.SuffixTreePredictor,
    }
    schedulers = {
        "none": scheduling.NoScheduler,
        "round_robin": scheduling.RoundRobinScheduler,
        "greedy": scheduling.RandomEnabledScheduler,  # old kind names, kept so old files load
        "deterministic": scheduling.BestOfRolloutsPlanScheduler,
        "monte_carlo": scheduling.MonteCarloScheduler,
    }
    return {"predictor": predictors, "scheduler": schedulers}


def translate(field: str, raw: dict) -> list[tuple[str, object]]:
    """(scenario field, typed config) pairs that an old-spelling mapping of `field` stands for."""
    kind = str(raw.get("kind", "none"))
    params = dict(raw.get("params", {}) or {})
    if field == "tracker":
        return _tracker(kind, params)
    if field == "intention":
        return _intention(kind, params, raw)
    if field == "motion_model":
        return _motion(kind, params)
    if field in ("predictor", "scheduler"):
        kinds = _kinds()[field]
        if kind not in kinds:
            raise ConfigError(f"{field}.kind", f"unknown kind {kind!r} (one of {sorted(kinds)})")
        return [(field, _typed(kinds[kind], params, field))]
    raise ConfigError(field, "not a system field")


def spell(config, tagged: bool = True) -> str:
    """The YAML of a config: its tag and the fields that differ from the defaults."""
    default = type(config)()
    changed = {
        f.name: getattr(config, f.name)
        for f in dataclasses.fields(config)
        if getattr(config, f.name) != getattr(default, f.name)
    }
    body = ", ".join(f"{k}: {_yaml_value(v)}" for k, v in changed.items())
    return (f"!{type(config).__name__} " if tagged else "") + f"{{{body}}}"


def _yaml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value if value and value.replace("_", "").isalnum() else repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_yaml_value(v)}" for k, v in value.items()) + "}"
    return repr(value)


def new_spelling(field: str, raw: dict) -> str:
    """The lines replacing an old-spelling `field: {kind: ..., params: ...}` (or the reason it
    cannot be translated)."""
    try:
        pairs = translate(field, raw)
    except (ConfigError, TypeError, ValueError) as err:
        return f"(cannot translate: {err})"
    return "; ".join(f"{name}: {spell(config, tagged=name != 'speed_scaling')}" for name, config in pairs)
