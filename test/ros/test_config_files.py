"""config/<node>.yaml sets every parameter of its node and no other, and documents each with its descriptor's text."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest
import yaml
from node_parameters import node_parameters

from grasp_intent_ros.launch.suite import OPTIONAL_NODES, SHARED_CONTROL_NODES, SUITE_NODES

CONFIG = Path(__file__).resolve().parents[2] / 'config'
WIDTH = 114
"""Comment text per line: 120 columns less the indent and '# '."""


def comments(path: Path) -> dict[str, str]:
    """Parameter name -> the comment lines right above it, joined by spaces."""
    found, block = {}, []
    for line in path.read_text().splitlines():
        key = re.match(r'^    ([a-z_]+):', line)
        if line.startswith('    #'):
            block.append(line.strip()[1:].strip())
            continue
        if key:
            found[key.group(1)] = ' '.join(block)
        block = []
    return found


@pytest.mark.parametrize('node', [*SUITE_NODES, *SHARED_CONTROL_NODES, 'scripted_operator', 'viewer'])
def test_every_parameter_is_documented_by_its_descriptor_text(node: str) -> None:
    specs = node_parameters(node)
    documented = comments(CONFIG / f'{node}.yaml')
    for spec in specs:
        wrapped = '\n'.join(f'    # {line}' for line in textwrap.wrap(spec.description, WIDTH))
        assert documented.get(spec.name) == spec.description, (
            f'config/{node}.yaml: the comment above {spec.name} must be its description:\n{wrapped}')
    assert set(documented) <= {spec.name for spec in specs}, f'config/{node}.yaml sets an unknown parameter'


@pytest.mark.parametrize('node', [*SUITE_NODES, *OPTIONAL_NODES])
def test_every_node_config_sets_exactly_its_nodes_parameters(node: str) -> None:
    document = yaml.safe_load((CONFIG / f'{node}.yaml').read_text())
    (section,) = document.values()
    assert sorted(section['ros__parameters']) == sorted(spec.name for spec in node_parameters(node)), (
        f'config/{node}.yaml: its parameters are not the node\'s')
