"""The demonstrations command on a scene of several objects: whose a close is, the labels, the refusals.

The rules (grasp_intent_ros.sessions.demonstrations' docstring, *A scene of several objects* and *Labels*) on
hand-built message sequences and on scene bags written as the recorder writes them: the cup and a flashlight, the
hand closing at the cup's grasp GRASP_X, the flashlight far from it or 1 cm from the cup.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numpy.testing import assert_allclose

from grasp_intent_ros.method.data import load_csv
from grasp_intent_ros.method.intent import DEFAULT_TASKS
from grasp_intent_ros.sessions.bag import QosSpec, SessionWriter
from grasp_intent_ros.sessions.demonstrations import extract, main
from grasp_intent_ros.wire.topics import OBJECT_POSE, OPERATOR_GRASP_TASKS

from ..session_bags import text
from .test_demonstrations import BASE_T_OBJ, CLOSED, HANDOVER, KIN, TRANSFER, USAGE, Fingers, features_at, pose

CUP, FLASHLIGHT = 'cup/object/pose', 'flashlight/object/pose'
SCENE = ('cup', 'flashlight')
FAR, NEAR = BASE_T_OBJ.copy(), BASE_T_OBJ.copy()
FAR[:3, 3] += [0.0, 0.4, 0.0]  # the flashlight 0.4 m from the cup: the grasp's palm is out of its bounds
NEAR[:3, 3] += [0.01, 0.0, 0.0]  # 1 cm: the cup's grasp is within the flashlight's bounds too


def scene(flashlight: Any = FAR, *labels: tuple[float, str], pose_topic: str = CUP) -> list[tuple[str, float, Any]]:
    """The cup's pose and the flashlight's at 0.505 s, ``labels`` (t, text), then one close at the cup."""
    return [(pose_topic, 0.505, pose()), *([] if flashlight is None else [(FLASHLIGHT, 0.505, pose(flashlight))]),
            *[(OPERATOR_GRASP_TASKS, t, text(value)) for t, value in labels],
            *Fingers().rest(1.0).move(CLOSED).rest(1.0).messages()]


def seen() -> float:
    """When the close of :func:`scene` is seen (s): the time of its rejection as ambiguous."""
    return float(run(scene(NEAR)).rejected[0].t)


def run(messages: list[tuple[str, float, Any]], objects: tuple[str, ...] = SCENE, tasks: int | None = USAGE,
        max_pose_age: float = math.inf) -> Any:
    return extract(sorted(messages, key=lambda m: m[1]), KIN, task_names=DEFAULT_TASKS, tasks=tasks,
                   max_pose_age=max_pose_age, objects=objects)


@pytest.mark.parametrize('flashlight', [FAR, None, 'malformed'])
def test_a_close_at_the_cup_is_the_cups_grasp_and_the_flashlights_other_close(flashlight: Any) -> None:
    """Far from the flashlight, or the flashlight's pose not known (none, or malformed): it cannot claim the close."""
    messages = scene(None if isinstance(flashlight, str) else flashlight)
    if isinstance(flashlight, str):
        messages.append((FLASHLIGHT, 0.505, pose(frame='world')))
    cup = run(messages)
    assert len(cup.grasps) == 1 and cup.rejected == () and cup.elsewhere == ()
    assert_allclose(cup.grasps[0].x, features_at(messages, cup.grasps[0].t))
    other = run(messages, ('flashlight', 'cup'))
    if flashlight is FAR:  # at the cup: the flashlight's run reports it, neither a grasp nor a rejection
        assert other.grasps == () and other.rejected == () and other.elsewhere == ((seen(), ('cup',)),)
    else:  # without its own pose the flashlight has no grasp: rejected as today's one-object rules say
        assert other.grasps == () and other.elsewhere == () and len(other.rejected) == 1


def test_a_close_within_the_bounds_of_both_objects_is_rejected_as_ambiguous() -> None:
    for objects, named in ((SCENE, 'cup and flashlight'), (SCENE[::-1], 'flashlight and cup')):
        found = run(scene(NEAR), objects)
        assert found.grasps == () and found.elsewhere == ()
        assert found.rejected[0].reasons == (f'ambiguous: within the feature bounds of {named}',)


def test_another_objects_stale_pose_still_claims_the_close() -> None:
    """The flashlight's pose 2.1 s old at the settled close (max 1 s): stale to measure, known to exclude."""
    messages = [m for m in scene(NEAR) if m[0] != CUP] + [(CUP, 2.0, pose())]
    assert run(messages, max_pose_age=1.0).rejected[0].reasons == (
        'ambiguous: within the feature bounds of cup and flashlight',)
    far = [m for m in scene(FAR) if m[0] != CUP] + [(CUP, 2.0, pose())]
    assert len(run(far, max_pose_age=1.0).grasps) == 1


