"""Pick joint postures for an arm's named poses whose joint-space paths keep clear of the operator.

A robot action moves its arm along straight lines in joint space between IK solutions; solved one
after the other from the previous pose, two neighbouring solutions can lie far apart and the line
between them swing a link up in front of the operator's head or the camera (issue 52: box_usb).
This tool takes the tool position of each of the arm's poses (its target, or where its joints put
the tool; --home moves the home), solves each from many seeds (`solve_tool_position`, the tool
pointing down unless the pose orients it; seeds drawn with `numpy.random.default_rng(--seed)`),
keeps the distinct solutions, and picks one per pose (the same one wherever a pose recurs) that
maximises the smallest clearance, along every line the arm may travel (`arm_segments`), of its
links beyond the shoulder from the operator standing at rest and from the camera's sight lines to
the operator's skeleton points; ties go to the smaller total joint step. The search is local
(coordinate descent from --restarts starts: each pose's clearest posture, then random ones), so
the pick is good, not proven best. A pose with an `approach` keeps its posture (the one of lowest
effective mass along it, docs/safety.md "Approach postures").

Prints each pose's joints as a YAML pose line and each segment's highest point; the last line is
one JSON object {"arm", "clearance_m", "poses": {name: joints}, "segments": [[from, to, m]]}.

Usage: PYTHONPATH=. python3 tools/pick_clear_postures.py SCENARIO ARM [--robot NAME] [--home X,Y,Z]
       [--candidates N] [--seed S] [--samples N] [--restarts N]
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import sys
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pydrake.multibody.plant import MultibodyPlant  # noqa: E402

from hrc_drake.cell.scenario import load_scenario  # noqa: E402
from hrc_drake.human.body import BodyModel  # noqa: E402
from hrc_drake.robots.description import robot_record  # noqa: E402
from hrc_drake.robots.ik import InfeasibleTarget, solve_tool_position  # noqa: E402
from hrc_drake.robots.models import add_robots, arm_joint_limits, arm_position_indices  # noqa: E402
from hrc_drake.robots.poses import solve_named_poses, tool_positions  # noqa: E402

#: solutions closer than this (rad, largest joint difference) count as one
DISTINCT_RAD = 0.2
#: links up to the shoulder barely move with the arm: their height is the floor of every path
SHOULDER_LINKS = ("link_1", "link_2")


def arm_links(plant, instance, arm: str):
    """The arm's bodies beyond the shoulder (YuMi-style names end in _l / _r; a one-arm robot
    keeps every body but its base and shoulder links)."""
    bodies = [plant.get_body(i) for i in plant.GetBodyIndices(instance)]
    suffix = "_" + arm[0]
    own = [b for b in bodies if b.name().endswith(suffix)]
    chosen = own if own else bodies[1:]
    return [b for b in chosen if not any(s in b.name() for s in SHOULDER_LINKS)
            and not b.name().startswith(f"gripper_{'l' if arm[0] == 'r' else 'r'}")]


def operator_segments(scenario) -> tuple[np.ndarray, np.ndarray]:
    """(starts, ends) of the segments the arm keeps clear of: the operator's skeleton standing at
    rest at its base (thorax-head, shoulders, upper arms, forearms) and the camera's sight line to
    each skeleton point (an arm across one hides that point from the tracker)."""
    body = BodyModel()
    base = scenario.operator.base
    points = body.points(body.rest_q(base.xyz[:2], base.rpy[2]))
    bones = [(0, 1), (2, 3), (2, 4), (3, 5), (4, 6), (5, 7)]
    camera = np.asarray(scenario.layout.camera.position, float)
    starts = [points[a] for a, _ in bones] + [camera] * len(points)
    ends = [points[b] for _, b in bones] + list(points)
    return np.array(starts), np.array(ends)


def point_segment_distances(points, starts, ends) -> np.ndarray:
    """Distances (P, S) from each point to each segment."""
    axis = ends - starts
    length2 = np.maximum((axis * axis).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - starts[None]) * axis[None]).sum(axis=2) / length2, 0.0, 1.0)
    closest = starts[None] + t[..., None] * axis[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2)


def arm_segments(home: str, actions: list[list[str]]) -> list[tuple[str, str]]:
    """The joint-space lines an arm may travel: along each action's poses, from the home to each
    action's first pose, and from each action's last pose to any action's first (a program or a
    scheduler may put any action after any other)."""
    pairs = {(a, b) for poses in actions for a, b in zip(poses[:-1], poses[1:], strict=True)}
    pairs |= {(home, poses[0]) for poses in actions}
    pairs |= {(before[-1], after[0]) for before in actions for after in actions}
    return sorted((a, b) for a, b in pairs if a != b)


def candidates(plant, context, instance, model, arm, target, count, rng, target_rpy=None):
    """Distinct IK solutions of `target` from `count` random seeds: the tool at `target_rpy`
    where the pose orients it, else pointing down (as `solve_named_poses` solves a target)."""
    lower, upper, _ = arm_joint_limits(plant, instance, model, arm)
    solutions: list[np.ndarray] = []
    for attempt in range(count):
        try:
            q = np.asarray(solve_tool_position(plant, context, instance, model, arm, target,
                                               target_rpy=target_rpy, q_seed=rng.uniform(lower, upper),
                                               tool_z_down=target_rpy is None, attempts=1, seed=attempt),
                           float)
        except InfeasibleTarget:
            continue
        if all(np.abs(q - s).max() > DISTINCT_RAD for s in solutions):
            solutions.append(q)
    return solutions


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario", type=Path)
    parser.add_argument("arm")
    parser.add_argument("--robot", default=None, help="the robot's name (default: the scenario's first)")
    parser.add_argument("--home", default=None,
                        help="a new tool position X,Y,Z (world, m) for the arm's home (default: where it is)")
    parser.add_argument("--candidates", type=int, default=40, help="IK seeds per target (default 40)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the IK seeds")
    parser.add_argument("--samples", type=int, default=21, help="points checked along each segment")
    parser.add_argument("--restarts", type=int, default=20, help="starts of the local search (default 20)")
    args = parser.parse_args(argv)
    for option, least in (("candidates", 1), ("samples", 2), ("restarts", 1)):
        if getattr(args, option) < least:
            parser.error(f"--{option}: at least {least}, got {getattr(args, option)}")
    home = None
    if args.home is not None:
        try:
            home = [float(v) for v in args.home.split(",")]
        except ValueError:
            home = []
        if len(home) != 3 or not all(math.isfinite(v) for v in home):
            parser.error(f"--home: three finite numbers X,Y,Z, got {args.home!r}")

    scenario = load_scenario(args.scenario)
    plant = MultibodyPlant(0.0)
    instances = add_robots(plant, scenario.robots, args.scenario)
    names = [r.name for _, r in instances]
    robot_name = args.robot if args.robot is not None else names[0]
    if robot_name not in names:
        parser.error(f"--robot: no robot {robot_name!r} in {args.scenario} (robots: {', '.join(names)})")
    instance, robot = instances[names.index(robot_name)]
    plant.Finalize()
    context = plant.CreateDefaultContext()
    poses = {p.name: p for p in robot.poses if p.arm == args.arm}
    actions = [a for a in robot.actions if a.arm == args.arm]
    arm_agent = next((a for a in robot.arms if a.arm == args.arm), None)
    if not actions or arm_agent is None or not arm_agent.home:
        parser.error(f"robot {robot.name!r}: arm {args.arm!r} needs a home and an action")
    named = solve_named_poses(scenario.robots, args.scenario)
    positions = tool_positions(scenario.robots, args.scenario)
    targets = {name: [round(float(v), 4) for v in positions[(robot.name, name)]] for name in poses}
    if args.home is not None:
        targets[arm_agent.home] = home
    segments = arm_segments(arm_agent.home, [list(a.poses) for a in actions])
    order = list(dict.fromkeys([arm_agent.home] + [p for a in actions for p in a.poses]))
    targets = {name: targets[name] for name in order}
    rng = np.random.default_rng(args.seed)
    solved = {}
    for name, xyz in targets.items():
        if name in poses and poses[name].approach:
            # a hand-over posture chosen for its lowest effective mass along `approach`: kept
            solved[name] = [np.asarray(named[(robot.name, name)], float)]
        else:
            pose = poses.get(name)
            rpy = pose.target.rpy if pose is not None and pose.target is not None and pose.orient else None
            solved[name] = candidates(plant, context, instance, robot_record(robot, args.scenario), args.arm,
                                      xyz, args.candidates, rng, rpy)
        print(f"{name:12s} {xyz}: {len(solved[name])} distinct solutions", flush=True)
        if not solved[name]:
            print(f"no IK solution of {name} at {xyz}", file=sys.stderr)
            return 1

    index = arm_position_indices(plant, instance, robot_record(robot, args.scenario), args.arm)
    links = arm_links(plant, instance, args.arm)
    base_q = plant.GetPositions(context).copy()

    keep_clear = operator_segments(scenario)

    @functools.cache
    def intrusion(a: str, i: int, b: str, j: int) -> float:
        """Minus the smallest clearance between the arm's links and the operator's body or the
        camera's sight lines along the joint-space line from pose a (solution i) to b (j)."""
        qa, qb = solved[a][i], solved[b][j]
        clearance = math.inf
        for s in np.linspace(0.0, 1.0, args.samples):
            q = base_q.copy()
            q[index] = qa + (qb - qa) * s
            plant.SetPositions(context, q)
            chain = np.array([plant.EvalBodyPoseInWorld(context, body).translation() for body in links])
            # the link origins and the midpoints between them stand for the arm
            points = np.vstack([chain, 0.5 * (chain[1:] + chain[:-1])])
            clearance = min(clearance, float(point_segment_distances(points, *keep_clear).min()))
        return -clearance

    def score(chosen: dict) -> tuple[float, float]:
        """(worst intrusion over every segment, total joint step) of an assignment."""
        worst = max(intrusion(a, chosen[a], b, chosen[b]) for a, b in segments)
        step = sum(float(np.abs(solved[a][chosen[a]] - solved[b][chosen[b]]).max()) for a, b in segments)
        return worst, step

    best = None
    for restart in range(args.restarts):
        # the first start: each pose's own clearest posture; then random ones
        chosen = ({n: min(range(len(solved[n])), key=lambda j, n=n: intrusion(n, j, n, j)) for n in order}
                  if restart == 0 else {n: int(rng.integers(len(solved[n]))) for n in order})
        current = score(chosen)
        improved = True
        while improved:  # coordinate descent: one pose's posture at a time, the others kept
            improved = False
            for name in order:
                for j in range(len(solved[name])):
                    trial = chosen | {name: j}
                    value = score(trial)
                    if value < current:
                        chosen, current, improved = trial, value, True
        if best is None or current < best[0]:
            best = (current, chosen)
    (worst, _), chosen = best
    lower, upper, _ = arm_joint_limits(plant, instance, robot_record(robot, args.scenario), args.arm)
    # rounded for the scenario file, and kept inside the limits the rounding may cross
    rounded = {n: np.clip(np.round(solved[n][j], 3), lower, upper) for n, j in chosen.items()}
    result = {"arm": args.arm, "clearance_m": round(-worst, 3),
              "poses": {n: [float(v) for v in q] for n, q in rounded.items()},
              "segments": [[a, b, round(-intrusion(a, chosen[a], b, chosen[b]), 3)] for a, b in segments]}
    for name, joints in result["poses"].items():
        print(yaml.safe_dump([{"name": name, "arm": args.arm, "joints": joints}],
                             default_flow_style=None, sort_keys=False).strip())
    for a, b, clearance in result["segments"]:
        print(f"  {a} -> {b}: clearance {clearance:.3f} m")
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
