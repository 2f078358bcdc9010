"""ament_python / pip packaging for grasp_intent_ros."""
import os
from glob import glob

from setuptools import find_packages, setup

package_name = 'grasp_intent_ros'

CONSOLE_SCRIPTS = {  # script name -> module (python -m grasp_intent_ros.<name> works for each too)
    'intent_interpreter': 'intent_interpreter',
    'model_server': 'model_server',
    'grasp_planner': 'grasp_planner',
    'assistance': 'assistance',
    'mock_arm': 'mock_arm',
    'send_intent': 'tools.send_intent',
    'demo': 'tools.demo',
    'recorder': 'tools.recorder',
    'reindex': 'tools.reindex',
    'replay': 'tools.replay',
    'report': 'tools.report',
    'paper_tables': 'tools.paper_tables',
    'ambiguity_report': 'tools.ambiguity_report',
    'generate_data': 'dataset.generate_data',
    'train': 'dataset.train',
}

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
    ] + [
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
        'rosbags>=0.10',
        'matplotlib>=3.7',
    ],
    extras_require={
        'ros': ['ros-jazzy-rclpy[fastrtps]', 'ros-jazzy-common-interfaces'],
        'test': ['pytest>=7', 'pytest-timeout>=2', 'hypothesis>=6', 'mypy>=1.9', 'types-PyYAML', 'ruff>=0.4',
                 'mcap-ros2-support>=0.5', 'colcon-core>=0.15', 'colcon-ros>=0.4'],
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
