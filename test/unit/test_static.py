"""Static checks: mypy, lint and the package's import contracts.

mypy --strict (setup.cfg), the lint configuration (ruff.toml: pycodestyle, pyflakes, import order, numpydoc
docstrings).

Import contracts, one per folder (:data:`CONTRACTS`, the layer table of CONTRIBUTING.md): a folder imports
of the package only itself and what its contract lists, and a ROS-free folder (:data:`ROS_FREE`) imports no
rclpy and no ROS message package. They are read from the source (every ``import`` and ``from ... import``,
relative ones resolved), so a contract is broken by a late import inside a function too.

Why not import-linter: its forbidden contracts name external packages one by one (a wildcard matches whole
name segments), and "no ROS package" is a pattern over every ``*_msgs`` and ``*_srvs`` package; these rules
fit in the lines below, against two more test dependencies (import-linter and grimp).
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'grasp_intent_ros'
ROS = re.compile(r'^(rclpy|rcl_interfaces|builtin_interfaces|[a-z_]+_msgs|[a-z_]+_srvs)(\.|$)')
BASE = ('errors', 'resources', 'parameters')
CONTRACTS: Mapping[str, tuple[str, ...]] = {
    'errors': (),
    'resources': (),
    'parameters': (),
    'latest_only': (),
    'commands': (),
    '__main__': ('commands',),
    'kernels': (),
    'method': (*BASE, 'kernels'),
    'planning': (*BASE, 'kernels', 'method'),
    'mico': (*BASE, 'kernels', 'method', 'planning'),
    'shared_control': (*BASE, 'method', 'planning', 'mico'),
    'objects': (*BASE, 'method', 'mico', 'cli.user_errors'),
    'wire': (*BASE, 'method', 'mico'),
    'scene': (*BASE, 'method', 'mico', 'wire', 'objects'),
    'ros': (*BASE, 'kernels', 'method', 'mico', 'wire', 'latest_only'),
    'ros.recording': (*BASE, 'wire', 'sessions.bag'),
    'nodes': (*BASE, 'kernels', 'method', 'planning', 'mico', 'shared_control', 'wire', 'ros', 'scene',
              'sessions.bag'),
    'sessions': (*BASE, 'method', 'mico', 'shared_control', 'wire', 'scene', 'objects', 'cli.user_errors',
                 'latest_only'),
    'sessions.replay': (*BASE, 'method', 'mico', 'wire', 'ros', 'launch', 'cli.user_errors'),
    'sessions.replay_client': (*BASE, 'method', 'mico', 'wire', 'ros'),
    'sessions.replayers': (*BASE, 'method', 'mico', 'wire', 'ros'),
    'sessions.fixtures': (*BASE, 'method', 'mico', 'wire', 'ros', 'launch', 'nodes.recorder'),
    'launch': (*BASE, 'method', 'mico', 'wire', 'ros', 'objects', 'cli'),
    'cli': (*BASE, 'method', 'planning', 'mico', 'wire', 'ros', 'objects'),
}
"""Folder (or module, the most specific entry wins) -> what else of the package it may import."""
ROS_FREE = ('errors', 'resources', 'parameters', 'latest_only', 'commands', 'kernels', 'method', 'planning', 'mico',
            'shared_control', 'objects', 'wire', 'scene', 'sessions')
"""Folders that import no rclpy and no ROS message package (``sessions`` but its live replay: below)."""
ROS_USERS = ('sessions.replay', 'sessions.replay_client', 'sessions.replayers', 'sessions.fixtures')
"""Modules of a ROS-free folder that talk ROS (the replay and the fixture recording run the nodes and are their
clients)."""


def module_name(path: Path, root: Path) -> str:
    """Dotted name of a source file below ``root`` (the directory holding the package)."""
    parts = list(path.relative_to(root).with_suffix('').parts)
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def imports(path: Path, root: Path) -> Iterator[str]:
    """Every module a source file imports (``from a import b`` yields ``a`` and ``a.b``)."""
    name = module_name(path, root)
    package = name if path.name == '__init__.py' else name.rpartition('.')[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split('.')[:len(package.split('.')) - node.level + 1] if node.level else []
            module = '.'.join([*base, *([node.module] if node.module else [])])
            yield module
            yield from (f'{module}.{alias.name}' for alias in node.names)


def within(module: str, prefixes: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(f'{p}.') for p in prefixes)


def contract(module: str) -> tuple[str, tuple[str, ...]] | None:
    """The most specific entry of :data:`CONTRACTS` for a module: (its subject, what it may import)."""
    short = module.removeprefix(f'{PACKAGE}.')
    subjects = [s for s in CONTRACTS if within(short, (s,))]
    if not subjects:
        return None
    subject = max(subjects, key=len)
    return subject, CONTRACTS[subject]


def violations(root: Path) -> list[str]:
    """Every import that breaks a contract, as 'module imports name'; a module no contract covers is one too."""
    found = []
    for path in sorted((root / PACKAGE).rglob('*.py')):
        name = module_name(path, root)
        if name == PACKAGE:
            continue
        rule = contract(name)
        if rule is None:
            found.append(f'{name} is in no contract')
            continue
        subject, allowed = rule
        own = f'{PACKAGE}.{subject.partition(".")[0]}'
        for imported in set(imports(path, root)):
            if within(imported, (PACKAGE,)) and imported != PACKAGE and not within(imported, (own,)):
                if not within(imported.removeprefix(f'{PACKAGE}.'), allowed):
                    found.append(f'{name} imports {imported}')
            short = name.removeprefix(f'{PACKAGE}.')
            if within(short, ROS_FREE) and not within(short, ROS_USERS) and ROS.match(imported):
                found.append(f'{name} imports {imported}')
    return sorted(found)


def test_import_rules_hold() -> None:
    assert violations(REPO) == []


def test_import_rules_catch_a_broken_rule(tmp_path: Path) -> None:
    package = tmp_path / PACKAGE
    for sub in ('method', 'wire', 'ros', 'sessions', 'sessions/bag', 'nodes', 'stray'):
        (package / sub).mkdir(parents=True)
        (package / sub / '__init__.py').write_text('')
    (package / '__init__.py').write_text('')
    (package / 'method' / 'model.py').write_text('def f():\n    from ..ros import conversions\n    import rclpy\n'
                                                 'from ..errors import ModelError\n')
    (package / 'wire' / 'arrays.py').write_text('from std_msgs.msg import String\nfrom ..method import model\n')
    (package / 'sessions' / 'pairing.py').write_text('from .bag import reader\nfrom ..launch import suite\n'
                                                     'import rclpy.node\n')
    (package / 'sessions' / 'replay.py').write_text('import rclpy\nfrom ..launch import suite\n')
    (package / 'nodes' / 'grasp_planner.py').write_text('from ..sessions.bag import writer\n'
                                                        'from ..sessions import pairing\n')
    assert violations(tmp_path) == [
        f'{PACKAGE}.method.model imports {PACKAGE}.ros',
        f'{PACKAGE}.method.model imports {PACKAGE}.ros.conversions',
        f'{PACKAGE}.method.model imports rclpy',
        f'{PACKAGE}.nodes.grasp_planner imports {PACKAGE}.sessions',
        f'{PACKAGE}.nodes.grasp_planner imports {PACKAGE}.sessions.pairing',
        f'{PACKAGE}.sessions.pairing imports {PACKAGE}.launch',
        f'{PACKAGE}.sessions.pairing imports {PACKAGE}.launch.suite',
        f'{PACKAGE}.sessions.pairing imports rclpy.node',
        f'{PACKAGE}.stray is in no contract',
        f'{PACKAGE}.wire.arrays imports std_msgs.msg',
        f'{PACKAGE}.wire.arrays imports std_msgs.msg.String',
    ]


def test_every_contract_names_a_folder_or_module_of_the_package() -> None:
    names = {module_name(path, REPO).removeprefix(f'{PACKAGE}.') for path in (REPO / PACKAGE).rglob('*.py')}
    for subject, allowed in CONTRACTS.items():
        for name in (subject, *allowed):
            assert name in names, name


def test_ros_free_layers_load_without_rclpy() -> None:
    """Every module of a ROS-free folder (but the live replay's) imports without loading rclpy."""
    modules = sorted(name for path in (REPO / PACKAGE).rglob('*.py')
                     if within(name := module_name(path, REPO).removeprefix(f'{PACKAGE}.'), ROS_FREE)
                     and not within(name, ROS_USERS)
                     and not name.endswith('__main__'))
    code = ('import sys, importlib\n'
            f'for m in {modules!r}: importlib.import_module(f"{PACKAGE}.{{m}}")\n'
            'assert "rclpy" not in sys.modules, "rclpy imported"\n')
    subprocess.run([sys.executable, '-c', code], cwd=REPO, check=True, timeout=120)


def test_playback_leaves_rclpy_unloaded() -> None:
    """A recorded session plays back in the viewer's page without ROS (the ``viewer`` extra only)."""
    code = ('import sys\nimport grasp_intent_ros.sessions.playback\n'
            'assert "rclpy" not in sys.modules, "rclpy imported"\n')
    subprocess.run([sys.executable, '-c', code], cwd=REPO, check=True, timeout=120)


TYPED = ('__init__.py', '__main__.py', 'errors.py', 'resources.py', 'parameters.py', 'latest_only.py', 'commands.py',
         'kernels', 'method', 'planning', 'mico', 'shared_control', 'wire', 'scene', 'ros', 'nodes', 'sessions')
"""What mypy --strict checks: every module but the command lines (launch, cli) and the data set (objects)..."""
UNTYPED = ('sessions/reindex.py', 'sessions/replay.py', 'sessions/replay_client.py', 'sessions/replayers.py',
           'sessions/report.py', 'sessions/playback.py')
"""... but these modules of the sessions' command lines and their replay clients, which were never held to it
(their errors are not fixed yet)."""


def test_mypy_strict() -> None:
    """Mypy --strict (setup.cfg) on :data:`TYPED`."""
    paths = [f'{PACKAGE}/{name}' for name in TYPED]
    excluded = '|'.join(re.escape(f'{PACKAGE}/{name}') for name in UNTYPED)
    result = subprocess.run([sys.executable, '-m', 'mypy', '--strict', '--follow-imports=silent',
                             f'--exclude=^({excluded})$', *paths],
                            cwd=REPO, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_checks_every_module_but_the_command_lines_and_the_data_set() -> None:
    untyped = ('launch', 'cli', 'objects', *UNTYPED)
    modules = sorted(p.relative_to(REPO / PACKAGE).as_posix() for p in (REPO / PACKAGE).rglob('*.py'))
    missed = [m for m in modules if not any(m == name or m.startswith(name.rstrip('/') + '/')
                                            for name in (*TYPED, *untyped))]
    assert missed == [], 'add them to TYPED (or, for a command line that fails mypy, to UNTYPED)'


def test_lint() -> None:
    result = subprocess.run([sys.executable, '-m', 'ruff', 'check', '--no-cache', '.'], cwd=REPO,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
