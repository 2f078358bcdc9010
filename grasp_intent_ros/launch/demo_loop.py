"""The demo's closed loop: a scripted operator with an ambiguous intent, helped to a grasp that serves its tasks.

The demo starts the scripted operator with the suite (:func:`operator_args`), held back: ``intent: none`` (it
publishes no w) and ``start_delay`` :data:`HELD_BACK` s (it sends zero twists), so the paper's cases run
undisturbed. For this section (:func:`run_closed_loop`) the demo switches the model server to :data:`LOOP_MODEL`,
sets the operator's ``intent`` to ``held`` (w = :data:`OPERATOR_W` with N(0, s^2) noise per task, s =
:data:`OPERATOR_W_NOISE`, every 0.1 s, seeded by :data:`OPERATOR_SEED`), waits for the grasp the planner shows
for it, and releases the reach (``start_delay`` 0). The operator, who wants :data:`OPERATOR_TASKS`, drives the
mock MICO under the assistance; at the shown grasp the suite's grasp command executes it (``grasp/execute``) and
closes the fingers (``grasp/close``). Then, for comparison, the same operator once more with the help off
(``assistance/enable`` false; ``execute_shown`` false: direct teleoperation closes the hand where the operator
stops, as the benchmarks' baseline), after the operator's reset of the arm (``episodes`` 2).

Printed per episode: the robot's share while the operator moved the hand (mean and max of ``assistance/alpha``
received between its first and last non-zero ``operator/twist``), the operator's time to grasp (its status: from
its reach's start to the fingers' close, an execution included), where the hand ended (the mock arm's
``joint_states`` through the MICO's forward kinematics) against the grasp shown at the close, and the judge's
verdict (:mod:`~grasp_intent_ros.objects.judge`, the object pose of the planner) at that pose with the closures the
fingers executed (the mock arm's finger positions, which carry its seeded closure error). The judge only reads:
nothing it finds reaches the operator, the planner or the assistance.

What repeats from run to run. With the help on, the hand ends at the shown grasp (the executed trajectory's end:
the planner's IK of the grasp, within its 0.1 mm and 1 mrad) and the fingers at the plan's closures plus the mock
arm's first seeded closure error, so the verdict is the same on every run as long as the planner shows the same
grasp for the noisy held w (the same demonstration: the planner's default method chose it for each of 2000 draws
of the noise, planned offline with the node's default options). The times, the alpha figures and, with the help
off, where the operator stops (anywhere within its 1 cm and 0.1 rad of the grasp, as the wall clock's timing
falls) vary; so may the help-off verdict. The fingers' closures without help repeat too (the same plan's, the
mock arm's second closure error).

Waits: each stage waits up to the demo's ``timeout`` (the grasp shown, the operator's close, the fingers at
rest); a stage that does not complete raises :class:`LoopError` naming what is missing (the demo prints it and
exits 1). The fingers are read once at rest (:func:`~grasp_intent_ros.wire.joint_states.fingers_settled`: still
within the rest rule's tolerance for its window, from their positions) in joint states received at least
:data:`~grasp_intent_ros.wire.joint_states.CLOSE_SETTLE` s after the operator's status reported the close (the
close request is served in milliseconds; the status may arrive up to its 1 s period after it).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped
from numpy.typing import NDArray
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64
from std_srvs.srv import SetBool

from ..errors import GraspIntentError
from ..method.model import GraspModel
from ..mico.frames import offset
from ..mico.kinematics import BASE_FRAME, FINGER_JOINTS, MicoKinematics
from ..objects.judge import judge, operator_verdict
from ..ros.qos import STREAM_DEPTH, input_qos
from ..wire import topics
from ..wire.diagnostics import KEY_EXECUTE, KEY_TIMES_TO_GRASP, OPERATOR_COMPONENT
from ..wire.joint_states import CLOSE_SETTLE, Hand, HandTracker, fingers_settled
from ..wire.model_document import ModelDocument
from ..wire.robot_state import joint_positions, pose_msg_to_matrix

__all__ = ['LOOP_MODEL', 'OPERATOR_TASKS', 'OPERATOR_W', 'OPERATOR_W_NOISE', 'OPERATOR_SEED', 'HELD_BACK',
           'OPERATOR_PARAMETERS', 'LoopError', 'Hand', 'Shown', 'Episode', 'LoopView',
           'operator_args', 'wait_for_close', 'format_episode', 'LoopObserver', 'run_closed_loop']

LOOP_MODEL = 'cup_7zone'
"""The model of the closed loop: the paper's cup, seven zones."""
OPERATOR_TASKS = ('usage', 'transfer')
"""The tasks the scripted operator wants (its ``task_set``): the paper's ambiguous two-task case."""
OPERATOR_W = (0.9, 0.9, 0.1)
"""The w it holds (its ``w``): usage and transfer likely, handover not."""
OPERATOR_W_NOISE = 0.05
"""The standard deviation of each task's noise on the held w (its ``w_noise``)."""
OPERATOR_SEED = 0
"""Its ``seed``: the device's noise and the held w's noise."""
HELD_BACK = 3600.0
"""Its ``start_delay`` (s) until the section releases it: the largest the parameter takes."""


