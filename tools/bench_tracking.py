"""Benchmark of the occlusion-aware skeleton tracker (thesis Ch. 9, issue 3).

Parts:
  speed  one particle-filter update, 8 points x 500 particles (median, ms), on synthetic frames
         with a wrist hidden behind a box and with everything seen; default mode (Kalman
         sampling of seen points) and the literal bootstrap mode;
  cell   diagrams/pcb_occlusion.yaml (thesis 9.1.3) simulated in Drake with the particle filter
         and with the Kalman baseline, N robot cycles each (a cycle: from one L_carry begin to
         the next, Fig. 9.7): (a) errors of the points the camera lost, PF vs KF (the KF both on
         the PF run's very frames, run alongside, and in its own run); which points were lost,
         why, and in which case of 9.1.2; (Fig. 9.7) robot cycle-time distributions, the true
         minimum human-robot distance vs the scenario's safety distance, time spent slowed;
  compare (issue 15 item 3, Fig. 9.7) the thesis's metric for every tracker x camera, through
         the campaign API (diagrams/campaigns/trackers.yaml: seeds x 120 s per cell):
         trackers hold (HoldLastSeenTracker: a lost point stays where last seen), kf2 / kf4
         (KalmanTracker order 2 / 4, kf4 the thesis's open loop), pf (the particle filter),
         each driving the slow-down rule of 9.1.3; cameras analytic (pcb_occlusion.yaml) and
         rendered (pcb_occlusion_rendered.yaml). Per cell: robot cycle time (one L_carry begin
         to the next, the extra column robot_cycles.times; mean over all cycles of all seeds),
         share of the 0.1 s samples whose true distance is under the safety distance
         (safety.fraction_below, mean over seeds) and the true minimum distance (min over
         seeds). "pf has shorter cycles than kf4 / kf2": one-sided Mann-Whitney rank-sum test
         (campaign.analysis.rank_sum_test) on the pooled robot cycles of the two cells;
  regions coverage of hidden points by each tracker's belief region (perception.regions), from
         the cell runs above (analytic camera, one run per tracker, every frame where the
         camera lost a point that the tracker has seen before): pf the particles inflated by
         0.02 m (union of balls, all 500 particles); kf2 / kf4 the 95 % covariance
         ellipsoid; hold a ball of 0.02 m around the held point. Next to the coverage the
         region's mean volume (coverage alone rewards huge regions) and its equal-volume ball
         radius. On the pf run's very frames also: the 95 % ellipsoid of the particles' own
         mean and covariance (pf_ellipsoid), and a ball around the last seen point with the
         pf region's volume in that frame (hold_at_pf_volume: the same size, another place);
  render ms per depth frame of the rendered camera (issue 15) in the PCB cell, at the
         scenario's resolution and the Kinect v2's 512 x 424;
  lego   RMS error of occluded points, PF vs KF, on the real arm trajectories of
         data/lego_assembly_arm with synthetic occluder boxes hiding the wrist and/or
         the elbow for 1-3 s (frame rate unknown: 30 Hz assumed).

Usage: python tools/bench_tracking.py [--quick | --smoke] [--cycles N] [--seeds N] [--duration S]
       [--workers N] [--elbow-occluders]
--smoke: every part once in this process on the smallest setting (the cell runs cut at 1 s of
simulated time, 1 s comparison runs, one frame, one lego window; figures meaningless; the tests
run it).
Last line: one JSON object with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from hrc_drake.datasets import data_root  # noqa: E402
from hrc_drake.messages import (  # noqa: E402
    L_ELBOW,
    L_SHOULDER,
    L_WRIST,
    R_ELBOW,
    R_SHOULDER,
    R_WRIST,
    SKELETON_POINTS,
    SkeletonFrame,
)
from hrc_drake.perception.geometry import BoxOcclusion  # noqa: E402
from hrc_drake.perception.particle_filter import SkeletonParticleFilter  # noqa: E402
from hrc_drake.perception.regions import (  # noqa: E402
    PARTICLE_RADIUS,
    REGION_MASS,
    ellipsoid_volume,
    in_ellipsoid,
)
from hrc_drake.perception.synthetic import reaching_sequence  # noqa: E402
from hrc_drake.perception.tracker import SkeletonTracker  # noqa: E402

RATE = 30.0
CAMERA = np.array([-0.2, 0.0, 1.7])
OCCLUDER = ([0.5, 0.27, 1.09], [0.05, 0.14, 0.16])
REST, BEHIND = np.array([0.8, 0.25, 1.0]), np.array([0.6, 0.3, 1.0])
WS_CENTER, WS_SIZE = np.array([0.2, 0.1, 1.0]), np.array([0.5, 0.8, 0.6])


def data_dir() -> Path:
    """The real recordings: the repository's data/, or $HRC_DRAKE_DATA (`hrc_drake.datasets`)."""
    return data_root()


def rms(errors) -> float:
    e = np.concatenate(errors) if errors else np.zeros(0)
    return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")


