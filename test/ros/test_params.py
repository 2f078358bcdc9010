"""grasp_intent_ros.ros.params: a parameter table declared with descriptors, validated as a whole."""

from __future__ import annotations

from typing import Any

import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter

from grasp_intent_ros.parameters import ParameterError, ParamSpec, finite_vector, one_of
from grasp_intent_ros.ros.params import declare_parameters

SPECS = (
    ParamSpec('mode', 'fast', 'How.', validator=one_of(('fast', 'slow'))),
    ParamSpec('size', (1.0, 2.0), 'Width and height, m.', validator=finite_vector(2, 'w, h in m', positive=True)),
    ParamSpec('count', 3, 'How many.', range=(1, 5)),
    ParamSpec('names', (), 'Names.', item_type=str),
)


def node(ros: Any, **overrides: Any) -> Any:
    return ros.add(rclpy.create_node('params_probe', context=ros.context, parameter_overrides=[
        Parameter(name, value=value) for name, value in overrides.items()]))


def test_descriptors_and_plain_values(ros) -> None:
    probe = node(ros)
    changes: list[dict[str, Any]] = []
    params = declare_parameters(probe, SPECS, on_change=changes.append)
    assert dict(params) == {'mode': 'fast', 'size': (1.0, 2.0), 'count': 3, 'names': ()}
    (described,) = probe.describe_parameters(['count'])
    assert described.type == ParameterType.PARAMETER_INTEGER and described.description == 'How many.'
    assert described.additional_constraints == 'in [1, 5]'
    assert probe.set_parameters([Parameter('size', value=[3.0, 4.0])])[0].successful
    assert params['size'] == (3.0, 4.0) and changes == [{'size': (3.0, 4.0)}]


def test_a_bad_value_rejects_the_whole_change_with_its_reason(ros) -> None:
    def check(values: Any) -> None:
        if values['count'] == 5 and values['mode'] != 'slow':
            raise ValueError('count 5 needs mode slow')

    probe = node(ros)
    params = declare_parameters(probe, SPECS, check=check)
    result = probe.set_parameters_atomically([Parameter('count', value=2), Parameter('mode', value='medium')])
    assert not result.successful and "mode: must be one of fast, slow; got 'medium'" in result.reason
    assert params['count'] == 3, 'nothing half-applied'
    result = probe.set_parameters([Parameter('size', value=[1.0, -1.0])])[0]
    assert not result.successful and 'must be 2 positive numbers (w, h in m)' in result.reason
    result = probe.set_parameters([Parameter('count', value=5)])[0]
    assert not result.successful and 'count 5 needs mode slow' in result.reason
    assert not probe.set_parameters([Parameter('count', value=9)])[0].successful  # the descriptor's range


def test_an_invalid_initial_value_fails_construction(ros) -> None:
    with pytest.raises(ParameterError, match="mode: must be one of fast, slow; got 'x'"):
        declare_parameters(node(ros, mode='x'), SPECS)


def test_a_read_only_sequence_with_an_empty_default_reads_as_empty_or_as_given(ros) -> None:
    """Unset (rclpy sets no read-only parameter after its declaration), it reads as its empty default."""
    spec = ParamSpec('fixed_names', [], 'Names, at start only.', item_type=str, read_only=True)
    assert dict(declare_parameters(node(ros), (spec,))) == {'fixed_names': ()}
    given = ros.add(rclpy.create_node('params_given', context=ros.context, parameter_overrides=[
        Parameter('fixed_names', value=['a', 'b'])]))
    assert dict(declare_parameters(given, (spec,))) == {'fixed_names': ('a', 'b')}
    assert not given.set_parameters([Parameter('fixed_names', value=['c'])])[0].successful
