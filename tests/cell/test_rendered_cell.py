"""A scenario chooses the rendered depth camera (issue 15 item 1): typed config and its checks,
the replay's markers of what the depth image hid, and (slow) the PCB cell with it."""

import base64
import re
import warnings

import msgpack  # installed with dask.distributed: reads the replay's messages
import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import Simulator

from hrc_drake.cell.replay import ReplayMarkers
from hrc_drake.cell.scenario import ScenarioError, load_scenario
from hrc_drake.cli import EXIT_BAD_INPUT, main
from hrc_drake.human.config import AnalyticDepthCamera, RenderedDepthCamera
from hrc_drake.messages import L_WRIST, R_WRIST, DepthFrame
from hrc_drake.systems import get_state
from tests.cell.system_examples import _markers_inputs, _scenario
from tests.conftest import DIAGRAMS

RENDERED = DIAGRAMS / "pcb_occlusion_rendered.yaml"


def _extending(tmp_path, sensor: str):
    (tmp_path / "base.yaml").write_text((DIAGRAMS / "pcb_occlusion.yaml").read_text())
    path = tmp_path / "cell.yaml"
    path.write_text(f"extends: base.yaml\nlayout:\n  camera:\n    sensor: {sensor}\n")
    return path


def test_the_rendered_scenario_only_switches_the_camera():
    rendered, analytic = load_scenario(RENDERED), load_scenario(DIAGRAMS / "pcb_occlusion.yaml")
    assert isinstance(rendered.layout.camera.sensor, RenderedDepthCamera)
    assert isinstance(analytic.layout.camera.sensor, AnalyticDepthCamera)  # the default
    rendered.layout.camera.sensor = AnalyticDepthCamera()
    rendered.description = analytic.description
    assert rendered == analytic
    header = RENDERED.read_text().split("\nextends")[0]
    assert "# Safety:" in header


@pytest.mark.parametrize("sensor, field", [
    ("!RenderedDepthCamera {wrong_surface_probability: 1.5}",
     "layout.camera.sensor.wrong_surface_probability"),
    ("!RenderedDepthCamera {width: 0}", "layout.camera.sensor.width"),
    ("!RenderedDepthCamera {height: 100000}", "layout.camera.sensor.height"),
    ("!RenderedDepthCamera {fov_x: 180}", "layout.camera.sensor.fov_x"),
    ("!RenderedDepthCamera {min_depth: 3.0, max_depth: 2.0}", "layout.camera.sensor.max_depth"),
    ("!RenderedDepthCamera {depth_tolerance: -0.1}", "layout.camera.sensor.depth_tolerance"),
    ("!RenderedDepthCamera {jitter_exponent: .nan}", "layout.camera.sensor.jitter_exponent"),
    ("!RenderedDepthCamera {wrong_surface_pixels: 1.5}", "layout.camera.sensor.wrong_surface_pixels"),
    ("!RenderedDepthCamera {widht: 64}", "layout.camera.sensor.widht"),
    ("!Kinect {}", "layout.camera.sensor"),
    ("{width: 64}", "layout.camera.sensor"),
])
def test_bad_camera_sensors_are_refused_by_load_and_validate(sensor, field, tmp_path, capsys):
    path = _extending(tmp_path, sensor)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    assert err.value.field == field
    assert main(["validate", str(path)]) == EXIT_BAD_INPUT
    assert field in capsys.readouterr().err


def test_a_recorded_skeleton_cannot_use_the_rendered_camera(tmp_path):
    path = _extending(tmp_path, "!RenderedDepthCamera {}")
    path.write_text(path.read_text() + "operator: {recorded: skeleton.csv}\n")
    with pytest.raises(ScenarioError, match="synthetic operator") as err:
        load_scenario(path)
    assert err.value.field == "layout.camera.sensor"


def shown_in_recording(html: str) -> dict[str, list]:
    """Path -> its recorded (time, visible) keys, from a replay's set_animation message."""
    shown = {}
    for blob in re.findall(r"base64,([A-Za-z0-9+/=]+)", html):
        data = base64.b64decode(blob)
        if b"set_animation" not in data:
            continue
        for animation in msgpack.unpackb(data, strict_map_key=False)["animations"]:
            for track in animation["clip"]["tracks"]:
                if track["name"] == ".visible":
                    shown[animation["path"]] = [(key["time"], key["value"]) for key in track["keys"]]
    return shown


