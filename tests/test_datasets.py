"""The real recordings ship with the repository (issue 37): found without anything beside it,
or in the folder $HRC_DRAKE_DATA names."""

from __future__ import annotations

import pytest

from hrc_drake.datasets import DATASETS, REPOSITORY_DATA, data_root, dataset_dir
from tests.conftest import REPO


def test_the_repository_ships_every_set_with_its_licence(monkeypatch):
    monkeypatch.delenv("HRC_DRAKE_DATA", raising=False)
    assert data_root() == REPOSITORY_DATA == REPO / "data"
    for name in DATASETS:
        folder = dataset_dir(name)
        assert (folder / "LICENSE").is_file(), name
        assert "MIT" in (folder / "LICENSE").read_text()
    assert len(list(dataset_dir("lego_assembly_arm").glob("Task*/Human*/trial*.txt"))) == 20


def test_another_folder_laid_out_the_same_way_is_used_instead(tmp_path, monkeypatch):
    (tmp_path / "real" / "ue_adl").mkdir(parents=True)
    monkeypatch.setenv("HRC_DRAKE_DATA", str(tmp_path))
    assert dataset_dir("ue_adl") == tmp_path / "real" / "ue_adl"
    with pytest.raises(FileNotFoundError, match="no kth_handover recordings at .*HRC_DRAKE_DATA"):
        dataset_dir("kth_handover")
    assert dataset_dir("kth_handover", override=REPOSITORY_DATA).is_dir()  # --data wins
    with pytest.raises(KeyError, match="unknown data set"):
        dataset_dir("mocap")
