r"""The approach to a grasp, ROS-free: the pose a hand steers to for a grasp, via its pre-grasp.

A hand approaches a grasp along the grasp's approach axis (the EE z axis): it steers to the grasp's
**pre-grasp**, the grasp moved back by ``standoff`` along that axis, until it is **in the approach corridor**,
then to the grasp itself. The hand at ``p`` (orientation ``R``) is in the corridor of the grasp at ``p_g``
(orientation ``R_g``, approach axis ``z_g``) when

.. math::

    |p - p_g| \le r \quad\text{or}\quad
    \bigl((p - p_g)\cdot z_g \le 0,\ |(p - p_g) - ((p - p_g)\cdot z_g)\, z_g| \le r,\ \theta(R_g R^T) \le \phi\bigr),

``r`` = ``corridor_radius`` (m), ``phi`` = ``corridor_angle`` (rad), ``theta`` the rotation angle; each bound
is inclusive. The pre-grasp keeps the grasp's orientation, so only the position of the pose steered to
depends on the hand. The rule holds no state: a hand that leaves the corridor steers to the pre-grasp again.

One definition, used by the assistance's robot twist (:func:`~.robot_twist.assistance_target`), the scripted
operators (:meth:`~.operators.ScriptedOperator.approach_target`) and the intent estimator's operator model
(:mod:`.estimator`), vectorised over grasps for the estimator's hundreds of goals.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..mico.frames import rotation_angles

__all__ = ['in_corridor', 'approach_positions']


def in_corridor(base_T_ee: NDArray[np.float64], positions: NDArray[np.float64], rotations: NDArray[np.float64], *,
                corridor_radius: float, corridor_angle: float) -> NDArray[np.bool_]:
    """Whether the hand is in each grasp's approach corridor (module docstring).

    Parameters
    ----------
    base_T_ee : ndarray, shape (4, 4)
        The hand's pose (a rigid transform; not checked here).
    positions : ndarray, shape (N, 3)
        The grasps' positions (m), same frame.
    rotations : ndarray, shape (N, 3, 3)
        The grasps' orientations; column 2 is the approach axis.
    corridor_radius, corridor_angle : float
        m, rad.

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    offset = base_T_ee[:3, 3] - positions
    distance = np.sqrt(np.einsum('ni,ni->n', offset, offset))
    axis = rotations[:, :, 2]
    along = np.einsum('ni,ni->n', offset, axis)
    lateral = offset - along[:, None] * axis
    behind = ((along <= 0.0) & (np.sqrt(np.einsum('ni,ni->n', lateral, lateral)) <= corridor_radius)
              & (rotation_angles(rotations, base_T_ee[:3, :3]) <= corridor_angle))
    out: NDArray[np.bool_] = (distance <= corridor_radius) | behind
    return out


def approach_positions(base_T_ee: NDArray[np.float64], positions: NDArray[np.float64],
                       rotations: NDArray[np.float64], *, standoff: float, corridor_radius: float,
                       corridor_angle: float) -> NDArray[np.float64]:
    """The position (m) of the pose the hand steers to for each grasp: the grasp's in its corridor, else its pre-grasp.

    Arguments as :func:`in_corridor`; ``standoff`` (m, >= 0) the pre-grasp's distance behind the grasp. The pose
    steered to has the grasp's orientation ``rotations[g]``. Returns an array of shape (N, 3); with ``standoff``
    0 it is ``positions``.
    """
    inside = in_corridor(base_T_ee, positions, rotations, corridor_radius=corridor_radius,
                         corridor_angle=corridor_angle)
    out: NDArray[np.float64] = positions - np.where(inside, 0.0, standoff)[:, None] * rotations[:, :, 2]
    return out
