"""grasp_intent_ros.launch.objects: the ``--object NAME=MODEL`` specs, and the chains NodeSuite starts for them."""

from __future__ import annotations

from pathlib import Path

import pytest

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.launch.objects import (
    SceneObject,
    chain_remappings,
    operator_object,
    parse_objects,
    scene_node_args,
)
from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import REMAPPINGS, SUITE_NODES, NodeSuite, node_environment
from grasp_intent_ros.resources import config_dir


def test_specs_become_objects_in_the_given_order() -> None:
    assert parse_objects(['cup=cup_7zone', 'flashlight=flashlight_7zone', 'cup_2=cup_7zone']) == (
        SceneObject('cup', 'cup_7zone'), SceneObject('flashlight', 'flashlight_7zone'),
        SceneObject('cup_2', 'cup_7zone'))
    assert parse_objects([]) == ()
    cup = SceneObject('cup', 'cup_7zone')
    assert (cup.namespace(), cup.namespace('/robot1')) == ('/cup', '/robot1/cup')
    assert cup.process_name('grasp_planner') == 'cup/grasp_planner'


@pytest.mark.parametrize(('spec', 'reason'), [
    ('cup', "'cup' is not NAME=MODEL"),
    ('cup=', "'cup=' is not NAME=MODEL"),
    ('=cup_7zone', "'=cup_7zone' is not NAME=MODEL"),
    ('1cup=cup_7zone', "object name '1cup' is not a ROS name token"),
    ('_cup=cup_7zone', "object name '_cup' is not a ROS name token"),
    ('a/b=cup_7zone', "object name 'a/b' is not a ROS name token"),
    ('cup-1=cup_7zone', "object name 'cup-1' is not a ROS name token"),
    ('grasp=cup_7zone', "object name 'grasp' is a folder of the suite's topics"),
    ('model=cup_7zone', "object name 'model' is a folder of the suite's topics"),
    ('cup=mug_7zone', "object 'cup': no model 'mug_7zone'; there are: cup_4zone, cup_5zone, cup_7zone, "
                      'flashlight_7zone'),
])
def test_a_bad_spec_is_refused_with_the_reason(spec: str, reason: str) -> None:
    with pytest.raises(GraspIntentError) as info:
        parse_objects(['flashlight=flashlight_7zone', spec])
    assert str(info.value).startswith(reason), info.value


def test_every_bad_spec_is_named_at_once_and_a_name_given_twice_is_refused() -> None:
    with pytest.raises(GraspIntentError) as info:
        parse_objects(['cup=cup_7zone', 'cup=cup_5zone', 'x=nope'])
    assert str(info.value).split('; ')[:2] == ["object 'cup' is named twice", "object 'x': no model 'nope'"]


def test_models_are_looked_up_in_the_given_directory(tmp_path: Path) -> None:
    (tmp_path / 'mug_3zone.yaml').write_text('not read: only the name is checked\n')
    assert parse_objects(['mug=mug_3zone'], models_dir=str(tmp_path)) == (SceneObject('mug', 'mug_3zone'),)
    with pytest.raises(GraspIntentError, match="no model 'cup_7zone'; there are: mug_3zone"):
        parse_objects(['cup=cup_7zone'], models_dir=str(tmp_path))
    with pytest.raises(GraspIntentError, match='is not a directory'):
        parse_objects(['cup=cup_7zone'], models_dir=str(tmp_path / 'missing'))


def test_the_scripted_operator_reaches_for_the_object_named_or_the_first() -> None:
    objects = parse_objects(['cup=cup_7zone', 'flashlight=flashlight_7zone'])
    assert operator_object(objects) == objects[0] and operator_object(objects, 'flashlight') == objects[1]
    with pytest.raises(GraspIntentError, match="object 'mug' is not one of the objects cup, flashlight"):
        operator_object(objects, 'mug')
    with pytest.raises(GraspIntentError, match='no objects'):
        operator_object(())
    assert scene_node_args('scripted_operator', objects) == ('-p', "object:='cup'")
    assert scene_node_args('scripted_operator', objects, operator='flashlight') == ('-p', "object:='flashlight'")


