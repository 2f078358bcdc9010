"""grasp_intent_ros.wire.topics: every topic typed, the topic groups, the input caps."""

from __future__ import annotations

import pytest

from grasp_intent_ros.errors import GraspIntentError
from grasp_intent_ros.wire import topics


def test_every_topic_has_a_type_and_the_groups_are_the_suite_s() -> None:
    constants = topics.__all__[:topics.__all__.index('DIAGNOSTICS') + 1]  # the topic names
    assert {getattr(topics, name) for name in constants} == set(topics.MSGTYPES)
    assert set(topics.INPUT_TOPICS) | set(topics.OUTPUT_TOPICS) <= set(topics.MSGTYPES)
    assert set(topics.PLAN_TOPICS) < set(topics.OUTPUT_TOPICS)
    assert topics.DIAGNOSTICS.startswith('/') and not any(name.startswith('/') for name in topics.INPUT_TOPICS)


def test_message_size_caps_and_name_bounds() -> None:
    for topic, cap in topics.MAX_MESSAGE_BYTES.items():
        assert topic in topics.MSGTYPES
        topics.check_message_size(topic, cap)
        with pytest.raises(GraspIntentError, match=f'{topic}: oversized message of {cap + 1} bytes'):
            topics.check_message_size(topic, cap + 1)
    with pytest.raises(KeyError):
        topics.check_message_size(topics.GRASP_MARKERS, 1)
    topics.check_names(['a' * topics.MAX_NAME_LENGTH] * 3, max_count=3, what='joint state')
    with pytest.raises(GraspIntentError, match='joint state: 4 names, the limit is 3'):
        topics.check_names(['a'] * 4, max_count=3, what='joint state')
    with pytest.raises(GraspIntentError, match='name 1 has 5000 characters'):
        topics.check_names(['a', 'b' * 5000], max_count=3, what='joint state')
