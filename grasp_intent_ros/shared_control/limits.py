"""The output twist's limits: speed and acceleration (:class:`TwistLimiter`), and norms without overflow. ROS-free.

The blended twist's linear and angular parts are scaled down to their speed limits, then each part's change
since the last output is scaled down to acceleration limit times the elapsed time
(:mod:`~grasp_intent_ros.shared_control.assistance`'s docstring, Limits).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ['norm', 'clip_norm', 'TwistLimiter']


def norm(x: NDArray[np.float64]) -> float:
    """|x|, without overflow for any finite ``x`` (inf when it exceeds the float range)."""
    size = float(np.abs(x).max())
    return size * _length(x / size) if size > 0.0 else 0.0


def clip_norm(x: NDArray[np.float64], limit: float) -> NDArray[np.float64]:
    """``x`` scaled down to norm ``limit`` when longer (direction kept; no overflow for any finite ``x``)."""
    size = float(np.abs(x).max())
    if size == 0.0:
        return x
    unit = x / size
    norm = _length(unit)
    return unit * (limit / norm) if size * norm > limit else x


def _length(unit: NDArray[np.float64]) -> float:
    """``float(np.linalg.norm(unit))`` of a real array, computed as it computes it, without its dispatch.

    Its flattened self's dot product, then the root (the same sum: the same bits); these run several times per output.
    """
    flat = unit.ravel(order='K')
    return math.sqrt(float(flat.dot(flat)))


@dataclass
class TwistLimiter:
    """Speed and acceleration limits of an output twist stream (module docstring).

    Attributes
    ----------
    max_linear, max_angular : float
        m/s, rad/s.
    max_linear_acceleration, max_angular_acceleration : float
        m/s^2, rad/s^2.
    max_dt : float
        Longest elapsed time (s) the acceleration limit grants (a gap in the stream is no licence to jump).
    """

    max_linear: float
    max_angular: float
    max_linear_acceleration: float
    max_angular_acceleration: float
    max_dt: float = 0.02

    def __post_init__(self) -> None:
        self.last = np.zeros(6)

    def limit(self, twist: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
        """``twist`` (shape (6,)) within the limits, ``dt`` s after the last output; becomes the last output.

        A non-finite twist counts as zero (never a NaN out).
        """
        if not np.all(np.isfinite(twist)):
            twist = np.zeros(6)
        dt = min(max(dt, 0.0), self.max_dt)
        lin, ang = clip_norm(twist[:3], self.max_linear), clip_norm(twist[3:], self.max_angular)
        lin = self.last[:3] + clip_norm(lin - self.last[:3], self.max_linear_acceleration * dt)
        ang = self.last[3:] + clip_norm(ang - self.last[3:], self.max_angular_acceleration * dt)
        self.last = np.concatenate([lin, ang])
        return self.last.copy()

    def stop(self) -> NDArray[np.float64]:
        """The zero twist, at once; becomes the last output."""
        self.last = np.zeros(6)
        return self.last.copy()
