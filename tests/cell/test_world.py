import pytest

from hrc_drake.cell.world import CellWorld
from hrc_drake.scheduling.flow import Buffer, FlowAction


def make_world():
    buffers = [
        Buffer(name="raw", kind="raw"),
        Buffer(name="mid", capacity=1),
        Buffer(name="out", kind="product"),
    ]
    actions = [
        FlowAction(name="make", agents=["r"], inputs=["raw"], outputs=["mid"]),
        FlowAction(name="finish", agents=["h"], inputs=["mid"], outputs=["out"], resources=["tool"]),
    ]
    return CellWorld(buffers, actions, {"tool": 1})


def test_start_takes_inputs_and_reserves_room():
    world = make_world()
    assert world.try_start("r", "make")
    # The one slot of `mid` is promised to the running action: a second start must wait.
    assert not world.try_start("r2", "make")
    assert world.parts["mid"] == 0
    world.finish("r", "make", time=1.0)
    assert world.parts["mid"] == 1
    assert not world.try_start("r", "make")


def test_products_and_resources():
    world = make_world()
    assert not world.try_start("h", "finish")
    world.try_start("r", "make")
    world.finish("r", "make")
    assert world.try_start("h", "finish")
    assert world.resource_free["tool"] == 0
    world.finish("h", "finish", time=5.0)
    assert world.finished_products == 1
    assert world.resource_free["tool"] == 1
    assert world.completions[-1].time == pytest.approx(5.0)
    assert world.parts["mid"] == 0


def test_actions_outside_the_flow_always_start():
    world = make_world()
    assert world.try_start("r", "go_home")
    world.finish("r", "go_home")
    assert world.parts == {"raw": 0, "mid": 0, "out": 0}
