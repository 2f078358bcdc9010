"""Recorded vs live answers of a session step, ROS-free (the replay's check).

:func:`compare_step` compares one step's live outputs with the recorded ones topic by topic, the i-th live
message with the i-th recorded one, within :class:`Tolerances`: v 1e-9; P and reconstructed w 1e-4; end-
effector position 1 mm and orientation 0.01 rad; joint targets and trajectory positions 1e-3 rad;
clarifications, rejections (status, level, reason) and frame/joint/zone names identical. Stamps are
never compared. A model document whose content (sha256) differs under the same name is a note, not a
failure: the differing plans that follow are what fails.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from ..errors import GraspIntentError
from ..wire.arrays import split_labels, split_posterior
from ..wire.diagnostics import LEVEL_NAMES
from ..wire.model_document import ModelHeader
from ..wire.topics import DIAGNOSTICS, MODEL_ACTIVE
from .outputs import Joints, Output, Pose, Rejection, Text, Trajectory, Undecodable, Value, Vector
from .pairing import Step

__all__ = ['Tolerances', 'Difference', 'summarize', 'compare_step', 'answered', 'diverged']


@dataclass(frozen=True)
class Tolerances:
    """Largest accepted |recorded - live| per quantity (absolute).

    Attributes
    ----------
    v
        Target vector entries.
    posterior
        P(zone | x) and reconstructed w entries.
    position_m
        End-effector position (Euclidean distance, m); also palm features.
    angle_rad
        End-effector orientation (rotation angle between the two, rad); also approach and
        roll features.
    joint_rad
        Joint targets and trajectory positions (rad); also finger features.
    duration_s
        Trajectory time from start (s).
    """

    v: float = 1e-9
    posterior: float = 1e-4
    position_m: float = 1e-3
    angle_rad: float = 0.01
    joint_rad: float = 1e-3
    duration_s: float = 0.01


@dataclass(frozen=True)
class Difference:
    """One difference between a recorded and a live output.

    Attributes
    ----------
    step
        Input number (1-based) whose answer differs.
    input
        The input's description.
    topic
        Output topic (relative) or '/diagnostics'.
    field
        What differs, e.g. 'P[UT]', 'position', 'message'.
    recorded
        The recorded value, formatted.
    live
        The live value, formatted.
    fatal
        False for a note that does not fail a check (a model's content differs).
    """

    step: int
    input: str
    topic: str
    field: str
    recorded: str
    live: str
    fatal: bool = True

    def __str__(self) -> str:
        kind = '' if self.fatal else 'note: '
        return (f'{kind}input #{self.step} ({self.input}): {self.topic} {self.field}: '
                f'recorded {self.recorded}, live {self.live}')


def summarize(value: Value) -> str:
    """A short one-line rendering of an output value."""
    if isinstance(value, Vector):
        data = ', '.join(f'{v:.6g}' for v in value.data[:10]) + (', ...' if value.data.size > 10 else '')
        return f'[{data}]'
    if isinstance(value, Text):
        return repr(value.data)
    if isinstance(value, Pose):
        return f'position {_fmt(value.position, 4)} m, q {_fmt(value.orientation, 4)} in {value.frame_id!r}'
    if isinstance(value, Joints):
        return f'{len(value.names)} joints {_fmt(value.positions, 4)} rad'
    if isinstance(value, Trajectory):
        return f'{len(value.times_s)} point(s) over {len(value.joint_names)} joints'
    if isinstance(value, ModelHeader):
        return f'model {value.name!r} (sha256 {value.sha256[:12]})'
    if isinstance(value, Rejection):
        return f'{LEVEL_NAMES.get(value.level, value.level)} from {value.status!r}: {value.reason!r}'
    return f'<undecodable: {value.reason}>'


def _fmt(values: NDArray[np.float64], digits: int = 6) -> str:
    return '(' + ', '.join(f'{v:.{digits}g}' for v in values) + ')'


def _beyond(diff: float, tol: float) -> str:
    return f' (|diff| {diff:.3g} > {tol:g})'


def _value_labels(vector: Vector, n: int) -> tuple[str, ...]:
    """Names of a vector's entries, from the last dimension label (a leading stamp axis is skipped).

    A posterior's '<zones>|<tasks>' label gives 'P[zone]' and 'w[task]'.
    """
    labels = _stripped_labels(vector)
    label = labels[-1] if labels else ''
    try:
        zones, _, tasks, _ = split_posterior(vector.data, label)
        names = [f'P[{z}]' for z in zones] + [f'w[{t}]' for t in tasks]
    except GraspIntentError:  # not a posterior: one name per entry
        names = [f'[{z}]' for z in split_labels(label)]
    return tuple(names) if len(names) == n else tuple(f'[{i}]' for i in range(n))


def _feature_tolerance(name: str, tol: Tolerances) -> float:
    bare = name.strip('[]')
    if bare.startswith('palm'):
        return tol.position_m
    if bare.startswith(('approach', 'roll')):
        return tol.angle_rad
    return tol.joint_rad


def _stripped_labels(vector: Vector) -> tuple[str, ...]:
    return tuple(label for label in vector.labels if not label.startswith('stamp='))


def _compare_vectors(topic: str, rec: Vector, live: Vector, tol: Tolerances) -> list[tuple[str, str, str]]:
    if _stripped_labels(rec) != _stripped_labels(live) or rec.data.shape != live.data.shape:
        return [('layout', f'labels {list(_stripped_labels(rec))}, {rec.data.size} values',
                 f'labels {list(_stripped_labels(live))}, {live.data.size} values')]
    names = _value_labels(rec, rec.data.size)
    out = []
    for name, r, v in zip(names, rec.data, live.data):
        if topic == 'intent/v':
            limit = tol.v
        elif topic == 'grasp/posterior':
            limit = tol.posterior
        else:
            limit = _feature_tolerance(name, tol)
        diff = abs(float(r) - float(v))
        if not diff <= limit:  # NaN differs too
            field_name = name if topic != 'intent/v' else f'v{name}'
            out.append((field_name, f'{r:.10g}', f'{v:.10g}{_beyond(diff, limit)}'))
    return out


def _rotation_angle(q1: NDArray[np.float64], q2: NDArray[np.float64]) -> float:
    n1, n2 = float(np.linalg.norm(q1)), float(np.linalg.norm(q2))
    if not (n1 > 0.0 and n2 > 0.0):
        return math.inf
    dot = min(1.0, abs(float(np.dot(q1, q2))) / (n1 * n2))
    return 2.0 * math.acos(dot)


def _compare_joint_lists(names: Sequence[str], rec: NDArray[np.float64], live: NDArray[np.float64],
                         tol: float, what: str) -> list[tuple[str, str, str]]:
    out = []
    for i, (r, v) in enumerate(zip(rec, live)):
        diff = abs(float(r) - float(v))
        if not diff <= tol:
            name = names[i] if i < len(names) else str(i)
            out.append((f'{what}[{name}]', f'{r:.6f} rad', f'{v:.6f} rad{_beyond(diff, tol)}'))
    return out


def _compare_values(topic: str, rec: Value, live: Value, tol: Tolerances) -> list[tuple[str, str, str, bool]]:
    """(field, recorded, live, fatal) for every difference between two values of one topic."""
    if isinstance(live, Undecodable) or type(rec) is not type(live):
        return [('message', summarize(rec), summarize(live), True)]
    out: list[tuple[str, str, str]] = []
    if isinstance(rec, Vector) and isinstance(live, Vector):
        out = _compare_vectors(topic, rec, live, tol)
    elif isinstance(rec, Text) and isinstance(live, Text):
        if rec.data != live.data:
            out = [('text', repr(rec.data), repr(live.data))]
    elif isinstance(rec, Pose) and isinstance(live, Pose):
        if rec.frame_id != live.frame_id:
            out.append(('frame_id', repr(rec.frame_id), repr(live.frame_id)))
        dist = float(np.linalg.norm(rec.position - live.position))
        if not dist <= tol.position_m:
            out.append(('position', f'{_fmt(rec.position)} m',
                        f'{_fmt(live.position)} m (distance {1e3 * dist:.3g} mm > {1e3 * tol.position_m:g} mm)'))
        angle = _rotation_angle(rec.orientation, live.orientation)
        if not angle <= tol.angle_rad:
            out.append(('orientation', f'q {_fmt(rec.orientation)}',
                        f'q {_fmt(live.orientation)} (rotation {angle:.3g} rad > {tol.angle_rad:g} rad)'))
    elif isinstance(rec, Joints) and isinstance(live, Joints):
        if rec.names != live.names or rec.positions.shape != live.positions.shape:
            out = [('name', str(list(rec.names)), str(list(live.names)))]
        else:
            out = _compare_joint_lists(rec.names, rec.positions, live.positions, tol.joint_rad, 'position')
    elif isinstance(rec, Trajectory) and isinstance(live, Trajectory):
        if rec.joint_names != live.joint_names or rec.positions.shape != live.positions.shape:
            out = [('joint_names/points', f'{list(rec.joint_names)}, {len(rec.times_s)} point(s)',
                    f'{list(live.joint_names)}, {len(live.times_s)} point(s)')]
        else:
            for k in range(len(rec.times_s)):
                out += _compare_joint_lists(rec.joint_names, rec.positions[k], live.positions[k],
                                            tol.joint_rad, f'points[{k}].positions')
                diff = abs(float(rec.times_s[k] - live.times_s[k]))
                if not diff <= tol.duration_s:
                    out.append((f'points[{k}].time_from_start', f'{rec.times_s[k]:.4f} s',
                                f'{live.times_s[k]:.4f} s{_beyond(diff, tol.duration_s)}'))
    elif isinstance(rec, ModelHeader) and isinstance(live, ModelHeader):
        if rec.name != live.name:
            out = [('model name', repr(rec.name), repr(live.name))]
        elif rec.sha256 != live.sha256:
            return [('model content', f'sha256 {rec.sha256[:12]}', f'sha256 {live.sha256[:12]} '
                     '(same name, different model: the plans that follow may differ)', False)]
    elif isinstance(rec, Rejection) and isinstance(live, Rejection):
        if (rec.status, rec.level, rec.reason) != (live.status, live.level, live.reason):
            out = [('rejection', summarize(rec), summarize(live))]
    elif isinstance(rec, Undecodable) and isinstance(live, Undecodable):
        pass
    return [(f, r, v, True) for f, r, v in out]


def _by_topic(outputs: Iterable[Output]) -> dict[str, list[Output]]:
    groups: dict[str, list[Output]] = defaultdict(list)
    for out in outputs:
        groups[out.topic].append(out)
    if DIAGNOSTICS in groups:  # rejections from different nodes: order by node, then arrival
        groups[DIAGNOSTICS].sort(key=lambda o: o.value.status if isinstance(o.value, Rejection) else '')
    return groups


_TOPIC_ORDER: Final = {topic: k for k, topic in enumerate((
    MODEL_ACTIVE, 'intent/v', 'intent/clarification', DIAGNOSTICS, 'grasp/posterior', 'grasp/pose',
    'grasp/joint_targets', 'grasp/trajectory', 'grasp/features'))}
"""Order in which a step's differences are listed: the cause first, the most telling outputs next."""


def compare_step(step: Step, live: Sequence[Output], tol: Tolerances = Tolerances()) -> list[Difference]:
    """The differences between a step's recorded outputs and the ``live`` outputs for the same input.

    Outputs are matched per topic in order (rejections per status name); a missing or extra message is
    a difference on field 'message'.
    """
    expected, got = _by_topic(step.expected), _by_topic(live)
    topics = sorted(set(expected) | set(got), key=lambda t: (_TOPIC_ORDER.get(t, len(_TOPIC_ORDER)), t))
    diffs = []
    for topic in topics:
        rec_list, live_list = expected.get(topic, []), got.get(topic, [])
        for i in range(max(len(rec_list), len(live_list))):
            if i >= len(live_list):
                diffs.append(Difference(step.index, step.description, topic, 'message',
                                        summarize(rec_list[i].value), 'nothing'))
            elif i >= len(rec_list):
                diffs.append(Difference(step.index, step.description, topic, 'message', 'nothing',
                                        summarize(live_list[i].value)))
            else:
                diffs += [Difference(step.index, step.description, topic, f, r, v, fatal)
                          for f, r, v, fatal in _compare_values(topic, rec_list[i].value, live_list[i].value, tol)]
    return diffs


def _counts(outputs: Iterable[Output]) -> dict[str, int]:
    counts: dict[str, int] = defaultdict(int)
    for out in outputs:
        counts[out.topic] += 1
    return counts


def answered(step: Step, live: Sequence[Output]) -> bool:
    """Whether ``live`` holds at least as many messages per topic as the step's recorded outputs."""
    have = _counts(live)
    return all(have[topic] >= n for topic, n in _counts(step.expected).items())


def diverged(step: Step, live: Sequence[Output]) -> bool:
    """Whether ``live`` holds a message the recording does not (a topic, or one message too many)."""
    want = _counts(step.expected)
    return any(n > want.get(topic, 0) for topic, n in _counts(live).items())