# ----------------------------------------------------------------------------- speed
def bench_speed(n_steps: int) -> dict:
    """Median update time on the frames of a reach behind the occluder where a point is hidden
    (label case1: the wrist), and on frames where all points are seen."""
    rng = np.random.default_rng(0)
    _, truth = reaching_sequence([REST, BEHIND, REST], [1.0, 1.0], torso_dir=(-1, 0, 0), dwell=1.0)
    occ = BoxOcclusion(CAMERA, [OCCLUDER])
    hidden = occ(truth)
    out = {}
    for mode in ("kalman", "bootstrap"):
        pf = SkeletonParticleFilter(500, dt=1 / RATE, rng=1, tracked_update=mode)
        occluded_ms, seen_ms = [], []
        k = 0
        while len(occluded_ms) < n_steps:
            i = k % len(truth)
            pts = truth[i] + rng.normal(0, 0.01, (8, 3))
            pts[hidden[i]] = np.nan
            t0 = time.perf_counter()
            pf.step(pts, is_hidden=occ)
            (occluded_ms if hidden[i].any() else seen_ms).append(1000 * (time.perf_counter() - t0))
            k += 1
        out[f"occluded_{mode}"] = float(np.median(occluded_ms))
        out[f"seen_{mode}"] = float(np.median(seen_ms))
    return out


# ------------------------------------------------------------------ replay runs
def run_trackers(frames_pts, frames_seen, is_hidden_at, truth, seed, params=None):
    """Run PF and KF over a sequence; errors (m) of the occluded points of each frame."""
    errors = {"particle_filter": [], "kalman": []}
    for kind in errors:
        tracker = SkeletonTracker(kind, params, None, WS_CENTER, WS_SIZE, RATE, seed)
        for k in range(len(frames_pts)):
            tracker.is_hidden = is_hidden_at(k)
            est = tracker.update(SkeletonFrame(time=k / RATE, points=frames_pts[k], tracked=frames_seen[k]))
            hidden = ~frames_seen[k]
            if np.any(hidden):
                errors[kind].append(np.linalg.norm(est.points[hidden] - truth[k, hidden], axis=1))
    return errors


# ------------------------------------------------------------------------------ lego
def lego_skeleton(raw: np.ndarray) -> np.ndarray:
    """(T, 18) lego columns -> (T, 8, 3); thorax = mid-shoulders, head 0.25 m above (camera y down)."""
    pts = np.empty((len(raw), 8, 3))
    pts[:, L_WRIST], pts[:, R_WRIST] = raw[:, 0:3], raw[:, 3:6]
    pts[:, L_ELBOW], pts[:, R_ELBOW] = raw[:, 6:9], raw[:, 9:12]
    pts[:, L_SHOULDER], pts[:, R_SHOULDER] = raw[:, 12:15], raw[:, 15:18]
    pts[:, 0] = 0.5 * (pts[:, L_SHOULDER] + pts[:, R_SHOULDER])
    pts[:, 1] = pts[:, 0] + [0.0, -0.25, 0.0]
    return pts


def occluder_for(targets: np.ndarray) -> tuple:
    """A thin box between the camera (origin) and the target points (M, 3), covering them."""
    depth = 0.6 * targets[:, 2].min()
    proj = targets * (depth / targets[:, 2:3])
    lo, hi = proj.min(axis=0) - 0.02, proj.max(axis=0) + 0.02
    center = 0.5 * (lo + hi)
    size = hi - lo
    center[2], size[2] = depth, 0.02
    return center, size


def bench_lego(files_limit: int, windows_per_file: int) -> dict:
    root = data_dir() / "lego_assembly_arm"
    if not root.is_dir():
        print(f"  lego data not found at {root}: part skipped")
        return {"skipped": True}
    files = sorted(root.glob("Task*/Human*/trial*.txt"))[:files_limit]
    all_err = {"particle_filter": [], "kalman": []}
    by_case = {"wrist": [0, 0], "elbow": [0, 0], "both": [0, 0]}
    rng = np.random.default_rng(7)
    for f_i, path in enumerate(files):
        raw = np.loadtxt(path)
        raw = raw[np.all(np.isfinite(raw), axis=1)]
        skel = lego_skeleton(raw)
        for _w in range(windows_per_file):
            warm = int(2 * RATE)
            length = int(rng.uniform(1.0, 3.0) * RATE)
            if len(skel) < warm + length + 10:
                continue
            start = int(rng.integers(0, len(skel) - warm - length - 1))
            seq = skel[start : start + warm + length + 10]
            side = rng.choice(["left", "right"])
            case = rng.choice(["wrist", "elbow", "both"])
            wrist, elbow = (L_WRIST, L_ELBOW) if side == "left" else (R_WRIST, R_ELBOW)
            target = {"wrist": [wrist], "elbow": [elbow], "both": [wrist, elbow]}[case]
            stretch = slice(warm, warm + length)
            box = occluder_for(seq[stretch][:, target].reshape(-1, 3))
            occ_on, occ_off = BoxOcclusion(np.zeros(3), [box]), BoxOcclusion(np.zeros(3), [])
            hidden = np.zeros(seq.shape[:2], dtype=bool)
            hidden[stretch] = occ_on(seq[stretch])
            pts = seq.copy()
            pts[hidden] = np.nan

            def is_hidden_at(k, on=occ_on, off=occ_off, lo=warm, hi=warm + length):
                return on if lo <= k < hi else off

            errs = run_trackers(pts, ~hidden, is_hidden_at, seq, f_i)
            for kind in all_err:
                all_err[kind] += errs[kind]
            e_pf, e_kf = rms(errs["particle_filter"]), rms(errs["kalman"])
            if np.isfinite(e_pf):
                by_case[case][0] += 1
                by_case[case][1] += int(e_pf < e_kf)
        print(
            f"  lego file {f_i + 1}/{len(files)} {path.relative_to(root)}: running PF "
            f"{rms(all_err['particle_filter']):.3f} m, KF {rms(all_err['kalman']):.3f} m",
            flush=True,
        )
    return {
        "rms_pf": rms(all_err["particle_filter"]),
        "rms_kf": rms(all_err["kalman"]),
        "windows_pf_better": {k: f"{v[1]}/{v[0]}" for k, v in by_case.items()},
    }


