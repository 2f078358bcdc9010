"""The demo's closed loop without ROS: its operator's parameters, the waits on a fake loop, the judge's lines."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import pytest

from grasp_intent_ros.launch.demo_loop import (
    OPERATOR_PARAMETERS,
    OPERATOR_TASKS,
    Episode,
    Hand,
    LoopError,
    Shown,
    format_episode,
    operator_args,
    wait_for_close,
)
from grasp_intent_ros.method.features import FINGERS
from grasp_intent_ros.method.registry import ModelFiles
from grasp_intent_ros.mico.frames import default_base_T_obj, features_to_obj_T_ee
from grasp_intent_ros.objects.demos import CUP_RULES
from grasp_intent_ros.objects.judge import judge, operator_verdict
from grasp_intent_ros.resources import config_dir
from grasp_intent_ros.shared_control.parameters import SCRIPTED_OPERATOR
from grasp_intent_ros.wire.diagnostics import KEY_EXECUTE, KEY_TIMES_TO_GRASP
from grasp_intent_ros.wire.joint_states import CLOSE_SETTLE

UT = 0b011
MODEL = ModelFiles(config_dir() / 'models').load('cup_7zone')
BASE_T_OBJ = default_base_T_obj()


def ut_grasp() -> tuple[np.ndarray, np.ndarray]:
    """A usage-and-transfer demonstration of the cup as a hand pose (base frame) and its closures."""
    x = MODEL.demo_x[int(np.flatnonzero(MODEL.demo_sets == UT)[0])]
    assert CUP_RULES.label(x) == UT
    return BASE_T_OBJ @ features_to_obj_T_ee(x), x[FINGERS]


def test_the_operators_parameters_are_its_own_and_valid() -> None:
    specs = {spec.name: spec for spec in SCRIPTED_OPERATOR}
    for name, value in OPERATOR_PARAMETERS.items():
        spec = specs[name]  # a name the node does not declare would be ignored without a word
        assert isinstance(value, (list, tuple)) == isinstance(spec.default, (list, tuple)), name
        if spec.range is not None:
            assert spec.range[0] <= value <= spec.range[1], name
        if spec.validator is not None:
            spec.validator(list(value) if isinstance(value, tuple) else value)
    args = operator_args()
    assert args[::2] == ['-p'] * len(OPERATOR_PARAMETERS)
    assert 'intent:=none' in args and 'task_set:=[usage,transfer]' in args and 'execute_shown:=true' in args


# ------------------------------------------------------------------------------------------ a fake loop
@dataclass
class FakeLoop:
    """A loop on a fake clock: ``events`` (time s, change) happen as :meth:`wait` advances it in 10 ms steps."""

    events: list[tuple[float, Callable[[FakeLoop], None]]]
    now: float = 0.0
    status: tuple[float, str, Mapping[str, str]] | None = None
    base_T_ee: np.ndarray = field(default_factory=lambda: np.eye(4))
    fingers: np.ndarray = field(default_factory=lambda: np.zeros(3))
    fingers_at_rest: bool = True
    moving: list[float] = field(default_factory=list)
    alpha: list[tuple[float, float]] = field(default_factory=list)
    grasp: Shown | None = None

    def wait(self, predicate: Callable[[], object], timeout: float) -> bool:
        deadline = self.now + timeout
        while not predicate():
            if self.now >= deadline:
                return False
            self.now = round(self.now + 0.01, 9)
            while self.events and self.events[0][0] <= self.now:
                self.events.pop(0)[1](self)
        return True

    def operator_status(self) -> tuple[float, str, Mapping[str, str]] | None:
        return self.status

    def hand(self) -> Hand | None:
        return Hand(self.now, self.base_T_ee, self.fingers.copy(), self.fingers_at_rest)

    def shown(self) -> Shown | None:
        return self.grasp

    def plans(self) -> int:
        return int(self.grasp is not None)

    def operator_motion(self, since: float) -> tuple[float, float] | None:
        times = [t for t in self.moving if t > since]
        return (times[0], times[-1]) if times else None

    def alphas(self, start: float, end: float) -> np.ndarray:
        return np.array([a for t, a in self.alpha if start <= t <= end])


def reaching_loop() -> FakeLoop:
    base_T_grasp, closures = ut_grasp()
    base_T_ee = base_T_grasp.copy()
    base_T_ee[:3, 3] += (0.12, 0.0, 0.0)
    return FakeLoop([], status=(0.0, 'reaching the shown grasp', {KEY_TIMES_TO_GRASP: ''}), base_T_ee=base_T_ee,
                    grasp=Shown(base_T_grasp, closures))


def test_an_operator_that_never_closes_the_hand_is_named_with_where_the_hand_is() -> None:
    loop = reaching_loop()
    with pytest.raises(LoopError) as raised:
        wait_for_close(loop, 1, 0.0, True, 1.0)
    assert str(raised.value) == ('episode 1: the scripted operator did not close the hand within 1 s of its '
                                 "release (the scripted operator: 'reaching the shown grasp'; the hand 12.0 cm and "
                                 '0.00 rad from the grasp shown)')
    assert loop.now == pytest.approx(1.0)


def test_fingers_that_never_come_to_rest_are_named() -> None:
    loop = reaching_loop()
    loop.events = [(0.2, lambda f: setattr(f, 'status', (f.now, 'holding', {KEY_TIMES_TO_GRASP: '4.00'}))),
                   (0.2, lambda f: setattr(f, 'fingers_at_rest', False))]
    with pytest.raises(LoopError, match=r'^episode 1: the fingers were not at rest within 2 s of the operator'):
        wait_for_close(loop, 1, 0.0, True, 2.0)


def test_an_episode_is_read_once_the_fingers_rest_after_the_close() -> None:
    loop = reaching_loop()
    base_T_grasp, planned = loop.grasp.base_T_grasp, loop.grasp.closures  # type: ignore[union-attr]
    executed = planned + (0.03, -0.02, 0.01)

    def arrive(f: FakeLoop) -> None:  # the executed trajectory's end: the hand at the grasp, the plan's closures
        f.base_T_ee, f.fingers, f.moving = base_T_grasp, planned.copy(), [0.5, 1.0, 2.0, 3.2]
        f.alpha = [(0.4, 0.2), (1.0, 0.4), (2.0, 0.9), (3.2, 0.5), (3.3, 0.0)]

    def report(f: FakeLoop) -> None:  # the status of the close, one tick before the close request is served
        f.status = (f.now, 'done: episode 1 reached the shown grasp in 4.86 s (executed)',
                    {KEY_TIMES_TO_GRASP: '4.86', KEY_EXECUTE: 'following the latest trajectory from now (0.10 s)'})

    def close(f: FakeLoop) -> None:
        f.fingers_at_rest = False

    def rest(f: FakeLoop) -> None:
        f.fingers, f.fingers_at_rest = executed.copy(), True

    loop.events = [(3.5, arrive), (4.0, report), (4.02, close), (4.1, rest)]
    episode = wait_for_close(loop, 1, 0.0, True, 10.0)
    assert loop.now == pytest.approx(4.0 + CLOSE_SETTLE)  # not at 4.0, where the fingers rested at the plan's closures
    np.testing.assert_array_equal(episode.hand.fingers, executed)
    assert episode.time_to_grasp == 4.86 and episode.moving == pytest.approx(2.7)
    np.testing.assert_array_equal(episode.alphas, [0.4, 0.9, 0.5])  # those received while the operator moved
    assert episode.execute == 'following the latest trajectory from now (0.10 s)'

    lines = format_episode(episode, MODEL, BASE_T_OBJ).splitlines()
    assert lines[0] == "robot's share     alpha mean 0.60, max 0.90 while the operator moved the hand, 2.7 s"
    assert lines[1] == "time to grasp     from the operator's reach to the fingers' close, 4.86 s"
    assert lines[2] == ('grasp command     grasp/execute (following the latest trajectory from now (0.10 s)), '
                        'then grasp/close')
    assert lines[3] == 'hand ended        0.0 mm, 0.000 rad from the grasp shown'
    assert lines[5] == ("serves (rules)    usage, transfer (UT) at the reached pose: the operator's tasks served")


def test_a_hand_closed_where_the_operator_stopped_is_judged_there() -> None:
    base_T_grasp, closures = ut_grasp()
    base_T_ee = base_T_grasp.copy()
    base_T_ee[2, 3] += 0.05  # 5 cm above it: the palm over the cup's rim, no usage
    episode = Episode(2, False, 5.0, np.zeros(3), 4.0, Hand(0.0, base_T_ee, closures, True),
                      Shown(base_T_grasp, closures), '')
    lines = format_episode(episode, MODEL, BASE_T_OBJ).splitlines()
    verdict = judge(MODEL, BASE_T_OBJ, base_T_ee, closures)
    assert lines[2] == 'grasp command     grasp/close where the operator stopped'
    assert lines[3] == 'hand ended        50.0 mm, 0.000 rad from the grasp shown'
    assert lines[5] == (f'serves (rules)    {verdict.text} at the reached pose: '
                        + operator_verdict(verdict, OPERATOR_TASKS, MODEL.task_names))
    assert verdict.label is not None and not verdict.label & 1  # the rules judge where the hand ended, not the grasp
