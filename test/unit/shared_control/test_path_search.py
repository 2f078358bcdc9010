"""grasp_intent_ros.shared_control.path_search: what clears the joint paths, and a search in a process of its own."""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import held_search
import numpy as np
from numpy.testing import assert_allclose
from numpy.typing import NDArray

from grasp_intent_ros.method.body import Cylinder, ObjectBody
from grasp_intent_ros.mico.collision import HandCollision
from grasp_intent_ros.mico.kinematics import HOME_Q, MicoKinematics
from grasp_intent_ros.shared_control.assistance import Assistance, Command
from grasp_intent_ros.shared_control.assistance_config import AssistanceConfig
from grasp_intent_ros.shared_control.clearance import PathClearance
from grasp_intent_ros.shared_control.limits import TwistLimiter
from grasp_intent_ros.shared_control.path_search import PathAnswer, PathRequest, PathSearch, PathWorker, seek_path
from grasp_intent_ros.shared_control.robot_twist import joint_space_twist

from .robot_alone import LABELS, TASKS

CUP = ObjectBody((Cylinder(np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, 1.0]), 0.04, 0.1),))
STILL = np.zeros(6)
END_TIMEOUT = 60.0
"""Seconds a test that asserts the worker's clean end (exit code 0) lets it take: the node's 1 s kills a process
that a loaded machine keeps from ending in time."""
"""The operator's twist: no input (the tests' assistance assists without input)."""


class Held:
    """A path source that seeks at once (:class:`PathSearch`) while ``answering``, else holds its last answer."""

    def __init__(self, kin: MicoKinematics) -> None:
        self.inner = PathSearch(kin)
        self.answering = True
        self.last: PathAnswer | None = None
        self.asked: list[tuple[int, int, str]] = []

    def seek(self, request: PathRequest) -> PathAnswer | None:
        self.asked.append(request.key)
        if self.answering:
            self.last = self.inner.seek(request)
        last = self.last
        return last if last is not None and (last.key[0], last.key[2]) == (request.key[0], request.key[2]) else None


def assisting(kin: MicoKinematics) -> tuple[Assistance, NDArray[np.float64], NDArray[np.float64]]:
    """An assistance at Home with a grasp 5 cm ahead (in the corridor), a cup 20 cm below it, v certain."""
    assistance = Assistance(AssistanceConfig(assist_without_input=True), TwistLimiter(0.2, 1.0, 1.0, 5.0), kin)
    assistance.set_joints(np.asarray(HOME_Q, dtype=np.float64).copy())
    assert assistance.base_T_ee is not None
    grasp = assistance.base_T_ee.copy()
    grasp[:3, 3] += 0.05 * grasp[:3, 2]
    base_T_obj = np.eye(4)
    base_T_obj[:3, 3] = grasp[:3, 3] + (0.0, 0.0, -0.2)
    assistance.set_grasp(grasp)
    assistance.set_object(base_T_obj, CUP)
    assistance.set_v(np.eye(7)[0], LABELS)
    assistance.set_posterior(np.eye(7)[0], LABELS, TASKS)
    return assistance, grasp, base_T_obj


def step(assistance: Assistance, now: float) -> Command:
    assistance.set_operator(STILL, now)
    return assistance.command(now)


def test_a_repeated_grasp_or_object_keeps_the_path_in_use_while_it_is_sought_again(kin: MicoKinematics) -> None:
    assistance, grasp, base_T_obj = assisting(kin)
    held = Held(kin)
    assistance.paths = held
    assert step(assistance, 0.0).phase == 'grasp'
    held.answering = False  # from now on a search takes until answering is set
    assistance.set_grasp(grasp.copy())  # the planner's same plan again: bit-identical
    assistance.set_object(base_T_obj.copy(), CUP)  # the tracker's same pose again
    command = step(assistance, 0.01)
    assert command.alpha > 0.0 and command.phase == 'grasp'  # the path in use
    assert held.asked[-1][0] == held.asked[0][0] and held.asked[-1][1] > held.asked[0][1]  # and sought again
    moved = grasp.copy()
    moved[0, 3] = np.nextafter(moved[0, 3], np.inf)  # one ulp: another grasp
    shifted = base_T_obj.copy()
    shifted[0, 3] += 1e-9
    other_cup = ObjectBody((Cylinder(np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, 1.0]), 0.04, 0.1),))  # equal
    changes = (lambda: assistance.set_grasp(moved), lambda: assistance.set_object(shifted, CUP),
               lambda: assistance.set_object(shifted, other_cup),
               lambda: (setattr(assistance, 'config', replace(assistance.config, clearance_margin=0.01)),
                        assistance.set_object(shifted, other_cup)))
    for i, change in enumerate(changes):
        change()
        command = step(assistance, 0.02 + 0.01 * i)
        assert command.alpha == 0.0 and command.phase == 'seeking a path', i  # no path of this grasp and object
        held.answering = True
        assert step(assistance, 0.02 + 0.01 * i).phase == 'grasp'
        held.answering = False


def test_a_via_point_reached_stays_behind_while_the_path_is_sought_again(kin: MicoKinematics) -> None:
    # the path's first point is popped when reached; the same grasp again keeps the path as it is (the via point
    # stays behind) until the new search answers
    assistance, grasp, _ = assisting(kin)
    q = np.asarray(HOME_Q, dtype=np.float64)
    via, end = q + 0.01, q + 0.2
    held = Held(kin)
    held.answering = False
    assistance.paths = held
    assistance._q_targets['grasp'] = (assistance._generation, [via, end])
    step(assistance, 0.0)  # within VIA_REACHED of the via point: on to the end
    assistance.set_grasp(grasp.copy())
    command = step(assistance, 0.01)
    assert command.alpha > 0.0 and assistance._q_targets['grasp'][1] == [end]
    expected = joint_space_twist(kin.jacobian(q), q, end, gain=2.0, max_linear=0.15, max_angular=0.8)
    assert_allclose(assistance.robot()[0], expected, atol=1e-12)  # toward the end, not back to the via point


