"""Which object's grasp the assistance follows in a scene of several objects: the scores and the hysteresis.

ROS-free. docs/several_objects.md ("The assistance: one arm, the goals of every object") gives the design. Each
object o with a grasp has the score

    c_o = s_o * o_o,    s_o = P(o) * P(grasp_o serves T | w^o),

``P(o)`` the operator's wanting the object (the intent estimator's ``intent/objects``, :func:`object_probabilities`),
``P(grasp_o serves T | w^o)`` the one-object :func:`~.arbitration.serving_probability` on that chain's v and its
grasp's task set (or posterior), ``o_o`` the operator's held agreement with the grasp's approach target (the
smaller of the linear and the angular part, :func:`~.arbitration.approach_agreement`, held per part while the
operator moves that part within its deadband, 1 before any measure: as the one-object assistance holds it).
The assistance's alpha is then ``alpha_max * c_o`` of the object it follows (:mod:`.scene_assistance`).

**The hysteresis** (:class:`Follower`). Before any object is followed, the first call with a scored object follows
the one of largest score, a tie to the first by name (Python's string order). Then the followed object (the
*holder*) changes only when one other object (the *challenger*: the largest score among the others, a tie to the
first by name) scores more than the holder's score plus ``margin`` at every update for at least ``hold_time``
seconds, the same challenger throughout; any update where that fails (another challenger, or a lead of at most
``margin``) starts the wait again. A holder that has no score any more (no grasp) is replaced at once by the best
of the scored objects. An exact tie never switches, and neither does float noise below ``margin``.

**The defaults** (``margin`` 0.1, ``hold_time`` 0.3 s) and why, from a hand-built scene of a reach that changes
object (test/unit/shared_control/test_scene_target.py): scores lie in [0, 1] and alpha is ``alpha_max`` times the
score, so a margin of 0.1 is a tenth of the whole range, far above the wobble of a held agreement or a streamed P(o)
between two periods, and small enough that an operator who turns to the other object (its agreement near 1, the
holder's falling to 0 within one twist) is past it at once. The hold of 0.3 s is twice the assistance's
``yield_time`` (0.15 s): an operator's swerve short enough not to make the robot yield does not change its object
either, while a sustained turn, which the estimator's P(o) follows within about 0.4 s (docs/several_objects.md),
switches 0.3 s after it leads.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

__all__ = ['FollowRule', 'Follower', 'object_probabilities']


@dataclass(frozen=True)
class FollowRule:
    """The hysteresis of :class:`Follower` (module docstring).

    Attributes
    ----------
    margin : float
        The lead (in score, [0, 1]) a challenger needs over the holder.
    hold_time : float
        Seconds the same challenger must keep that lead.
    """

    margin: float = 0.1
    hold_time: float = 0.3


class Follower:
    """The object the assistance follows, from the objects' scores over time (module docstring: the hysteresis)."""

    def __init__(self, rule: FollowRule | None = None) -> None:
        self.rule = FollowRule() if rule is None else rule
        self.followed: str | None = None
        """The object followed (None before any object was scored)."""
        self._challenger: tuple[str, float] | None = None
        """The challenger leading by more than the margin, and since when (s)."""

    def update(self, scores: Mapping[str, float], now: float) -> str | None:
        """The object followed after the scores ``scores`` (object -> c_o, only objects with a grasp) at ``now`` (s).

        Unchanged while ``scores`` is empty.
        """
        if not scores:
            self._challenger = None
            return self.followed
        names = sorted(scores)
        if self.followed not in scores:
            self.followed, self._challenger = _best(names, scores), None
            return self.followed
        assert self.followed is not None
        others = [name for name in names if name != self.followed]
        top = _best(others, scores) if others else None
        if top is None or not scores[top] > scores[self.followed] + self.rule.margin:
            self._challenger = None
        elif self._challenger is None or self._challenger[0] != top:
            self._challenger = (top, now)
        if self._challenger is not None and now - self._challenger[1] >= self.rule.hold_time:
            self.followed, self._challenger = self._challenger[0], None
        return self.followed


def _best(names: Sequence[str], scores: Mapping[str, float]) -> str:
    """The first of ``names`` with the largest score (``max`` keeps the first of equal ones)."""
    return max(names, key=lambda name: scores[name])


def object_probabilities(names: Sequence[str], received: Mapping[str, float] | None,
                         scene_size: int) -> dict[str, float]:
    """P(o) of each object of ``names`` (the objects with a grasp), in a scene of ``scene_size`` objects.

    ``received``: the newest ``intent/objects`` (object -> P(o)); an object it does not name has P(o) 0 (the
    estimator names only the objects whose goals are ready). None (none received, e.g. no estimator running):
    ``1 / scene_size`` each, uniform over the scene's objects whether or not their grasps have come yet, so alpha
    stays at most ``alpha_max / scene_size`` while the object is unknown (an object whose chain answered first is
    not favoured for that), and one object alone has P(o) = 1 exactly (today's one-object assistance).
    """
    if received is None:
        return {name: 1.0 / scene_size for name in names}
    return {name: float(received.get(name, 0.0)) for name in names}
