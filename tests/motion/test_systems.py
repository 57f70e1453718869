import numpy as np
import pytest

pytest.importorskip("pydrake")

from pydrake.common.value import AbstractValue  # noqa: E402
from pydrake.systems.analysis import Simulator  # noqa: E402
from pydrake.systems.framework import DiagramBuilder, LeafSystem  # noqa: E402
from pydrake.systems.primitives import ConstantValueSource, VectorLogSink  # noqa: E402

from hrc_drake.errors import ConfigError  # noqa: E402
from hrc_drake.human.body import BodyModel  # noqa: E402
from hrc_drake.messages import (  # noqa: E402
    Capsules,  # noqa: E402
    SkeletonEstimate,
    SweptVolumes,
)
from hrc_drake.motion.config import (  # noqa: E402
    GPMotionModel,
    SeparationSpeedScaling,
    WorstCaseMotionModel,
)
from hrc_drake.motion.systems import HumanMotionPredictor, SpeedScaler, predictor_kwargs  # noqa: E402


class ScriptedSkeleton(LeafSystem):
    """The operator walks toward the robot at 0.5 m/s from x = 1.4, waving the right arm."""

    def __init__(self, body):
        super().__init__()
        self.body = body
        self.DeclareAbstractOutputPort("skeleton_estimate", lambda: AbstractValue.Make(SkeletonEstimate()),
                                       self._calc)

    def _calc(self, context, output):
        t = context.get_time()
        q = self.body.rest_q((max(1.4 - 0.5 * t, 0.6), 0.0), np.pi)
        q[8] = 0.5 + 0.4 * np.sin(2.0 * t)
        output.set_value(SkeletonEstimate(time=t, points=self.body.points(q)))


def _robot_capsules():
    # a vertical link at the origin, radius 0.05
    return Capsules(np.array([[0.0, 0.0, 0.8]]), np.array([[0.0, 0.0, 1.3]]), np.array([0.05]))