def test_while_the_path_is_sought_the_output_is_the_operators_alone(kin: MicoKinematics) -> None:
    assistance, _, _ = assisting(kin)
    held = Held(kin)
    held.answering = False
    assistance.paths = held
    operator = np.array([0.0, 0.0, 0.01, 0.0, 0.0, 0.0])
    assistance.set_operator(operator, 0.0)
    command = assistance.command(0.0)
    assert command.alpha == 0.0 and command.phase == 'seeking a path'
    assert_allclose(command.twist, operator, atol=0.0)  # within the limits: exactly the operator's
    held.answering = True
    assistance.set_operator(operator, 0.01)
    command = assistance.command(0.01)
    assert command.alpha > 0.0 and command.phase == 'grasp'


def wait_until(condition: Callable[[], object], timeout: float = 60.0) -> bool:
    """Poll ``condition`` until true or ``timeout`` s pass (a condition with a deadline); whether it became true."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        threading.Event().wait(0.002)
    return True


def test_the_worker_seeks_in_a_process_of_its_own_and_answers_as_this_one(kin: MicoKinematics) -> None:
    assistance, grasp, base_T_obj = assisting(kin)
    request = PathRequest((1, 1, 'grasp'), assistance.q.copy(), grasp, grasp, 0.05, 0.05,
                          PathClearance(kin, HandCollision(), CUP, base_T_obj))
    errors: list[str] = []
    worker = PathWorker(name='paths under test', on_error=errors.append)
    try:
        assert worker.pid != os.getpid()
        assert worker.wait_ready(60.0)  # its models built and its warm-up run
        answers: list[PathAnswer | None] = []
        assert wait_until(lambda: answers.append(worker.seek(request)) or answers[-1] is not None)
        answer, here = answers[-1], seek_path(kin, request)
        assert answer is not None and answer.key == request.key and answer.cleared == here.cleared
        assert answer.path is not None and here.path is not None
        for a, b in zip(answer.path, here.path, strict=True):
            assert_allclose(a, b, atol=0.0)  # the same search on the same inputs: the same answer
    finally:
        worker.stop(timeout=END_TIMEOUT)
    assert worker.returncode == 0 and not errors  # ended by the request, not killed


def test_the_worker_seeks_the_newest_request_only(kin: MicoKinematics, tmp_path: Path) -> None:
    (tmp_path / 'armed').touch()
    assistance, grasp, _ = assisting(kin)
    errors: list[str] = []
    worker = PathWorker(name='paths under test', on_error=errors.append,
                        search=functools.partial(held_search.held, tmp_path))
    try:
        assistance.paths = worker
        assert step(assistance, 0.0).alpha == 0.0
        assert wait_until((tmp_path / 'started').exists)  # the first request is being sought
        assert step(assistance, 0.01).alpha == 0.0  # the same request is not handed over twice
        for dy in (0.01, 0.02):  # two newer requests while the first is sought: the second replaces the first
            moved = grasp.copy()
            moved[:3, 3] += (0.0, dy, 0.0)
            assistance.set_grasp(moved)
            assert step(assistance, 0.02).alpha == 0.0
        (tmp_path / 'release').touch()
        now = [0.02]

        def assisted() -> bool:
            now[0] += 0.01
            return step(assistance, now[0]).alpha > 0.0
        assert wait_until(assisted)
        pids = (tmp_path / 'sought').read_text().split()
        assert pids == [str(worker.pid)] * 2  # in the worker's process: the first, then the newest only
        assert np.array_equal(np.load(tmp_path / 'grasp_0.npy'), grasp)
        assert np.array_equal(np.load(tmp_path / 'grasp_1.npy'), moved)
        assert not errors
    finally:
        (tmp_path / 'release').touch()
        worker.stop()


def test_a_search_that_raises_answers_no_path_and_is_reported(kin: MicoKinematics) -> None:
    assistance, grasp, _ = assisting(kin)
    request = PathRequest((1, 1, 'grasp'), assistance.q.copy(), grasp, grasp, 0.05, 0.05, None)
    errors: list[str] = []
    worker = PathWorker(name='paths under test', on_error=errors.append, search=held_search.failing)
    try:
        answers: list[PathAnswer | None] = []
        assert wait_until(lambda: answers.append(worker.seek(request)) or answers[-1] is not None)
        assert answers[-1] == PathAnswer(request.key, None, False)
        assert len(errors) == 1 and 'RuntimeError: a search that fails' in errors[0]
        second = replace(request, key=(1, 2, 'grasp'))
        assert wait_until(lambda: worker.seek(second) == PathAnswer(second.key, None, False))  # it serves on
    finally:
        worker.stop(timeout=END_TIMEOUT)
    assert worker.returncode == 0


def test_the_process_ends_with_its_caller() -> None:
    # a caller that ends without stopping the worker (killed, say): the worker's process ends too, none left behind
    code = ('import os; from grasp_intent_ros.shared_control.path_search import PathWorker; '
            'worker = PathWorker(name="orphan", on_error=print); print(worker.pid, flush=True); os._exit(0)')
    caller = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120, check=True)
    pid = int(caller.stdout.split()[0])

    def ended() -> bool:
        try:
            state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
        except FileNotFoundError:
            return True
        return state in ('Z', 'X')  # ended (a zombie until its new parent reaps it)
    assert wait_until(ended)
