"""A grasp's clearance as the hand's collision check reports it: the table, the depths and stops found, the verdict.

The table is a plane in the object frame (:class:`Table`); :class:`~.collision.HandCollision` finds, for one grasp,
how deep the hand goes below it and into the object's body on the approach and where each closing finger stops
(:class:`Clearance`, :class:`FingerStop`), and :class:`Clearance` turns that into a verdict under
:data:`~.limits.LIMITS` (:meth:`Clearance.fault`). ``.collision``'s docstring states what each figure measures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError
from .frames import check_transform
from .limits import LIMITS, Limits

__all__ = ['Table', 'FingerStop', 'Clearance']


@dataclass(frozen=True)
class Table:
    """The support plane in the object frame: points with ``normal . p >= offset`` are above it (m).

    Raises
    ------
    KinematicsError
        For a normal that is not finite and non-zero, or a non-finite offset.
    """

    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0

    def __post_init__(self) -> None:
        n = np.asarray(self.normal, dtype=np.float64)
        norm = float(np.linalg.norm(n)) if n.shape == (3,) and np.all(np.isfinite(n)) else 0.0
        if norm < 1e-9 or not math.isfinite(self.offset):
            raise KinematicsError(f'a table needs a finite non-zero normal and a finite offset, got {self.normal!r}, '
                                  f'{self.offset!r}')
        object.__setattr__(self, 'normal', tuple(float(c) for c in n / norm))
        object.__setattr__(self, 'offset', float(self.offset) / norm)

    @classmethod
    def in_object_frame(cls, base_plane: ArrayLike, base_T_obj: ArrayLike) -> Table:
        """The table ``(nx, ny, nz, d)`` of the base frame (``n . p >= d`` above it) in the object's frame.

        Raises
        ------
        KinematicsError
            For a plane that is not 4 finite numbers with a non-zero normal, or a bad transform.
        """
        plane = np.asarray(base_plane, dtype=np.float64)
        if plane.shape != (4,) or not np.all(np.isfinite(plane)):
            raise KinematicsError(f'a table plane is 4 finite numbers (nx, ny, nz, d), got {plane.tolist()}')
        T = check_transform(base_T_obj, 'base_T_obj')
        n_base = plane[:3]
        return cls(tuple((T[:3, :3].T @ n_base).tolist()), float(plane[3] - n_base @ T[:3, 3]))

    def depth(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """How far points (..., 3) lie below the plane (m; negative above it)."""
        out: NDArray[np.float64] = self.offset - points @ np.asarray(self.normal)
        return out


@dataclass(frozen=True)
class FingerStop:
    """Where a closing finger stopped: ``closure`` (rad) and ``on`` 'object', 'table' or '' (reached its plan)."""

    closure: float
    on: str


@dataclass(frozen=True)
class Clearance:
    """One grasp's clearance (:mod:`.collision`'s docstring); depths in m, positive into the table or the object.

    Attributes
    ----------
    table_depth : float
        Deepest hand part below the table along the approach, fingers open (negative: clear by that much).
    table_part : str
        Which part (:data:`~.collision.HAND_PARTS`).
    palm_depth, finger_depth : float
        Deepest the palm/wrist and an open finger go into the object along the approach (negative: clear).
    stops : tuple of FingerStop, length 3
    """

    table_depth: float
    table_part: str
    palm_depth: float
    finger_depth: float
    stops: tuple[FingerStop, FingerStop, FingerStop]

    def fault(self, limits: Limits = LIMITS) -> str | None:
        """Why the grasp is in collision under ``limits``, or None when it is not."""
        faults = []
        if self.table_depth > limits.table:
            faults.append(f'{self.table_part} {1e3 * self.table_depth:.1f} mm below the table')
        if self.palm_depth > limits.palm:
            faults.append(f'palm {1e3 * self.palm_depth:.1f} mm into the object')
        if self.finger_depth > limits.finger:
            faults.append(f'an open finger {1e3 * self.finger_depth:.1f} mm into the object')
        return '; '.join(faults) or None

    def summary(self) -> str:
        """The clearance in words (mm; 'into' for a depth, 'clear' for a distance), then where the fingers stop."""
        def mm(depth: float) -> str:
            return 'clear' if depth == -math.inf else \
                f'{1e3 * abs(depth):.1f} mm {"into" if depth > 0.0 else "clear"}'
        stops = ', '.join(f'{s.on or "its plan"} at {s.closure:.2f} rad' for s in self.stops)
        return (f'table {mm(self.table_depth)} ({self.table_part}), palm {mm(self.palm_depth)}, open fingers '
                f'{mm(self.finger_depth)}; fingers stop on {stops}')

    @property
    def fingers_on_table(self) -> int:
        """How many fingers stop on the table while closing."""
        return sum(stop.on == 'table' for stop in self.stops)
