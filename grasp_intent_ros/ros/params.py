"""Node parameters declared from a table, validated together, never half-applied.

A node lists its parameters as :class:`ParamSpec` entries and calls :func:`declare_parameters`
once in its constructor. Each parameter gets a ParameterDescriptor (type, description, range,
read-only) that rclpy enforces; on top of that, every change is checked by the spec's validator and
by an optional whole-table ``check`` in an on-set callback that sees *all* parameters of the request
at once and rejects the whole request with a reason. Only accepted changes reach the node, through
``on_change`` called from the post-set callback, so the node's state is never half-updated.

Values come from the spec default, overridden by ``--ros-args --params-file config/<node>.yaml``
(node name as the key, ``/**/<node>`` to match it in any namespace). Initial values are validated the
same way; an invalid one makes the constructor raise :class:`ParameterError`.

Read current values from the returned :class:`Parameters` mapping (a dict lookup), never with
``get_parameter`` in a hot path. Values are plain Python: bool, int, float, str, or tuples of them.
"""

from __future__ import annotations

import array
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..errors import InvalidIntentError
from ..method.intent import DEFAULT_TASKS, MAX_TASKS, all_zones

__all__ = ['ParamSpec', 'Parameters', 'ParameterError', 'declare_parameters', 'one_of', 'finite_vector',
           'check_task_names', 'TASK_NAMES']

Validator = Callable[[Any], object]
"""Called with a proposed value; raises ValueError (e.g. a core GraspIntentError) with the reason."""


def one_of(choices: Sequence[str]) -> Validator:
    """A validator accepting only ``choices``."""
    def check(value: str) -> None:
        if value not in choices:
            raise ValueError(f'must be one of {", ".join(choices)}; got {value!r}')
    return check


def finite_vector(n: int, meaning: str, *, positive: bool = False) -> Validator:
    """A validator of ``n`` finite (and, with ``positive``, > 0) numbers; ``meaning`` ends the reason."""
    def check(value: Sequence[float]) -> None:
        if len(value) != n or not all(math.isfinite(v) and (v > 0.0 or not positive) for v in value):
            kind = 'positive' if positive else 'finite'
            raise ValueError(f'must be {n} {kind} numbers ({meaning}), got {list(value)}')
    return check


class ParameterError(ValueError):
    """An initial parameter value (default or from a params file) fails validation."""


@dataclass(frozen=True)
class ParamSpec:
    """One parameter of a node.

    Attributes
    ----------
    name : str
    default : bool, int, float, str or a sequence of one of these
        Also fixes the type unless ``type`` is given (needed for an empty sequence).
    description : str
        Shown by ``ros2 param describe``; state the unit.
    type : rclpy.parameter.Parameter.Type, optional
    range : (low, high) or (low, high, step), optional
        Inclusive; becomes a FloatingPointRange (float) or IntegerRange (int) enforced by rclpy.
    read_only : bool
        Settable only at start-up (params file or override).
    validator : callable, optional
        Further check of a single value: raises ValueError with the reason.
    constraints : str
        Free text for ``additional_constraints``; default: the range, if any.
    """

    name: str
    default: Any
    description: str
    type: Parameter.Type | None = None
    range: tuple[float, float] | tuple[float, float, float] | None = None
    read_only: bool = False
    validator: Validator | None = None
    constraints: str = ''

    def param_type(self) -> Parameter.Type:
        """The declared type: ``type`` if given, else inferred from the default."""
        inferred: Parameter.Type = Parameter.Type.from_parameter_value(_to_rclpy(self.default))
        if self.type is None:
            return inferred
        if _is_sequence(self.default) and len(self.default) == 0:
            return self.type
        if inferred != self.type:
            raise TypeError(f'parameter {self.name!r}: default {self.default!r} is not of type {self.type}')
        return self.type

    def descriptor(self) -> ParameterDescriptor:
        """The ParameterDescriptor for this spec."""
        ptype = self.param_type()
        desc = ParameterDescriptor(name=self.name, type=ptype.value, description=self.description,
                                   read_only=self.read_only)
        constraints = self.constraints
        if self.range is not None:
            low, high = self.range[0], self.range[1]
            step = self.range[2] if len(self.range) == 3 else 0
            if ptype == Parameter.Type.DOUBLE:
                desc.floating_point_range = [FloatingPointRange(
                    from_value=float(low), to_value=float(high), step=float(step))]
            elif ptype == Parameter.Type.INTEGER:
                desc.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=int(step))]
            else:
                raise TypeError(f'parameter {self.name!r}: a range needs a float or int parameter')
            constraints = constraints or f'in [{low}, {high}]'
        desc.additional_constraints = constraints
        return desc


def check_task_names(names: Sequence[str]) -> None:
    """1..MAX_TASKS unique, non-empty names without commas. Raises InvalidIntentError."""
    all_zones(len(names))
    if any(not n or ',' in n or n != n.strip() for n in names):
        raise InvalidIntentError(f'task names must be non-empty, without commas or surrounding spaces: '
                                 f'{list(names)}')
    if len(set(names)) != len(names):
        raise InvalidIntentError(f'task names must be unique: {list(names)}')


