"""Grasps demonstrated on an arm, read from session bags into a training CSV (the ``demonstrations`` command).

    python -m grasp_intent_ros demonstrations BAG [BAG ...] --out CSV [--tasks T1,T2] [--object NAME]
                                              [--task-names T1,T2,T3 | --model MODEL.yaml] [--append]
                                              [--max-pose-age S] [--close-rise RAD]
                                              [--settle-tolerance RAD] [--settle-window S]

A demonstrator teleoperates the MICO to a grasp and closes the hand while the recorder runs
(``python -m grasp_intent_ros recorder BAG``: its default topics hold ``joint_states``, ``object/pose`` and
``operator/grasp_tasks``). Each grasp becomes a row of the :mod:`grasp_intent_ros.method.data` CSV, which
``train`` reads as is. The rules, on the bag's receive times (one clock for every topic):

Closes (on the finger positions alone: a driver's finger velocities may be absent, or noisy at rest)
    The ``joint_states`` messages are read as the suite reads a real arm's
    (:class:`~grasp_intent_ros.wire.joint_states.HandTracker`: each joint's latest position from whichever
    message named it last, the arm and the fingers perhaps in separate messages); a *joint state* here is a
    message that names a finger while every arm and finger joint is known (the others only update the arm),
    its hand that tracker's :class:`~grasp_intent_ros.wire.joint_states.Hand`. Its *closure* is the mean of the
    three finger positions, ``(f1 + f2 + f3) / 3`` rad. The fingers are *at rest* at a joint state of time ``t``
    by the suite's rest rule (:class:`~grasp_intent_ros.wire.joint_states.FingerRest`): over the joint states
    from the latest one of time at or before ``t - window`` up to it, every finger's positions span (max - min)
    at most ``tolerance`` rad: still for ``window`` s at least; a joint state's time is its header stamp while
    every one so far had a non-zero stamp later than the one before, else its receive time (that rule's clock:
    receive times misjudge a backlog written in a burst). The *rest* is the closure at
    the latest earlier joint state at rest (before the first, the first joint state's). While no motion is in
    progress, a finger motion is seen at a joint state whose closure is at least ``rise`` rad above the rest
    (a *close*) or below it (an *opening*, which is no grasp); it ends at the next joint state at rest, where a
    close is a grasp. A close whose closure falls ``rise`` below its highest since it was seen (an opening
    whose closure rises ``rise`` above its lowest) ends there unsettled, and a motion the other way is seen
    at that joint state: a close that opens again before it settles, or that the bag ends in, is rejected
    (the fingers never settled); an opening that closes again is counted. The three amounts are a
    :class:`CloseRule` (defaults :data:`CLOSE_RISE`, :data:`SETTLE_TOLERANCE`, :data:`SETTLE_WINDOW`, each
    with its reason). Comparisons: ``>=`` for a rise or a fall (the amount counts), ``<=`` for a span, and
    times in integer nanoseconds (the stamps', a bag's own); a closure and a span are computed from the message's
    numbers by the same IEEE operations in a fixed order, so one bag gives one answer on every machine. It sees
    motion, not contact; a finger slower than ``tolerance / window`` is at rest (docs/sessions.md: what it cannot tell).
The grasp
    At the settled joint state: the hand's pose (forward kinematics of the arm joints) relative to the latest
    ``object/pose`` received at or before it, and the fingers' positions (the executed closures), as the 10
    features (:func:`~grasp_intent_ros.mico.frames.obj_T_ee_to_features`). Rejected when no object pose was
    received, when the latest is malformed (another frame than the arm's base, a non-unit quaternion), when it
    was received more than ``max_pose_age`` s before the settled joint state (in integer ns; stale: default
    :data:`MAX_POSE_AGE`; ``inf`` for an object the demonstrator vouches did not move), or when the features
    fall outside the feature space's bounds (the hand closed away from the object).
A scene of several objects (``--object NAME``: that object's grasps)
    A bag whose session topics are a scene (:func:`~grasp_intent_ros.sessions.scenes.detect_scene`: the arm's
    ``joint_states`` in its namespace, one chain per object below it) is read for one object, named as its
    chain's last name (``cup`` for ``/cup``): the joint states and labels in the arm's namespace, each object's
    pose on ``<object>/object/pose`` there. The grasp is measured against ``NAME``'s pose by the rules above
    (its absence, malformation or staleness rejects the close). The other objects whose pose is *known* (their
    latest received well-formed, whatever its age: an object no longer tracked is where it was last seen) are
    checked too: the close is ``NAME``'s grasp when its features are within the bounds relative to ``NAME`` and
    outside them relative to every other known object; within the bounds of ``NAME`` and of another, it is
    rejected as ambiguous, naming them; outside ``NAME``'s and within another's, it is that object's close,
    printed and counted as such (no rejection: that object's own run reads it); outside every one, rejected as
    away from ``NAME``. An object with no known pose cannot claim a close. Without ``--object`` a scene's bag is
    refused, naming its chains; with it, a one-chain bag is refused (its objects have no names), and so is a
    scene without ``NAME``.
Labels (inclusive: every task the grasp serves)
    A ``std_msgs/String`` on ``operator/grasp_tasks`` holding comma-separated task names labels the next close
    seen after it was received, and that close only (a second label before any close replaces the first,
    and is printed). A close without one takes the command's ``--tasks``; without either it is rejected
    (unlabelled). A label naming an unknown task rejects the close it labels. In a scene the operator's topic is
    the arm's (``operator/grasp_tasks`` in its namespace), and a label may name the object it is meant for,
    ``cup: usage,transfer``: a close labelled for ``NAME`` that is another object's (for another object that is
    ``NAME``'s) is rejected, naming both; a close of another object is that object's whatever else its label
    says; an object not of the scene (or any object in a one-chain bag) makes the label unknown. Never guessed.

Every grasp found (time from the bag's first message, features, tasks) and every close rejected (its time and
reasons) is printed. Exit status 0 when rows were written, 1 when no grasp was found (nothing written), 2 with
the reason for a bad bag (unreadable, no ``joint_states``, a malformed joint state, a scene without ``--object``
or one chain with it) or bad arguments.
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from ..cli.user_errors import report_user_errors
from ..errors import DataError, GraspIntentError
from ..method.data import Demonstrations, load_csv, save_csv
from ..method.intent import DEFAULT_TASKS
from ..method.model import GraspModel
from ..method.parameters import check_task_names
from ..mico.kinematics import MicoKinematics
from ..wire.joint_states import FINGER_SET, SETTLE_TOLERANCE, SETTLE_WINDOW, Hand, HandTracker, RestRule
from ..wire.topics import JOINT_STATES, OPERATOR_GRASP_TASKS
from .bag import read_messages
from .demonstration_objects import ObjectPoses, bag_topics, split_label

__all__ = ['MAX_POSE_AGE', 'CLOSE_RISE', 'SETTLE_TOLERANCE', 'SETTLE_WINDOW', 'CloseRule', 'Grasp', 'Rejected',
           'Extraction', 'parse_tasks', 'extract', 'read_bag', 'describe', 'main']

MAX_POSE_AGE: Final = 1.0
"""Default oldest object pose (s before the settled joint state) a grasp is measured against."""

CLOSE_RISE: Final = 0.2
"""Default rise (rad) of the mean finger closure from the rest that makes a close (a fall: an opening).