@pytest.mark.parametrize("kind", ["worst_case", "gp_c"])
def test_predictor_and_scaler_in_a_diagram(kind):
    body = BodyModel()
    builder = DiagramBuilder()
    source = builder.AddSystem(ScriptedSkeleton(body))
    config = (GPMotionModel(variant=kind[-1].upper(), order=2, horizon=0.3, n_trials=20, rate=20.0)
              if kind.startswith("gp") else WorstCaseMotionModel(horizon=0.3, rate=20.0))
    predictor = builder.AddSystem(HumanMotionPredictor(body, config, seed=1))
    scaler = builder.AddSystem(SpeedScaler(SeparationSpeedScaling(clearance=0.1, reaction_time=0.1,
                                                                  stopping_time=0.3, robot_speed=1.0)))
    robot = builder.AddSystem(ConstantValueSource(AbstractValue.Make(_robot_capsules())))
    builder.Connect(source.get_output_port(0), predictor.GetInputPort("skeleton_estimate"))
    builder.Connect(predictor.GetOutputPort("swept_volumes"), scaler.GetInputPort("swept_volumes"))
    builder.Connect(robot.get_output_port(0), scaler.GetInputPort("robot_capsules"))
    override_log = builder.AddSystem(VectorLogSink(1, 0.05))
    distance_log = builder.AddSystem(VectorLogSink(1, 0.05))
    builder.Connect(scaler.GetOutputPort("speed_override"), override_log.get_input_port())
    builder.Connect(scaler.GetOutputPort("min_distance"), distance_log.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    simulator.Initialize()
    # before any estimate: no human, full speed
    assert scaler.GetOutputPort("speed_override").Eval(scaler.GetMyContextFromRoot(context))[0] == 1.0
    simulator.AdvanceTo(1.6)
    swept = predictor.GetOutputPort("swept_volumes").Eval(predictor.GetMyContextFromRoot(context))
    assert isinstance(swept, SweptVolumes)
    assert swept.names == body.CAPSULE_NAMES and swept.start.shape == (6, 3)
    assert swept.horizon == pytest.approx(0.3)
    overrides = override_log.FindLog(context).data()[0]
    distances = distance_log.FindLog(context).data()[0]
    finite = np.isfinite(distances)
    assert finite.sum() > 20
    # the operator walks in: the clearance shrinks and the robot slows down, never above 1
    assert distances[finite][-1] < distances[finite].max() - 0.2
    assert np.all((overrides >= 0) & (overrides <= 1))
    assert overrides[-1] < 1.0
    # the override follows the rule applied to the logged clearance, one update later at most
    rule = scaler.rule
    expected = np.array([rule.override(d) for d in distances[finite]])
    assert np.allclose(overrides[finite], expected)


def test_bad_params_are_clear_errors():
    body = BodyModel()
    with pytest.raises(TypeError, match="ordr"):
        GPMotionModel(ordr=3)
    with pytest.raises(ConfigError, match=r"motion_model\.order: must be an integer"):
        HumanMotionPredictor(body, GPMotionModel(order=2.5))
    with pytest.raises(ConfigError, match=r"motion_model\.variant"):
        HumanMotionPredictor(body, GPMotionModel(variant="D"))
    with pytest.raises(TypeError, match="speed"):
        SeparationSpeedScaling(speed=1.0)
    with pytest.raises(ConfigError, match=r"speed_scaling\.robot_speed"):
        SpeedScaler(SeparationSpeedScaling(robot_speed=0.0))
    with pytest.raises(ConfigError, match=r"motion_model\.rate"):
        HumanMotionPredictor(body, WorstCaseMotionModel(rate=100.0))
    assert predictor_kwargs(GPMotionModel(percentile=-1))["percentile"] is None
    assert predictor_kwargs(GPMotionModel(variant="A"))["kind"] == "gp_a"
    assert predictor_kwargs(WorstCaseMotionModel())["kind"] == "worst_case"


def test_scaler_ahead_port_lets_a_retreating_robot_move():
    human = SweptVolumes(time=0.0, names=("torso",), start=np.array([[0.5, 0.0, 0.8]]),
                         end=np.array([[0.5, 0.0, 1.3]]), radius=np.array([0.2]), horizon=0.3)
    params = SeparationSpeedScaling(clearance=0.1, reaction_time=0.1, stopping_time=0.3, robot_speed=1.0,
                                    lookahead=0.1)
    overrides = {}
    for label, ahead_x in (("retreat", -0.05), ("approach", 0.2), ("unwired", None)):
        builder = DiagramBuilder()
        scaler = builder.AddSystem(SpeedScaler(params))
        swept = builder.AddSystem(ConstantValueSource(AbstractValue.Make(human)))
        robot = builder.AddSystem(ConstantValueSource(AbstractValue.Make(_robot_capsules())))  # link at x = 0
        builder.Connect(swept.get_output_port(0), scaler.GetInputPort("swept_volumes"))
        builder.Connect(robot.get_output_port(0), scaler.GetInputPort("robot_capsules"))
        if ahead_x is not None:
            start, end, radius = _robot_capsules()
            shift = np.array([ahead_x, 0.0, 0.0])
            moved = Capsules(start + shift, end + shift, radius)
            ahead = builder.AddSystem(ConstantValueSource(AbstractValue.Make(moved)))
            builder.Connect(ahead.get_output_port(0), scaler.GetInputPort("robot_capsules_ahead"))
        simulator = Simulator(builder.Build())
        simulator.Initialize()
        simulator.AdvanceTo(0.1)
        context = scaler.GetMyContextFromRoot(simulator.get_context())
        assert scaler.GetOutputPort("min_distance").Eval(context)[0] == pytest.approx(0.25)
        overrides[label] = scaler.GetOutputPort("speed_override").Eval(context)[0]
    # clearance 0.25: the plain rule (1 m/s) gives (0.25 - 0.1) / 0.25 = 0.6; closing in at 2 m/s
    # halves it; retreating is free
    assert overrides["unwired"] == pytest.approx(0.6)
    assert overrides["approach"] == pytest.approx(0.3)
    assert overrides["retreat"] == pytest.approx(1.0)
