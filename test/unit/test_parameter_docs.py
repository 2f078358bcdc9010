"""docs/nodes.md's parameter table matches the nodes' parameter tables: every parameter, its default and range.

The suite's nodes (:data:`grasp_intent_ros.launch.suite.SUITE_NODES`) are documented there parameter by
parameter; a row names one or more parameters of a node and gives their defaults, the first backquoted values
of its default column (YAML, as a params file writes them) or, without backquotes, its first word; a range its
meaning column states (``1-20``) is the parameter's declared one.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from node_parameters import node_parameters

from grasp_intent_ros.launch.suite import SUITE_NODES

DOCS = Path(__file__).resolve().parents[2] / 'docs' / 'nodes.md'


def rows() -> Iterator[tuple[str, list[str], str, str]]:
    """The rows of docs/nodes.md's "Parameters" table: (node, the parameters named, default cell, meaning cell)."""
    text = DOCS.read_text().split('\n## Parameters\n', 1)[1].split('\n## ', 1)[0]
    node = ''
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip('|').split('|')]
        if len(cells) != 4 or cells[1] in ('parameter', '---'):
            continue
        node = cells[0].strip('`') or node
        yield node, re.findall(r'`(\w+)`', cells[1]), cells[2], cells[3]


def documented() -> dict[str, dict[str, Any]]:
    """Node -> parameter -> its default as docs/nodes.md's "Parameters" table gives it."""
    table: dict[str, dict[str, Any]] = {}
    for node, names, default, _ in rows():
        values = re.findall(r'`([^`]*)`', default) or default.split()[:1]
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


RANGE = re.compile(r'(?<![\w.-])(\d+(?:\.\d+)?)-(\d+(?:\.\d+)?)(?![\w.-])')
"""A range a row's meaning states, ``1-20`` or ``0-0.05``: the parameter's inclusive range."""


def test_every_range_the_parameter_table_states_is_the_declared_one() -> None:
    stated = {(node, name): (float(m.group(1)), float(m.group(2))) for node, names, _, meaning in rows()
              for name in names for m in RANGE.finditer(meaning)}
    assert {('grasp_planner', 'n_starts'), ('grasp_planner', 'object_margin')} <= set(stated)
    declared = {(node, spec.name): spec.range for node in SUITE_NODES for spec in node_parameters(node)}
    wrong = {key: (value, declared.get(key)) for key, value in stated.items()
             if declared.get(key) is None or tuple(map(float, declared[key][:2])) != value}
    assert wrong == {}, 'docs/nodes.md: ranges (stated, declared)'


def test_the_range_pattern_reads_ranges_not_exponents_or_compounds() -> None:
    found = [m.group(0) for m in RANGE.finditer('1-20; m, 0-0.05: within 1e-12, a 560-demonstration model, eqs. 3-4a')]
    assert found == ['1-20', '0-0.05']
