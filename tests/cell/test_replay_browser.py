"""Render the self-contained replay in headless Chromium with networking off."""

import shutil
import subprocess
import warnings

import numpy as np
import pytest

from hrc_drake.cli import main

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def screenshot(html, png, profile, virtual_ms):
    cmd = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--enable-unsafe-swiftshader",
        "--use-angle=swiftshader",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--proxy-server=127.0.0.1:9",
        "--proxy-bypass-list=<-loopback>",
        f"--user-data-dir={profile}",
        "--window-size=900,700",
        f"--virtual-time-budget={virtual_ms}",
        f"--screenshot={png}",
        html.as_uri(),
    ]
    subprocess.run(cmd, check=True, capture_output=True, timeout=180)
    import matplotlib.image

    return matplotlib.image.imread(str(png))[..., :3]


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it from Debian)")
def test_replay_renders_and_moves(tmp_path, diagrams_dir):
    replay = tmp_path / "replay.html"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert (
            main(
                [
                    "simulate",
                    str(diagrams_dir / "torch_clock.yaml"),
                    "--duration",
                    "14",
                    "--replay",
                    str(replay),
                ]
            )
            == 0
        )
    early = screenshot(replay, tmp_path / "early.png", tmp_path / "p1", 1500)
    late = screenshot(replay, tmp_path / "late.png", tmp_path / "p2", 11000)
    for image in (early, late):
        assert image.std() > 0.05, "the replay rendered a blank page"
    changed = np.abs(early - late).sum(axis=-1) > 0.1
    assert changed.mean() > 0.005, f"only {changed.mean():.4f} of the pixels changed between 1.5 s and 11 s"
