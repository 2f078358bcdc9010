"""Each node's parameter table, found from its module's docstring without importing the node (no rclpy).

A node module's docstring says where its table lives: ``Parameters: :data:`grasp_intent_ros.<module>.<NAME>```
(or ``:data:`NAME``` for a table in the node module itself). The config and docs checks read the tables
through this pointer, so a node whose pointer is stale fails them.
"""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

from grasp_intent_ros.parameters import ParamSpec

NODES = Path(__file__).resolve().parents[1] / 'grasp_intent_ros' / 'nodes'
POINTER = re.compile(r'^Parameters: :data:`~?([\w.]+)`', re.MULTILINE)


def table_name(node: str) -> str:
    """The dotted name of ``node``'s table, as its module's docstring gives it."""
    doc = ast.get_docstring(ast.parse((NODES / f'{node}.py').read_text())) or ''
    found = POINTER.search(doc)
    assert found, f'nodes/{node}.py: its docstring names no parameter table ("Parameters: :data:`...`")'
    name = found.group(1)
    return name if '.' in name else f'grasp_intent_ros.nodes.{node}.{name}'


def node_parameters(node: str) -> tuple[ParamSpec, ...]:
    """``node``'s parameter table (importing the node module only when the table is in it)."""
    module, _, name = table_name(node).rpartition('.')
    table: tuple[ParamSpec, ...] = getattr(importlib.import_module(module), name)
    return table
