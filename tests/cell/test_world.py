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


def _request(t, agent, action, kind, seq):
    from hrc_drake.messages import WorldRequest

    return WorldRequest(time=t, agent=agent, action=action, kind=kind, seq=seq)


def test_requests_are_arbitrated_finishes_first_then_oldest_start():
    world = CellWorld(
        [Buffer(name="raw", kind="raw"), Buffer(name="mid", capacity=1), Buffer(name="out", kind="product")],
        [
            FlowAction(name="make", agents=["r"], inputs=["raw"], outputs=["mid"]),
            FlowAction(name="use_a", agents=["a"], inputs=["mid"], outputs=["out"]),
            FlowAction(name="use_b", agents=["b"], inputs=["mid"], outputs=["out"]),
        ],
    )
    # both users ask for the one part before it exists: both refused, both pending
    world.handle_requests([_request(1.0, "b", "use_b", "start", 1), _request(0.9, "a", "use_a", "start", 1)])
    assert world.refused == {"a": 1, "b": 1} and not world.granted
    assert world.handle_requests([_request(1.0, "r", "make", "start", 1)]) is None
    assert world.granted == {"r": 1} and world.running == {"r": "make"}
    # the maker's finish is applied before the pending starts: the oldest request (a) gets the part
    world.handle_requests([_request(2.0, "r", "make", "finish", 2)])
    assert world.granted == {"r": 1, "a": 1} and "b" in world.pending and world.parts["mid"] == 0
    # b keeps waiting until another part arrives
    world.handle_requests([_request(3.0, "r", "make", "start", 3), _request(3.0, "a", "use_a", "finish", 2)])
    assert world.finished_products == 1 and "b" in world.pending
    world.handle_requests([_request(4.0, "r", "make", "finish", 4)])
    assert world.granted["b"] == 1 and not world.pending
    snapshot = world.snapshot(4.0)
    assert snapshot.granted == world.granted and snapshot.refused == world.refused


def test_a_clone_shares_nothing_an_update_changes():
    world = CellWorld(
        [Buffer(name="raw", kind="raw"), Buffer(name="mid", capacity=2)],
        [FlowAction(name="make", agents=["r"], inputs=["raw"], outputs=["mid"])],
    )
    copy = world.clone()
    copy.handle_requests([_request(0.0, "r", "make", "start", 1), _request(0.0, "r", "make", "finish", 2)])
    assert copy.parts["mid"] == 1 and copy.granted == {"r": 1}
    assert world.parts["mid"] == 0 and not world.granted and not world.running and not world.completions