class LoopError(RuntimeError):
    """The closed loop did not complete a stage within its deadline; the message says which and what is missing."""


@dataclass(frozen=True)
class Shown:
    """The latest grasp the planner showed: ``base_T_grasp`` (4, 4), base frame; ``closures`` (3,), rad."""

    base_T_grasp: NDArray[np.float64]
    closures: NDArray[np.float64]


@dataclass(frozen=True)
class Episode:
    """One episode as the demo saw it.

    Attributes
    ----------
    number : int
        The operator's episode, from 1.
    help_on : bool
        Whether the assistance was enabled.
    time_to_grasp : float
        The operator's, s.
    alphas : ndarray
        ``assistance/alpha`` received while the operator moved the hand.
    moving : float
        s from the operator's first to its last non-zero twist.
    hand : Hand
        Where the hand ended, the fingers at rest after the close.
    shown : Shown
        The grasp shown at the close.
    execute : str
        The operator's last ``grasp/execute`` answer ('' when this episode asked none).
    """

    number: int
    help_on: bool
    time_to_grasp: float
    alphas: NDArray[np.float64]
    moving: float
    hand: Hand
    shown: Shown
    execute: str


class LoopView(Protocol):
    """What the section reads of the running loop and how it waits (the demo's ROS side, or a test's fake)."""

    def wait(self, predicate: Callable[[], object], timeout: float) -> bool:
        """Process inputs until ``predicate()`` holds (True) or ``timeout`` s pass (False)."""

    def operator_status(self) -> tuple[float, str, Mapping[str, str]] | None:
        """The operator's latest status: (monotonic receipt s, message, values); None before any."""

    def hand(self) -> Hand | None:
        """The hand of the joint states so far (each joint's latest position); None while one is not known."""

    def shown(self) -> Shown | None:
        """The latest grasp shown; None before any."""

    def plans(self) -> int:
        """How many grasps have been shown."""

    def operator_motion(self, since: float) -> tuple[float, float] | None:
        """Monotonic receipt times of the first and last non-zero operator twist received after ``since``."""

    def alphas(self, start: float, end: float) -> NDArray[np.float64]:
        """``assistance/alpha`` received between ``start`` and ``end`` (monotonic s)."""


OPERATOR_PARAMETERS: Mapping[str, bool | int | float | str | tuple[str, ...] | tuple[float, ...]] = {
    'seed': OPERATOR_SEED, 'device': 'spacemouse', 'task_set': OPERATOR_TASKS, 'w': OPERATOR_W,
    'w_noise': OPERATOR_W_NOISE, 'intent': 'none', 'start_delay': HELD_BACK, 'episodes': 1, 'hold': 0.0,
    'close_on_reach': True, 'execute_shown': True,
}
"""The scripted operator's parameters at the suite's start (its others are its config file's): held back."""


