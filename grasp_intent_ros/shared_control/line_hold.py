"""The target's IK solution the assistance holds for a proposal, and its release when the robot's motion stalls.

:func:`~.joint_path.ik_line` keeps the solution a proposal's last own joint line went to (the held solution)
while its line stays clear of the object, so that the descent from joints the operator's share has moved does
not switch between the target's solutions, each switch reversing the robot's twist. Held, a line can cross the
wrist's singularity (joint 5 through 0 or pi) where the arm's servo cannot follow it: the joints stop short of
the held solution and stay there. :class:`LineHold` keeps, per phase (``'pre-grasp'``, ``'grasp'``), the held
solution, the joints at each path request since there was one, and lets go of it for good (for this proposal)
when the joints made no progress toward it over :data:`STALL_WINDOW` (:func:`stalled`): from then on that
phase's requests carry no held solution, and the search answers as without one (the descent's from the joints).
What the robot knows only: its joints and its own answers, never the object's true pose. ROS-free.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray

__all__ = ['STALL_WINDOW', 'STALL_PROGRESS', 'stalled', 'LineHold']

STALL_WINDOW = 1.0
"""s: the window over which the joints must near the held solution (twice the joystick's mode switch, 0.5 s
of no input, so that a switch alone never stalls the robot's motion)."""
STALL_PROGRESS = 0.02
"""rad: the least decrease of the joints' (Euclidean) distance to the held solution over :data:`STALL_WINDOW`
that counts as progress (a servo at the wrist's singularity moves its joints by less than that in a window; the
robot's share at its slowest, alpha 0.1 at ``gain_joint`` over a line 0.2 rad long, nears it by more)."""


def stalled(q_then: NDArray[np.float64], q: NDArray[np.float64], held: NDArray[np.float64]) -> bool:
    """Whether joints that went from ``q_then`` to ``q`` over a window made no progress toward ``held``.

    True when ``|q_then - held| - |q - held| < STALL_PROGRESS`` (Euclidean, rad): the joints came nearer the held
    solution by less than :data:`STALL_PROGRESS`, or went away from it. A threshold on the distance's decrease,
    not a comparison of two near-equal costs: float noise decides only for a decrease within rounding of it.
    """
    return float(np.linalg.norm(q_then - held)) - float(np.linalg.norm(q - held)) < STALL_PROGRESS


class LineHold:
    """Per phase, for one proposal: the held solution, the joints at the requests since, and whether let go.

    :meth:`request` gives the held solution a path request carries (None: nothing held, or let go) and records
    the joints; :meth:`answered` holds an answer's end; :meth:`reset` (a new proposal) forgets everything.

    The rule, per phase:

    - **Held**: the end of the phase's last answered path that was the search's own (not
      :func:`~.clearance.clear_path`'s replacement): the target's IK solution its line went to.
    - **Let go** at a request at time t when something is held and the joints of the newest earlier request at
      least :data:`STALL_WINDOW` before t (requests since the phase's first held answer only) and the joints now
      are :func:`stalled` toward the held solution. Let go, the phase holds nothing more for this proposal
      (its answers are no longer held): the stall of a held line is not tried again.
    """

    def __init__(self) -> None:
        self._held: dict[str, NDArray[np.float64]] = {}
        self._joints: dict[str, deque[tuple[float, NDArray[np.float64]]]] = {}
        self._let_go: set[str] = set()

    def reset(self) -> None:
        """A new proposal: nothing held, nothing let go."""
        self._held, self._joints, self._let_go = {}, {}, set()

    def let_go(self, phase: str) -> bool:
        """Whether ``phase``'s hold was let go for this proposal."""
        return phase in self._let_go

    def request(self, phase: str, q: NDArray[np.float64], now: float) -> NDArray[np.float64] | None:
        """The held solution for a request at ``now`` (s) from joints ``q`` (rad), None when none; records ``q``.

        Lets go of the held solution first when the joints stalled toward it over the window (class docstring).
        """
        held = self._held.get(phase)
        if held is None:
            return None
        joints = self._joints.setdefault(phase, deque())
        while len(joints) > 1 and joints[1][0] <= now - STALL_WINDOW:
            joints.popleft()  # the newest at least a window old stays first
        if joints and joints[0][0] <= now - STALL_WINDOW and stalled(joints[0][1], q, held):
            self._let_go.add(phase)
            del self._held[phase], self._joints[phase]
            return None
        joints.append((now, q.copy()))
        return held

    def answered(self, phase: str, path: list[NDArray[np.float64]] | None, cleared: bool) -> None:
        """An answer taken for ``phase``: its end held when it is the search's own path and the phase not let go."""
        if path is not None and not cleared and phase not in self._let_go:
            self._held[phase] = path[-1].copy()
