"""Assembly flows of the thesis scheduling examples (figures are missing from the text, so the
flows below are reconstructions from the captions and prose; each says what is assumed).

The `fig_*` / `use_case_*` functions return (flow, buffers, human_pattern, robot_agents) ready
for `compile_flow`; `fig_6_5_example_a` and `fig_6_5_example_b` return small PcTPN directly.
"""

from __future__ import annotations

import numpy as np

from hrc_drake.distributions import Distribution
from hrc_drake.scheduling.flow import Buffer, Flow, FlowAction
from hrc_drake.scheduling.petri import PcTPN


def _u(low, high):
    return Distribution(kind="uniform", low=low, high=high)


def _n(mean, std):
    return Distribution(kind="normal", mean=mean, std=std)


def fig_6_5_example_a() -> PcTPN:
    """Fig. 6.5, Example A (reconstructed from 6.2.1; the figure is missing): transitions 1 and 2,
    uncontrollable, U[0, 1] and U[0, 0.75], both enabled in m0 and in conflict for the token of
    place p0 (firing one disables the other). Expected: alpha_bar_1 in [0, 1], alpha_bar_2 in
    [0, 0.75]; the real support of alpha_1 is [0, 0.75]."""
    pre = np.array([[1, 1], [0, 0], [0, 0]])
    post = np.array([[0, 0], [1, 0], [0, 1]])
    return PcTPN(
        ["p0", "p1", "p2"], ["t1", "t2"], pre, post, [False, False], [_u(0.0, 1.0), _u(0.0, 0.75)],
        [1, 0, 0], [0.0, 0.0, 0.0],
    )


def fig_6_5_example_b() -> PcTPN:
    """Fig. 6.5, Example B (reconstructed from 6.2.1; the figure is missing): transitions 1 and 2
    as in Example A, each preceded by a deterministic transition, 3 before 1 and 4 before 2, and
    in conflict for the token of place r. The delays of 3 and 4 are not given; 0 s and 0.5 s are
    the values that give the unconditioned supports the text states, alpha_bar_1 in [0, 1] and
    alpha_bar_2 in [0.5, 1.25], with real support of alpha_2 [0.5, 1]."""
    places = ["p3", "p4", "q1", "q2", "r", "p1", "p2"]
    names = ["t1", "t2", "t3", "t4"]
    pre = np.zeros((7, 4), dtype=int)
    post = np.zeros((7, 4), dtype=int)
    pre[[2, 4], 0] = 1  # t1: q1 + r -> p1
    post[5, 0] = 1
    pre[[3, 4], 1] = 1  # t2: q2 + r -> p2
    post[6, 1] = 1
    pre[0, 2], post[2, 2] = 1, 1  # t3: p3 -> q1
    pre[1, 3], post[3, 3] = 1, 1  # t4: p4 -> q2
    delays = [_u(0.0, 1.0), _u(0.0, 0.75), Distribution("fixed", mean=0.0), Distribution("fixed", mean=0.5)]
    return PcTPN(places, names, pre, post, [False] * 4, delays, [1, 1, 0, 0, 1, 0, 0], np.zeros(7))


def fig_7_6():
    """Fig. 7.6 / Table 7.1: robot action 1 (U[3,3]), human action 2 (U[2,4]), collaborative
    action 3 (U[5,7]); wait quantum U[1,1]. Assumed flow: 1 and 2 each feed a one-slot buffer
    that the collaborative action 3 empties; the human alternates 2 and 3."""
    buffers = [
        Buffer("raw", kind="raw"),
        Buffer("b1", capacity=1),
        Buffer("b2", capacity=1),
        Buffer("done", kind="product"),
    ]
    flow = Flow(
        actions=[
            FlowAction("action1", ["robot"], ["raw"], ["b1"], duration=Distribution("fixed", mean=3.0)),
            FlowAction("action2", ["human"], ["raw"], ["b2"], duration=_u(2.0, 4.0)),
            FlowAction("action3", ["human", "robot"], ["b1", "b2"], ["done"], duration=_u(5.0, 7.0)),
        ]
    )
    return flow, buffers, ["action2", "action3"], ["robot"]


def fig_7_11():
    """Fig. 7.11: two sequential jobs A and B of three actions; each of R1, R2, H does one action
    per job; durations N(15 s, 1.67 s); human pattern A, A, B, B. Assumed orders:
    job A = R1 -> H -> R2, job B = R2 -> H -> R1, one-slot buffers in between."""
    d = _n(15.0, 1.67)
    buffers = [Buffer("raw", kind="raw"), Buffer("product", kind="product")]
    buffers += [Buffer(name, capacity=1) for name in ("a1", "a2", "b1", "b2")]
    flow = Flow(
        actions=[
            FlowAction("A1", ["r1"], ["raw"], ["a1"], duration=d),
            FlowAction("A2", ["human"], ["a1"], ["a2"], duration=d),
            FlowAction("A3", ["r2"], ["a2"], ["product"], duration=d),
            FlowAction("B1", ["r2"], ["raw"], ["b1"], duration=d),
            FlowAction("B2", ["human"], ["b1"], ["b2"], duration=d),
            FlowAction("B3", ["r1"], ["b2"], ["product"], duration=d),
        ]
    )
    return flow, buffers, ["A2", "A2", "B2", "B2"], ["r1", "r2"]


