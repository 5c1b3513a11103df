"""The in-process bus."""

from __future__ import annotations

from bim2rdt.bus import LocalBus


def test_subscribers_get_matching_messages_and_retained_ones_on_subscribe():
    bus = LocalBus().connect()
    bus.publish("site/a/wearable/w1/status", b"online", retain=True)
    got = []
    bus.subscribe("site/a/wearable/+/#", lambda topic, payload: got.append((topic, payload)))
    bus.publish("site/a/wearable/w2/accel", b"x")
    bus.publish("site/b/wearable/w2/accel", b"other site")
    assert got == [("site/a/wearable/w1/status", b"online"), ("site/a/wearable/w2/accel", b"x")]