def operator_args() -> list[str]:
    """:data:`OPERATOR_PARAMETERS` as the operator process's ``-p name:=value`` arguments (YAML values)."""
    def text(value: object) -> str:
        if isinstance(value, bool):
            return 'true' if value else 'false'
        if isinstance(value, tuple):
            return f'[{",".join(text(v) for v in value)}]'
        return str(value)

    return [arg for name, value in OPERATOR_PARAMETERS.items() for arg in ('-p', f'{name}:={text(value)}')]


def _times(values: Mapping[str, str]) -> list[float]:
    return [float(t) for t in values.get(KEY_TIMES_TO_GRASP, '').split(',') if t.strip()]


def _where(view: LoopView) -> str:
    """The loop's state for a failure message: the operator's status, the hand against the grasp shown."""
    status, hand, shown = view.operator_status(), view.hand(), view.shown()
    parts = ['no status from the scripted operator' if status is None else f'the scripted operator: {status[1]!r}']
    if hand is None:
        parts.append('no joint_states with every arm and finger joint from the mock arm')
    elif shown is None:
        parts.append('no grasp shown')
    else:
        distance, angle = offset(hand.base_T_ee, shown.base_T_grasp)
        parts.append(f'the hand {100 * distance:.1f} cm and {angle:.2f} rad from the grasp shown')
    return '; '.join(parts)


def wait_for_close(view: LoopView, number: int, released: float, help_on: bool, timeout: float) -> Episode:
    """Wait for episode ``number``'s close (the operator released at monotonic ``released`` s), then its fingers.

    Raises
    ------
    LoopError
        When the operator's status does not report the episode's close within ``timeout`` s, or the fingers are not
        seen at rest :data:`~grasp_intent_ros.wire.joint_states.CLOSE_SETTLE` s after that within ``timeout`` s
        more; the message names what is missing.
    """
    def closed() -> bool:
        status = view.operator_status()
        return status is not None and len(_times(status[2])) >= number

    if not view.wait(closed, timeout):
        raise LoopError(f'episode {number}: the scripted operator did not close the hand within {timeout:g} s of its '
                        f'release ({_where(view)})')
    status = view.operator_status()
    assert status is not None
    seen, _, values = status

    if not view.wait(lambda: fingers_settled(view.hand(), seen, CLOSE_SETTLE), timeout):
        raise LoopError(f'episode {number}: the fingers were not at rest within {timeout:g} s of the operator\'s close '
                        f'({_where(view)})')
    hand, shown, motion = view.hand(), view.shown(), view.operator_motion(released)
    assert hand is not None and shown is not None
    start, end = motion if motion is not None else (released, released)
    return Episode(number, help_on, _times(values)[number - 1], view.alphas(start, end), end - start, hand, shown,
                   values.get(KEY_EXECUTE, '') if help_on else '')


def _row(label: str, text: str) -> str:
    return f'{label:<18}{text}'


def format_episode(episode: Episode, model: GraspModel, base_T_obj: NDArray[np.float64]) -> str:
    """The episode's lines for a reader, in the demo's style (module docstring)."""
    hand, shown = episode.hand, episode.shown
    distance, angle = offset(hand.base_T_ee, shown.base_T_grasp)
    verdict = judge(model, base_T_obj, hand.base_T_ee, hand.fingers)
    share = (f'alpha mean {float(np.mean(episode.alphas)):.2f}, max {float(np.max(episode.alphas)):.2f}'
             if episode.alphas.size else 'no alpha received')
    command = (f'grasp/execute ({episode.execute}), then grasp/close' if episode.execute
               else 'grasp/close where the operator stopped')
    lines = [
        _row("robot's share", f'{share} while the operator moved the hand, {episode.moving:.1f} s'),
        _row('time to grasp', f"from the operator's reach to the fingers' close, {episode.time_to_grasp:.2f} s"),
        _row('grasp command', command),
        _row('hand ended', f'{1000 * distance:.1f} mm, {angle:.3f} rad from the grasp shown'),
        _row('fingers', '  '.join(f'{f:.4f}' for f in hand.fingers) + ' rad (executed: the closure error included)'),
        _row('serves (rules)', f'{verdict.text} at the reached pose: '
             + operator_verdict(verdict, OPERATOR_TASKS, model.task_names)),
    ]
    return '\n'.join(lines)


