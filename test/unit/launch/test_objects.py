"""grasp_intent_ros.launch.objects: the ``--object NAME=MODEL`` specs, and the chains NodeSuite starts for them."""

from __future__ import annotations

from pathlib import Path

import pytest

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.launch.objects import (
    SCENE_NODES,
    SceneObject,
    chain_remappings,
    parse_objects,
    refuse_unbuilt,
    scene_node_args,
)
from grasp_intent_ros.launch.suite import REMAPPINGS, SUITE_NODES, NodeProcess, NodeSuite, node_environment
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


def test_optional_nodes_beside_objects_are_refused_naming_them_but_those_of_the_scene() -> None:
    refuse_unbuilt([])
    refuse_unbuilt(['mock_arm', 'intent_estimator', 'viewer', 'assistance'])
    with pytest.raises(GraspIntentError, match=r'^scripted_operator with --object: not built yet'):
        refuse_unbuilt(['mock_arm', 'scripted_operator', 'assistance'])


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

    started.clear()
    with pytest.raises(GraspIntentError, match='^scripted_operator with --object'):
        suite.start_nodes(objects=objects, extra=['viewer', 'scripted_operator'])
    with pytest.raises(GraspIntentError, match='give no model'):
        suite.start_nodes(objects=objects, model='cup_7zone')
    assert not started


def test_the_viewer_starts_once_after_the_chains_at_the_suites_namespace_with_the_objects_names(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``suite --object ... --with viewer``; no process is started (``start`` recorded)."""
    started: list[tuple[str, str | None, tuple[str, ...]]] = []
    monkeypatch.setattr(NodeSuite, 'start',
                        lambda self, module, *args, name=None: started.append((module, name, args)))
    assert SCENE_NODES == ('mock_arm', 'assistance', 'intent_estimator', 'viewer')
    objects = parse_objects(['cup=cup_5zone', 'flashlight=flashlight_7zone'])
    NodeSuite(97, log_dir=tmp_path).start_nodes(namespace='/robot1', objects=objects, extra=['viewer'])
    assert [(module, name) for module, name, _ in started] == [
        *((module, f'{obj}/{module}') for obj in ('cup', 'flashlight') for module in SUITE_NODES), ('viewer', None)]
    args = started[-1][2]
    assert args[:2] == ('--params-file', str(config_dir() / 'viewer.yaml'))
    assert [args[i + 1] for i, a in enumerate(args) if a == '-r'] == ['__ns:=/robot1']
    assert [args[i + 1] for i, a in enumerate(args) if a == '-p'] == ["objects:=['cup','flashlight']"]
    assert scene_node_args(objects[:1]) == ('-p', "objects:=['cup']")


def test_a_chain_process_is_named_by_its_object_and_its_logs_too(tmp_path: Path) -> None:
    module = 'absent_node'
    proc = NodeProcess.start(module, env=node_environment(97), log_dir=tmp_path, name=f'cup/{module}')
    proc.wait(30.0)
    assert proc.module == 'cup/absent_node'
    assert (proc.stdout_path.name, proc.stderr_path.name) == ('cup.absent_node.out',
                                                              'cup.absent_node.err')
    assert f'No module named grasp_intent_ros.nodes.{module}' in proc.stderr()
    assert proc.problem().startswith('cup/absent_node (pid ')
