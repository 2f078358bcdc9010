"""The object the assistance follows: the hysteresis, its ties, and P(o) without an estimator."""

from __future__ import annotations

import pytest

from grasp_intent_ros.shared_control.scene_target import Follower, FollowRule, object_probabilities

RULE = FollowRule(margin=0.1, hold_time=0.3)


def test_the_first_object_followed_is_the_best_and_a_tie_goes_to_the_first_by_name() -> None:
    follower = Follower(RULE)
    assert follower.update({}, 0.0) is None
    assert follower.update({'flashlight': 0.2, 'cup': 0.2}, 0.0) == 'cup'  # a tie before any is held: name order
    assert Follower(RULE).update({'flashlight': 0.0, 'cup': 0.0}, 0.0) == 'cup'
    assert Follower(RULE).update({'cup': 0.2, 'flashlight': 0.2 + 1e-15}, 0.0) == 'flashlight'  # best, however little


def test_a_challenger_switches_only_after_leading_by_the_margin_for_the_hold_time() -> None:
    follower = Follower(RULE)
    assert follower.update({'cup': 0.5, 'flashlight': 0.1}, 0.0) == 'cup'
    # a tie, and a lead of the margin exactly, never switch, however long
    for t in (0.1, 0.5, 1.0):
        assert follower.update({'cup': 0.5, 'flashlight': 0.5}, t) == 'cup'
        assert follower.update({'cup': 0.25, 'flashlight': 0.35}, t + 0.01) == 'cup'
    # leading by more than the margin: the switch after hold_time, not before
    assert follower.update({'cup': 0.1, 'flashlight': 0.5}, 2.0) == 'cup'
    assert follower.update({'cup': 0.1, 'flashlight': 0.5}, 2.25) == 'cup'
    assert follower.update({'cup': 0.1, 'flashlight': 0.5}, 2.5) == 'flashlight'
    # and back only the same way
    assert follower.update({'cup': 0.5, 'flashlight': 0.1}, 3.0) == 'flashlight'
    assert follower.update({'cup': 0.5, 'flashlight': 0.1}, 3.5) == 'cup'


def test_a_lead_that_lapses_or_changes_hands_starts_the_wait_again() -> None:
    follower = Follower(RULE)
    follower.update({'a': 0.5, 'b': 0.0, 'c': 0.0}, 0.0)
    follower.update({'a': 0.1, 'b': 0.5, 'c': 0.0}, 1.0)
    follower.update({'a': 0.1, 'b': 0.15, 'c': 0.0}, 1.2)  # the lead lapses
    assert follower.update({'a': 0.1, 'b': 0.5, 'c': 0.0}, 1.35) == 'a'  # 0.35 s since the first lead: not held
    follower.update({'a': 0.1, 'b': 0.3, 'c': 0.5}, 1.5)  # another challenger
    assert follower.update({'a': 0.1, 'b': 0.5, 'c': 0.3}, 1.75) == 'a'
    assert follower.update({'a': 0.1, 'b': 0.5, 'c': 0.3}, 2.0) == 'a'
    assert follower.update({'a': 0.1, 'b': 0.5, 'c': 0.3}, 2.125) == 'b'  # b led from 1.75 s


def test_a_holder_without_a_score_is_replaced_at_once_and_no_score_changes_nothing() -> None:
    follower = Follower(RULE)
    follower.update({'cup': 0.5}, 0.0)
    assert follower.update({}, 1.0) == 'cup'
    assert follower.update({'flashlight': 0.0}, 1.0) == 'flashlight'


def test_p_o_is_uniform_over_the_scenes_objects_until_one_is_received() -> None:
    assert object_probabilities(['cup'], None, 1) == {'cup': 1.0}
    assert object_probabilities(['cup', 'flashlight'], None, 2) == {'cup': 0.5, 'flashlight': 0.5}
    # the flashlight's chain has not answered yet: the cup is not favoured for answering first
    assert object_probabilities(['cup'], None, 2) == {'cup': 0.5}
    received = {'flashlight': 0.75}  # the estimator names only the objects whose goals are ready
    assert object_probabilities(['cup', 'flashlight'], received, 2) == {'cup': 0.0, 'flashlight': 0.75}


@pytest.mark.parametrize('margin', [0.0, 0.1])
def test_equal_scores_never_switch_whatever_the_margin(margin: float) -> None:
    follower = Follower(FollowRule(margin=margin, hold_time=0.0))
    follower.update({'cup': 0.3, 'flashlight': 0.0}, 0.0)
    assert follower.update({'cup': 0.3, 'flashlight': 0.3}, 5.0) == 'cup'