# ------------------------------------------------------------------------------ cell
SCENARIO = REPO / "diagrams" / "pcb_occlusion.yaml"
#: A robot cycle of 9.1.3: from one pick of a board at the slide (L_carry begins) to the next.
CYCLE_AGENT, CYCLE_ACTION = "yumi_left", "L_carry"
ROBOT_ACTIONS = ("L_carry", "R_assemble", "L_unload")
#: --elbow-occluders: shelves 1.35 m tall (1.22 m in the scenario), shelf_green widened to y >= 0.20;
#: with the scenario's camera they hide elbow and wrist together (case 3), see the closing report.
ELBOW_OCCLUDERS = {
    "shelf_fuses": ([0.60, -0.33, 1.085], [0.06, 0.30, 0.53]),
    "shelf_green": ([0.62, 0.365, 1.085], [0.06, 0.33, 0.53]),
}
ARMS = ((L_ELBOW, L_WRIST), (R_ELBOW, R_WRIST))


class OcclusionProbe:
    """Listener of the cell's `OcclusionTracker` (called with each new frame and its estimate).

    Records, per frame: the true skeleton at the frame's time (the operator core), which points
    the camera lost and why (occluder box, robot link, out of view), which occlusion case of
    9.1.2 each arm is in, and the error of the estimate of every lost point. `shadow`: an
    optional second `SkeletonTracker` fed the same frames (the KF on the PF run's frames).
    """

    def __init__(self, truth, camera_model, shadow=None):
        self.truth = truth
        self.camera = camera_model
        self.shadow = shadow
        self.frames = 0
        self.hidden = np.zeros(8, dtype=int)
        self.by_box = np.zeros(8, dtype=int)
        self.by_view = np.zeros(8, dtype=int)
        self.cases = {"wrist": 0, "elbow": 0, "both": 0}
        self.errors: list = []
        self.shadow_errors: list = []
        #: per (hidden point, frame) of every region: (inside, volume m^3)
        self.regions: dict = {}
        self._last_seen = np.full((8, 3), np.nan)

    def _add_region(self, name, inside, volume) -> None:
        store = self.regions.setdefault(name, ([], []))
        store[0].extend(np.asarray(inside, bool).tolist())
        store[1].extend(np.asarray(volume, float).tolist())

    def on_core(self, frame, core) -> None:
        """Core listener: is each lost point inside the tracker's belief region (regions.py)?"""
        truth = self.truth(frame.time)
        lost = ~(np.asarray(frame.tracked, bool) & np.all(np.isfinite(frame.points), axis=1))
        inside, volume = core.region_contains(truth, lost)
        judged = lost & np.isfinite(volume)
        if np.any(judged):
            self._add_region("own", inside[judged], volume[judged])
            pf = core.particle_filter
            if pf is not None:
                cloud = pf.positions[judged]
                mean = cloud.mean(axis=1)
                offset = cloud - mean[:, None, :]
                cov = np.einsum("pni,pnj->pij", offset, offset) / cloud.shape[1] + 1e-12 * np.eye(3)
                self._add_region("pf_ellipsoid", in_ellipsoid(mean, cov, truth[judged]),
                                 ellipsoid_volume(cov))
                radius = np.cbrt(3.0 * volume[judged] / (4.0 * np.pi))
                held = self._last_seen[judged]
                near = np.linalg.norm(truth[judged] - held, axis=1) <= radius
                self._add_region("hold_at_pf_volume", near & np.all(np.isfinite(held), axis=1),
                                 volume[judged])
        seen = ~lost
        self._last_seen[seen] = np.asarray(frame.points, float)[seen]

    def __call__(self, frame, estimate) -> None:
        truth = self.truth(frame.time)
        lost = ~(np.asarray(frame.tracked, bool) & np.all(np.isfinite(frame.points), axis=1))
        self.frames += 1
        self.hidden += lost
        box = self.camera.is_occluded(truth)
        self.by_box += lost & box
        self.by_view += lost & ~box & ~self.camera.in_view(truth)
        for elbow, wrist in ARMS:
            if lost[elbow] or lost[wrist]:
                key = "both" if lost[elbow] and lost[wrist] else ("elbow" if lost[elbow] else "wrist")
                self.cases[key] += 1
        if self.shadow is not None:
            shadow_estimate = self.shadow.update(frame)
        if np.any(lost):
            self.errors.append(np.linalg.norm(estimate.points[lost] - truth[lost], axis=1))
            if self.shadow is not None:
                self.shadow_errors.append(np.linalg.norm(shadow_estimate.points[lost] - truth[lost], axis=1))