def test_each_object_gets_a_chain_in_its_namespace_with_its_model_reading_the_arms_joint_states(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No process is started (``start`` recorded)."""
    started: list[tuple[str, str | None, tuple[str, ...]]] = []
    monkeypatch.setattr(NodeSuite, 'start',
                        lambda self, module, *args, name=None: started.append((module, name, args)))
    suite = NodeSuite(97, log_dir=tmp_path)
    objects = parse_objects(['cup=cup_5zone', 'flashlight=flashlight_7zone'])
    suite.start_nodes(namespace='/robot1', objects=objects)
    assert [(module, name) for module, name, _ in started] == [
        (module, f'{obj}/{module}') for obj in ('cup', 'flashlight') for module in SUITE_NODES]
    for module, name, args in started:
        obj = name.split('/')[0]
        model = dict(cup='cup_5zone', flashlight='flashlight_7zone')[obj]
        assert args[:2] == ('--params-file', str(config_dir() / f'{module}.yaml'))
        remaps = [args[i + 1] for i, a in enumerate(args) if a == '-r']
        assert remaps == [f'__ns:=/robot1/{obj}', 'joint_states:=/robot1/joint_states'], (name, args)
        assert (f'model:={model}' in args) == (module == 'model_server'), (name, args)
    assert chain_remappings() == ('joint_states:=/joint_states',)

    started.clear()
    suite.start_nodes(namespace='/robot1', objects=objects, extra=['intent_estimator'])
    assert [name for _, name, _ in started[:-1]] == [f'{obj}/{module}' for obj in ('cup', 'flashlight')
                                                      for module in SUITE_NODES]
    module, name, args = started[-1]  # one estimator over both chains, at the suite's namespace
    assert (module, name) == ('intent_estimator', None)
    assert args[:2] == ('--params-file', str(config_dir() / 'intent_estimator.yaml'))
    assert [args[i + 1] for i, a in enumerate(args) if a == '-r'] == ['__ns:=/robot1']
    assert [args[i + 1] for i, a in enumerate(args) if a == '-p'] == ["objects:=['cup','flashlight']"]

    started.clear()  # the shared-control loop: the mock arm and the assistance at the suite's namespace, over both
    suite.start_nodes(namespace='/robot1', objects=objects, shared_control=True, extra=['intent_estimator'])
    assert [(module, name) for module, name, _ in started[len(objects) * len(SUITE_NODES):]] == [
        ('mock_arm', None), ('assistance', None), ('intent_estimator', None)]
    for module, _, args in started[-3:-1]:
        assert [args[i + 1] for i, a in enumerate(args) if a == '-r'] == ['__ns:=/robot1', *REMAPPINGS.get(module, ())]
        assert [args[i + 1] for i, a in enumerate(args) if a == '-p'] == ["objects:=['cup','flashlight']"]

    started.clear()  # the scripted operator at the suite's namespace, reaching for the flashlight, w the estimator's
    suite.start_nodes(namespace='/robot1', objects=objects, shared_control=True, operator='flashlight',
                      extra=['intent_estimator', 'scripted_operator'])
    module, name, args = started[-1]
    assert (module, name) == ('scripted_operator', None)
    assert [args[i + 1] for i, a in enumerate(args) if a == '-r'] == ['__ns:=/robot1']
    assert [args[i + 1] for i, a in enumerate(args) if a == '-p'] == ["object:='flashlight'", 'intent:=none']
    arm_args = next(args for module, _, args in started if module == 'mock_arm')
    assert [arm_args[i + 1] for i, a in enumerate(arm_args) if a == '-r'] == [  # each chain's trajectory, unmapped
        '__ns:=/robot1', 'servo/delta_twist_cmds:=assistance/twist']

    started.clear()
    with pytest.raises(GraspIntentError, match="object 'mug' is not one of the objects"):
        suite.start_nodes(objects=objects, extra=['scripted_operator'], operator='mug')
    with pytest.raises(GraspIntentError, match='give no model'):
        suite.start_nodes(objects=objects, model='cup_7zone')
    assert not started


def test_the_viewer_starts_once_after_the_chains_at_the_suites_namespace_with_the_objects_names(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``suite --object ... --with viewer``; no process is started (``start`` recorded)."""
    started: list[tuple[str, str | None, tuple[str, ...]]] = []
    monkeypatch.setattr(NodeSuite, 'start',
                        lambda self, module, *args, name=None: started.append((module, name, args)))
    objects = parse_objects(['cup=cup_5zone', 'flashlight=flashlight_7zone'])
    NodeSuite(97, log_dir=tmp_path).start_nodes(namespace='/robot1', objects=objects, extra=['viewer'])
    assert [(module, name) for module, name, _ in started] == [
        *((module, f'{obj}/{module}') for obj in ('cup', 'flashlight') for module in SUITE_NODES), ('viewer', None)]
    args = started[-1][2]
    assert args[:2] == ('--params-file', str(config_dir() / 'viewer.yaml'))
    assert [args[i + 1] for i, a in enumerate(args) if a == '-r'] == ['__ns:=/robot1']
    assert [args[i + 1] for i, a in enumerate(args) if a == '-p'] == ["objects:=['cup','flashlight']"]
    assert scene_node_args('viewer', objects[:1]) == ('-p', "objects:=['cup']")


def test_a_chain_process_is_named_by_its_object_and_its_logs_too(tmp_path: Path) -> None:
    module = 'absent_node'
    proc = NodeProcess.start(module, env=node_environment(97), log_dir=tmp_path, name=f'cup/{module}')
    proc.wait(30.0)
    assert proc.module == 'cup/absent_node'
    assert (proc.stdout_path.name, proc.stderr_path.name) == ('cup.absent_node.out',
                                                              'cup.absent_node.err')
    assert f'No module named grasp_intent_ros.nodes.{module}' in proc.stderr()
    assert proc.problem().startswith('cup/absent_node (pid ')
