"""A pip install gives ``ros2 run grasp_intent_ros <name>`` what it needs, as a colcon install does.

The package is built as a wheel (what ``pip install '.[ros]'`` builds) from a copy of its sources and
installed into a fresh venv. The ament index (``ament_index_python``, what ``ros2 pkg`` and ``ros2 run``
read) finds the package under that venv as prefix, and lists one executable per command of
``grasp_intent_ros/commands.py`` in ``lib/grasp_intent_ros``; one of them runs as ``ros2 run`` runs it
(the file itself), with the venv's Python. The venv reaches the third-party packages of the test's own
environment through a ``.pth`` file, so that nothing is downloaded.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from grasp_intent_ros.commands import COMMANDS

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'grasp_intent_ros'
SOURCES = ('package.xml', 'setup.py', 'setup.cfg', 'README.md', 'resource', PACKAGE, 'config', 'bags')


def test_a_wheel_installs_the_executables_ament_index_lists_for_ros2_run(tmp_path: Path) -> None:
    src = tmp_path / 'src'
    src.mkdir()
    for name in SOURCES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=shutil.ignore_patterns('__pycache__', '*.egg-info'))
        else:
            shutil.copy(path, src / name)
    built = subprocess.run([sys.executable, '-m', 'pip', 'wheel', '--no-deps', '--no-build-isolation', '-w',
                            str(tmp_path / 'dist'), str(src)], capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stderr[-4000:]
    venv = tmp_path / 'venv'
    subprocess.run([sys.executable, '-m', 'venv', '--without-pip', str(venv)], check=True, timeout=120)
    purelib = Path(sysconfig.get_path('purelib', vars={'base': str(venv), 'platbase': str(venv)}))
    # the test environment's packages after the venv's own (with its .pth files: some packages need them)
    (purelib / 'test_environment.pth').write_text(f'import site; site.addsitedir({sysconfig.get_path("purelib")!r})\n')
    wheel = next((tmp_path / 'dist').glob('*.whl'))
    installed = subprocess.run([sys.executable, '-m', 'pip', '--python', str(venv / 'bin' / 'python'), 'install',
                                '--no-deps', '--no-index', str(wheel)], capture_output=True, text=True, timeout=300)
    assert installed.returncode == 0, installed.stderr[-4000:]

    env = {k: v for k, v in os.environ.items() if not k.startswith(('AMENT_', 'PYTHONPATH', 'VIRTUAL_ENV'))}
    env['AMENT_PREFIX_PATH'] = str(venv)
    code = ('from ament_index_python.packages import get_package_prefix, get_packages_with_prefixes\n'
            'import os\n'
            f'prefix = get_package_prefix({PACKAGE!r})\n'
            f'lib = os.path.join(prefix, "lib", {PACKAGE!r})\n'
            'print(prefix)\n'
            'print(" ".join(sorted(n for n in os.listdir(lib) if os.access(os.path.join(lib, n), os.X_OK))))\n')
    index = subprocess.run([str(venv / 'bin' / 'python'), '-c', code], env=env, capture_output=True, text=True,
                           timeout=120)
    assert index.returncode == 0, index.stderr
    prefix, executables = index.stdout.splitlines()
    assert Path(prefix) == venv
    assert set(executables.split()) == set(COMMANDS)
    run = subprocess.run([str(venv / 'lib' / PACKAGE / 'suite'), '--help'], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and '--domain-id' in run.stdout, run.stderr
    where = subprocess.run([str(venv / 'lib' / PACKAGE / 'paper_tables'), '--help'], env=env, cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
    assert where.returncode == 0, where.stderr
    located = subprocess.run([str(venv / 'bin' / 'python'), '-c', f'import {PACKAGE}; print({PACKAGE}.__file__)'],
                             env=env, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert Path(located.stdout.strip()).is_relative_to(purelib), 'the installed package, not the repository'