def region_stats(inside, volume) -> dict:
    """Coverage (share of hidden point-frames whose truth lies in the region), the region's mean
    and median volume (m^3) and the radius (m) of a ball of the mean volume."""
    inside, volume = np.asarray(inside, bool), np.asarray(volume, float)
    if not inside.size:
        return {"coverage": float("nan"), "mean_volume_m3": float("nan"), "median_volume_m3": float("nan"),
                "mean_volume_radius_m": float("nan"), "n": 0}
    mean = float(np.mean(volume))
    return {"coverage": float(np.mean(inside)), "mean_volume_m3": mean,
            "median_volume_m3": float(np.median(volume)),
            "mean_volume_radius_m": float(np.cbrt(3.0 * mean / (4.0 * np.pi))), "n": int(inside.size)}


def error_stats(errors) -> dict:
    e = np.concatenate(errors) if errors else np.zeros(0)
    if not e.size:
        return {"rms": float("nan"), "median": float("nan"), "p95": float("nan"), "n": 0}
    return {
        "rms": float(np.sqrt(np.mean(e**2))),
        "median": float(np.median(e)),
        "p95": float(np.percentile(e, 95)),
        "n": int(e.size),
    }


#: The trackers compared (issue 15 item 3): name -> config (kf4 is the thesis's open loop).
TRACKERS = ("hold", "kf2", "kf4", "pf")
#: The cameras compared: name -> scenario label of diagrams/campaigns/trackers.yaml.
CAMERAS = {"analytic": "pcb_occlusion", "rendered": "pcb_occlusion_rendered"}
CAMPAIGN = REPO / "diagrams" / "campaigns" / "trackers.yaml"
#: the comparison campaign's folder unless --out names one
DEFAULT_OUT = Path("/tmp/bench_tracking_campaign")
#: Regions judged on the pf run's frames: its own, its particles' 95 % ellipsoid, a ball of its volume
#: around the last seen point.
PF_FRAME_REGIONS = ("own", "pf_ellipsoid", "hold_at_pf_volume")


def tracker_config(kind: str):
    from hrc_drake.perception.config import HoldLastSeenTracker, KalmanTracker, ParticleFilterTracker

    return {
        "particle_filter": lambda: ParticleFilterTracker(particles=500),
        "pf": lambda: ParticleFilterTracker(particles=500),
        "kalman": KalmanTracker,
        "kf4": KalmanTracker,
        "kf2": lambda: KalmanTracker(order=2),
        "hold": HoldLastSeenTracker,
    }[kind]()


def load_pcb_scenario(kind: str, elbow_occluders: bool, operator_x: float | None = None):
    from hrc_drake.cell.scenario import load_scenario

    scenario = load_scenario(SCENARIO)
    scenario.tracker = tracker_config(kind)
    if operator_x is not None:
        scenario.operator.base.xyz[0] = float(operator_x)
    if elbow_occluders:
        for occluder in scenario.layout.occluders:
            if occluder.name in ELBOW_OCCLUDERS:
                occluder.center, occluder.size = (list(v) for v in ELBOW_OCCLUDERS[occluder.name])
    return scenario


