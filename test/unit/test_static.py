"""Static checks: mypy, lint and the package's import rules.

mypy --strict (setup.cfg), the lint configuration (ruff.toml: pycodestyle, pyflakes, import order, numpydoc
docstrings).

Import rules (the layers of the README's layout):
- ``core`` is the method: it imports nothing of rclpy or the ROS message packages, ``ros``, ``bag``,
  ``protocol``, ``sessions``, ``tools``, ``dataset`` or the nodes;
- ``bag`` and ``protocol`` import no rclpy and no ROS message package, and nothing of ``ros`` or ``sessions``;
- ``sessions`` (the session analysis) imports no rclpy and no ROS message package; of the package only
  ``core``, ``bag`` and ``protocol`` (nothing of ``ros``, ``tools``, ``dataset`` or the nodes);
- the nodes (the viewer too) and ``scene`` import nothing of ``bag`` or ``sessions``.
They are read from the source (every ``import`` and ``from ... import``, relative ones resolved), so a rule is
broken by a late import inside a function too.

Why not import-linter: its forbidden contracts name external packages one by one (a wildcard matches whole
name segments), and "no ROS package" is a pattern over every ``*_msgs`` and ``*_srvs`` package; these rules
fit in the 50 lines below, against two more test dependencies (import-linter and grimp).
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from grasp_intent_ros.tools.suite import SHARED_CONTROL_NODES, SUITE_NODES

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'grasp_intent_ros'
NODES = (*(f'{PACKAGE}.{n}' for n in SUITE_NODES + SHARED_CONTROL_NODES), f'{PACKAGE}.viewer')
ROS = re.compile(r'^(rclpy|rcl_interfaces|builtin_interfaces|[a-z_]+_msgs|[a-z_]+_srvs)(\.|$)')
RULES: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...] = (
    ((f'{PACKAGE}.core',), (f'{PACKAGE}.ros', f'{PACKAGE}.bag', f'{PACKAGE}.protocol', f'{PACKAGE}.sessions',
                             f'{PACKAGE}.tools', f'{PACKAGE}.dataset', *NODES)),
    ((f'{PACKAGE}.bag', f'{PACKAGE}.protocol'), (f'{PACKAGE}.ros', f'{PACKAGE}.sessions')),
    ((f'{PACKAGE}.sessions',), (f'{PACKAGE}.ros', f'{PACKAGE}.tools', f'{PACKAGE}.dataset', *NODES)),
    ((*NODES, f'{PACKAGE}.scene'), (f'{PACKAGE}.bag', f'{PACKAGE}.sessions')),
    # the simulated loop never reads the objects' task rules (dataset): only a benchmark judges with them
    ((f'{PACKAGE}.shared_control',), (f'{PACKAGE}.ros', f'{PACKAGE}.tools', f'{PACKAGE}.dataset', *NODES)),
)
"""(modules the rule is about, what they must not import); ROS_FREE import no ROS package."""
ROS_FREE = (f'{PACKAGE}.core', f'{PACKAGE}.bag', f'{PACKAGE}.protocol', f'{PACKAGE}.sessions',
            f'{PACKAGE}.shared_control')


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


def violations(root: Path) -> list[str]:
    """Every import that breaks a rule, as 'module imports name'."""
    found = []
    for path in sorted((root / PACKAGE).rglob('*.py')):
        name = module_name(path, root)
        for imported in set(imports(path, root)):
            for subjects, forbidden in RULES:
                if within(name, subjects) and within(imported, forbidden):
                    found.append(f'{name} imports {imported}')
            if within(name, ROS_FREE) and ROS.match(imported):
                found.append(f'{name} imports {imported}')
    return sorted(found)


def test_import_rules_hold() -> None:
    assert violations(REPO) == []


def test_import_rules_catch_a_broken_rule(tmp_path: Path) -> None:
    package = tmp_path / PACKAGE
    for sub in ('core', 'bag', 'ros', 'sessions'):
        (package / sub).mkdir(parents=True)
        (package / sub / '__init__.py').write_text('')
    (package / '__init__.py').write_text('')
    (package / 'core' / 'model.py').write_text('def f():\n    from ..ros import conversions\n    import rclpy\n')
    (package / 'bag' / 'writer.py').write_text('from std_msgs.msg import String\nfrom ..ros.qos import input_qos\n')
    (package / 'protocol.py').write_text('from .core import model\n')
    (package / 'sessions' / 'pairing.py').write_text('from ..bag import reader\nfrom ..tools import replay\n'
                                                     'import rclpy.node\n')
    (package / 'grasp_planner.py').write_text('from .bag import writer\nfrom . import protocol\n')
    assert violations(tmp_path) == [
        f'{PACKAGE}.bag.writer imports {PACKAGE}.ros.qos',
        f'{PACKAGE}.bag.writer imports {PACKAGE}.ros.qos.input_qos',
        f'{PACKAGE}.bag.writer imports std_msgs.msg',
        f'{PACKAGE}.bag.writer imports std_msgs.msg.String',
        f'{PACKAGE}.core.model imports {PACKAGE}.ros',
        f'{PACKAGE}.core.model imports {PACKAGE}.ros.conversions',
        f'{PACKAGE}.core.model imports rclpy',
        f'{PACKAGE}.grasp_planner imports {PACKAGE}.bag',
        f'{PACKAGE}.grasp_planner imports {PACKAGE}.bag.writer',
        f'{PACKAGE}.sessions.pairing imports {PACKAGE}.tools',
        f'{PACKAGE}.sessions.pairing imports {PACKAGE}.tools.replay',
        f'{PACKAGE}.sessions.pairing imports rclpy.node',
    ]


def test_ros_free_layers_load_without_rclpy() -> None:
    code = ('import sys, importlib, pkgutil\n'
            'import grasp_intent_ros.core as c, grasp_intent_ros.bag, grasp_intent_ros.protocol\n'
            'import grasp_intent_ros.sessions as s, grasp_intent_ros.shared_control as sc\n'
            'for p in (c, s, sc):\n'
            '    for m in pkgutil.iter_modules(p.__path__): importlib.import_module(f"{p.__name__}.{m.name}")\n'
            'import grasp_intent_ros.tools.report\n'
            'assert "rclpy" not in sys.modules, "rclpy imported"\n')
    subprocess.run([sys.executable, '-c', code], cwd=REPO, check=True, timeout=120)


def test_mypy_strict() -> None:
    """Mypy --strict (setup.cfg) on the typed layers: core, bag, protocol, sessions, ros, scene and the nodes."""
    paths = ['grasp_intent_ros/core', 'grasp_intent_ros/bag', 'grasp_intent_ros/protocol.py',
             'grasp_intent_ros/sessions', 'grasp_intent_ros/ros', 'grasp_intent_ros/scene',
             'grasp_intent_ros/shared_control',
             *(f'grasp_intent_ros/{node.rpartition(".")[2]}.py' for node in NODES)]
    result = subprocess.run([sys.executable, '-m', 'mypy', '--strict', '--follow-imports=silent', *paths],
                            cwd=REPO, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr


def test_lint() -> None:
    result = subprocess.run([sys.executable, '-m', 'ruff', 'check', '--no-cache', '.'], cwd=REPO,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