# ------------------------------------------------------------------------------------------ the ROS side
class LoopObserver(Node):
    """The section's :class:`LoopView` of the running loop, and its two switches (the operator's parameters, the help).

    ``wait`` spins the demo's executor (this node is added to it) until a predicate holds or a timeout passes, and
    raises as soon as a node process has exited (the demo's ``_spin_until``).
    """

    def __init__(self, wait: Callable[[Callable[[], object], float], bool]) -> None:
        super().__init__('grasp_intent_demo_loop')
        self._wait = wait
        self._hands = HandTracker(MicoKinematics())  # received on the monotonic clock; the rest by the stamps
        self._status: tuple[float, str, Mapping[str, str]] | None = None
        self._poses: dict[tuple[int, int], NDArray[np.float64]] = {}  # grasp/pose by stamp, until its targets come
        self._shown: Shown | None = None
        self._plans = 0
        self._moving: list[float] = []  # receipt times of the non-zero operator twists
        self._alphas: list[tuple[float, float]] = []
        self.operator_parameters = AsyncParameterClient(self, 'scripted_operator')
        self.enable_client = self.create_client(SetBool, topics.ASSISTANCE_ENABLE)
        # keep-last 1: fingers_settled times each joint state by its receipt, so a backlog taken late would pass for
        # joint states sent after the close; the rest rule reads what it takes (a joint state dropped only thins its
        # window)
        self.create_subscription(JointState, topics.JOINT_STATES, self._on_joints, input_qos(1))
        self.create_subscription(PoseStamped, topics.GRASP_POSE, self._on_pose, input_qos())
        self.create_subscription(JointState, topics.GRASP_JOINT_TARGETS, self._on_targets, input_qos())
        self.create_subscription(TwistStamped, topics.OPERATOR_TWIST, self._on_twist, input_qos(STREAM_DEPTH))
        self.create_subscription(Float64, topics.ASSISTANCE_ALPHA,
                                 lambda msg: self._alphas.append((time.monotonic(), msg.data)), input_qos(STREAM_DEPTH))
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 50)

    def _on_joints(self, msg: JointState) -> None:
        try:
            self._hands.add(msg, time.monotonic())
        except GraspIntentError as exc:  # not read: the hand stays the previous messages'
            self.get_logger().warning(f'joint_states not read: {exc}', throttle_duration_sec=5.0)

    def _on_pose(self, msg: PoseStamped) -> None:
        self._poses[(msg.header.stamp.sec, msg.header.stamp.nanosec)] = pose_msg_to_matrix(msg, frame_id=BASE_FRAME)

    def _on_targets(self, msg: JointState) -> None:
        base_T_grasp = self._poses.pop((msg.header.stamp.sec, msg.header.stamp.nanosec), None)
        closures = joint_positions(msg, FINGER_JOINTS)
        if base_T_grasp is not None and closures is not None:
            self._shown, self._plans = Shown(base_T_grasp, closures), self._plans + 1
            self._poses.clear()  # older poses have no targets to come: the planner publishes the two together

    def _on_twist(self, msg: TwistStamped) -> None:
        t = msg.twist
        if any((t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z)):
            self._moving.append(time.monotonic())

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name.endswith(OPERATOR_COMPONENT):
                self._status = (time.monotonic(), status.message, {kv.key: kv.value for kv in status.values})

    def wait(self, predicate: Callable[[], object], timeout: float) -> bool:  # noqa: D102 (LoopView)
        return self._wait(predicate, timeout)

    def operator_status(self) -> tuple[float, str, Mapping[str, str]] | None:  # noqa: D102
        return self._status

    def hand(self) -> Hand | None:  # noqa: D102
        return self._hands.hand()

    def shown(self) -> Shown | None:  # noqa: D102
        return self._shown

    def plans(self) -> int:  # noqa: D102
        return self._plans

    def operator_motion(self, since: float) -> tuple[float, float] | None:  # noqa: D102
        times = [t for t in self._moving if t > since]
        return (times[0], times[-1]) if times else None

    def alphas(self, start: float, end: float) -> NDArray[np.float64]:  # noqa: D102
        return np.array([a for t, a in self._alphas if start <= t <= end], dtype=np.float64)

    def set_operator(self, timeout: float, **values: str | float | int | bool) -> None:
        """Set the scripted operator's parameters; LoopError when it does not accept them within ``timeout`` s."""
        client = self.operator_parameters
        future = client.set_parameters([Parameter(name, value=value) for name, value in values.items()])
        if not self.wait(future.done, timeout):
            raise LoopError(f'the scripted operator did not answer set_parameters({values}) within {timeout:g} s')
        refused = [r.reason for r in future.result().results if not r.successful]
        if refused:
            raise LoopError(f'the scripted operator refused {values}: {"; ".join(refused)}')

    def enable_assistance(self, on: bool, timeout: float) -> None:
        """Switch the assistance on or off (``assistance/enable``); LoopError when it does not answer in time."""
        future = self.enable_client.call_async(SetBool.Request(data=on))
        if not self.wait(future.done, timeout) or not future.result().success:
            raise LoopError(f'{topics.ASSISTANCE_ENABLE} did not switch the assistance {"on" if on else "off"} within '
                            f'{timeout:g} s')