def test_a_label_may_name_its_object_and_a_disagreement_is_rejected() -> None:
    for label, task_set in (('cup: usage,transfer', USAGE | TRANSFER), ('handover', HANDOVER)):
        found = run(scene(FAR, (0.25, label)), tasks=None)
        assert [(g.task_set, g.label) for g in found.grasps] == [(task_set, 'label at 0.250 s')]
    meant_elsewhere = scene(FAR, (0.25, 'flashlight: handover'))
    assert run(meant_elsewhere).rejected[0].reasons == (
        'the label at 0.250 s names flashlight, but the hand is at cup',)
    assert run(meant_elsewhere, SCENE[::-1]).rejected[0].reasons == (
        'the label at 0.250 s names flashlight, but the hand is at cup',)
    assert run(scene(FAR, (0.25, 'cup: handover')), SCENE[::-1]).elsewhere == ((seen(), ('cup',)),)
    unknown = run(scene(FAR, (0.25, 'mug: usage')))
    assert unknown.rejected[0].reasons == (
        "the label at 0.250 s: 'mug: usage' names mug, not an object of the scene (cup, flashlight)",)
    one_chain = run(scene(None, (0.25, 'cup: usage'), pose_topic=OBJECT_POSE), ())
    assert one_chain.grasps == () and one_chain.rejected[0].reasons == (
        "the label at 0.250 s: 'cup: usage' names an object (cup), but the bag is one chain, not a scene",)


def write_scene(path: Path, messages: list[tuple[str, float, Any]], namespace: str) -> str:
    """Relative topics below ``namespace``, each message at its time (s) as its receive time."""
    with SessionWriter(path) as bag:
        for topic, t, msg in sorted(messages, key=lambda m: m[1]):
            full = f'{namespace}/{topic}'
            if full not in bag.topics:
                bag.add_topic(full, msg.__msgtype__, qos=QosSpec())
            bag.write_message(full, round(t * 1e9), msg)
    return str(path)


def test_a_scenes_bag_gives_each_object_its_own_grasps(tmp_path: Path, capsys: Any) -> None:
    """The labels on the arm's operator/grasp_tasks (the cup chain's own is not read); the chains in /robot1."""
    messages = scene(FAR, (0.25, 'cup: handover')) + [('cup/operator/grasp_tasks', 0.3, text('transfer'))]
    bag = write_scene(tmp_path / 'scene', messages, '/robot1')
    assert main([bag, '--object', 'cup', '--out', str(tmp_path / 'cup.csv'), '--max-pose-age', 'inf']) == 0
    cup = load_csv(tmp_path / 'cup.csv')
    assert cup.task_sets.tolist() == [HANDOVER]
    assert_allclose(cup.x[0], features_at(messages, 2.6), atol=5e-7)  # still from 2.1 s; the CSV's 6 decimals
    capsys.readouterr()
    assert main([bag, '--object', 'flashlight', '--out', str(tmp_path / 'flashlight.csv'), '--tasks', 'usage',
                 '--max-pose-age', 'inf']) == 1
    printed = capsys.readouterr().out
    assert f'close at {seen():.3f} s is at cup' in printed and '0 close(s) rejected' in printed
    assert '1 close(s) at other objects' in printed and not (tmp_path / 'flashlight.csv').exists()


def test_the_command_refuses_a_scene_without_object_and_one_chain_with_it(tmp_path: Path, capsys: Any) -> None:
    bag = write_scene(tmp_path / 'scene', scene(FAR), '')
    out = str(tmp_path / 'x.csv')
    assert main([bag, '--out', out, '--tasks', 'usage']) == 2
    err = capsys.readouterr().err
    assert 'scene of several objects (chains /cup, /flashlight)' in err and '--object' in err
    assert main([bag, '--object', 'mug', '--out', out, '--tasks', 'usage']) == 2
    assert 'has no object mug: its objects are cup, flashlight' in capsys.readouterr().err
    one_chain = write_scene(tmp_path / 'one', scene(None, pose_topic=OBJECT_POSE), '')
    assert main([one_chain, '--object', 'cup', '--out', out, '--tasks', 'usage']) == 2
    assert 'is one chain (in /), not a scene' in capsys.readouterr().err and not Path(out).exists()
    assert main([one_chain, '--out', out, '--tasks', 'usage', '--max-pose-age', 'inf']) == 0
    assert np.array_equal(load_csv(out).task_sets, [USAGE])
