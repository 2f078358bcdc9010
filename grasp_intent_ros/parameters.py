"""Node parameters as data, ROS-free: one :class:`ParamSpec` per parameter, beside the feature it configures.

A node's parameter table is a tuple of specs (name, default, description with the unit, inclusive range,
read-only flag, validator), kept in the feature folder whose code the parameters configure (e.g.
:data:`grasp_intent_ros.shared_control.parameters.ASSISTANCE`), so that the maths, its defaults and the
text ``ros2 param describe`` shows live together; rules over several parameters of a table are a plain
function of the values (``check(values)``, raising ValueError). The one routine that declares a table on a
node (ParameterDescriptors, validation on every change, on-set callbacks) is
:func:`grasp_intent_ros.ros.params.declare_parameters`; config/<node>.yaml and docs/nodes.md are checked
against the tables by tests.

Values are plain Python: bool, int, float, str, or tuples of one of these.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

__all__ = ['ParamSpec', 'ParameterError', 'Validator', 'one_of', 'finite_vector', 'config_from']

Validator = Callable[[Any], object]
"""Called with a proposed value; raises ValueError (e.g. a GraspIntentError) with the reason."""

C = TypeVar('C')


class ParameterError(ValueError):
    """An initial parameter value (default or from a params file) fails validation."""


@dataclass(frozen=True)
class ParamSpec:
    """One parameter of a node.

    Attributes
    ----------
    name : str
    default : bool, int, float, str or a sequence of one of these
        Also fixes the type (a sequence's from its first element, else ``item_type``).
    description : str
        Shown by ``ros2 param describe``; state the unit.
    item_type : type, optional
        The element type (bool, int, float or str) of a sequence parameter whose default is empty.
    range : (low, high) or (low, high, step), optional
        Inclusive; a float or int parameter's range, enforced by the middleware.
    read_only : bool
        Settable only at start-up (params file or override).
    validator : callable, optional
        Further check of a single value: raises ValueError with the reason.
    constraints : str
        Free text for the descriptor's ``additional_constraints``; default: the range, if any.
    """

    name: str
    default: Any
    description: str
    item_type: type | None = None
    range: tuple[float, float] | tuple[float, float, float] | None = None
    read_only: bool = False
    validator: Validator | None = None
    constraints: str = ''

    def constraint_text(self) -> str:
        """The descriptor's ``additional_constraints``: ``constraints``, else the range as 'in [low, high]'."""
        if self.constraints or self.range is None:
            return self.constraints
        return f'in [{self.range[0]}, {self.range[1]}]'


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


def config_from(cls: type[C], values: Mapping[str, Any]) -> C:
    """The dataclass ``cls`` built from the values of its fields' names (its own checks run: ValueError)."""
    return cls(**{field.name: values[field.name] for field in dataclasses.fields(cls)})  # type: ignore[arg-type]