def run_cell(kind: str, n_cycles: int, named_poses, elbow_occluders: bool, operator_x: float | None,
             max_time: float | None = None) -> dict:
    """Simulate pcb_occlusion.yaml with tracker `kind` until n_cycles robot cycles are complete, or
    `max_time` simulated s (default: 120 s a cycle and two more, where a cell that stalls stops)."""
    from pydrake.systems.analysis import Simulator

    from hrc_drake.cell.build import build_cell, camera_model

    scenario = load_pcb_scenario(kind, elbow_occluders, operator_x)
    cell = build_cell(scenario, SCENARIO, named_poses=named_poses)
    lay = scenario.layout
    shadow = None
    if kind in ("particle_filter", "pf"):
        shadow = SkeletonTracker(
            "kalman", {}, None, lay.workspace_center, lay.workspace_size, lay.camera.rate
        )
    simulator = Simulator(cell.diagram)
    source = cell.system("operator")
    source_context = source.GetMyContextFromRoot(simulator.get_context())

    def truth(t):  # the true skeleton: the run's operator, in the simulator's context
        return source.operator(source_context).points(t)

    probe = OcclusionProbe(truth, camera_model(scenario), shadow)
    cell.system("tracker").listeners.append(probe)
    cell.system("tracker").core_listeners.append(probe.on_core)
    simulator.set_target_realtime_rate(0.0)
    simulator.Initialize()
    start_wall = time.perf_counter()
    if max_time is None:
        max_time = 120.0 * (n_cycles + 2)  # a cycle takes ~45 s; a cell that stalls stops here
    t, begins = 0.0, []
    while len(begins) < n_cycles + 1 and t < max_time:
        t = min(t + 2.0, max_time)
        simulator.AdvanceTo(t)
        new = [
            e.time
            for e in cell.log(simulator.get_context()).events
            if getattr(e, "agent", "") == CYCLE_AGENT and e.action == CYCLE_ACTION and e.kind == "begin"
        ]
        if len(new) > len(begins) and len(new) > 1:
            print(
                f"  {kind}: cycle {len(new) - 1}/{n_cycles} took {new[-1] - new[-2]:5.1f} s "
                f"(t = {t:6.0f} s, wall {time.perf_counter() - start_wall:5.0f} s)",
                flush=True,
            )
        begins = new
    wall = time.perf_counter() - start_wall
    log = cell.log(simulator.get_context())
    cycles = np.diff(begins)[:n_cycles]
    end = begins[min(len(begins) - 1, n_cycles)] if len(begins) > 1 else t
    times = np.asarray(log.times)
    in_run = times <= end
    distances = np.asarray(log.distances)[in_run]
    overrides = np.asarray(log.overrides)[in_run]
    safety = float(scenario.safety_distance)
    arg = int(np.argmin(distances))
    durations = {a: [] for a in ROBOT_ACTIONS}
    open_begin = {}
    for e in log.events:
        if e.action in durations and e.time <= end:
            if e.kind == "begin":
                open_begin[e.action] = e.time
            elif e.kind == "end" and e.action in open_begin:
                durations[e.action].append(e.time - open_begin.pop(e.action))
    result = {
        "kind": kind,
        "cycles": cycles.tolist(),
        "simulated_s": float(end),
        "wall_s": wall,
        "min_distance_m": float(distances[arg]),
        "min_distance_at_s": float(times[in_run][arg]),
        "below_safety_fraction": float(np.mean(distances < safety)),
        "safety_distance_m": safety,
        "slowed_fraction": float(np.mean(overrides < 1.0)),
        "robot_action_mean_s": {a: float(np.mean(v)) if v else float("nan") for a, v in durations.items()},
        "frames": probe.frames,
        "hidden_frames": probe.hidden.tolist(),
        "hidden_by_box": probe.by_box.tolist(),
        "hidden_out_of_view": probe.by_view.tolist(),
        "arm_cases": dict(probe.cases),
        "error": error_stats(probe.errors),
        "regions": {name: region_stats(*values) for name, values in probe.regions.items()},
    }
    if shadow is not None:
        result["shadow_kf_error"] = error_stats(probe.shadow_errors)
    return result


RENDERED_SCENARIO = REPO / "diagrams" / "pcb_occlusion_rendered.yaml"


def bench_render(n_frames: int, named_poses, settle: float = 5.0) -> dict:
    """Milliseconds per depth frame of the rendered camera (RgbdSensor, RenderEngineVtk) in the
    PCB cell (diagrams/pcb_occlusion_rendered.yaml), median over `n_frames` frames of a run from
    `settle` s on, at the scenario's resolution and at the Kinect v2's full 512 x 424."""
    from pydrake.systems.analysis import Simulator

    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.scenario import load_scenario

    out = {}
    for width, height in ((None, None), (512, 424)):
        scenario = load_scenario(RENDERED_SCENARIO)
        sensor = scenario.layout.camera.sensor
        if width is not None:
            sensor.width, sensor.height = width, height
        cell = build_cell(scenario, RENDERED_SCENARIO, named_poses=named_poses)
        simulator = Simulator(cell.diagram)
        simulator.Initialize()
        simulator.AdvanceTo(settle)  # the operator and the robot at work
        context = simulator.get_mutable_context()
        depth_sensor = cell.system("rendered_depth_sensor")
        sensor_context = depth_sensor.GetMyContextFromRoot(context)
        port = depth_sensor.depth_image_32F_output_port()
        times = []
        for k in range(n_frames):
            context.SetTime(settle + k / 30.0)  # new poses: the image is rendered again
            cell.scene_graph.get_query_output_port().Eval(cell.scene_graph.GetMyContextFromRoot(context))
            start = time.perf_counter()
            port.Eval(sensor_context)
            times.append(time.perf_counter() - start)
        out[f"{sensor.width}x{sensor.height}"] = 1e3 * float(np.median(times))
    return out


def bench_compare(seeds: int, duration: float, workers: int, out_dir: Path) -> dict:
    """Every tracker x camera of diagrams/campaigns/trackers.yaml over `seeds` seeds of `duration`
    s, through the campaign API; the cell figures of Fig. 9.7 per cell and the one-sided tests."""
    import dataclasses

    from hrc_drake.campaign.analysis import rank_sum_test
    from hrc_drake.campaign.engine import run_campaign
    from hrc_drake.campaign.spec import load_campaign

    campaign = load_campaign(CAMPAIGN)
    campaign = dataclasses.replace(campaign, duration=float(duration), seeds=list(range(seeds)))
    outcome = run_campaign(campaign, out_dir, workers=workers, progress=sys.stderr)
    rows = outcome.rows[outcome.rows["status"] == "ok"]
    out = {"cycles_s": {}, "cycle_mean_s": {}, "below_safety_fraction": {}, "min_distance_m": {},
           "time_below_s": {}, "mean_speed_override": {}, "products_mean_cycle_s": {}, "runs": {},
           "failed": int(outcome.failed)}
    for tracker in TRACKERS:
        for key in out:
            if key != "failed":
                out[key].setdefault(tracker, {})
        for camera, label in CAMERAS.items():
            cell = rows[(rows["variant"] == tracker) & (rows["scenario"] == label)]
            cycles = [float(c) for run in cell["robot_cycles.times"] for c in run]
            out["cycles_s"][tracker][camera] = cycles
            out["cycle_mean_s"][tracker][camera] = float(np.mean(cycles)) if cycles else float("nan")
            out["below_safety_fraction"][tracker][camera] = float(cell["safety.fraction_below"].mean())
            out["min_distance_m"][tracker][camera] = float(cell["min_human_robot_distance"].min())
            out["time_below_s"][tracker][camera] = float(cell["safety.time_below_s"].sum())
            out["mean_speed_override"][tracker][camera] = float(cell["mean_speed_override"].mean())
            out["products_mean_cycle_s"][tracker][camera] = float(cell["mean_time_between_products"].mean())
            out["runs"][tracker][camera] = int(len(cell))
    tests = {}
    for baseline in ("kf4", "kf2", "hold"):
        for camera in CAMERAS:
            _, p, effect = rank_sum_test(out["cycles_s"]["pf"][camera], out["cycles_s"][baseline][camera],
                                         alternative="less")
            tests[f"pf_shorter_than_{baseline}.{camera}"] = {"p": p, "rank_biserial": effect}
    out["tests"] = tests
    out["tests_csv"] = str(Path(out_dir) / "tests.csv")
    return out


