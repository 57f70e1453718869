"""Where the real recordings are: the repository's `data/` folder (each set with its source's
LICENSE and a README of provenance), or the folder `$HRC_DRAKE_DATA` (or a `--data` option) names,
laid out the same way (`lego_assembly_arm/`, `real/kth_handover/`, `real/ue_adl/`): other
participants of a set can then be checked without changing a line."""

from __future__ import annotations

import os
from pathlib import Path

#: the environment variable naming another data folder
DATA_VARIABLE = "HRC_DRAKE_DATA"
#: the data shipped with the repository (a source checkout; a wheel has none)
REPOSITORY_DATA = Path(__file__).resolve().parents[1] / "data"
#: the recordings and where each lies under a data folder
DATASETS = {"lego_assembly_arm": "lego_assembly_arm", "kth_handover": "real/kth_handover",
            "ue_adl": "real/ue_adl"}


def data_root(override: str | Path | None = None) -> Path:
    """The data folder: `override`, else $HRC_DRAKE_DATA, else the repository's `data/`."""
    if override:
        return Path(override).expanduser()
    env = os.environ.get(DATA_VARIABLE)
    return Path(env).expanduser() if env else REPOSITORY_DATA


def dataset_dir(name: str, override: str | Path | None = None) -> Path:
    """The folder of recording set `name` (`DATASETS`); FileNotFoundError saying where it looked."""
    if name not in DATASETS:
        raise KeyError(f"unknown data set {name!r}; known: {sorted(DATASETS)}")
    path = data_root(override) / DATASETS[name]
    if not path.is_dir():
        raise FileNotFoundError(f"no {name} recordings at {path}: point ${DATA_VARIABLE} (or --data) at a "
                                f"folder laid out like {REPOSITORY_DATA}")
    return path
