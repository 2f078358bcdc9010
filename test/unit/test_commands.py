"""The command table: every command runs through ``python -m grasp_intent_ros``; pip puts one name on PATH.

(The colcon side, one script per command where ``ros2 run`` looks, is test/system/test_colcon_build.py.)
"""

from __future__ import annotations

import ast
import subprocess
import sys
from importlib.metadata import distribution
from pathlib import Path

from grasp_intent_ros.commands import COMMANDS, SCRIPT

PACKAGE_DIR = Path(__file__).resolve().parents[2] / 'grasp_intent_ros'


def test_every_command_names_a_module_with_a_main() -> None:
    for name, module in COMMANDS.items():
        path = PACKAGE_DIR.joinpath(*module.split('.')).with_suffix('.py')
        tree = ast.parse(path.read_text(), str(path))
        assert any(isinstance(n, ast.FunctionDef) and n.name == 'main' for n in tree.body), (name, path)


def test_no_command_names_its_own_prog() -> None:
    # __main__ sets argv[0] to how the command was called ('python -m grasp_intent_ros NAME', 'grasp-intent-ros
    # NAME'), argparse's prog unless a parser fixes its own; then --help and errors would name another command line
    fixed = []
    for name, module in COMMANDS.items():
        path = PACKAGE_DIR.joinpath(*module.split('.')).with_suffix('.py')
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr == 'ArgumentParser' and any(k.arg == 'prog' for k in node.keywords)):
                fixed.append(name)
    assert fixed == []


def test_pip_installs_one_script_and_no_generic_names() -> None:
    scripts = {ep.name for ep in distribution('grasp_intent_ros').entry_points if ep.group == 'console_scripts'}
    assert scripts == {SCRIPT}


def test_a_command_runs_with_its_own_arguments_and_an_unknown_one_exits_2() -> None:
    run = [sys.executable, '-m', 'grasp_intent_ros']
    result = subprocess.run([*run, 'ambiguity_report', '--help'], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stdout.startswith('usage: python -m grasp_intent_ros ambiguity_report')
    result = subprocess.run([*run, 'no_such_command'], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "unknown command 'no_such_command'" in result.stderr
    assert all(name in result.stderr for name in COMMANDS)
    result = subprocess.run(run, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and 'a command is required' in result.stderr