def use_case_a(pattern: int = 1, early_release: bool = True, checked_stock: int = 1):
    """Use case a (7.2.1, 7.5.1): fuse (YuMi left), IC (human), quality check (both arms),
    collaborative macro-operation (human + both arms). Durations are not given in the text:
    assumed N(6,1), N(12,1.5), N(6,1), N(14,1.5) s. Pattern 1: IC, collab; pattern 2:
    IC, IC, collab, collab.

    One checked board is in stock at the start (assumed; `checked_stock`). With empty buffers
    and pattern 1 the collaboration always needs the board the human has just finished, so the human waits for
    its quality check every cycle (>= IC + check + collab = 32 s per product whatever the
    scheduler); with one board of stock the check runs during the next IC, which is how the
    pcTPN scheduler of Fig. 7.15 has the robots ready when the human is (27.63 s per product).
    As in Fig. 7.3 the left arm ends its part of the collaboration before the right
    (`early_release`; its part's duration, N(5, 0.5) s, is assumed)."""
    buffers = [
        Buffer("feeder", kind="raw"),
        Buffer("fused", capacity=2),
        Buffer("with_ic", capacity=2),
        Buffer("checked", capacity=2, initial=checked_stock),
        Buffer("product", kind="product"),
    ]
    flow = Flow(
        actions=[
            FlowAction("fuse", ["yumi_left"], ["feeder"], ["fused"], duration=_n(6.0, 1.0)),
            FlowAction("ic", ["human"], ["fused"], ["with_ic"], duration=_n(12.0, 1.5)),
            FlowAction("check", ["yumi_left", "yumi_right"], ["with_ic"], ["checked"], duration=_n(6.0, 1.0)),
            FlowAction(
                "collab",
                ["human", "yumi_left", "yumi_right"],
                ["checked"],
                ["product"],
                duration=_n(14.0, 1.5),
                early_release={"yumi_left": _n(5.0, 0.5)} if early_release else {},
            ),
        ]
    )
    if pattern == 1:
        human = ["ic", "collab"]
    elif pattern == 2:
        human = ["ic", "ic", "collab", "collab"]
    else:
        raise ValueError(f"use_case_a: pattern must be 1 or 2, got {pattern}")
    return flow, buffers, human, ["yumi_left", "yumi_right"]


def use_case_b(pattern: int = 1):
    """Reconstruction of use case b (7.5.2, Fig. 7.18; the net itself is not in the text), the
    flow of the cell `diagrams/carts.yaml` (a test keeps the two equal). Human: padding the box,
    trimming a label, labelling. IRB 140: functional test, storing. YuMi (two arm agents): cap
    assembly (right), housing in two parts: the first with the box on cart 1 (left arm), after
    which cart 1 is released, the second onto cart 2 (right arm), which takes it to the human.
    Each cart is a transport block of 6.3.4 with its way back; the token buffers cart<k>_home /
    cart<k>_empty say where it is. Carts cost nothing idle (`USE_CASE_B_AGENT_COSTS`).
    Durations assumed. Pattern 1: pad, trim, label; pattern 2: pad, pad, trim, trim, label, label."""
    buffers = [
        Buffer("boxes", kind="raw"),
        Buffer("sheets", kind="raw"),
        Buffer("adapters", kind="raw"),
        Buffer("padded", capacity=2),
        Buffer("cart1_home", capacity=1, initial=1),
        Buffer("box_at_yumi", capacity=1),
        Buffer("cart1_empty", capacity=1),
        Buffer("tested", capacity=2),
        Buffer("capped", capacity=2),
        Buffer("half_housed", capacity=1),
        Buffer("cart2_home", capacity=1, initial=1),
        Buffer("housed", capacity=1),
        Buffer("at_human", capacity=1),
        Buffer("cart2_empty", capacity=1),
        Buffer("labels", capacity=2),
        Buffer("labelled", capacity=1),
        Buffer("shipped", kind="product"),
    ]
    move = _n(2.4, 0.3)
    flow = Flow(
        actions=[
            FlowAction("pad", ["human"], ["boxes"], ["padded"], duration=_n(8.0, 1.5)),
            FlowAction("cart1_go", ["cart1"], ["padded", "cart1_home"], ["box_at_yumi"], duration=move),
            FlowAction("test", ["irb140"], ["adapters"], ["tested"], duration=_n(6.0, 0.8)),
            FlowAction("cap", ["yumi_right"], ["tested"], ["capped"], duration=_n(6.0, 0.8)),
            FlowAction("house1", ["yumi_left"], ["capped", "box_at_yumi"], ["half_housed", "cart1_empty"],
                       duration=_n(5.0, 0.6)),
            FlowAction("cart1_back", ["cart1"], ["cart1_empty"], ["cart1_home"], duration=move),
            FlowAction("house2", ["yumi_right"], ["half_housed", "cart2_home"], ["housed"],
                       duration=_n(5.0, 0.6)),
            FlowAction("cart2_go", ["cart2"], ["housed"], ["at_human"], duration=move),
            FlowAction("trim", ["human"], ["sheets"], ["labels"], duration=_n(6.0, 1.0)),
            FlowAction("label", ["human"], ["at_human", "labels"], ["labelled", "cart2_empty"],
                       duration=_n(5.0, 1.0)),
            FlowAction("cart2_back", ["cart2"], ["cart2_empty"], ["cart2_home"], duration=move),
            FlowAction("store", ["irb140"], ["labelled"], ["shipped"], duration=_n(5.0, 0.6)),
        ],
    )
    if pattern == 1:
        human = ["pad", "trim", "label"]
    elif pattern == 2:
        human = ["pad", "pad", "trim", "trim", "label", "label"]
    else:
        raise ValueError(f"use_case_b: pattern must be 1 or 2, got {pattern}")
    return flow, buffers, human, ["yumi_right", "yumi_left", "irb140", "cart1", "cart2"]


USE_CASE_B_AGENT_COSTS = {"cart1": 0.0, "cart2": 0.0}
