"""The object's body as solid primitives: where the palm centre may not go.

A grasp whose palm centre lies inside the object is physically impossible, and the Gaussian grasp
model alone does not know that: it is a constraint of the planner. The body is a union of solid
primitives in the object frame (the frame of the grasp features, metres):

- :class:`Cylinder`: a capped solid cylinder (``centre``, unit ``axis``, ``radius``, ``length``).
- :class:`Box`: a solid box aligned with the object frame (``centre``, ``half_extents``).

:class:`ObjectBody` adds a ``margin``: the planner keeps ``distance(palm) >= margin``. Demonstrations
with the palm on the surface (palm contact) are at distance 0, so the margin is small (default 1 mm):
it keeps float noise from ever putting a planned palm inside.

In a model document (see :meth:`ObjectBody.to_document`)::

    body:
      margin: 0.001
      primitives:
      - {type: cylinder, centre: [0.0, 0.0, 0.05], axis: [0.0, 0.0, 1.0], radius: 0.04, length: 0.1}
      - {type: box, centre: [0.06, 0.0, 0.05], half_extents: [0.01, 0.005, 0.025]}
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelFormatError

__all__ = ['Cylinder', 'Box', 'Primitive', 'ObjectBody', 'DEFAULT_MARGIN']

DEFAULT_MARGIN = 0.001
"""Default clearance (m) of the palm centre from the body."""


def _vec3(value: Any, what: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ModelFormatError(f'{what}: {exc}') from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ModelFormatError(f'{what} must be 3 finite numbers, got {value!r}')
    return arr


def _norm3(v: NDArray[np.float64]) -> float:
    """|v| with its sum in a fixed order (np.linalg.norm takes BLAS's dot, whose order depends on the CPU)."""
    x, y, z = v.tolist()
    return math.sqrt(x * x + y * y + z * z)


def _positive(value: Any, what: str) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ModelFormatError(f'{what} must be a number, got {value!r}') from None
    if not (np.isfinite(out) and out > 0.0):
        raise ModelFormatError(f'{what} must be positive and finite, got {value!r}')
    return out


@dataclass(frozen=True, eq=False)
class Cylinder:
    """A capped solid cylinder: axis through ``centre`` along unit ``axis``, ``length`` end to end (m)."""

    centre: NDArray[np.float64]
    axis: NDArray[np.float64]
    radius: float
    length: float
    perpendicular: NDArray[np.float64] = field(init=False, repr=False)
    """A fixed unit vector perpendicular to the axis: the radial direction of points on the axis."""

    def __post_init__(self) -> None:
        axis = _vec3(self.axis, 'cylinder axis')
        norm = _norm3(axis)
        if norm < 1e-9:
            raise ModelFormatError('cylinder axis must be non-zero')
        object.__setattr__(self, 'centre', _vec3(self.centre, 'cylinder centre'))
        object.__setattr__(self, 'axis', axis / norm)
        object.__setattr__(self, 'radius', _positive(self.radius, 'cylinder radius'))
        object.__setattr__(self, 'length', _positive(self.length, 'cylinder length'))
        perp = np.cross(self.axis, [1.0, 0.0, 0.0] if abs(self.axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        object.__setattr__(self, 'perpendicular', perp / _norm3(perp))

    def distance(self, p: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Signed distance of points p (N, 3) to the surface (< 0 inside) and its gradient (N, 3)."""
        rel = p - self.centre
        t = rel @ self.axis
        radial = rel - t[:, None] * self.axis
        rho = np.sqrt(np.einsum('ni,ni->n', radial, radial))
        # radial unit vector; on the axis itself a fixed perpendicular (never noise)
        e_r = np.where(rho[:, None] > 1e-12, radial / np.maximum(rho, 1e-12)[:, None], self.perpendicular)
        e_t = np.where(t[:, None] < 0.0, -self.axis, self.axis)
        dr, dt = rho - self.radius, np.abs(t) - 0.5 * self.length
        out_r, out_t = np.maximum(dr, 0.0), np.maximum(dt, 0.0)
        outside = np.hypot(out_r, out_t)
        is_out = outside > 0.0
        sd = np.where(is_out, outside, np.maximum(dr, dt))
        w_r = np.where(is_out, out_r / np.maximum(outside, 1e-300), dr >= dt)
        w_t = np.where(is_out, out_t / np.maximum(outside, 1e-300), dr < dt)
        return sd, w_r[:, None] * e_r + w_t[:, None] * e_t

    @property
    def bounding_radius(self) -> float:
        """m: the radius of the smallest sphere about ``centre`` that holds the cylinder."""
        return math.hypot(self.radius, 0.5 * self.length)

    def to_document(self) -> dict[str, Any]:
        """YAML-ready mapping."""
        return {'type': 'cylinder', 'centre': [float(v) for v in self.centre],
                'axis': [float(v) for v in self.axis], 'radius': self.radius, 'length': self.length}


@dataclass(frozen=True, eq=False)
class Box:
    """A solid box aligned with the object frame: ``centre`` and ``half_extents`` (m)."""

    centre: NDArray[np.float64]
    half_extents: NDArray[np.float64]

    def __post_init__(self) -> None:
        half = _vec3(self.half_extents, 'box half_extents')
        if np.any(half <= 0.0):
            raise ModelFormatError(f'box half_extents must be positive, got {half.tolist()}')
        object.__setattr__(self, 'centre', _vec3(self.centre, 'box centre'))
        object.__setattr__(self, 'half_extents', half)

    def distance(self, p: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Signed distance of points p (N, 3) to the surface (< 0 inside) and its gradient (N, 3)."""
        rel = p - self.centre
        q = np.abs(rel) - self.half_extents
        sign = np.where(rel < 0.0, -1.0, 1.0)
        out = np.maximum(q, 0.0)
        outside = np.linalg.norm(out, axis=1)
        is_out = np.any(q > 0.0, axis=1)
        face = np.argmax(q, axis=1)
        grad_in = np.zeros_like(p)
        grad_in[np.arange(len(p)), face] = sign[np.arange(len(p)), face]
        grad_out = sign * out / np.maximum(outside, 1e-300)[:, None]
        sd = np.where(is_out, outside, q.max(axis=1))
        return sd, np.where(is_out[:, None], grad_out, grad_in)

    @property
    def bounding_radius(self) -> float:
        """m: the radius of the smallest sphere about ``centre`` that holds the box."""
        return float(np.linalg.norm(self.half_extents))

    def to_document(self) -> dict[str, Any]:
        """YAML-ready mapping."""
        return {'type': 'box', 'centre': [float(v) for v in self.centre],
                'half_extents': [float(v) for v in self.half_extents]}


Primitive = Union[Cylinder, Box]


@dataclass(frozen=True)
class ObjectBody:
    """The object's solid body (a union of primitives) and the palm centre's clearance from it.

    Attributes
    ----------
    primitives : tuple of Cylinder or Box
    margin : float
        Required distance (m) of the palm centre from the body, >= 0.
    """

    primitives: tuple[Primitive, ...]
    margin: float = DEFAULT_MARGIN

    def __post_init__(self) -> None:
        if not self.primitives:
            raise ModelFormatError('a body needs at least one primitive')
        if not (np.isfinite(self.margin) and self.margin >= 0.0):
            raise ModelFormatError(f'body margin must be finite and >= 0, got {self.margin!r}')

    def distance(self, p: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Signed distance (m) of points to the body (< 0 inside) and its unit gradient.

        Parameters
        ----------
        p : array_like, shape (N, 3)

        Returns
        -------
        sd : ndarray, shape (N,)
            Minimum over the primitives (the union); ties go to the first primitive.
        grad : ndarray, shape (N, 3)
            Outward unit normal of the nearest primitive.
        """
        pts = np.atleast_2d(np.asarray(p, dtype=np.float64))
        if len(self.primitives) == 1:
            return self.primitives[0].distance(pts)
        parts = [prim.distance(pts) for prim in self.primitives]
        sds = np.stack([s for s, _ in parts])          # (M, N)
        grads = np.stack([g for _, g in parts])        # (M, N, 3)
        nearest = np.argmin(sds, axis=0)
        cols = np.arange(pts.shape[0])
        return sds[nearest, cols], grads[nearest, cols]

    @property
    def reach(self) -> float:
        """m: a bound on the body's points' distance from the object frame's origin (centre plus bounding radius)."""
        return max(_norm3(prim.centre) + prim.bounding_radius for prim in self.primitives)

    def push_out(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        """Points moved along the body's normal to clearance ``margin`` where they are closer (N, 3).

        Points already clear are returned unchanged; a few passes resolve overlapping primitives.
        """
        out = np.array(p, dtype=np.float64, copy=True)
        for _ in range(4):
            sd, grad = self.distance(out)
            short = sd < self.margin
            if not short.any():
                break
            out[short] += (self.margin - sd[short])[:, None] * grad[short]
        return out

    @cached_property
    def kernel_arrays(self) -> tuple[Any, ...]:
        """The primitives as the planner's compiled kernels take them, then the margin (built once).

        ``(kinds, centres, axes, perps, radii, lengths, halfs, margin)``: ``kinds`` 0 for a cylinder, 1
        for a box; ``axes``/``perps``/``radii``/``lengths`` are the cylinders' (zero for a box),
        ``halfs`` the boxes' half extents (zero for a cylinder).
        """
        cylinders = [p if isinstance(p, Cylinder) else None for p in self.primitives]
        return (np.array([0 if c is not None else 1 for c in cylinders], dtype=np.int64),
                np.array([p.centre for p in self.primitives], dtype=np.float64).reshape(-1, 3),
                np.array([c.axis if c is not None else np.zeros(3) for c in cylinders]).reshape(-1, 3),
                np.array([c.perpendicular if c is not None else np.zeros(3) for c in cylinders]).reshape(-1, 3),
                np.array([c.radius if c is not None else 0.0 for c in cylinders], dtype=np.float64),
                np.array([c.length if c is not None else 0.0 for c in cylinders], dtype=np.float64),
                np.array([p.half_extents if isinstance(p, Box) else np.zeros(3)
                          for p in self.primitives]).reshape(-1, 3),
                float(self.margin))

    def to_document(self) -> dict[str, Any]:
        """YAML-ready mapping: ``{margin, primitives: [...]}``."""
        return {'margin': float(self.margin), 'primitives': [prim.to_document() for prim in self.primitives]}

    @classmethod
    def from_document(cls, doc: Any) -> ObjectBody:
        """Parse :meth:`to_document`'s mapping. Raises ModelFormatError naming the bad field."""
        if not isinstance(doc, dict) or not isinstance(doc.get('primitives'), list):
            raise ModelFormatError('body must be a mapping with a list "primitives"')
        prims: list[Primitive] = []
        for i, item in enumerate(doc['primitives']):
            if not isinstance(item, dict):
                raise ModelFormatError(f'body primitive {i} must be a mapping')
            kind = item.get('type')
            try:
                if kind == 'cylinder':
                    prims.append(Cylinder(centre=item['centre'], axis=item['axis'], radius=item['radius'],
                                          length=item['length']))
                elif kind == 'box':
                    prims.append(Box(centre=item['centre'], half_extents=item['half_extents']))
                else:
                    raise ModelFormatError(f"body primitive {i}: type must be 'cylinder' or 'box', got {kind!r}")
            except KeyError as exc:
                raise ModelFormatError(f'body primitive {i} ({kind}) lacks field {exc}') from None
        try:
            margin = float(doc.get('margin', DEFAULT_MARGIN))
        except (TypeError, ValueError):
            raise ModelFormatError(f'body margin must be a number, got {doc.get("margin")!r}') from None
        return cls(primitives=tuple(prims), margin=margin)