def run_closed_loop(view: LoopObserver, doc: ModelDocument, base_T_obj: NDArray[np.float64], timeout: float) -> None:
    """The section (module docstring): release the operator on ``doc`` (the active model), two episodes, printed.

    Raises
    ------
    LoopError
        When a stage does not complete within ``timeout`` s (:func:`wait_for_close`), or the operator or the
        assistance does not take a switch.
    """
    w = ', '.join(f'{name} {v:.3f}' for name, v in zip(doc.model.task_names, OPERATOR_W))
    print(f'  model {doc.name} ({len(doc.model.zones)} zones); the operator wants {" and ".join(OPERATOR_TASKS)}, '
          f'seed {OPERATOR_SEED}')
    print('    ' + _row('w (held)', f'{w}  (on intent/w every 0.1 s, N(0, {OPERATOR_W_NOISE:g}^2) per task)'))
    plans = view.plans()
    view.set_operator(timeout, intent='held')
    if not view.wait(lambda: view.plans() > plans, timeout):
        raise LoopError(f'no grasp shown for the scripted operator\'s held w within {timeout:g} s ({_where(view)})')
    released = time.monotonic()
    view.set_operator(timeout, start_delay=0.0)
    helped = wait_for_close(view, 1, released, True, timeout)
    p = helped.shown.base_T_grasp[:3, 3]
    shown = judge(doc.model, base_T_obj, helped.shown.base_T_grasp, helped.shown.closures)
    print('    ' + _row('grasp shown', f'position [m]  x {p[0]:+.4f}  y {p[1]:+.4f}  z {p[2]:+.4f}  '
                                    f'(frame {BASE_FRAME})'))
    print('    ' + _row('serves (rules)', shown.text))
    print('  with the help (assistance/enable true): the suite executes the shown grasp, then closes the fingers')
    print('    ' + format_episode(helped, doc.model, base_T_obj).replace('\n', '\n    '), flush=True)
    view.enable_assistance(False, timeout)
    released = time.monotonic()
    view.set_operator(timeout, execute_shown=False, episodes=2)  # it resets the arm, then reaches again
    alone = wait_for_close(view, 2, released, False, timeout)
    print('  without it (assistance/enable false): direct teleoperation, the hand closes where the operator stops')
    print('    ' + format_episode(alone, doc.model, base_T_obj).replace('\n', '\n    '))
    print("  one episode each, not a benchmark: the README's Performance table compares the suite with direct "
          'teleoperation\n  in the simulated loop, 50 episodes x 3 repeats per object and operator\n', flush=True)
