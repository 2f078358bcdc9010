"""The robot twist's joint path toward its target, sought from a snapshot: the search, and the thread it runs in.

:class:`~.assistance.Assistance` needs, once per target (the grasp or its pre-grasp) and generation (every grasp
and object set, a repeated one too, asks for it again from the joints of that moment), the joint path its robot
twist follows (its module docstring). It hands the search a :class:`PathRequest`, a snapshot of everything the
search reads: the joints q at that moment, the target, the grasp, the bound's reference and slack, the object as
perceived (a :class:`~.clearance.PathClearance`) and the clear way this proposal had. :func:`seek_path` is the
search, one definition, whichever thread runs it:

- :class:`PathSearch` answers at once, in the caller's thread (the simulator, the tests, the node's warm-up):
  the closed loop on a simulated clock stays synchronous and deterministic, every path sought from the joints
  of the first output after the grasp or object was set.
- :class:`PathWorker` answers in a thread of its own (the assistance node), so that a search (milliseconds,
  tens at worst) never delays an output. The caller's thread owns the :class:`~.assistance.Assistance` and all
  its state; the worker thread owns its own kinematics and hand model (pinocchio's and coal's scratch data are
  not shared between threads), and reads only the request, whose arrays nobody changes. The answer comes back
  as one reference, taken by the caller on its next output. Requests are newest-only
  (:class:`~grasp_intent_ros.latest_only.LatestOnlyWorker`): a request replaced before its search began is never
  sought; the newest request is always sought, so no input is lost, only superseded. An answer for an older
  request of the same grasp, object and phase is still taken (the assistance's class docstring says what it
  uses while a search runs).

ROS-free.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..latest_only import LatestOnlyWorker
from ..mico.collision import HandCollision
from ..mico.kinematics import MicoKinematics
from .clearance import PathClearance, clear_path
from .joint_path import joint_path, line_turns, near_grasp

__all__ = ['PathRequest', 'PathAnswer', 'seek_path', 'PathSource', 'PathSearch', 'PathWorker']


@dataclass(frozen=True)
class PathRequest:
    """What a path search reads, taken at one moment (nobody changes its arrays afterwards).

    Attributes
    ----------
    key : tuple of (int, int, str)
        The assistance's epoch (its grasp and object), generation (its request) and the phase (``'grasp'`` or
        ``'pre-grasp'``) the path is for.
    q : ndarray, shape (6,)
        The joints (rad) the path starts from.
    base_T_target, base_T_grasp : ndarray, shape (4, 4)
        The target (the grasp or its pre-grasp) and the grasp, base frame.
    slack, reference : float
        m: :func:`~.joint_path.joint_path`'s and :func:`~.joint_path.near_grasp`'s.
    clearance : PathClearance or None
        The object as perceived (None: no check).
    previous : tuple of ndarray, shape (6,)
        The clear way that replaced this proposal's path for this phase, its points still ahead (empty: none).
    """

    key: tuple[int, int, str]
    q: NDArray[np.float64]
    base_T_target: NDArray[np.float64]
    base_T_grasp: NDArray[np.float64]
    slack: float
    reference: float
    clearance: PathClearance | None
    previous: tuple[NDArray[np.float64], ...] = ()


@dataclass(frozen=True)
class PathAnswer:
    """A search's answer for ``key``: ``path``, its points after q (rad; None: no joint path).

    ``cleared``: the path is :func:`~.clearance.clear_path`'s replacement of the assistance's own.
    """

    key: tuple[int, int, str]
    path: list[NDArray[np.float64]] | None
    cleared: bool


def seek_path(kin: MicoKinematics, request: PathRequest) -> PathAnswer:
    """The joint path toward ``request.base_T_target`` from ``request.q`` (:class:`~.assistance.Assistance`).

    The IK (no restarts) from q, ``[q_t]`` with the wrist's 2 pi branch that turns the hand the short way
    (:func:`~.joint_path.line_turns`), or when it fails :func:`~.joint_path.joint_path`; then, with a
    clearance, :func:`~.clearance.clear_path` (admissible: :func:`~.joint_path.near_grasp`, the same bound).
    ``kin`` must be the calling thread's own, and ``request.clearance`` built on it.
    """
    q, target, grasp = request.q, request.base_T_target, request.base_T_grasp
    ik = kin.ik(target, q, restarts=0)  # the solution the joints descend to
    path: list[NDArray[np.float64]] | None
    if ik.success:
        path = [line_turns(kin, q, ik.q, target, grasp, slack=request.slack, reference=request.reference)]
    else:
        path = joint_path(kin, q, target, grasp, slack=request.slack, reference=request.reference)
    if path is not None and request.clearance is not None:
        near = functools.partial(near_grasp, kin, q, base_T_grasp=grasp, slack=request.slack,
                                 reference=request.reference)
        cleared = clear_path(request.clearance, q, path, target, list(request.previous) or None, near)
        if cleared is not path:
            return PathAnswer(request.key, cleared, True)
    return PathAnswer(request.key, path, False)


class PathSource(Protocol):
    """Where the assistance's path searches run."""

    def seek(self, request: PathRequest) -> PathAnswer | None:
        """The newest answer for ``request``'s epoch and phase (its generation may be older), or None."""


class PathSearch:
    """Seeks at once in the caller's thread, with ``kin`` (the assistance's own)."""

    def __init__(self, kin: MicoKinematics) -> None:
        self.kin = kin

    def seek(self, request: PathRequest) -> PathAnswer:
        return seek_path(self.kin, request)


class PathWorker:
    """Seeks in a thread of its own with its own ``kin`` and ``hand`` (module docstring); :meth:`stop` ends it.

    ``guard`` wraps the thread's handler (e.g. ``NodeDiagnostics.guard``): it must catch what the search
    raises. A search that raises answers None (no joint path: the assistance's Cartesian twist) and the
    exception goes on to ``guard``.
    """

    def __init__(self, kin: MicoKinematics, hand: HandCollision, *, name: str,
                 guard: Callable[[Callable[[PathRequest | None], None]], Callable[[PathRequest | None], None]]
                 | None = None) -> None:
        self.kin, self.hand = kin, hand
        self._asked: tuple[int, int, str] | None = None  # the caller's thread's: the key last handed over
        self._answer: PathAnswer | None = None  # written by the worker thread, read by the caller's
        handle = self._handle if guard is None else guard(self._handle)
        self._worker: LatestOnlyWorker[PathRequest | None] = LatestOnlyWorker(
            None, handle, name=name, ready=lambda request: request is not None)

    def seek(self, request: PathRequest) -> PathAnswer | None:
        """The newest answer for ``request``'s epoch and phase, None for none; hands ``request`` over unless it was.

        The answer may be for an older generation while ``request`` is sought (the caller tells by its key).
        """
        if self._asked != request.key:
            self._asked = request.key
            self._worker.update(lambda _: request)
        answer = self._answer
        if answer is not None and answer.key[0] == request.key[0] and answer.key[2] == request.key[2]:
            return answer
        return None

    def stop(self) -> None:
        """Stop the thread after its current search and wait for it."""
        self._worker.stop()

    def _handle(self, request: PathRequest | None) -> None:
        assert request is not None
        clearance = request.clearance
        own = None if clearance is None else clearance.on(self.kin, self.hand)
        try:
            self._answer = seek_path(self.kin, replace(request, clearance=own))
        except Exception:
            self._answer = PathAnswer(request.key, None, False)
            raise
