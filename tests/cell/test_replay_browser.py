"""Render the self-contained replay in headless Chromium with networking off."""

import re
import shutil
import subprocess
import warnings

import numpy as np
import pytest

from hrc_drake.cli import main

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _chromium(profile, virtual_ms):
    return [
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
    ]


def screenshot(html, png, profile, virtual_ms):
    cmd = [*_chromium(profile, virtual_ms), f"--screenshot={png}", html.as_uri()]
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


def page_after(html, profile, virtual_ms) -> str:
    """The page's DOM after `virtual_ms` of virtual time (what the overlay's script wrote)."""
    cmd = [*_chromium(profile, virtual_ms), "--dump-dom", html.as_uri()]
    return subprocess.run(cmd, check=True, capture_output=True, timeout=180, text=True).stdout


def _clock(dom: str) -> float:
    match = re.search(r'id="hrc-clock">t = ([0-9.]+) s<', dom)
    assert match, "no simulated clock in the page"
    return float(match.group(1))


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it from Debian)")
def test_the_replay_names_its_run_shows_the_simulated_time_and_its_colours(tmp_path, diagrams_dir, capfd):
    """A replay explains itself: its title (scenario, seed, duration), a clock that follows the
    animation's time as it plays, and a legend of the colours (tracked points, goal flashes,
    swept volumes where the cell has them). A replay-only run announces no live server."""
    replay = tmp_path / "replay.html"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["simulate", str(diagrams_dir / "full_pipeline.yaml"), "--duration", "8", "--seed", "3",
                     "--replay", str(replay)]) == 0
    captured = capfd.readouterr()
    assert "listening for connections" not in captured.out + captured.err
    assert "localhost:" not in captured.out
    early = page_after(replay, tmp_path / "p1", 2000)
    late = page_after(replay, tmp_path / "p2", 5000)
    for dom in (early, late):
        assert "full_pipeline" in re.search(r'id="hrc-title"[^>]*>([^<]*)<', dom).group(1)
        subtitle = re.search(r'id="hrc-subtitle"[^>]*>([^<]*)<', dom).group(1)
        assert "seed 3" in subtitle and "8 s simulated" in subtitle
        legend = dom[dom.index('id="hrc-legend"'):]
        for label in ("measured by the camera", "estimate", "goal flash", "swept volumes", "speed lamp"):
            assert label in legend, label
    # the clock runs with the animation: later in virtual time, a later simulated time, within the run
    assert 0.0 <= _clock(early) < _clock(late) <= 8.0
    assert "<title>full_pipeline (seed 3)" in early
