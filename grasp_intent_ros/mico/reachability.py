"""The MICO's reachability of a grasp: the planner's robot constraint, IK of the grasp's pose from a seed.

A grasp's features are reachable at an object's pose when IK of the end effector's pose they give converges
(:func:`~.ik.solve_ik` with the default tolerances, from the seed then random restarts). Each answer is kept,
so the accepted grasp's joint angles and pose are computed once.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import KinematicsError
from .frames import check_transform, features_to_obj_T_ee
from .ik import IK_MAX_ITER, IK_POS_TOL, IK_ROT_TOL, IkResult, solve_ik
from .kinematics import HOME_Q, MicoKinematics

__all__ = ['Reachability']


class Reachability:
    """The MICO's reachability as a robot constraint for :func:`grasp_intent_ros.planning.planner.plan`.

    Passed as ``accept=``: grasp features x are reachable when IK of ``base_T_obj @ features_to_obj_T_ee(x)``
    converges from ``q_seed`` (then up to ``restarts`` random restarts; :func:`~.ik.solve_ik` with
    :data:`~.ik.IK_POS_TOL`, :data:`~.ik.IK_ROT_TOL`, :data:`~.ik.IK_MAX_ITER` and the restart seeds of
    generator seed 0).

    Every IK answer and its target pose are kept, so the accepted candidate's joint angles and pose are not
    computed twice.

    Parameters
    ----------
    kin : MicoKinematics
    base_T_obj : array_like, shape (4, 4)
        Object pose in the base frame.
    q_seed : array_like, shape (6,), optional
        IK seed and branch reference (rad), e.g. the latest joint reading; :data:`~.kinematics.HOME_Q` if None.
    restarts : int
        Random IK restarts after the seeded attempt fails.
    """

    def __init__(self, kin: MicoKinematics, base_T_obj: ArrayLike, q_seed: ArrayLike | None = None, *,
                 restarts: int = 8) -> None:
        self.kin = kin
        self.base_T_obj = check_transform(base_T_obj, 'base_T_obj')
        self.q_seed = np.array(HOME_Q) if q_seed is None else kin.check_q(q_seed, 'q_seed')
        if restarts < 0:
            raise KinematicsError(f'need restarts >= 0, got {restarts}')
        self.restarts = restarts
        self.answers: dict[bytes, IkResult] = {}
        """IK answer per candidate (key: ``x.tobytes()``)."""
        self._targets: dict[bytes, NDArray[np.float64]] = {}
        self.seconds = 0.0
        """Time spent in IK so far (s)."""

    def target(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """``base_T_ee`` of features x, shape (4, 4): the pose IK solves for (computed on first use; read-only)."""
        key = np.asarray(x, dtype=np.float64).tobytes()
        if (base_T_ee := self._targets.get(key)) is None:
            base_T_ee = self._targets[key] = self.base_T_obj @ features_to_obj_T_ee(x)
            base_T_ee.flags.writeable = False
        return base_T_ee

    def answer(self, x: NDArray[np.float64]) -> IkResult:
        """The IK answer for features x (solved on first use)."""
        key = np.asarray(x, dtype=np.float64).tobytes()
        if key not in self.answers:
            start = time.perf_counter()
            self.answers[key] = solve_ik(self.kin, self.target(x), self.q_seed, restarts=self.restarts,
                                         pos_tol=IK_POS_TOL, rot_tol=IK_ROT_TOL, max_iter=IK_MAX_ITER, rng=None)
            self.seconds += time.perf_counter() - start
        return self.answers[key]

    def __call__(self, x: NDArray[np.float64]) -> bool:
        """Whether the arm reaches the grasp x."""
        return self.answer(x).success
