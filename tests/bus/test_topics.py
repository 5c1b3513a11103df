"""Topic names and MQTT wildcard matching."""

from __future__ import annotations

import pytest

from bim2rdt.bus import accel_topic, device_of, status_topic, topic_matches
from bim2rdt.bus.topics import TopicError


def test_wearable_topics_follow_the_site_layout():
    assert accel_topic("s1", "w-7") == "site/s1/wearable/w-7/accel"
    assert status_topic("s1", "w-7") == "site/s1/wearable/w-7/status"
    assert device_of("site/s1/wearable/w-7/accel") == "w-7"
    assert device_of("site/s1/safety/events") is None


@pytest.mark.parametrize("pattern, topic, expected", [
    ("site/+/wearable/+/accel", "site/a/wearable/b/accel", True),
    ("site/+/wearable/+/accel", "site/a/wearable/b/status", False),
    ("site/#", "site/a/wearable/b/accel", True),
    ("site/a/+", "site/a/b/c", False),
])
def test_wildcards_match_like_mqtt(pattern, topic, expected):
    assert topic_matches(pattern, topic) is expected


@pytest.mark.parametrize("bad", ["a/b", "+", "#", "", "x" * 65])
def test_a_device_id_that_is_not_one_topic_level_is_refused(bad):
    with pytest.raises(TopicError):
        accel_topic("s", bad)
