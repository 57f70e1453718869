"""Searches over cells (`hrc-drake search`): Optuna's samplers propose scenario overrides, the
campaign engine runs them (`search.engine`); falsification and optimisation presets."""
