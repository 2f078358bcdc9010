"""package.xml and setup.py against what the code imports, and every rosdep key against ros/rosdistro.

``test/data/rosdep_keys_jazzy.txt`` lists the keys of rosdep/base.yaml and rosdep/python.yaml and the
packages of jazzy/distribution.yaml in ros/rosdistro at the commit named in its header: a key that is
not there makes ``rosdep install --from-paths . -i --rosdistro jazzy`` fail.
"""

from __future__ import annotations

import ast
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
KEYS_FILE = REPO / 'test' / 'data' / 'rosdep_keys_jazzy.txt'

# Python modules that are not ROS packages -> (rosdep key, pip requirement name)
THIRD_PARTY = {
    'numpy': ('python3-numpy', 'numpy'),
    'scipy': ('python3-scipy', 'scipy'),
    'numba': ('python3-numba', 'numba'),
    'yaml': ('python3-yaml', 'pyyaml'),
    'matplotlib': ('python3-matplotlib', 'matplotlib'),
    'mpl_toolkits': ('python3-matplotlib', 'matplotlib'),  # mplot3d ships with matplotlib
    'pinocchio': ('pinocchio', 'pin'),
    'coal': ('coal', 'coal'),
    'rosbags': ('python3-rosbags-pip', 'rosbags'),
    'pytest': ('python3-pytest', 'pytest'),
    'hypothesis': ('python3-hypothesis', 'hypothesis'),
    'packaging': ('python3-packaging', 'packaging'),
    'mcap': ('mcap-ros2-support', 'mcap-ros2-support'),
    'mcap_ros2': ('mcap-ros2-support', 'mcap-ros2-support'),
    'websockets': ('python3-websockets', 'websockets'),
}
PIP_ONLY_OPTIONAL = {'viser': 'viewer'}
"""Modules without a rosdep key that only an optional feature imports -> the setup.py extra that installs them
(package.xml can declare no key for them; it says so in a comment)."""


def valid_keys() -> set[str]:
    lines = KEYS_FILE.read_text().splitlines()
    assert re.search(r'ros/rosdistro at commit [0-9a-f]{40}', ' '.join(lines[:3])), 'keys file names its source'
    return {line.strip() for line in lines if line.strip() and not line.startswith('#')}


def dependencies(kinds: tuple[str, ...]) -> list[str]:
    root = ET.parse(REPO / 'package.xml').getroot()
    return [e.text.strip() for kind in kinds for e in root.iter(kind) if e.text]


def imported_modules(source: Path) -> dict[str, set[Path]]:
    """Top-level names of every absolute import in ``source``: a .py file, or the .py files below a directory."""
    found: dict[str, set[Path]] = {}
    for path in [source] if source.is_file() else sorted(source.rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split('.')[0], set()).add(path.relative_to(REPO))
    return found


def required_keys(modules: dict[str, set[Path]], keys: set[str], local: set[str]) -> dict[str, str]:
    """Rosdep key per imported module; fails for a module that is neither stdlib, local, ROS nor mapped."""
    out = {}
    for module, where in sorted(modules.items()):
        if module in sys.stdlib_module_names or module in local or module in PIP_ONLY_OPTIONAL:
            continue
        if module in THIRD_PARTY:
            out[module] = THIRD_PARTY[module][0]
        elif module in keys:  # a ROS package: its name is its key
            out[module] = module
        else:
            raise AssertionError(f'{module} (imported by {sorted(map(str, where))}) has no known rosdep key: '
                                 'add it to THIRD_PARTY and to package.xml')
    return out


def test_every_package_xml_key_is_a_rosdistro_key() -> None:
    keys = valid_keys()
    declared = dependencies(('depend', 'build_depend', 'exec_depend', 'test_depend', 'buildtool_depend'))
    assert declared, 'package.xml declares no dependencies'
    unknown = [k for k in declared if k not in keys]
    assert not unknown, f'not rosdep keys of ROS 2 Jazzy: {unknown}'
    assert len(set(declared)) == len(declared), f'declared twice: {declared}'


def test_keys_file_rejects_the_keys_that_broke_rosdep() -> None:
    keys = valid_keys()
    assert {'rclpy', 'rcl_interfaces', 'builtin_interfaces', 'python3-numpy', 'python3-rosbags-pip'} <= keys
    assert not {'python3-mcap-pip', 'python3-mcap-ros2-support-pip'} & keys


def test_runtime_imports_are_exec_depends_and_nothing_more() -> None:
    keys = valid_keys()
    needed = required_keys(imported_modules(REPO / 'grasp_intent_ros'), keys, {'grasp_intent_ros'})
    exec_depends = set(dependencies(('depend', 'exec_depend')))
    missing = {m: k for m, k in needed.items() if k not in exec_depends}
    assert not missing, f'imported by the package but not exec_depend in package.xml: {missing}'
    unused = exec_depends - set(needed.values())
    assert not unused, f'exec_depend that the package never imports (drop it, or test_depend): {unused}'


def test_test_imports_are_declared() -> None:
    keys = valid_keys()
    scripts = {p.stem: p for p in (REPO / 'benchmarks').glob('*.py')}  # on the tests' path (setup.cfg)
    local = {'grasp_intent_ros', 'conftest', '_bench', *scripts,
             *(p.stem for p in (REPO / 'test').glob('*.py'))}  # test/ helpers
    imported = imported_modules(REPO / 'test')
    shared = [REPO / 'benchmarks' / '_bench', *(scripts[m] for m in sorted(imported) if m in scripts)]
    for source in shared:  # what the tests import of benchmarks/: its imports are the tests' too
        for module, paths in imported_modules(source).items():
            imported.setdefault(module, set()).update(paths)
    needed = required_keys(imported, keys, local)
    declared = set(dependencies(('depend', 'exec_depend', 'test_depend')))
    missing = {m: k for m, k in needed.items() if k not in declared}
    assert not missing, f'imported by the tests but not declared in package.xml: {missing}'


def test_setup_py_install_requires_matches_the_third_party_exec_depends() -> None:
    tree = ast.parse((REPO / 'setup.py').read_text())
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'setup')
    requires = next(ast.literal_eval(k.value) for k in call.keywords if k.arg == 'install_requires')
    pip_names = {re.split(r'[<>=!~ ]', r, maxsplit=1)[0].lower() for r in requires}
    exec_depends = set(dependencies(('depend', 'exec_depend')))
    expected = {pip for key, pip in THIRD_PARTY.values() if key in exec_depends}
    assert pip_names == expected, f'setup.py install_requires {sorted(pip_names)} != package.xml {sorted(expected)}'


def test_pip_only_modules_are_in_their_setup_py_extra() -> None:
    tree = ast.parse((REPO / 'setup.py').read_text())
    call = next(n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'setup')
    extras = next(ast.literal_eval(k.value) for k in call.keywords if k.arg == 'extras_require')
    for module, extra in PIP_ONLY_OPTIONAL.items():
        names = {re.split(r'[<>=!~ \[]', r, maxsplit=1)[0].lower() for r in extras.get(extra, [])}
        assert module in names, f'{module} is imported but not in the setup.py extra {extra!r}: {extras.get(extra)}'
