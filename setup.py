"""ament_python / pip packaging for grasp_intent_ros."""
import os
import runpy
import sys
from glob import glob

from setuptools import find_packages, setup

package_name = 'grasp_intent_ros'

# The commands (grasp_intent_ros/commands.py, read without importing the package).
_commands = runpy.run_path(os.path.join(os.path.dirname(os.path.realpath(__file__)), package_name, 'commands.py'))
# colcon builds with setuptools' own `install` or `develop` command, whose scripts setup.cfg puts into
# lib/grasp_intent_ros: where `ros2 run grasp_intent_ros <name>` looks and no shell's PATH does, so one
# script per command. pip builds a wheel, whose scripts land in the user's bin/: there one script,
# grasp-intent-ros <name>, so that no generic name (demo, train, report) shadows another program.
COLCON = bool({'install', 'develop'} & set(sys.argv[1:]))
CONSOLE_SCRIPTS = _commands['COMMANDS'] if COLCON else {_commands['SCRIPT']: '__main__'}
# A wheel (pip) still gets `ros2 run grasp_intent_ros <name>`: one small script per command in the package's
# lib/grasp_intent_ros (data files), where ament's index has ros2 run look; each runs the command with the
# Python of the installation's prefix (a venv's bin/python3), else the python3 on PATH.
RUN_SCRIPT = '''#!/bin/sh
# ros2 run grasp_intent_ros {name}: python -m grasp_intent_ros {name} with this installation's Python
py="$(dirname "$0")/../../bin/python3"
[ -x "$py" ] || py=python3
exec "$py" -m grasp_intent_ros {name} "$@"
'''


def _run_scripts() -> list[str]:
    """The scripts of ``ros2 run`` for a wheel, written under build/ (paths relative to setup.py)."""
    if COLCON:
        return []  # setuptools' own scripts (setup.cfg) are there
    paths = []
    for name in _commands['COMMANDS']:
        path = os.path.join('build', 'ros2_run', name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, 'w') as script:
            script.write(RUN_SCRIPT.format(name=name))
        os.chmod(path, 0o755)
        paths.append(path)
    return paths


setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(include=[package_name, f'{package_name}.*']),
    package_data={package_name: ['py.typed']},  # typed package (PEP 561)
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{package_name}']),
        (f'share/{package_name}', ['package.xml']),
        (f'share/{package_name}/config', glob('config/*.yaml') + glob('config/*.urdf') + glob('config/*.xml')),
        (f'share/{package_name}/config/models', glob('config/models/*.yaml')),
        (f'share/{package_name}/config/data', glob('config/data/*.csv')),
    ] + ([(f'lib/{package_name}', _run_scripts())] if not COLCON else []) + [
        # recorded sessions, one directory per bag
        (f'share/{package_name}/{os.path.dirname(path)}', [path])
        for path in sorted(glob('bags/*/*')) if os.path.isfile(path)
    ],
    python_requires='>=3.10',
    install_requires=[
        'numpy>=1.24',
        'scipy>=1.10',
        'numba>=0.60',
        'pyyaml>=6',
        'pin>=2.7',
        'coal>=3',  # the hand's collision checks (mico/collision.py); pin brings it too
        'rosbags>=0.10',
        'mcap-ros2-support>=0.5',  # brings mcap (sessions/bag/repair.py); mcap-ros2-support is the rosdep key that does
        'matplotlib>=3.7',
    ],
    extras_require={
        'ros': ['ros-jazzy-rclpy[fastrtps]', 'ros-jazzy-common-interfaces'],
        # the browser viewer (python -m grasp_intent_ros viewer); viser has no rosdep key (package.xml says so)
        'viewer': ['viser>=1.1'],
        # the benchmarks' independent collision judge (benchmarks/judge_physics.py); not for the package itself
        'bench': ['mujoco>=3.2'],
        'test': ['pytest>=7', 'pytest-timeout>=2', 'pytest-xdist>=3', 'hypothesis>=6', 'packaging>=23', 'mypy>=1.9',
                 'types-PyYAML', 'ruff>=0.4', 'colcon-core>=0.15', 'colcon-ros>=0.4', 'viser>=1.1'],
    },
    zip_safe=True,
    maintainer='grasp_intent_ros developers',
    maintainer_email='grasp-intent-ros@example.org',
    description='Intent-uncertainty-aware shared-control grasp planning for the Kinova MICO (ROS 2 Jazzy).',
    license='BSD-3-Clause',
    entry_points={
        'console_scripts': [f'{name} = {package_name}.{module}:main' for name, module in CONSOLE_SCRIPTS.items()],
    },
)