def _recorded_markers(depth: DepthFrame):
    """The replay of ReplayMarkers run 0.3 s on the markers' example inputs and `depth`."""
    meshcat = Meshcat()
    markers = ReplayMarkers(_scenario(), meshcat, fps=10.0, show_skeleton=True, show_swept=False)
    context = markers.CreateDefaultContext()
    inputs = _markers_inputs("tray", 1, 1.0, 1.05)
    for name in ("world", "skeleton_frame", "skeleton_estimate", "intention_events", "speed_override"):
        value = inputs[name]
        markers.GetInputPort(name).FixValue(
            context, np.asarray(value, float) if name == "speed_override" else AbstractValue.Make(value))
    markers.GetInputPort("depth_frame").FixValue(context, AbstractValue.Make(depth))
    simulator = Simulator(markers, context)
    meshcat.StartRecording(10.0, False)
    simulator.Initialize()
    simulator.AdvanceTo(0.3)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    return markers, context, shown_in_recording(meshcat.StaticHtml())


def test_the_replay_shows_the_points_the_depth_image_hid():
    """Hidden and lost: a dark marker at the true point; jumped to a wrong surface: a magenta
    one where it was measured; no such marker for the points the image shows."""
    truth = np.full((8, 3), 1.0)
    hidden = np.zeros(8, dtype=bool)
    hidden[[L_WRIST, R_WRIST]] = True
    wrong = np.zeros(8, dtype=bool)
    wrong[R_WRIST] = True
    markers, context, shown = _recorded_markers(
        DepthFrame(time=0.0, hidden=hidden, wrong_surface=wrong, true_points=truth))
    now = get_state(context, markers._markers).shown
    assert f"/markers/skeleton/untracked/{L_WRIST}" in now
    assert f"/markers/skeleton/wrong_surface/{R_WRIST}" in now
    assert not any(f"/markers/skeleton/untracked/{k}" in now for k in range(8) if k != L_WRIST)
    assert not any(f"/markers/skeleton/wrong_surface/{k}" in now for k in range(8) if k != R_WRIST)
    # the recording turns them on (they start hidden)
    assert shown[f"/markers/skeleton/untracked/{L_WRIST}"][-1][1] is True
    assert shown[f"/markers/skeleton/wrong_surface/{R_WRIST}"][-1][1] is True
    # nothing hidden: no marker of the depth image is ever shown
    _, _, shown = _recorded_markers(DepthFrame(time=0.0, hidden=np.zeros(8, bool), true_points=truth))
    assert not any("untracked" in path or "wrong_surface" in path for path in shown)


@pytest.mark.slow
def test_the_pcb_cell_runs_with_the_rendered_camera_and_its_replay_shows_untracked_points():
    """10 s of diagrams/pcb_occlusion_rendered.yaml with the particle filter: the depth image
    hides points (the shelves, the robot, the body), the tracker follows them, the replay
    records their markers."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate

    scenario = load_scenario(RENDERED)
    meshcat = Meshcat()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cell = build_cell(scenario, RENDERED, meshcat=meshcat, replay_fps=10.0)
    camera, tracker = cell.system("depth_camera"), cell.system("tracker")
    hidden_seen, estimates = np.zeros(8, int), []

    def listen(frame, estimate):
        hidden_seen[:] += ~frame.tracked
        estimates.append(estimate)

    tracker.listeners.append(listen)
    result = simulate(cell, 10.0, progress=None, record=True)
    assert result.simulated_time == 10.0 and not result.interrupted
    depth = camera.GetOutputPort("depth_frame").Eval(camera.GetMyContextFromRoot(result.context))
    assert depth.depth.shape == (212, 256) and depth.time == pytest.approx(10.0 - 1 / 30, abs=0.04)
    assert hidden_seen.sum() > 10, hidden_seen  # untracked points occur
    assert len(estimates) >= 290 and all(np.all(np.isfinite(e.points)) for e in estimates[30:])
    shown = shown_in_recording(meshcat.StaticHtml())
    assert any("/markers/skeleton/untracked/" in path and any(v for _, v in keys)
               for path, keys in shown.items())
