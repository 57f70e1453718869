"""The proactive pipeline of thesis 8.2 (Fig. 8.11) on a hand-made YuMi problem."""

import numpy as np
import pytest

from hrc_drake.messages import R_ELBOW, R_SHOULDER, R_WRIST
from hrc_drake.motion.config import ProactivePlanner
from hrc_drake.motion.geometry import point_capsule_distance
from hrc_drake.motion.proactive import ProactivePlannerCore, nominal_path, table_box
from hrc_drake.robots.chain import SerialChain

QA = np.array([-0.858, -0.681, 2.086, 0.062, 4.18, 0.645, -1.942])
QB = np.array([-0.922, -0.442, 1.624, 0.778, 4.382, 0.894, -0.897])  # tool from y = 0.47 to 0.03 m


def reach(y: float, rng, frames: int = 30) -> np.ndarray:
    """Skeleton estimates (frames, 8, 3) of a right-arm reach toward the robot at lateral y."""
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, frames))[:, None]
    shoulder = np.array([1.25, y, 0.55])
    wrist = np.array([0.9, y, 0.3]) + s * np.array([-0.4, 0.0, 0.0])
    elbow = 0.5 * (shoulder + wrist) + np.array([0.0, 0.0, -0.08])
    points = np.full((frames, 8, 3), np.nan)
    points[:, R_SHOULDER] = shoulder
    points[:, R_ELBOW] = elbow
    points[:, R_WRIST] = wrist
    return points + rng.normal(0.0, 0.005, points.shape)


def run(overlap: str, seed: int = 0, precision: str = "float32"):
    """Three reaches of a1 (across the robot's path) and of a2 (far to the side), the robot doing
    r1 while the human does `overlap`; returns the core after its first replanning."""
    chain = SerialChain.from_model("yumi", "left")
    settings = ProactivePlanner(gpdm_iterations=30, latent_dim=2, potential_precision=precision)
    core = ProactivePlannerCore("yumi_left", "r1", ["a1", "a2"], {"a1": "right", "a2": "right"},
                                nominal_path(QA, QB), chain, [table_box([0.5, 0.0], [1.2, 1.6, 0.1], 0.0)],
                                settings, rng=seed)
    rng = np.random.default_rng(seed)
    t = 0.0
    for _ in range(3):
        for action, y in (("a1", 0.22), ("a2", -0.6)):
            assert not core.maybe_replan(t)
            core.human_event(t, action, "begin")
            if action == overlap:
                core.robot_event(t, "yumi_left", "r1", "begin")
            for frame in reach(y, rng):
                core.observe_points(frame)
            t += 1.0
            core.human_event(t, action, "end")
            core.robot_event(t, "yumi_left", "r1", "end")
            core.robot_event(t, "yumi_left", "other", "begin")  # ignored: not r1
            t += 1.0
    assert core.ready and all(len(d) == 3 for d in core.databases.values())
    assert core.maybe_replan(t) and core.seq_ == 1
    assert not core.maybe_replan(t + 1.0)  # 20 s between replannings
    return core, chain


def clearance(chain, path, cloud_points) -> float:
    starts, ends, radii = chain.capsules(path)
    return min(point_capsule_distance(cloud_points, s, e, radii).min()
               for s, e in zip(starts, ends, strict=True))


def test_the_robot_avoids_the_action_the_human_does_during_its_own():
    core, chain = run("a1")
    report = core.reports_[-1]
    assert report.weights == pytest.approx((1.0, 0.0))
    assert report.proactive_cost < 0.7 * report.nominal_cost
    np.testing.assert_allclose(core.path_[[0, -1]], core.nominal[[0, -1]])
    lower, upper = chain.joint_limits
    assert np.all(core.path_ >= lower) and np.all(core.path_ <= upper)
    # the reaches of a1 sweep the wrist from x = 0.9 to 0.5 at y = 0.22, z = 0.3
    sweep = np.stack([np.linspace(0.5, 0.9, 20), np.full(20, 0.22), np.full(20, 0.3)], axis=1)
    assert clearance(chain, core.path_, sweep) > clearance(chain, core.nominal, sweep) + 0.02
    print(f"\nproactive replanning: GPDM {report.gpdm_s:.2f} s, clouds {report.cloud_s:.2f} s, "
          f"STOMP {report.stomp_s:.2f} s, {report.cloud_points} cloud points")


def test_an_action_done_elsewhere_leaves_the_path_nominal():
    core, _ = run("a2")
    assert core.reports_[-1].weights == pytest.approx((0.0, 1.0))
    away, _ = run("a1")
    deformation = np.abs(core.path_ - core.nominal).max()
    assert deformation < 0.5 * np.abs(away.path_ - away.nominal).max()


def test_float32_potentials_plan_the_path_of_float64():
    single, _ = run("a1", precision="float32")
    double, _ = run("a1", precision="float64")
    assert single.reports_[-1].nominal_cost == pytest.approx(double.reports_[-1].nominal_cost, rel=1e-5)
    assert single.reports_[-1].proactive_cost == pytest.approx(double.reports_[-1].proactive_cost, rel=1e-3)
    np.testing.assert_allclose(single.path_, double.path_, atol=1e-3)


def test_bad_setup_is_refused():
    from hrc_drake.errors import ConfigError

    with pytest.raises(ConfigError, match="proactive_planner.potential_precision"):
        ProactivePlanner(robot_action="r1", start_pose="p", human_actions=["a1"],
                         potential_precision="float16").validate("proactive_planner")
    chain = SerialChain.from_model("yumi", "left")
    with pytest.raises(ValueError, match="moving arm"):
        ProactivePlannerCore("yumi_left", "r1", ["a1"], {}, nominal_path(QA, QB), chain)
    with pytest.raises(ValueError, match="nominal path"):
        ProactivePlannerCore("yumi_left", "r1", ["a1"], {"a1": "left"}, np.zeros((43, 6)), chain)
    with pytest.raises(ValueError, match="waypoints"):
        nominal_path(QA, QB, 2)
