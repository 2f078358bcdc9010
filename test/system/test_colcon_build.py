"""The package builds with colcon and installs what ``ros2 run`` and ``ros2 launch`` users rely on.

colcon-core + colcon-ros, as on a ROS machine.

A copy of the package sources is built with ``colcon build`` into a temporary workspace, then the
install tree is checked: package.xml and the ament resource marker (what ``ros2 pkg`` and
``get_package_share_directory`` find), config, models, data and the recorded bags in the share
directory, one console script per command of ``grasp_intent_ros/commands.py`` in ``lib/grasp_intent_ros``
(where ``ros2 run`` looks), and the installed package finding its config through the ament index. Skipped,
with the reason, only where colcon is not installed (the ``test`` extra installs it).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from grasp_intent_ros.commands import COMMANDS

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'grasp_intent_ros'
SOURCES = ('package.xml', 'setup.py', 'setup.cfg', 'README.md', 'resource', PACKAGE, 'config', 'bags')

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec('colcon_core') is None or importlib.util.find_spec('colcon_ros') is None,
    reason='colcon-core and colcon-ros are not installed (pip install colcon-core colcon-ros, or the test extra)')


def entry_points() -> set[str]:
    """The command names, one script each in a colcon install."""
    return set(COMMANDS)


@pytest.fixture(scope='module')
def install(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``colcon build`` of a copy of the package; returns the package's install prefix."""
    ws = tmp_path_factory.mktemp('colcon_ws')
    src = ws / 'src' / PACKAGE
    src.mkdir(parents=True)
    ignore = shutil.ignore_patterns('__pycache__', '*.egg-info')
    for name in SOURCES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=ignore)
        else:
            shutil.copy(path, src / name)
    env = {k: v for k, v in os.environ.items() if not k.startswith(('COLCON', 'AMENT_', 'CMAKE_PREFIX'))}
    env['PATH'] = f'{Path(sys.executable).parent}{os.pathsep}{env.get("PATH", "")}'
    result = subprocess.run(
        [sys.executable, '-m', 'colcon', 'build', '--base-paths', 'src', '--event-handlers', 'console_direct+'],
        cwd=ws, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, f'colcon build failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}'
    assert f'Finished <<< {PACKAGE}' in result.stdout + result.stderr, result.stdout[-2000:]
    return ws / 'install' / PACKAGE


def test_install_tree_has_the_package_manifest_marker_config_models_and_bags(install: Path) -> None:
    share = install / 'share' / PACKAGE
    assert (share / 'package.xml').read_bytes() == (REPO / 'package.xml').read_bytes()
    marker = install / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE
    assert marker.is_file(), 'no ament resource marker: ros2 pkg / get_package_share_directory cannot find it'
    for pattern in ('*.yaml', '*.urdf', '*.xml', 'models/*.yaml', 'data/*.csv'):
        shipped = sorted(p.relative_to(REPO / 'config') for p in (REPO / 'config').glob(pattern))
        assert shipped, pattern
        assert sorted(p.relative_to(share / 'config') for p in (share / 'config').glob(pattern)) == shipped
    bags = sorted(p.relative_to(REPO) for p in (REPO / 'bags').glob('*/*') if p.is_file())
    assert bags and sorted(p.relative_to(share) for p in (share / 'bags').glob('*/*')) == bags
    for bag in bags:
        assert (share / bag).read_bytes() == (REPO / bag).read_bytes()


def test_one_console_script_per_entry_point_where_ros2_run_looks(install: Path) -> None:
    scripts = install / 'lib' / PACKAGE
    expected = entry_points()
    assert {'intent_interpreter', 'model_server', 'grasp_planner', 'recorder', 'replay'} <= expected
    assert {p.name for p in scripts.iterdir()} == expected
    for name in expected:
        assert os.access(scripts / name, os.X_OK), f'{name} is not executable'
        text = (scripts / name).read_text()
        assert text.startswith('#!') and name in text, text


def test_installed_package_runs_and_finds_its_config_through_the_ament_index(install: Path,
                                                                              tmp_path: Path) -> None:
    """As after ``source install/setup.bash``.

    The installed code (not the checkout) on PYTHONPATH, the install prefix on AMENT_PREFIX_PATH, started outside
    the repository.
    """
    site = sorted(install.glob('lib/python3*/site-packages'))
    assert len(site) == 1, site
    env = {k: v for k, v in os.environ.items() if k not in ('GRASP_INTENT_ROS_CONFIG', 'PYTHONPATH')}
    env.update(PYTHONPATH=str(site[0]), AMENT_PREFIX_PATH=str(install))
    code = ('import grasp_intent_ros as g, grasp_intent_ros.resources as r; '
            'print(g.__file__); print(r.config_dir())')
    out = subprocess.run([sys.executable, '-c', code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=120, check=True).stdout.splitlines()
    assert Path(out[0]).is_relative_to(site[0]), f'imported {out[0]}, not the installed package'
    assert Path(out[1]) == install / 'share' / PACKAGE / 'config'
    # a console script (ROS-free: no DDS traffic) as ``ros2 run grasp_intent_ros ambiguity_report`` runs it
    result = subprocess.run([str(install / 'lib' / PACKAGE / 'ambiguity_report')], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert 'cup_7zone' in result.stdout
