"""The one routine that declares a node's parameter table: descriptors, validation as a whole, on-set callbacks.

A node's parameters are a table of :class:`~grasp_intent_ros.parameters.ParamSpec` (ROS-free, kept beside the
feature they configure); the node calls :func:`declare_parameters` once in its constructor. Each parameter
gets a ParameterDescriptor (type, description, range as a FloatingPointRange or IntegerRange, read-only) that
rclpy enforces, and all are declared in one ``Node.declare_parameters`` call; on top of that, every change
is checked by the spec's validator and by an optional whole-table ``check`` in an on-set callback that sees
*all* parameters of the request at once and rejects the whole request with a reason. Only accepted changes
reach the node, through ``on_change`` called from the post-set callback, so the node's state is never
half-updated.

Values come from the spec default, overridden by ``--ros-args --params-file config/<node>.yaml``
(node name as the key, ``/**/<node>`` to match it in any namespace). Initial values are validated the
same way; an invalid one makes the constructor raise :class:`~grasp_intent_ros.parameters.ParameterError`.

Read current values from the returned :class:`Parameters` mapping (a dict lookup), never with
``get_parameter`` in a hot path. Values are plain Python: bool, int, float, str, or tuples of them.
"""

from __future__ import annotations

import array
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, TypeVar

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..parameters import ParameterError, ParamSpec

__all__ = ['Parameters', 'ParameterError', 'declare_parameters', 'descriptor']

T = TypeVar('T')
_ARRAY_TYPES = {bool: Parameter.Type.BOOL_ARRAY, int: Parameter.Type.INTEGER_ARRAY,
                float: Parameter.Type.DOUBLE_ARRAY, str: Parameter.Type.STRING_ARRAY}


def _param_type(spec: ParamSpec) -> Parameter.Type:
    """The declared type: inferred from the default, or ``item_type``'s array for an empty sequence."""
    if _is_sequence(spec.default) and len(spec.default) == 0:
        if spec.item_type not in _ARRAY_TYPES:
            raise TypeError(f'parameter {spec.name!r}: an empty default needs item_type bool, int, float or str')
        return _ARRAY_TYPES[spec.item_type]
    inferred: Parameter.Type = Parameter.Type.from_parameter_value(_to_rclpy(spec.default))
    if spec.item_type is not None and inferred != _ARRAY_TYPES.get(spec.item_type):
        raise TypeError(f'parameter {spec.name!r}: default {spec.default!r} is not a sequence of {spec.item_type}')
    return inferred


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """The ParameterDescriptor of ``spec`` (its range a FloatingPointRange or an IntegerRange)."""
    ptype = _param_type(spec)
    desc = ParameterDescriptor(name=spec.name, type=ptype.value, description=spec.description,
                               read_only=spec.read_only, additional_constraints=spec.constraint_text())
    if spec.range is not None:
        low, high = spec.range[0], spec.range[1]
        step = spec.range[2] if len(spec.range) == 3 else 0
        if ptype == Parameter.Type.DOUBLE:
            desc.floating_point_range = [FloatingPointRange(from_value=float(low), to_value=float(high),
                                                            step=float(step))]
        elif ptype == Parameter.Type.INTEGER:
            desc.integer_range = [IntegerRange(from_value=int(low), to_value=int(high), step=int(step))]
        else:
            raise TypeError(f'parameter {spec.name!r}: a range needs a float or int parameter')
    return desc


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
        empty = [spec for spec in specs if _is_sequence(spec.default) and len(spec.default) == 0]
        # an empty default declares the type alone (rclpy cannot infer an empty array's), then sets it
        declared = node.declare_parameters('', [
            (spec.name, _param_type(spec) if spec in empty else _to_rclpy(spec.default), descriptor(spec))
            for spec in specs])
        unset = [spec for spec, param in zip(specs, declared) if param.type_ == Parameter.Type.NOT_SET]
        if settable := [spec for spec in unset if not spec.read_only]:
            node.set_parameters([Parameter(spec.name, _param_type(spec), []) for spec in settable])
        # a read-only one cannot be set after its declaration: it stays unset in rclpy, empty here
        self._values: dict[str, Any] = {spec.name: () if spec.read_only and spec in unset
                                        else _plain(node.get_parameter(spec.name).value) for spec in specs}
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

    def build(self, name: str, make: Callable[[Any], T]) -> T:
        """``make(value of name)``, as the node's start-up uses it (e.g. the kinematics of ``urdf_path``).

        Raises
        ------
        ParameterError
            When ``make`` raises ValueError or FileNotFoundError: the parameter's name and the reason.
        """
        try:
            return make(self._values[name])
        except (ValueError, FileNotFoundError) as exc:
            raise ParameterError(f'{name}: {exc}') from None

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
