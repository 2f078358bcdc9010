"""docs/nodes.md's parameter table matches the nodes' parameter tables: every parameter, with its default.

The suite's nodes (:data:`grasp_intent_ros.launch.suite.SUITE_NODES`) are documented there parameter by
parameter; a row names one or more parameters of a node and gives their defaults, the first backquoted values
of its default column (YAML, as a params file writes them) or, without backquotes, its first word.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from node_parameters import node_parameters

from grasp_intent_ros.launch.suite import SUITE_NODES

DOCS = Path(__file__).resolve().parents[2] / 'docs' / 'nodes.md'


def documented() -> dict[str, dict[str, Any]]:
    """Node -> parameter -> its default as docs/nodes.md's "Parameters" table gives it."""
    text = DOCS.read_text().split('\n## Parameters\n', 1)[1].split('\n## ', 1)[0]
    table: dict[str, dict[str, Any]] = {}
    node = ''
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if len(cells) != 4 or cells[1] in ('parameter', '---'):
            continue
        node = cells[0].strip('`') or node
        names = re.findall(r'`(\w+)`', cells[1])
        values = re.findall(r'`([^`]*)`', cells[2]) or cells[2].split()[:1]
        assert len(values) >= len(names), f'docs/nodes.md: no default for each of {names}'
        for name, value in zip(names, values):
            table.setdefault(node, {})[name] = yaml.safe_load(value)
    return table


def plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


@pytest.mark.parametrize('node', SUITE_NODES)
def test_the_parameter_table_gives_every_parameter_with_its_default(node: str) -> None:
    specs = {spec.name: plain(spec.default) for spec in node_parameters(node)}
    docs = documented().get(node, {})
    assert sorted(docs) == sorted(specs), f'docs/nodes.md: the parameters of {node}'
    wrong = {name: (docs[name], default) for name, default in specs.items() if docs[name] != default}
    assert wrong == {}, f'docs/nodes.md: defaults of {node} (documented, declared)'
