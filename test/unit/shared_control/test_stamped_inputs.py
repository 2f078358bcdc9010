"""shared_control.stamped_inputs: each operator twist with the hand and the grasp shown at its stamp."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from grasp_intent_ros.errors import InvalidIntentError
from grasp_intent_ros.shared_control.stamped_inputs import Paired, StampedInputs

MS = 1_000_000
"""One millisecond in ns."""


def pose(x: float) -> np.ndarray:
    out = np.eye(4)
    out[0, 3] = x
    return out


def taken(pairs: list[Paired[str]]) -> list[tuple[str, float | None, float | None]]:
    """(command, hand x, proposal x) of each pair."""
    return [(p.command, None if p.hand is None else float(p.hand[0, 3]),
             None if p.proposal is None else float(p.proposal[0, 3])) for p in pairs]


def test_a_twist_waits_for_the_joint_state_after_its_stamp_and_takes_the_one_before() -> None:
    inputs: StampedInputs[str] = StampedInputs(wait=0.1)
    inputs.hand(10 * MS, pose(1.0))
    inputs.twist(15 * MS, 0.0, 'a')
    assert inputs.due(0.01) == [] and len(inputs) == 1  # the hand at 15 ms is not known yet
    inputs.hand(20 * MS, pose(2.0))
    assert taken(inputs.due(0.02)) == [('a', 1.0, None)]
    assert len(inputs) == 0


def test_a_twist_stamped_with_a_joint_state_takes_that_one() -> None:
    inputs: StampedInputs[str] = StampedInputs(wait=0.1)
    inputs.hand(10 * MS, pose(1.0))
    inputs.twist(10 * MS, 0.0, 'a')
    assert taken(inputs.due(0.0)) == [('a', 1.0, None)]


def test_the_grasp_shown_is_the_newest_stamped_before_the_twist_whatever_arrives_first() -> None:
    inputs: StampedInputs[str] = StampedInputs(wait=0.1)
    inputs.proposal(5 * MS, pose(-1.0))
    inputs.twist(12 * MS, 0.0, 'a')
    inputs.proposal(14 * MS, pose(-2.0))  # arrives before the hand that releases 'a', stamped after it
    inputs.twist(16 * MS, 0.0, 'b')
    inputs.proposal(11 * MS, pose(-3.0))  # late, stamped before both
    inputs.hand(10 * MS, pose(1.0))
    inputs.hand(20 * MS, pose(2.0))
    assert taken(inputs.due(0.0)) == [('a', 1.0, -3.0), ('b', 1.0, -2.0)]


def test_pairing_does_not_depend_on_arrival_order() -> None:
    """Every arrival order of the joint states and grasps before the twists pairs alike.

    The twists are released by a joint state stamped after them.
    """
    hands = [(s * MS, pose(float(s))) for s in (0, 10, 20, 30)]
    grasps = [(s * MS, pose(-float(s))) for s in (3, 17)]
    twists = [(s * MS, f't{s}') for s in (5, 15, 25)]
    results = set()
    for order in itertools.permutations([('h', h) for h in hands[:3]] + [('g', g) for g in grasps]):
        inputs: StampedInputs[str] = StampedInputs(wait=0.1)
        out: list[Paired[str]] = []
        for kind, (stamp, value) in order:
            (inputs.hand if kind == 'h' else inputs.proposal)(stamp, value)
        for stamp, name in twists:
            inputs.twist(stamp, 0.0, name)
        inputs.hand(*hands[3])
        out += inputs.due(0.0)
        results.add(tuple(taken(out)))
    assert results == {(('t5', 0.0, -3.0), ('t15', 10.0, -3.0), ('t25', 20.0, -17.0))}


def test_a_twist_whose_joint_state_is_late_is_taken_after_the_wait() -> None:
    inputs: StampedInputs[str] = StampedInputs(wait=0.1)
    inputs.hand(10 * MS, pose(1.0))
    inputs.twist(15 * MS, 1.0, 'a')
    inputs.twist(16 * MS, 1.05, 'b')
    assert inputs.due(1.09) == []
    assert taken(inputs.due(1.1)) == [('a', 1.0, None)]  # 'b' waits its own 0.1 s
    assert taken(inputs.due(1.16)) == [('b', 1.0, None)]


def test_unstamped_inputs_are_taken_as_they_come() -> None:
    inputs: StampedInputs[str] = StampedInputs(wait=0.1)
    inputs.twist(None, 0.0, 'a')
    assert taken(inputs.due(0.0)) == [('a', None, None)]  # no joint state yet: the caller does not use it
    inputs.hand(None, pose(1.0))
    inputs.proposal(None, pose(-1.0))
    inputs.twist(50 * MS, 0.0, 'b')  # the newest joint state has no stamp: the newest hand
    assert taken(inputs.due(0.0)) == [('b', 1.0, -1.0)]
    inputs.hand(60 * MS, pose(2.0))
    inputs.twist(None, 0.0, 'c')
    assert taken(inputs.due(0.0)) == [('c', 2.0, -1.0)]
    inputs.proposal(70 * MS, None)  # none shown from 70 ms
    inputs.twist(65 * MS, 0.0, 'd')
    inputs.twist(75 * MS, 0.0, 'e')
    inputs.hand(80 * MS, pose(3.0))
    assert taken(inputs.due(0.0)) == [('d', 2.0, -1.0), ('e', 2.0, None)]


def test_history_is_bounded_and_keeps_what_was_shown_before_it() -> None:
    inputs: StampedInputs[str] = StampedInputs(wait=0.1, history=2)
    for stamp in (10, 20, 30):
        inputs.hand(stamp * MS, pose(float(stamp)))
        inputs.proposal(stamp * MS, pose(-float(stamp)))
    inputs.twist(5 * MS, 0.0, 'old')  # older than every kept entry: the oldest hand, the grasp shown before
    assert taken(inputs.due(0.0)) == [('old', 20.0, -10.0)]


def test_settings_are_checked() -> None:
    for wait, history in ((0.0, 1), (float('nan'), 1), (0.1, 0)):
        with pytest.raises(InvalidIntentError):
            StampedInputs(wait=wait, history=history)