The MICO's fingers run over 0-1.51 rad (the URDF's limits), and every shipped demonstration's mean closure is at
least 0.8 rad (a close from open rises that much); 0.2 rad is 100 times a real encoder's noise of about 0.002 rad
(about 170 standard deviations of the mean of three fingers), so noise never makes a motion, and 10 times
:data:`SETTLE_TOLERANCE`."""

@dataclass(frozen=True)
class CloseRule:
    """The amounts of the close rule (module docstring): ``rise`` rad, ``tolerance`` rad, ``window`` s.

    Raises
    ------
    DataError
        Unless ``0 <= tolerance < rise`` (a motion is more than the fingers' wobble at rest) and ``window > 0``,
        all finite.
    """

    rise: float = CLOSE_RISE
    tolerance: float = SETTLE_TOLERANCE
    window: float = SETTLE_WINDOW

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rise) and 0.0 <= self.tolerance < self.rise and 0.0 < self.window < math.inf):
            raise DataError(f'the close rule needs 0 <= settle tolerance < close rise and a settle window > 0, all '
                            f'finite; got tolerance {self.tolerance} rad, rise {self.rise} rad, window {self.window} s')

    @property
    def rest(self) -> RestRule:
        """The rest rule of its tolerance and window (the suite's one, :mod:`~grasp_intent_ros.wire.joint_states`)."""
        return RestRule(self.tolerance, self.window)


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
    """A close that gives no grasp: ``t`` s (receive time of the joint state it was seen at) and why."""

    t: float
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class Extraction:
    """What one message sequence holds: its grasps, the closes rejected, the openings seen and notes.

    ``elsewhere``: the closes of a scene's other objects, each (s it was seen at, the objects it is at).
    """

    grasps: tuple[Grasp, ...]
    rejected: tuple[Rejected, ...]
    openings: int
    notes: tuple[str, ...]
    elsewhere: tuple[tuple[float, tuple[str, ...]], ...] = ()


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
    """A motion in progress: seen at (s), direction, the label pending then, the closure's highest (lowest) since."""

    start: float
    closing: bool
    label: tuple[float, tuple[str | None, int] | str] | None
    extreme: float


class _Extractor:
    """The rules of the module docstring over one bag's messages, fed in receive order."""

    def __init__(self, kin: MicoKinematics, task_names: Sequence[str], tasks: int | None, poses: ObjectPoses,
                 rule: CloseRule) -> None:
        self.kin, self.task_names, self.tasks, self.poses = kin, tuple(task_names), tasks, poses
        self.rule, self.hands = rule, HandTracker(kin, rule.rest)
        self.rest: float | None = None  # the closure at the latest joint state at rest so far (rad)
        # (received, (object named or None, task set) or why not), pending
        self.label: tuple[float, tuple[str | None, int] | str] | None = None
        self.motion: _Motion | None = None
        self.grasps: list[Grasp] = []
        self.rejected: list[Rejected] = []
        self.notes: list[str] = []
        self.elsewhere: list[tuple[float, tuple[str, ...]]] = []
        self.openings = 0

    def grasp_tasks(self, t: float, msg: Any) -> None:
        if self.label is not None and (self.motion is None or self.motion.label is not self.label):
            self.notes.append(f'the label at {self.label[0]:.3f} s is replaced by the one at {t:.3f} s '
                              'before any close')
        try:
            named, tasks = split_label(str(msg.data), self.poses.objects)
            self.label = (t, (named, parse_tasks(tasks, self.task_names)))
        except DataError as exc:
            self.label = (t, str(exc))

    def joint_state(self, t: float, msg: Any) -> None:
        if FINGER_SET.isdisjoint(self.hands.add(msg, t)) or (hand := self.hands.hand()) is None:
            return  # no new finger reading, or the arm or a finger not known yet
        fingers, at_rest = hand.fingers, hand.fingers_at_rest
        closure = (float(fingers[0]) + float(fingers[1]) + float(fingers[2])) / 3.0
        rise = self.rule.rise
        motion = self.motion
        if motion is None:
            rest = closure if self.rest is None else self.rest
            if closure - rest >= rise or rest - closure >= rise:
                self.motion = _Motion(t, closure > rest, self.label, closure)
            elif at_rest or self.rest is None:
                self.rest = closure
            return
        if at_rest:
            self.motion, self.rest = None, closure
            if motion.closing:
                self._close(motion, hand)
            else:
                self.openings += 1
            return
        motion.extreme = max(motion.extreme, closure) if motion.closing else min(motion.extreme, closure)
        if motion.closing and motion.extreme - closure >= rise:
            self._reject(motion, f'fingers never settled: they opened at {t:.3f} s')
            self.motion = _Motion(t, False, self.label, closure)
        elif not motion.closing and closure - motion.extreme >= rise:
            self.openings += 1
            self.motion = _Motion(t, True, self.label, closure)

    def end(self, t: float) -> None:
        """The bag ended at ``t`` s."""
        if self.motion is not None and self.motion.closing:
            self._reject(self.motion, f'fingers never settled: the bag ends {t - self.motion.start:.3f} s after the '
                                      'close began')
        elif self.motion is not None:
            self.openings += 1
        self.motion = None

    def _take_label(self, motion: _Motion) -> tuple[float, tuple[str | None, int] | str] | None:
        """The close's own label, no longer pending unless another arrived since the close began."""
        if motion.label is not None and self.label is motion.label:
            self.label = None
        return motion.label

    def _reject(self, motion: _Motion, reason: str) -> None:
        self._take_label(motion)
        self.rejected.append(Rejected(motion.start, (reason,)))

    def _close(self, motion: _Motion, hand: Hand) -> None:
        label, found, target = self._take_label(motion), self.poses.attribute(hand), self.poses.target
        named = None if label is None or isinstance(label[1], str) else label[1][0]
        if found.other and named != target:
            self.elsewhere.append((motion.start, found.other))
            return
        reasons = []
        if label is not None and isinstance(label[1], str):
            reasons.append(f'the label at {label[0]:.3f} s: {label[1]}')
        elif label is None and self.tasks is None:
            reasons.append('unlabelled: no label before the close and no --tasks')
        elif label is not None and named is not None and (found.other or (named != target and found.x is not None)):
            reasons.append(f'the label at {label[0]:.3f} s names {named}, but the hand is at '
                           f'{", ".join(found.other) or target}')
        reasons += found.reasons
        if reasons or found.x is None:
            self.rejected.append(Rejected(motion.start, tuple(reasons)))
        elif label is not None:
            assert not isinstance(label[1], str)
            self.grasps.append(Grasp(hand.received, found.x, label[1][1], f'label at {label[0]:.3f} s'))
        else:
            assert self.tasks is not None
            self.grasps.append(Grasp(hand.received, found.x, self.tasks, '--tasks'))


def extract(messages: Iterable[tuple[str, float, Any]], kin: MicoKinematics, *, task_names: Sequence[str],
            tasks: int | None = None, max_pose_age: float = MAX_POSE_AGE, rule: CloseRule = CloseRule(),
            objects: Sequence[str] = ()) -> Extraction:
    """The grasps and rejected closes of a session's messages, by the rules of the module docstring.

    Parameters
    ----------
    messages : iterable of (topic, t, message)
        In receive order: the relative topic (``joint_states``, ``operator/grasp_tasks``, ``object/pose`` or in a
        scene ``<object>/object/pose``; others are ignored), its receive time (s) and the decoded message
        (attribute access: rosbags' or rclpy's).
    kin : MicoKinematics
    task_names : sequence of str
        The CSV's task columns, in order: bit i of a task set is ``task_names[i]``.
    tasks : int, optional
        The task set of a close without its own label (``--tasks``); None: such a close is rejected.
    max_pose_age : float
        The oldest object pose (s before the settled joint state) a grasp is measured against (> 0, may be inf).
    rule : CloseRule
        What makes a close and its end.
    objects : sequence of str
        A scene's objects, the one whose grasps are read first; none for a one-chain session.

    Raises
    ------
    DataError
        For a malformed joint state (duplicate names, positions not finite, ...), naming its time.
    """
    poses = ObjectPoses(objects, max_pose_age)
    extractor = _Extractor(kin, task_names, tasks, poses, rule)
    handlers: dict[str, Callable[[float, Any], None]] = {
        JOINT_STATES: extractor.joint_state, OPERATOR_GRASP_TASKS: extractor.grasp_tasks,
        **{topic: functools.partial(poses.take, name) for topic, name in poses.topics.items()}}
    t = math.nan
    for topic, t, msg in messages:
        if (handler := handlers.get(topic)) is None:
            continue
        try:
            handler(t, msg)
        except GraspIntentError as exc:
            raise DataError(f'malformed {topic} message at {t:.3f} s: {exc}') from None
    extractor.end(t)
    return Extraction(tuple(extractor.grasps), tuple(extractor.rejected), extractor.openings, tuple(extractor.notes),
                      tuple(extractor.elsewhere))


def _bag_messages(path: Path, relative: dict[str, str]) -> Iterator[tuple[str, float, Any]]:
    """The bag's messages on ``relative``'s topics as (relative topic, s from the bag's first message, message)."""
    t0: int | None = None
    for message in read_messages(path):
        t0 = message.timestamp_ns if t0 is None else t0
        if message.topic in relative:
            yield relative[message.topic], (message.timestamp_ns - t0) * 1e-9, message.decode()


def read_bag(path: str | os.PathLike[str], kin: MicoKinematics, *, task_names: Sequence[str], tasks: int | None = None,
             max_pose_age: float = MAX_POSE_AGE, rule: CloseRule = CloseRule(),
             target: str | None = None) -> Extraction:
    """:func:`extract` of a session bag's messages (times in s from its first message); a scene's ``target``'s.

    Raises
    ------
    BagReadError
        As :func:`~.demonstration_objects.bag_topics`: a bag that cannot be read, a scene without ``target`` or a
        one-chain session with one, no ``joint_states``, a topic of another type.
    DataError
        For a malformed joint state, naming the bag.
    """
    relative, objects = bag_topics(Path(path), target)
    try:
        return extract(_bag_messages(Path(path), relative), kin, task_names=task_names, tasks=tasks,
                       max_pose_age=max_pose_age, rule=rule, objects=objects)
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
    events += [(t, f'{bag}: close at {t:.3f} s is at {", ".join(at)}') for t, at in found.elsewhere]
    for _, line in sorted(events, key=lambda event: event[0]):
        yield line
    for note in found.notes:
        yield f'{bag}: note: {note}'
    yield (f'{bag}: {len(found.grasps)} grasp(s), {len(found.rejected)} close(s) rejected, '
           f'{found.openings} opening(s)' + (f', {len(found.elsewhere)} close(s) at other objects'
                                             if found.elsewhere else ''))


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
    parser.add_argument('--object', default=None, metavar='NAME',
                        help="the object of a scene's bag whose grasps are read (a one-chain bag refuses it)")
    parser.add_argument('--append', action='store_true', help='add the grasps to an existing CSV (its tasks)')
    parser.add_argument('--max-pose-age', type=float, default=MAX_POSE_AGE,
                        help=f'oldest object pose a grasp is measured against, s before it (default '
                             f'{MAX_POSE_AGE:g}; inf: the object never moved)')
    for flag, default, unit, what in (
            ('--close-rise', CLOSE_RISE, 'RAD', 'rise of the mean finger closure from a rest that is a close'),
            ('--settle-tolerance', SETTLE_TOLERANCE, 'RAD', 'span of each finger over the window at rest'),
            ('--settle-window', SETTLE_WINDOW, 'S', 'how long the fingers stay within the tolerance at rest')):
        parser.add_argument(flag, type=float, default=default, metavar=unit, help=f'{what} (default {default:g})')
    args = parser.parse_args(argv)
    status = [0]

    def body() -> None:
        if not args.max_pose_age > 0.0:
            raise DataError(f'--max-pose-age must be > 0 s (or inf), got {args.max_pose_age}')
        rule = CloseRule(args.close_rise, args.settle_tolerance, args.settle_window)
        if args.out.exists() and not args.append:
            raise DataError(f'{args.out} exists: --append adds to it')
        existing = load_csv(args.out) if args.append and args.out.exists() else None
        task_names = _task_names(args, existing)
        tasks = None if args.tasks is None else parse_tasks(args.tasks, task_names)
        kin = MicoKinematics()
        found = [(bag, read_bag(bag, kin, task_names=task_names, tasks=tasks, max_pose_age=args.max_pose_age,
                                rule=rule, target=args.object))
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
