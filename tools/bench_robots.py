"""Benchmark of the robot models: geometry checks, capsule kinematics, IK and discrete-plant speed,
and per shipped arm robot (issue 54) its IK success on tool-down targets in front of its base and
the same task (pcb_ic, use case a of thesis 5.4.1) with each robot: `models.<robot>.ik_success_pct`,
`models.<robot>.cell_products` (300 s, the scenario as shipped: its declared safety mode) and
`models.<robot>.verdict`.

Usage: python tools/bench_robots.py [--quick | --smoke]
Prints a table and, as its last line, one JSON object with the figures (times are medians).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from hrc_drake.robots.ik import InfeasibleTarget, solve_tool_position
from hrc_drake.robots.models import (
    RobotCapsuleKinematics,
    add_robot,
    arm_joint_limits,
    arm_position_indices,
    set_pd_gains,
)

# KINEMATICS.md 1.2 (body frame, right arm) and 2.5 (IRB 140 base frame)
YUMI_RIGHT = {
    "1": (0.0536, -0.0725, 0.4149),
    "2": (0.1178, -0.1253, 0.4780),
    "7": (0.2756, -0.1658, 0.5431),
    "3": (0.3636, -0.1668, 0.5576),
    "4": (0.4905, -0.0787, 0.4880),
    "5": (0.5259, -0.0072, 0.4213),
    "6": (0.5645, 0.0015, 0.4184),
}


def kinematic_plant():
    plant = MultibodyPlant(0.0)
    yumi = add_robot(plant, "yumi", "yumi")
    irb = add_robot(plant, "irb140", "irb", (1.5, 0.0, 0.0), (0.0, 0.0, np.pi))
    plant.Finalize()
    return plant, yumi, irb


def geometry_checks(plant, yumi, irb):
    context = plant.CreateDefaultContext()
    err = max(
        np.linalg.norm(
            plant.GetJointByName(f"yumi_joint_{k}_r", yumi)
            .frame_on_child()
            .CalcPoseInWorld(context)
            .translation()
            - (np.array(p) + [0, 0, 0.1])
        )
        for k, p in YUMI_RIGHT.items()
    )
    return {"yumi_joint_origin_max_error_mm": 1000 * err}


def reach(plant, instance, model, arm, frames, samples, rng):
    """Max distance between two frames over random joint vectors inside the limits."""
    context = plant.CreateDefaultContext()
    idx = arm_position_indices(plant, instance, model, arm)
    lower, upper, _ = arm_joint_limits(plant, instance, model, arm)
    a, b = (plant.GetFrameByName(f, instance) for f in frames)
    best = 0.0
    q = plant.GetPositions(context)
    for _ in range(samples):
        q[idx] = rng.uniform(lower, upper)
        plant.SetPositions(context, q)
        best = max(
            best,
            float(
                np.linalg.norm(
                    b.CalcPoseInWorld(context).translation() - a.CalcPoseInWorld(context).translation()
                )
            ),
        )
    return best


def time_capsules(plant, yumi, irb, repeats, rng):
    kin = RobotCapsuleKinematics(plant, [(yumi, "yumi"), (irb, "irb140")])
    context = plant.CreateDefaultContext()
    times = []
    q = plant.GetPositions(context)
    for _ in range(repeats):
        q = q + rng.normal(0, 0.01, q.shape)
        t0 = time.perf_counter()
        plant.SetPositions(context, q)
        kin.capsules(context)
        times.append(time.perf_counter() - t0)
    return kin.num_capsules, 1e6 * float(np.median(times))


def time_ik(plant, yumi, n, rng):
    context = plant.CreateDefaultContext()
    times, ok, errors = [], 0, []
    for k in range(n):
        arm, sign = ("right", -1) if k % 2 == 0 else ("left", 1)
        target = np.array([rng.uniform(0.30, 0.50), sign * rng.uniform(0.05, 0.30), rng.uniform(0.15, 0.35)])
        t0 = time.perf_counter()
        try:
            q = solve_tool_position(plant, context, yumi, "yumi", arm, target, tool_z_down=True, seed=k)
            ok += 1
            ctx = plant.CreateDefaultContext()
            full = plant.GetPositions(ctx)
            full[arm_position_indices(plant, yumi, "yumi", arm)] = q
            plant.SetPositions(ctx, full)
            tool = plant.GetFrameByName(f"yumi_tool_{arm[0]}", yumi).CalcPoseInWorld(ctx).translation()
            errors.append(np.linalg.norm(tool - target))
        except InfeasibleTarget:
            pass
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times)), ok / n, 1e3 * float(np.max(errors)) if errors else float("nan")


def time_discrete(time_step, sim_time):
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step)
    yumi = add_robot(plant, "yumi", "yumi", (0.0, 0.0, 0.75))
    irb = add_robot(plant, "irb140", "irb", (1.5, 0.0, 0.0), (0.0, 0.0, np.pi))
    for instance in (yumi, irb):
        set_pd_gains(plant, instance)
    plant.Finalize()
    q_goal = np.zeros(plant.num_positions())
    q_goal[arm_position_indices(plant, yumi, "yumi", "right")] = [0.5, -0.6, 0.0, 0.3, 0.0, 0.6, 0.0]
    q_goal[arm_position_indices(plant, yumi, "yumi", "left")] = [-0.5, -0.6, 0.0, 0.3, 0.0, 0.6, 0.0]
    q_goal[arm_position_indices(plant, irb, "irb140", "arm")] = [0.2, 0.3, -0.4, 0.0, 0.5, 0.0]
    for instance in (yumi, irb):
        actuated = [plant.get_joint_actuator(i).joint() for i in plant.GetJointActuatorIndices(instance)]
        x_d = np.concatenate([[q_goal[j.position_start()] for j in actuated], np.zeros(len(actuated))])
        builder.Connect(
            builder.AddSystem(ConstantVectorSource(x_d)).get_output_port(),
            plant.get_desired_state_input_port(instance),
        )
        builder.Connect(
            builder.AddSystem(ConstantVectorSource(np.zeros(len(actuated)))).get_output_port(),
            plant.get_actuation_input_port(instance),
        )
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    t0 = time.perf_counter()
    simulator.AdvanceTo(sim_time)
    wall = time.perf_counter() - t0
    q = plant.GetPositions(plant.GetMyContextFromRoot(simulator.get_context()))
    return sim_time / wall, float(np.max(np.abs(q - q_goal)))


#: the same assembly task with each shipped arm robot (the cart is no arm)
TASK_CELLS = {"yumi": "pcb_ic", "ur5e": "pcb_ic_ur5e", "panda": "pcb_ic_panda"}
#: the arm whose IK is sampled, per model
IK_ARMS = {"yumi": "right", "irb140": "arm", "ur5e": "arm", "panda": "arm"}


def model_ik_success(model: str, arm: str, n: int, rng) -> float:
    """% of n tool-down targets in a box in front of the base (x 0.3-0.5 m, |y| <= 0.3 m, z 0.1-0.35 m
    above it) that `solve_tool_position` reaches."""
    plant = MultibodyPlant(0.0)
    instance = add_robot(plant, model, model)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    ok = 0
    for k in range(n):
        target = np.array([rng.uniform(0.30, 0.50), rng.uniform(-0.30, 0.30), rng.uniform(0.10, 0.35)])
        try:
            solve_tool_position(plant, context, instance, model, arm, target, tool_z_down=True, seed=k)
            ok += 1
        except InfeasibleTarget:
            pass
    return 100.0 * ok / n


def model_cell(cell: str, duration: float) -> tuple[int, str, str]:
    """(products, verdict code, verdict line) of the shipped `cell` run for `duration` s as shipped."""
    from hrc_drake.cell.build import build_cell
    from hrc_drake.cell.run import simulate
    from hrc_drake.cell.scenario import load_scenario

    result = simulate(build_cell(load_scenario(cell)), duration)
    safety = result.metrics["safety"]
    return int(result.metrics["products_finished"]), str(safety["verdict_code"]), str(safety["verdict"])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small sample sizes (< 1 min)")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the whole path once, figures meaningless (the tests run it)")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    if args.smoke:
        n_reach, n_caps, n_ik, sim_time = 200, 20, 2, 0.05
    elif args.quick:
        n_reach, n_caps, n_ik, sim_time = 20000, 2000, 20, 1.0
    else:
        n_reach, n_caps, n_ik, sim_time = 200000, 20000, 100, 5.0

    plant, yumi, irb = kinematic_plant()
    results = geometry_checks(plant, yumi, irb)
    print("sampling reach ...", flush=True)
    results["yumi_reach_j2_flange_m"] = reach(
        plant, yumi, "yumi", "right", ("yumi_link_2_r", "yumi_link_7_r"), n_reach, rng
    )
    results["irb140_reach_j2_wrist_m"] = reach(
        plant, irb, "irb140", "arm", ("irb140_link_2", "irb140_link_5"), n_reach // 4, rng
    )
    print("timing capsules ...", flush=True)
    results["num_capsules"], results["capsules_us"] = time_capsules(plant, yumi, irb, n_caps, rng)
    print(f"timing IK over {n_ik} targets ...", flush=True)
    results["ik_ms"], results["ik_success_rate"], results["ik_max_error_mm"] = time_ik(plant, yumi, n_ik, rng)
    for step in (0.01, 0.001):
        print(f"simulating discrete plant h={step} s for {sim_time} s ...", flush=True)
        rtf, dev = time_discrete(step, sim_time)
        results[f"discrete_{int(step * 1000)}ms_realtime_factor"] = rtf
        results[f"discrete_{int(step * 1000)}ms_final_error_rad"] = dev

    cell_time = 2.0 if args.smoke else 300.0
    # the smoke setting runs one cell: the path is the same for each robot
    cells = {"ur5e": TASK_CELLS["ur5e"]} if args.smoke else TASK_CELLS
    for model, arm in IK_ARMS.items():
        print(f"{model}: IK over {n_ik} targets ...", flush=True)
        results[f"models.{model}.ik_success_pct"] = model_ik_success(model, arm, n_ik, rng)
        if model in cells:
            print(f"{model}: {TASK_CELLS[model]} for {cell_time:g} s ...", flush=True)
            products, code, line = model_cell(TASK_CELLS[model], cell_time)
            results[f"models.{model}.cell_products"] = products
            results[f"models.{model}.verdict"] = code
            print(f"  {products} products; {line}", flush=True)

    rows = [
        (
            "YuMi joint origins vs KINEMATICS.md 1.2, max error",
            f"{results['yumi_joint_origin_max_error_mm']:.2f} mm",
            "< 2 mm",
        ),
        (
            "YuMi reach j2 -> flange (sampled)",
            f"{results['yumi_reach_j2_flange_m']:.3f} m",
            "0.575 m computed; ABB reach 559 mm",
        ),
        (
            "IRB 140 reach j2 -> wrist centre (sampled)",
            f"{results['irb140_reach_j2_wrist_m']:.3f} m",
            "0.360 + 0.380 = 0.740 m",
        ),
        (
            "capsules(context), YuMi + IRB 140",
            f"{results['capsules_us']:.1f} us ({results['num_capsules']} caps)",
            "",
        ),
        (
            "IK solve (tool down, YuMi)",
            f"{results['ik_ms']:.1f} ms",
            f"success {results['ik_success_rate']:.0%}, max err {results['ik_max_error_mm']:.2f} mm",
        ),
        (
            "discrete plant 10 ms, PD, real-time factor",
            f"{results['discrete_10ms_realtime_factor']:.1f} x",
            f"final |q - q_d| {results['discrete_10ms_final_error_rad']:.4f} rad",
        ),
        (
            "discrete plant 1 ms, PD, real-time factor",
            f"{results['discrete_1ms_realtime_factor']:.1f} x",
            f"final |q - q_d| {results['discrete_1ms_final_error_rad']:.4f} rad",
        ),
    ]
    for model in IK_ARMS:
        task = (f"{TASK_CELLS[model]} {cell_time:g} s: {results[f'models.{model}.cell_products']} products, "
                f"{results[f'models.{model}.verdict']}") if model in cells else ""
        success = results[f"models.{model}.ik_success_pct"]
        rows.append((f"{model}: IK success (tool down, in front)", f"{success:.0f} %", task))
    print(f"\n{'figure':48s} {'measured':>26s}   reference")
    for name, value, ref in rows:
        print(f"{name:48s} {value:>26s}   {ref}")
    print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in results.items()}))


if __name__ == "__main__":
    main()
