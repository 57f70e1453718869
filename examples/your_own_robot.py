"""Your own robot in a cell, from its URDF: the scenario names the file (relative to itself), the
arm by its tool frame, and the rest is read from the URDF: the chain's joints, capsules fitted to
the links' collision shapes, PD gains from each joint's load. Here the URDF is a copy of the
shipped UR5e's, standing in for yours; the cell is pcb_ic's task (use case a of thesis 5.4.1) with
that robot (`extends:` the shipped pcb_ic_ur5e, its robot replaced by the URDF one). The run
prints what was read from the URDF, the ISO/TS 15066 verdict and the products; then a typo in the
tool frame, refused with its field path before anything is built.

    python3 examples/your_own_robot.py [--out DIR] [--duration S]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hrc_drake.cell.build import build_cell  # noqa: E402
from hrc_drake.cell.run import simulate  # noqa: E402
from hrc_drake.cell.scenario import load_scenario  # noqa: E402
from hrc_drake.cell.shipped import resolve  # noqa: E402
from hrc_drake.errors import ScenarioError  # noqa: E402
from hrc_drake.robots.description import robot_record  # noqa: E402
from hrc_drake.robots.models import model_file  # noqa: E402

#: pcb_ic's tool positions (its comment lists them), solved by IK for this arm, tool down
POSES = {"home": [0.25, -0.30, 0.95], "feeder": [0.46, -0.26, 0.85], "check": [0.32, -0.30, 0.92],
         "camera": [0.32, -0.30, 1.02], "fixture": [0.52, 0.00, 0.86], "caps": [0.40, -0.08, 0.84],
         "hold": [0.50, 0.02, 0.90], "storage": [0.32, -0.32, 0.86]}


def own_robot(tool_frame: str = "ur5e_tool") -> dict:
    """The scenario's robot: a URDF beside the scenario, its arm named by the tool frame."""
    return {
        "name": "cobot",
        "urdf": "my_cobot.urdf",
        "chains": [{"name": "arm", "tool_frame": tool_frame, "gripper_stroke": 0.0425,
                    "gripper_joints": ["ur5e_finger_joint_l", "ur5e_finger_joint_r"]}],
        "capsule_margin": 0.03,  # the collision cylinders are the links' nominal radii: widen them
        "base": {"xyz": [0.0, -0.15, 0.75]},
        "poses": [{"name": name, "arm": "arm", "target": {"xyz": xyz}} for name, xyz in POSES.items()],
        "actions": [
            {"name": "R_check", "arm": "arm", "poses": ["feeder", "check", "camera", "check", "feeder"],
             "dwell": 0.5},
            {"name": "R_place", "arm": "arm", "poses": ["feeder", "fixture"], "dwell": 0.3},
            {"name": "R_cap", "arm": "arm", "poses": ["caps", "hold"], "dwell": 0.3},
            {"name": "R_close", "arm": "arm", "poses": ["storage"], "dwell": 0.5},
        ],
        "arms": [{"agent": "robot", "arm": "arm", "home": "home",
                  "program": ["R_check", "R_place", "R_cap", "R_close"]}],
    }


def write_cell(folder: Path, robot: dict) -> Path:
    """The URDF and a scenario beside it (written with yaml.safe_dump, never by formatting text)."""
    with model_file("ur5e.urdf") as urdf:
        shutil.copy(urdf, folder / "my_cobot.urdf")
    path = folder / "my_cell.yaml"
    scenario = {"extends": str(resolve("pcb_ic_ur5e")), "description": "pcb_ic with my own cobot",
                "robots": [robot]}
    path.write_text(yaml.safe_dump(scenario, sort_keys=False))
    return path


def main(argv: list[str] | None = None) -> dict:
    """Run the example; the run's metrics."""
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path,
                        help="folder for the URDF and the scenario (default: a temporary one)")
    parser.add_argument("--duration", type=float, default=120.0, help="simulated seconds (default 120)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.out or Path(scratch)
        folder.mkdir(parents=True, exist_ok=True)
        path = write_cell(folder, own_robot())
        scenario = load_scenario(path)
        record = robot_record(scenario.robots[0], path)
        print(f"{path.name}: robot 'cobot' from {Path(record.urdf_path).name}")
        print(f"  arm 'arm': {len(record.arm('arm').joints)} joints read from the URDF, "
              f"{', '.join(record.arm('arm').joints)}")
        print(f"  {len(record.capsules)} capsules fitted to its collision shapes (+0.03 m), "
              f"static bodies {sorted(record.static_bodies)}")
        print(f"  judged with a stopping deceleration of {record.stopping_deceleration:g} m/s^2 "
              "(none stated: the shipped robots' assumption)")
        result = simulate(build_cell(scenario), args.duration)
        metrics = result.metrics
        print(f"{args.duration:g} s simulated: {metrics['products_finished']} products")
        print(metrics["safety"]["verdict"])

        try:
            load_scenario(write_cell(folder, own_robot(tool_frame="ur5e_tol")))
        except ScenarioError as err:
            print(f"a typo in the tool frame is refused before anything runs:\n  {err}")
    return metrics


if __name__ == "__main__":
    main()
