"""Grasps demonstrated on an arm, read from session bags into a training CSV (the ``demonstrations`` command).

    python -m grasp_intent_ros demonstrations BAG [BAG ...] --out CSV [--tasks T1,T2]
                                              [--task-names T1,T2,T3 | --model MODEL.yaml] [--append]
                                              [--max-pose-age S]

A demonstrator teleoperates the MICO to a grasp and closes the hand while the recorder runs
(``python -m grasp_intent_ros recorder BAG``: its default topics hold ``joint_states``, ``object/pose`` and
``operator/grasp_tasks``). Each grasp becomes a row of the :mod:`grasp_intent_ros.method.data` CSV, which
``train`` reads as is. The rules, on the bag's receive times (one clock for every topic):

Closes
    Each ``joint_states`` message is read as a :class:`~grasp_intent_ros.wire.robot_state.Hand` (messages
    without the arm and finger joints are skipped). A finger motion starts at a joint state whose fingers are
    not at rest while no motion is in progress; it is a *close* when the three finger velocities there sum to a
    positive value (the closures grow), else an opening, which is no grasp. A motion ends at the first joint
    state for which :func:`~grasp_intent_ros.wire.robot_state.fingers_settled` holds with the motion's start
    as the close (at rest, at least ``CLOSE_SETTLE`` s after it). A motion whose velocities' sum changes sign
    before it settles ends there, and one the other way begins: a close that opens again before it settles, or
    that the bag ends in, is rejected (the fingers never settled); an opening that closes again is counted.
The grasp
    At the settled joint state: the hand's pose (forward kinematics of the arm joints) relative to the latest
    ``object/pose`` received at or before it, and the fingers' positions (the executed closures), as the 10
    features (:func:`~grasp_intent_ros.mico.frames.obj_T_ee_to_features`). Rejected when no object pose was
    received, when the latest is malformed (another frame than the arm's base, a non-unit quaternion), when it
    was received more than ``max_pose_age`` s before the settled joint state (stale: default
    :data:`MAX_POSE_AGE`; ``inf`` for an object the demonstrator vouches did not move), or when the features
    fall outside the feature space's bounds (the hand closed away from the object).
Labels (inclusive: every task the grasp serves)
    A ``std_msgs/String`` on ``operator/grasp_tasks`` holding comma-separated task names labels the next close
    that starts after it was received, and that close only (a second label before any close replaces the first,
    and is printed). A close without one takes the command's ``--tasks``; without either it is rejected
    (unlabelled). A label naming an unknown task rejects the close it labels. Never guessed.

Every grasp found (time from the bag's first message, features, tasks) and every close rejected (its time and
reasons) is printed. Exit status 0 when rows were written, 1 when no grasp was found (nothing written), 2 with
the reason for a bad bag (unreadable, no ``joint_states``, a malformed joint state) or bad arguments.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from ..cli.user_errors import report_user_errors
from ..errors import DataError, GraspIntentError
from ..method.data import Demonstrations, load_csv, save_csv
from ..method.features import MICO_3F
from ..method.intent import DEFAULT_TASKS
from ..method.model import GraspModel
from ..method.parameters import check_task_names
from ..mico.frames import obj_T_ee_to_features
from ..mico.kinematics import BASE_FRAME, FINGER_JOINTS, MicoKinematics
from ..wire.robot_state import CLOSE_SETTLE, Hand, fingers_settled, hand_state, pose_msg_to_matrix
from ..wire.topics import JOINT_STATES, MSGTYPES, OBJECT_POSE, OPERATOR_GRASP_TASKS
from .bag import BagReadError, read_messages, topics_info
from .pairing import detect_namespace

__all__ = ['MAX_POSE_AGE', 'Grasp', 'Rejected', 'Extraction', 'parse_tasks', 'extract', 'read_bag', 'describe',
           'main']

MAX_POSE_AGE: Final = 1.0
"""Default oldest object pose (s before the settled joint state) a grasp is measured against."""


@dataclass(frozen=True)
class Grasp:
    """A demonstrated grasp: ``t`` s (receive time of the settled joint state), ``x`` shape (10,), its task set.

    ``label`` says where the task set came from: 'label at <t> s' or '--tasks'.
    """

    t: float
    x: NDArray[np.float64]
    task_set: int
    label: str


@dataclass(frozen=True)
class Rejected:
    """A close that gives no grasp: ``t`` s (receive time of the motion's first joint state) and why."""

    t: float
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class Extraction:
    """What one message sequence holds: its grasps, the closes rejected, the openings seen and notes."""

    grasps: tuple[Grasp, ...]
    rejected: tuple[Rejected, ...]
    openings: int
    notes: tuple[str, ...]


def parse_tasks(text: str, task_names: Sequence[str]) -> int:
    """Task-set bitmask of comma-separated task names (bit i = ``task_names[i]``; spaces ignored).

    Raises
    ------
    DataError
        For no name, an unknown name or a name given twice.
    """
    names = [name.strip() for name in text.split(',')]
    if not any(names) or not all(names):
        raise DataError(f'a task set is comma-separated task names of {", ".join(task_names)}; got {text!r}')
    unknown = [name for name in names if name not in task_names]
    if unknown:
        raise DataError(f'unknown task(s) {", ".join(unknown)} in {text!r}; tasks: {", ".join(task_names)}')
    if len(set(names)) != len(names):
        raise DataError(f'a task named twice in {text!r}')
    return sum(1 << task_names.index(name) for name in set(names))


@dataclass
class _Motion:
    """A finger motion in progress: its start (s), direction, and the label pending when it started."""

    start: float
    closing: bool
    label: tuple[float, int | str] | None


class _Extractor:
    """The rules of the module docstring over one bag's messages, fed in receive order."""

    def __init__(self, kin: MicoKinematics, task_names: Sequence[str], tasks: int | None, max_pose_age: float) -> None:
        self.kin, self.task_names, self.tasks, self.max_pose_age = kin, tuple(task_names), tasks, max_pose_age
        self.pose: tuple[float, NDArray[np.float64] | str] | None = None  # (received, base_T_obj or why not)
        self.label: tuple[float, int | str] | None = None  # (received, task set or why not), pending
        self.motion: _Motion | None = None
        self.grasps: list[Grasp] = []
        self.rejected: list[Rejected] = []
        self.notes: list[str] = []
        self.openings = 0

    def object_pose(self, t: float, msg: Any) -> None:
        try:
            self.pose = (t, pose_msg_to_matrix(msg, frame_id=BASE_FRAME))
        except GraspIntentError as exc:
            self.pose = (t, str(exc))

    def grasp_tasks(self, t: float, msg: Any) -> None:
        if self.label is not None and (self.motion is None or self.motion.label is not self.label):
            self.notes.append(f'the label at {self.label[0]:.3f} s is replaced by the one at {t:.3f} s '
                              'before any close')
        try:
            self.label = (t, parse_tasks(str(msg.data), self.task_names))
        except DataError as exc:
            self.label = (t, str(exc))

    def joint_state(self, t: float, msg: Any) -> None:
        hand = hand_state(msg, self.kin, t)
        if hand is None:
            return
        velocities = dict(zip(msg.name, msg.velocity))
        velocity = sum(float(velocities.get(name, 0.0)) for name in FINGER_JOINTS)  # > 0: closing
        motion = self.motion
        if motion is not None and fingers_settled(hand, motion.start, CLOSE_SETTLE):
            self.motion = None
            if motion.closing:
                self._close(motion, hand)
            else:
                self.openings += 1
            return
        if motion is not None and velocity != 0.0 and (velocity > 0.0) != motion.closing:  # reversed, unsettled
            if motion.closing:
                self._reject(motion, f'fingers never settled: they opened at {t:.3f} s')
            else:
                self.openings += 1
            motion = self.motion = None
        if motion is None and not hand.fingers_at_rest:
            self.motion = _Motion(t, velocity > 0.0, self.label)

    def end(self, t: float) -> None:
        """The bag ended at ``t`` s."""
        if self.motion is not None and self.motion.closing:
            self._reject(self.motion, f'fingers never settled: the bag ends {t - self.motion.start:.3f} s after the '
                                      'close began')
        elif self.motion is not None:
            self.openings += 1
        self.motion = None

    def _take_label(self, motion: _Motion) -> tuple[float, int | str] | None:
        """The close's own label, no longer pending unless another arrived since the close began."""
        if motion.label is not None and self.label is motion.label:
            self.label = None
        return motion.label

    def _reject(self, motion: _Motion, reason: str) -> None:
        self._take_label(motion)
        self.rejected.append(Rejected(motion.start, (reason,)))

    def _close(self, motion: _Motion, hand: Hand) -> None:
        reasons = []
        label = self._take_label(motion)
        if label is not None and isinstance(label[1], str):
            reasons.append(f'the label at {label[0]:.3f} s: {label[1]}')
        elif label is None and self.tasks is None:
            reasons.append('unlabelled: no label before the close and no --tasks')
        x = None
        if self.pose is None:
            reasons.append('no object pose')
        elif isinstance(self.pose[1], str):
            reasons.append(f'the latest object pose, at {self.pose[0]:.3f} s, is malformed: {self.pose[1]}')
        elif hand.received - self.pose[0] > self.max_pose_age:
            reasons.append(f'stale object pose: the latest, at {self.pose[0]:.3f} s, is '
                           f'{hand.received - self.pose[0]:.3f} s old (at most {self.max_pose_age:g} s)')
        else:
            x = obj_T_ee_to_features(np.linalg.inv(self.pose[1]) @ hand.base_T_ee, hand.fingers)
            outside = [name for name, value, low, high in zip(MICO_3F.names, x, MICO_3F.lower, MICO_3F.upper)
                       if not low <= value <= high]
            if outside:
                reasons.append('the hand is not at the object: ' + ', '.join(
                    f'{name} = {x[MICO_3F.names.index(name)]:.4f}' for name in outside) + ' outside the feature bounds')
        if reasons or x is None:
            self.rejected.append(Rejected(motion.start, tuple(reasons)))
            return
        if label is not None:
            assert isinstance(label[1], int)
            self.grasps.append(Grasp(hand.received, x, label[1], f'label at {label[0]:.3f} s'))
        else:
            assert self.tasks is not None
            self.grasps.append(Grasp(hand.received, x, self.tasks, '--tasks'))


def extract(messages: Iterable[tuple[str, float, Any]], kin: MicoKinematics, *, task_names: Sequence[str],
            tasks: int | None = None, max_pose_age: float = MAX_POSE_AGE) -> Extraction:
    """The grasps and rejected closes of a session's messages, by the rules of the module docstring.

    Parameters
    ----------
    messages : iterable of (topic, t, message)
        In receive order: the relative topic (``joint_states``, ``object/pose``, ``operator/grasp_tasks``;
        others are ignored), its receive time (s) and the decoded message (attribute access: rosbags' or rclpy's).
    kin : MicoKinematics
    task_names : sequence of str
        The CSV's task columns, in order: bit i of a task set is ``task_names[i]``.
    tasks : int, optional
        The task set of a close without its own label (``--tasks``); None: such a close is rejected.
    max_pose_age : float
        The oldest object pose (s before the settled joint state) a grasp is measured against (> 0, may be inf).

    Raises
    ------
    DataError
        For a malformed joint state (duplicate names, positions not finite, ...), naming its time.
    """
    extractor = _Extractor(kin, task_names, tasks, max_pose_age)
    handlers = {JOINT_STATES: extractor.joint_state, OBJECT_POSE: extractor.object_pose,
                OPERATOR_GRASP_TASKS: extractor.grasp_tasks}
    t = math.nan
    for topic, t, msg in messages:
        if (handler := handlers.get(topic)) is None:
            continue
        try:
            handler(t, msg)
        except GraspIntentError as exc:
            raise DataError(f'malformed {topic} message at {t:.3f} s: {exc}') from None
    extractor.end(t)
    return Extraction(tuple(extractor.grasps), tuple(extractor.rejected), extractor.openings, tuple(extractor.notes))


def _bag_messages(path: Path) -> Iterator[tuple[str, float, Any]]:
    """A bag's ``joint_states``, ``object/pose`` and ``operator/grasp_tasks`` as (topic, t, message).

    ``t``: receive time in s from the bag's first message. Raises BagReadError (SessionError) for an unreadable
    bag, one without ``joint_states``, or one of these topics with another type.
    """
    infos = topics_info(path)
    namespace = detect_namespace(infos)
    relative = {f'{namespace}/{topic}': topic for topic in (JOINT_STATES, OBJECT_POSE, OPERATOR_GRASP_TASKS)}
    if f'{namespace}/{JOINT_STATES}' not in infos:
        raise BagReadError(f'bag {path} has no {namespace}/{JOINT_STATES}: record the arm with the recorder\'s '
                           'default topics')
    for topic, rel in relative.items():
        if topic in infos and infos[topic].msgtype != MSGTYPES[rel]:
            raise BagReadError(f'bag {path}: {topic} holds {infos[topic].msgtype}, not {MSGTYPES[rel]}')
    t0: int | None = None
    for message in read_messages(path):
        t0 = message.timestamp_ns if t0 is None else t0
        if message.topic in relative:
            yield relative[message.topic], (message.timestamp_ns - t0) * 1e-9, message.decode()


def read_bag(path: str | os.PathLike[str], kin: MicoKinematics, *, task_names: Sequence[str], tasks: int | None = None,
             max_pose_age: float = MAX_POSE_AGE) -> Extraction:
    """:func:`extract` of a session bag's messages (times in s from its first message).

    Raises
    ------
    BagReadError
        For a bag that cannot be read, one without ``joint_states``, or a topic of another type.
    DataError
        For a malformed joint state, naming the bag.
    """
    try:
        return extract(_bag_messages(Path(path)), kin, task_names=task_names, tasks=tasks,
                       max_pose_age=max_pose_age)
    except DataError as exc:
        raise DataError(f'bag {path}: {exc}') from None


def _task_list(task_set: int, task_names: Sequence[str]) -> str:
    return ','.join(name for i, name in enumerate(task_names) if task_set >> i & 1)


def _features(x: NDArray[np.float64]) -> str:
    values = x.tolist()
    return ('palm ' + ' '.join(f'{v:.5f}' for v in values[0:3]) + '  approach '
            + ' '.join(f'{v:.5f}' for v in values[3:6]) + f'  roll {values[6]:.5f}  fingers '
            + ' '.join(f'{v:.5f}' for v in values[7:10]))


def describe(bag: str, found: Extraction, task_names: Sequence[str]) -> Iterator[str]:
    """The lines the command prints for one bag: every grasp, every close rejected, the notes, a count."""
    events: list[tuple[float, str]] = [
        (g.t, f'{bag}: grasp at {g.t:.3f} s, tasks {_task_list(g.task_set, task_names)} ({g.label})\n'
              f'    {_features(g.x)}') for g in found.grasps]
    events += [(r.t, f'{bag}: close at {r.t:.3f} s rejected: {"; ".join(r.reasons)}') for r in found.rejected]
    for _, line in sorted(events, key=lambda event: event[0]):
        yield line
    for note in found.notes:
        yield f'{bag}: note: {note}'
    yield (f'{bag}: {len(found.grasps)} grasp(s), {len(found.rejected)} close(s) rejected, '
           f'{found.openings} opening(s)')


def _task_names(args: argparse.Namespace, existing: Demonstrations | None) -> tuple[str, ...]:
    """The CSV's task columns: the appended CSV's, a model's, ``--task-names`` or the default tasks."""
    names: tuple[str, ...] | None = None
    if args.model is not None:
        names = GraspModel.load(args.model).task_names
    elif args.task_names is not None:
        names = tuple(name.strip() for name in args.task_names.split(','))
        check_task_names(names)
    if existing is None:
        return names or DEFAULT_TASKS
    if names is not None and names != existing.task_names:
        raise DataError(f'{args.out} has the tasks {", ".join(existing.task_names)}, not {", ".join(names)}')
    return existing.task_names


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point; returns the exit status (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('bags', type=Path, nargs='+', metavar='BAG', help='session bags recorded by the recorder')
    parser.add_argument('--out', type=Path, required=True, help='the CSV to write (method.data format)')
    parser.add_argument('--tasks', default=None,
                        help='comma-separated tasks of every close without its own label, e.g. usage,transfer')
    names = parser.add_mutually_exclusive_group()
    names.add_argument('--task-names', default=None,
                       help=f'the CSV\'s task columns, in order (default {",".join(DEFAULT_TASKS)})')
    names.add_argument('--model', type=Path, default=None, help="a model YAML whose task names are the CSV's")
    parser.add_argument('--append', action='store_true', help='add the grasps to an existing CSV (its tasks)')
    parser.add_argument('--max-pose-age', type=float, default=MAX_POSE_AGE,
                        help=f'oldest object pose a grasp is measured against, s before it (default '
                             f'{MAX_POSE_AGE:g}; inf: the object never moved)')
    args = parser.parse_args(argv)
    status = [0]

    def body() -> None:
        if not args.max_pose_age > 0.0:
            raise DataError(f'--max-pose-age must be > 0 s (or inf), got {args.max_pose_age}')
        if args.out.exists() and not args.append:
            raise DataError(f'{args.out} exists: --append adds to it')
        existing = load_csv(args.out) if args.append and args.out.exists() else None
        task_names = _task_names(args, existing)
        tasks = None if args.tasks is None else parse_tasks(args.tasks, task_names)
        kin = MicoKinematics()
        found = [(bag, read_bag(bag, kin, task_names=task_names, tasks=tasks, max_pose_age=args.max_pose_age))
                 for bag in args.bags]  # every bag read before anything is written
        for bag, extraction in found:
            print('\n'.join(describe(str(bag), extraction, task_names)))
        grasps = [g for _, extraction in found for g in extraction.grasps]
        if not grasps:
            print(f'no grasp found: {args.out} not written')
            status[0] = 1
            return
        new = Demonstrations(np.array([g.x for g in grasps]), np.array([g.task_set for g in grasps]), task_names)
        rows = new if existing is None else Demonstrations(np.vstack([existing.x, new.x]),
                                                           np.concatenate([existing.task_sets, new.task_sets]),
                                                           task_names)
        save_csv(rows, args.out)
        print(f'wrote {len(new)} grasp(s) to {args.out} ({len(rows)} row(s))')

    return report_user_errors(body, prog='demonstrations') or status[0]


if __name__ == '__main__':
    sys.exit(main())