TASK_NAMES = ParamSpec(
    'task_names', DEFAULT_TASKS,
    'Names of the m principal tasks, in the order of the entries of w (m = expected length of w). The same '
    'list on every node of the suite: a model of other tasks is refused.',
    validator=check_task_names, constraints=f'1..{MAX_TASKS} unique names without commas')
"""The suite's tasks: the interpreter reads w by them; every node serves only models of these tasks."""


def _is_sequence(value: Any) -> bool:
    return isinstance(value, (list, tuple, array.array))


def _to_rclpy(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _plain(value: Any) -> Any:
    """A parameter value as plain immutable Python (array.array and list become tuples)."""
    return tuple(value) if _is_sequence(value) else value


class Parameters(Mapping[str, Any]):
    """The declared parameters of one node with their current, validated values.

    Built by :func:`declare_parameters`. Behaves as a read-only mapping name -> value.
    """

    def __init__(self, node: Node, specs: Sequence[ParamSpec], *,
                 check: Callable[[Mapping[str, Any]], object] | None = None,
                 on_change: Callable[[Mapping[str, Any]], object] | None = None) -> None:
        self._node = node
        self._specs = {s.name: s for s in specs}
        if len(self._specs) != len(specs):
            raise ValueError('parameter specs must have unique names')
        self._check = check
        self._on_change = on_change
        for spec in specs:
            ptype = spec.param_type()
            default = _to_rclpy(spec.default)
            if _is_sequence(default) and len(default) == 0:
                declared = node.declare_parameter(spec.name, ptype, spec.descriptor())
                if declared.type_ == Parameter.Type.NOT_SET:
                    node.set_parameters([Parameter(spec.name, ptype, [])])
            else:
                node.declare_parameter(spec.name, default, spec.descriptor())
        self._values: dict[str, Any] = {
            name: _plain(node.get_parameter(name).value) for name in self._specs}
        reason = self.validate(self._values, self._values)
        if reason:
            raise ParameterError(f'{node.get_fully_qualified_name()}: {reason}')
        node.add_on_set_parameters_callback(self._on_set)
        node.add_post_set_parameters_callback(self._on_post_set)

    # Mapping interface
    def __getitem__(self, name: str) -> Any:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def validate(self, proposed: Mapping[str, Any], changed: Mapping[str, Any]) -> str:
        """Reasons why ``proposed`` (all values, ``changed`` among them) is invalid; '' when valid.

        Runs the validator of every changed parameter, collecting all reasons, then (only if those
        pass) the whole-table check.
        """
        reasons = []
        for name, value in changed.items():
            validator = self._specs[name].validator
            if validator is None:
                continue
            try:
                validator(value)
            except ValueError as exc:
                reasons.append(f'{name}: {exc}')
        if not reasons and self._check is not None:
            try:
                self._check(proposed)
            except ValueError as exc:
                reasons.append(str(exc))
        return '; '.join(reasons)

    def _on_set(self, params: list[Parameter]) -> SetParametersResult:
        changed = {p.name: _plain(p.value) for p in params if p.name in self._specs}
        if not changed:
            return SetParametersResult(successful=True)
        try:
            reason = self.validate({**self._values, **changed}, changed)
        except Exception as exc:  # noqa: BLE001 - a validator bug must not kill the parameter service
            self._node.get_logger().error(f'parameter validation failed: {type(exc).__name__}: {exc}')
            reason = f'internal error while validating: {type(exc).__name__}: {exc}'
        if reason:
            self._node.get_logger().warning(f'rejected parameter change {changed}: {reason}')
            return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _on_post_set(self, params: list[Parameter]) -> None:
        changed = {p.name: _plain(p.value) for p in params if p.name in self._specs}
        if not changed:
            return
        self._values.update(changed)
        self._node.get_logger().info(f'parameters set: {changed}')
        if self._on_change is None:
            return
        try:
            self._on_change(changed)
        except Exception as exc:  # noqa: BLE001 - must not escape into the parameter service
            self._node.get_logger().error(
                f'applying parameters {changed} failed: {type(exc).__name__}: {exc}')


def declare_parameters(node: Node, specs: Sequence[ParamSpec], *,
                       check: Callable[[Mapping[str, Any]], object] | None = None,
                       on_change: Callable[[Mapping[str, Any]], object] | None = None) -> Parameters:
    """Declare ``specs`` on ``node`` and install validation; return the live value mapping.

    Parameters
    ----------
    node : Node
    specs : sequence of ParamSpec
    check : callable, optional
        ``check(values)`` with all proposed values (a mapping name -> value); raises ValueError with
        the reason to reject the whole change. Use it for rules spanning several parameters.
    on_change : callable, optional
        ``on_change(changed)`` after a change was accepted and stored (not for the initial values:
        the node configures itself from the returned mapping after this call).

    Raises
    ------
    ParameterError
        If an initial value fails a validator or ``check``.
    rclpy.exceptions.ParameterException
        If an initial value has the wrong type or lies outside its range (rclpy's own checks).
    """
    return Parameters(node, specs, check=check, on_change=on_change)
