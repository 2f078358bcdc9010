"""grasp_intent_ros.launch.suite on plain ``python -c`` processes (no ROS node is started)."""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path

import pytest

from grasp_intent_ros.launch.objects import SceneObject
from grasp_intent_ros.launch.process import NodeProcess
from grasp_intent_ros.launch.suite import (
    FASTDDS_PROFILE,
    RUN_DOMAIN_IDS,
    TEST_DOMAIN_IDS,
    NodeSuite,
    SuiteError,
    domain_id_from_environment,
    node_environment,
    use_loopback_discovery,
)
from grasp_intent_ros.resources import config_dir

from .probe_process import READY_SLEEPER, run, wait_logged_ready

SCENE = (SceneObject('cup', 'cup_7zone'), SceneObject('flashlight', 'flashlight_7zone'))


def test_node_environment_is_loopback_only_and_unbuffered() -> None:
    base = {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET', 'ROS_STATIC_PEERS': '10.0.0.1', 'HOME': '/home/x'}
    env = node_environment(42, base)
    assert env == {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'ROS_DOMAIN_ID': '42', 'HOME': '/home/x',
                   'PYTHONUNBUFFERED': '1', 'RCUTILS_LOGGING_BUFFERED_STREAM': '0',
                   'FASTRTPS_DEFAULT_PROFILES_FILE': str(config_dir() / FASTDDS_PROFILE),
                   'RMW_FASTRTPS_USE_QOS_FROM_XML': '1'}
    assert base['ROS_STATIC_PEERS'] == '10.0.0.1'  # not modified
    mine = node_environment(42, {**base, 'FASTRTPS_DEFAULT_PROFILES_FILE': 'mine.xml'})
    assert mine['FASTRTPS_DEFAULT_PROFILES_FILE'] == 'mine.xml', "the user's own profile is kept"
    assert 'RMW_FASTRTPS_USE_QOS_FROM_XML' not in mine, 'and rmw_fastrtps uses it as the user chose'


def test_fastdds_profile_sets_timing_loopback_data_locators_and_payload_memory_only() -> None:
    """The profile sets discovery timing, user data on UDP 127.0.0.1, payload memory; never transports or peers.

    Which interfaces and peers discovery uses stays with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; the one
    locator the profile sets is the loopback address (the file's comment says why). Readers and writers
    hold a payload only while its sample is held (DYNAMIC), without data sharing.
    """
    import xml.etree.ElementTree as ET
    ns = {'p': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}
    root = ET.parse(config_dir() / FASTDDS_PROFILE).getroot()
    participants = root.findall('p:participant', ns)
    assert len(participants) == 1 and participants[0].get('is_default_profile') == 'true'
    assert [child.tag.split('}')[1] for child in root] == ['participant', 'data_writer', 'data_reader']
    for endpoint in root.findall('p:data_writer', ns) + root.findall('p:data_reader', ns):
        assert endpoint.get('is_default_profile') == 'true'
        assert [(child.tag.split('}')[1], (child.text or '').strip()) for child in endpoint] == [
            ('historyMemoryPolicy', 'DYNAMIC'), ('qos', '')]
        assert endpoint.find('p:qos/p:data_sharing/p:kind', ns).text == 'OFF'
    discovery = participants[0].find('p:rtps/p:builtin/p:discovery_config', ns)
    assert discovery is not None
    assert sorted(child.tag.split('}')[1] for child in discovery) == ['initialAnnouncements', 'leaseAnnouncement']
    assert [child.tag.split('}')[1] for child in participants[0].find('p:rtps/p:builtin', ns)] == ['discovery_config']
    rtps = participants[0].find('p:rtps', ns)
    assert [child.tag.split('}')[1] for child in rtps] == ['defaultUnicastLocatorList', 'builtin']
    locators = rtps.findall('p:defaultUnicastLocatorList/p:locator', ns)
    assert [[(child.tag.split('}')[1], [(a.tag.split('}')[1], a.text) for a in child]) for child in locator]
            for locator in locators] == [[('udpv4', [('address', '127.0.0.1')])]]


def test_domain_id_is_validated_once() -> None:
    assert domain_id_from_environment({'ROS_DOMAIN_ID': ' 42 '}) == 42
    assert domain_id_from_environment({'ROS_DOMAIN_ID': ''}, unset=0) == 0
    assert domain_id_from_environment({}) in RUN_DOMAIN_IDS and not set(RUN_DOMAIN_IDS) & set(TEST_DOMAIN_IDS)
    for bad in ('102', '-1', 'x', '4.2'):
        with pytest.raises(SuiteError, match='0..101'):
            domain_id_from_environment({'ROS_DOMAIN_ID': bad})
    with pytest.raises(SuiteError, match='0..101'):
        NodeSuite(102)


def test_loopback_discovery_is_set_in_the_given_environment() -> None:
    env = {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SUBNET', 'ROS_STATIC_PEERS': '10.0.0.1'}
    assert use_loopback_discovery(env) == 'SUBNET'
    assert env == {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
                   'FASTRTPS_DEFAULT_PROFILES_FILE': str(config_dir() / FASTDDS_PROFILE),
                   'RMW_FASTRTPS_USE_QOS_FROM_XML': '1'}
    mine = {'FASTRTPS_DEFAULT_PROFILES_FILE': 'mine.xml'}
    assert use_loopback_discovery(mine) is None
    assert mine == {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST', 'FASTRTPS_DEFAULT_PROFILES_FILE': 'mine.xml'}


def test_suite_waits_notices_a_death_and_stops_by_pid(tmp_path: Path) -> None:
    suite = NodeSuite(97, log_dir=tmp_path)
    suite.processes += [run(tmp_path, READY_SLEEPER), NodeProcess([sys.executable, '-c', 'import sys; sys.exit(4)'],
                                                            module='quitter', env=suite.env, log_dir=tmp_path)]
    spins: list[float] = []
    with pytest.raises(SuiteError, match=r'quitter \(pid \d+\) exited with code 4'):
        suite.wait_ready(lambda: ['not yet'], spins.append, 30.0)
    assert suite.wait_ready(lambda: [], spins.append, 0.0) == []
    wait_logged_ready(suite.processes[0])
    assert suite.stop(include_exited=False) == [f'probe (pid {suite.processes[0].pid}) exited with code '
                                                f'{-signal.SIGTERM}:\n    | (empty)']
    assert suite.stop(tail_lines=0) == [f'probe (pid {suite.processes[0].pid}) exited with code {-signal.SIGTERM}',
                                        f'quitter (pid {suite.processes[1].pid}) exited with code 4']
    suite.remove_logs()
    assert tmp_path.is_dir(), 'a log directory given by the caller stays'


def test_nodes_stop_one_at_a_time_the_last_started_first_each_in_a_session_of_its_own(tmp_path: Path) -> None:
    """Each writes to one shared file (appends are ordered) when it gets SIGTERM and just before it exits."""
    journal = tmp_path / 'journal'
    code = ('import os, signal, sys, time\n'
            'name = sys.argv[1]\n'
            'def note(what):\n'
            '    with open({journal!r}, "a") as f:\n'
            '        f.write(f"{{name}} {{what}}\\n")\n'
            'def stop(*_):\n'
            '    note("signalled"); time.sleep(0.2); note("exits"); sys.exit(0)\n'
            'signal.signal(signal.SIGTERM, stop)\n'
            'note(f"session {{os.getsid(0) == os.getpid()}}")\n'
            'while True:\n'
            '    time.sleep(1)\n').format(journal=str(journal))
    suite = NodeSuite(97, log_dir=tmp_path)
    for name in ('first', 'second', 'third'):
        suite.processes.append(NodeProcess([sys.executable, '-c', code, name], module=name, env=suite.env,
                                           log_dir=tmp_path))
    assert suite.wait_ready(lambda: [] if journal.is_file() and len(journal.read_text().splitlines()) == 3
                            else ['not yet'], lambda seconds: time.sleep(seconds), 30.0) == []
    assert suite.stop() == []
    lines = journal.read_text().splitlines()
    assert sorted(lines[:3]) == ['first session True', 'second session True', 'third session True']
    assert lines[3:] == ['third signalled', 'third exits', 'second signalled', 'second exits', 'first signalled',
                         'first exits']


def test_optional_nodes_start_on_request_after_the_suite_with_every_params_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``suite --with NAME`` for any entry of OPTIONAL_NODES; no process is started (``start`` recorded)."""
    import grasp_intent_ros.launch.suite as suite_module

    monkeypatch.setattr(suite_module, 'OPTIONAL_NODES', ('viewer_like',))
    started: list[tuple[str, tuple[str, ...]]] = []
    monkeypatch.setattr(NodeSuite, 'start', lambda self, module, *args, name=None: started.append((module, args)))
    mine = tmp_path / 'mine.yaml'
    suite = NodeSuite(97, log_dir=tmp_path)
    suite.start_nodes(namespace='/r1', params_files=[mine], extra=['viewer_like'])
    assert [m for m, _ in started] == [*suite_module.SUITE_NODES, 'viewer_like']
    for module, args in started:
        files = [args[i + 1] for i, a in enumerate(args) if a == '--params-file']
        own = config_dir() / f'{module}.yaml'
        assert files == ([str(own)] if own.is_file() else []) + [str(mine.resolve())], (module, args)
        assert ('-r', '__ns:=/r1') == args[args.index('-r'):args.index('-r') + 2]
    started.clear()
    with pytest.raises(SuiteError, match="no optional node nope; there are: viewer_like"):
        suite.start_nodes(extra=['nope'])
    assert not started


def test_the_shared_control_nodes_get_their_config_and_the_suite_remappings() -> None:
    args = NodeSuite.node_args('mock_arm', namespace='/robot1')
    assert args[:2] == ['--params-file', str(config_dir() / 'mock_arm.yaml')]
    assert args[2:] == ['-r', '__ns:=/robot1', '-r', 'arm_controller/joint_trajectory:=grasp/trajectory',
                        '-r', 'servo/delta_twist_cmds:=assistance/twist']
    # over a scene's chains the arm reads each chain's trajectory: the twist's remapping alone
    cup = SceneObject('cup', 'cup_7zone')
    assert NodeSuite.node_args('mock_arm', objects=[cup])[2:] == ['-r', 'servo/delta_twist_cmds:=assistance/twist',
                                                                  '-p', "objects:=['cup']"]
    assert NodeSuite.node_args('assistance') == ['--params-file', str(config_dir() / 'assistance.yaml')]


@pytest.mark.parametrize('objects', [(), SCENE], ids=['one object', 'a scene'])
def test_beside_the_intent_estimator_the_scripted_operator_holds_no_w(objects: tuple[SceneObject, ...]) -> None:
    """The estimator gives w (every object's, in a scene): the operator's held w would be a second publisher."""
    def intent(estimated: bool) -> list[str]:
        args = NodeSuite.node_args('scripted_operator', objects=objects, estimated=estimated)
        return [value for flag, value in zip(args, args[1:]) if flag == '-p' and value.startswith('intent:=')]

    assert intent(False) == []
    assert intent(True) == ['intent:=none']