def nested(table: dict, fn) -> dict:
    """{tracker: {camera: fn(value)}}."""
    return {t: {c: fn(v) for c, v in cams.items()} for t, cams in table.items()}


def histogram_rows(samples: dict, n_bins: int = 8) -> list[str]:
    """Text histogram of the cycle times of every tracker on common bins (cf. Fig. 9.7)."""
    values = [np.asarray(v, float) for v in samples.values() if len(v)]
    if not values:  # no run completed a cycle
        return []
    values = np.concatenate(values)
    edges = np.linspace(np.floor(values.min()), np.ceil(values.max()) + 1e-9, n_bins + 1)
    rows = [f"  {'cycle time (s)':>16s} " + " ".join(f"{k:>16s}" for k in samples)]
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        counts = [int(np.sum((np.asarray(v) >= lo) & (np.asarray(v) < hi))) for v in samples.values()]
        rows.append(f"  {lo:7.1f} - {hi:6.1f} " + " ".join(f"{'#' * c:>16s}" for c in counts))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, under a minute")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    parser.add_argument("--cycles", type=int, default=None,
                        help="robot cycles per tracker run (30; --quick 1)")
    parser.add_argument(
        "--elbow-occluders",
        action="store_true",
        help="taller/wider shelves that also hide the elbows (case 3), see ELBOW_OCCLUDERS",
    )
    parser.add_argument(
        "--operator-x",
        type=float,
        default=None,
        help="operator base x (m; the scenario has 1.0, 1.1 keeps the safety distance)",
    )
    parser.add_argument("--seeds", type=int, default=None, help="seeds per tracker x camera (5; --quick 1)")
    parser.add_argument("--duration", type=float, default=None,
                        help="simulated s of every comparison run (120; --quick 30)")
    parser.add_argument("--workers", type=int, default=2, help="campaign worker processes (0: this one)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder of the comparison campaign (runs.parquet, tests.csv, plots; default "
                             f"{DEFAULT_OUT}, --smoke: a temporary one)")
    args = parser.parse_args(argv)
    smoke = args.smoke
    quick = args.quick or smoke  # smoke: the --quick path, smaller
    if smoke:  # the comparison runs in this process
        args.workers = 0
    n_seeds = args.seeds if args.seeds is not None else (1 if quick else 5)
    duration = args.duration if args.duration is not None else (1.0 if smoke else 30.0 if quick else 120.0)
    n_cycles = args.cycles if args.cycles is not None else (1 if quick else 30)
    if n_cycles < 1:
        parser.error(f"--cycles must be >= 1, got {n_cycles}")
    print("speed (8 points x 500 particles, one update)", flush=True)
    speed = bench_speed(2 if smoke else 100 if quick else 500)

    from hrc_drake.robots.poses import solve_named_poses

    print(
        f"pcb_occlusion.yaml in Drake: {n_cycles} robot cycles per tracker"
        + (" (elbow occluders)" if args.elbow_occluders else "")
        + (f" (operator at x = {args.operator_x} m)" if args.operator_x is not None else ""),
        flush=True,
    )
    named_poses = solve_named_poses(load_pcb_scenario("particle_filter", False).robots, SCENARIO)
    cell = {
        kind: run_cell(kind, n_cycles, named_poses, args.elbow_occluders, args.operator_x,
                       max_time=1.0 if smoke else None)
        for kind in TRACKERS
    }
    pf, kf = cell["pf"], cell["kf4"]

    print(f"tracker x camera comparison ({CAMPAIGN.name}): {n_seeds} seeds x {duration:g} s per cell",
          flush=True)
    if args.out is not None:
        folder = nullcontext(args.out)
    else:
        folder = tempfile.TemporaryDirectory() if smoke else nullcontext(DEFAULT_OUT)
    with folder as out:
        compare = bench_compare(n_seeds, duration, args.workers, Path(out))

    print("rendered depth camera (pcb_occlusion_rendered.yaml)", flush=True)
    render = bench_render(1 if smoke else 30 if quick else 200, named_poses, settle=0.2 if smoke else 5.0)

    print("lego_assembly_arm with synthetic occluders", flush=True)
    lego = bench_lego(1 if smoke else 3 if quick else 20, 1 if smoke else 2 if quick else 5)

    print()
    print("hidden frames per point (PF run; camera frames at 30 Hz):")
    print(f"  {'point':16s} {'lost':>6s} {'by shelf':>9s} {'by robot':>9s} {'out of view':>12s}")
    for i, name in enumerate(SKELETON_POINTS):
        lost, box, view = pf["hidden_frames"][i], pf["hidden_by_box"][i], pf["hidden_out_of_view"][i]
        print(f"  {name:16s} {lost:6d} {box:9d} {lost - box - view:9d} {view:12d}")
    print(f"  of {pf['frames']} frames; arm occlusion cases (frames x arms): {json.dumps(pf['arm_cases'])}")
    print()
    print(f"{'figure':52s} {'PF':>10s} {'KF':>10s}")
    for key, label in [
        ("occluded_kalman", "update 8x500, wrist hidden (ms, median)"),
        ("seen_kalman", "update 8x500, all seen (ms, median)"),
        ("occluded_bootstrap", "same, literal bootstrap mode, hidden (ms)"),
        ("seen_bootstrap", "same, literal bootstrap mode, all seen (ms)"),
    ]:
        print(f"{label:52s} {speed[key]:10.3f}")
    for resolution, ms in render.items():
        print(f"{'rendered depth frame ' + resolution + ' (ms, median)':52s} {ms:10.3f}")
    shadow = pf["shadow_kf_error"]
    for stat in ("rms", "median", "p95"):
        print(
            f"{'cell (a): ' + stat + ' error of lost points, same frames (m)':52s} "
            f"{pf['error'][stat]:10.3f} {shadow[stat]:10.3f}"
        )
    print(
        f"{'cell (a): rms error of lost points, own runs (m)':52s} {pf['error']['rms']:10.3f} "
        f"{kf['error']['rms']:10.3f}"
    )
    if not lego.get("skipped"):
        print(
            f"{'lego (b): RMS error occluded points (m)':52s} {lego['rms_pf']:10.3f} {lego['rms_kf']:10.3f}"
        )
        print(f"{'lego (b): windows where PF beats KF':52s} {json.dumps(lego['windows_pf_better'])}")
    rows = [
        ("robot cycles", lambda r: float(len(r["cycles"]))),
        ("cycle time mean (s)", lambda r: float(np.mean(r["cycles"]))),
        ("cycle time median (s)", lambda r: float(np.median(r["cycles"]))),
        ("cycle time std (s)", lambda r: float(np.std(r["cycles"]))),
        ("L_carry + R_assemble + L_unload mean (s)", lambda r: sum(r["robot_action_mean_s"].values())),
        ("share of time slowed by the 9.1.3 rule", lambda r: r["slowed_fraction"]),
        ("true min human-robot distance (m)", lambda r: r["min_distance_m"]),
        ("share of samples below safety distance", lambda r: r["below_safety_fraction"]),
        ("wall time of the run (s)", lambda r: r["wall_s"]),
    ]
    for label, get in rows:
        print(f"{'Fig. 9.7: ' + label:52s} {get(pf):10.3f} {get(kf):10.3f}")
    print(
        f"  safety distance of the scenario: {pf['safety_distance_m']} m; minimum at t = "
        f"{pf['min_distance_at_s']:.1f} s (PF), {kf['min_distance_at_s']:.1f} s (KF)"
    )
    print("robot cycle-time histogram (Fig. 9.7):")
    for row in histogram_rows({"PF": pf["cycles"], "KF": kf["cycles"]}):
        print(row)

    print()
    print(f"Fig. 9.7 per tracker x camera ({n_seeds} seeds x {duration:g} s; robot cycles pooled):")
    print(f"  {'tracker':8s} {'camera':9s} {'cycles':>6s} {'cycle mean (s)':>14s} {'below safety':>12s} "
          f"{'min dist (m)':>12s} {'speed':>6s}")
    for tracker in TRACKERS:
        for camera in CAMERAS:
            print(f"  {tracker:8s} {camera:9s} {len(compare['cycles_s'][tracker][camera]):6d} "
                  f"{compare['cycle_mean_s'][tracker][camera]:14.2f} "
                  f"{compare['below_safety_fraction'][tracker][camera]:12.4f} "
                  f"{compare['min_distance_m'][tracker][camera]:12.3f} "
                  f"{compare['mean_speed_override'][tracker][camera]:6.3f}")
    for name, test in compare["tests"].items():
        print(f"  one-sided rank-sum {name}: p = {test['p']:.3g}, rank-biserial {test['rank_biserial']:.2f}")
    print()
    print(f"hidden points inside the belief region (analytic camera, {n_cycles} cycles per tracker run):")
    print(f"  {'region':20s} {'coverage':>9s} {'n':>7s} {'mean vol (cm^3)':>16s} "
          f"{'equal-vol radius (m)':>21s}")
    region_rows = [(k, cell[k]["regions"].get("own")) for k in TRACKERS]
    region_rows += [(k, pf["regions"].get(k)) for k in PF_FRAME_REGIONS[1:]]
    for name, stats in region_rows:
        if stats:
            print(f"  {name:20s} {stats['coverage']:9.3f} {stats['n']:7d} "
                  f"{1e6 * stats['mean_volume_m3']:16.1f} "
                  f"{stats['mean_volume_radius_m']:21.3f}")

    def r4(x):
        return None if x is None or not np.isfinite(x) else round(float(x), 4)

    def region(run, name, field, scale=1.0):
        return r4(scale * run["regions"].get(name, {}).get(field, float("nan")))

    figures = {
        "quick": bool(args.quick),
        "smoke": smoke,
        "elbow_occluders": args.elbow_occluders,
        "operator_x": args.operator_x,
        "render_ms_per_frame": round(next(iter(render.values())), 3),
        "render_ms_per_frame_by_resolution": {k: round(v, 3) for k, v in render.items()},
        "update_ms_median_8x500_occluded": round(speed["occluded_kalman"], 3),
        "update_ms_median_8x500_all_seen": round(speed["seen_kalman"], 3),
        "update_ms_median_8x500_occluded_bootstrap": round(speed["occluded_bootstrap"], 3),
        "update_ms_median_8x500_all_seen_bootstrap": round(speed["seen_bootstrap"], 3),
        "cell_frames_pf_run": pf["frames"],
        "cell_hidden_frames_pf_run": dict(zip(SKELETON_POINTS, pf["hidden_frames"], strict=True)),
        "cell_arm_cases_pf_run": pf["arm_cases"],
        "cell_rms_lost_pf_m": r4(pf["error"]["rms"]),
        "cell_rms_lost_kf_same_frames_m": r4(shadow["rms"]),
        "cell_rms_lost_kf_own_run_m": r4(kf["error"]["rms"]),
        "cell_median_lost_pf_m": r4(pf["error"]["median"]),
        "cell_median_lost_kf_same_frames_m": r4(shadow["median"]),
        "lego_rms_pf_m": None if lego.get("skipped") else r4(lego["rms_pf"]),
        "lego_rms_kf_m": None if lego.get("skipped") else r4(lego["rms_kf"]),
        "cycles": [len(pf["cycles"]), len(kf["cycles"])],
        "cycle_mean_pf_s": r4(np.mean(pf["cycles"])),
        "cycle_mean_kf_s": r4(np.mean(kf["cycles"])),
        "cycle_median_pf_s": r4(np.median(pf["cycles"])),
        "cycle_median_kf_s": r4(np.median(kf["cycles"])),
        "cycle_times_pf_s": [round(c, 2) for c in pf["cycles"]],
        "cycle_times_kf_s": [round(c, 2) for c in kf["cycles"]],
        "slowed_fraction_pf": r4(pf["slowed_fraction"]),
        "slowed_fraction_kf": r4(kf["slowed_fraction"]),
        "min_distance_pf_m": r4(pf["min_distance_m"]),
        "min_distance_kf_m": r4(kf["min_distance_m"]),
        "below_safety_fraction_pf": r4(pf["below_safety_fraction"]),
        "below_safety_fraction_kf": r4(kf["below_safety_fraction"]),
        "safety_distance_m": pf["safety_distance_m"],
        "compare_seeds": n_seeds,
        "compare_duration_s": duration,
        "cycle_mean_s": nested(compare["cycle_mean_s"], r4),
        "below_safety_fraction": nested(compare["below_safety_fraction"], r4),
        "min_distance_m": nested(compare["min_distance_m"], r4),
        "time_below_s": nested(compare["time_below_s"], r4),
        "mean_speed_override": nested(compare["mean_speed_override"], r4),
        "robot_cycles_n": nested(compare["cycles_s"], len),
        "products_mean_cycle_s": nested(compare["products_mean_cycle_s"], r4),
        "compare_failed_runs": compare["failed"],
        "pf_shorter_cycles_tests": {k: {"p": r4(v["p"]), "rank_biserial": r4(v["rank_biserial"])}
                                    for k, v in compare["tests"].items()},
        "region_coverage": {k: region(cell[k], "own", "coverage") for k in TRACKERS},
        "region_mean_volume_cm3": {k: region(cell[k], "own", "mean_volume_m3", 1e6) for k in TRACKERS},
        "region_mean_volume_radius_m": {k: region(cell[k], "own", "mean_volume_radius_m") for k in TRACKERS},
        "region_hidden_point_frames": {k: cell[k]["regions"].get("own", {}).get("n", 0) for k in TRACKERS},
        "region_coverage_pf_frames": {k: region(pf, k, "coverage") for k in PF_FRAME_REGIONS},
        "region_mean_volume_cm3_pf_frames": {
            k: region(pf, k, "mean_volume_m3", 1e6) for k in PF_FRAME_REGIONS},
        "region_rule": f"pf: particles + {PARTICLE_RADIUS} m balls; kf: {REGION_MASS:.0%} ellipsoid; "
                       f"hold: {PARTICLE_RADIUS} m ball",
        "cell_cycle_mean_s_by_tracker_own_runs": {k: r4(np.mean(cell[k]["cycles"])) for k in TRACKERS},
        "loadavg": [round(x, 2) for x in os.getloadavg()],
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
