"""MQTT topic names of the site bus and MQTT wildcard matching.

``site/{site}/wearable/{device}/accel``: acceleration batches, QoS 1, de-duplicated by (device, seq).
``site/{site}/wearable/{device}/status``: retained presence; the device's last will sets it offline.
``site/{site}/safety/events``: what the HAV monitor concludes (activity started, EAV reached, ...).
"""

from __future__ import annotations

import re

from bim2rdt.errors import Bim2RdtError

_LEVEL = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


class TopicError(Bim2RdtError):
    """A site or device id that cannot be one MQTT topic level."""


def check_level(name: str, what: str) -> str:
    """``name`` if it is a safe single topic level (letters, digits, _ . -), else TopicError."""
    if not isinstance(name, str) or not _LEVEL.match(name):
        raise TopicError(f"{what} {name!r} must be 1-64 letters, digits, '_', '.' or '-'")
    return name


def accel_topic(site: str, device: str) -> str:
    """The topic a wearable publishes its acceleration batches on.

    Args:
        site: The site id (one topic level).
        device: The wearable's device id (one topic level).

    Returns:
        ``site/{site}/wearable/{device}/accel``.

    Raises:
        TopicError: A site or device id that is not one safe topic level.
    """
    return f"site/{check_level(site, 'site')}/wearable/{check_level(device, 'device')}/accel"


def status_topic(site: str, device: str) -> str:
    """The topic a wearable publishes its status messages on.

    Args:
        site: The site id (one topic level).
        device: The wearable's device id (one topic level).

    Returns:
        ``site/{site}/wearable/{device}/status``.

    Raises:
        TopicError: A site or device id that is not one safe topic level.
    """
    return f"site/{check_level(site, 'site')}/wearable/{check_level(device, 'device')}/status"


def events_topic(site: str) -> str:
    """The topic the HAV monitor publishes its safety events on.

    Args:
        site: The site id (one topic level).

    Returns:
        ``site/{site}/safety/events``.

    Raises:
        TopicError: A site id that is not one safe topic level.
    """
    return f"site/{check_level(site, 'site')}/safety/events"


def wearable_pattern(site: str, leaf: str = "+") -> str:
    """Subscription pattern for every wearable's ``leaf`` topic.

    Args:
        site: The site id (one topic level).
        leaf: ``accel``, ``status``, ``summary``, or ``+`` for all of them.

    Returns:
        ``site/{site}/wearable/+/{leaf}``.

    Raises:
        TopicError: A site id that is not one safe topic level.
    """
    return f"site/{check_level(site, 'site')}/wearable/+/{leaf}"


def device_of(topic: str) -> str | None:
    """The device id in a wearable's topic.

    Args:
        topic: A topic such as ``site/{site}/wearable/{device}/accel``.

    Returns:
        The device id, or None for any other topic.
    """
    levels = topic.split("/")
    if len(levels) == 5 and levels[0] == "site" and levels[2] == "wearable":
        return levels[3]
    return None


def topic_matches(pattern: str, topic: str) -> bool:
    """MQTT wildcard match: ``+`` is one level, a trailing ``#`` is any number of levels.

    Args:
        pattern: The topic filter.
        topic: The topic.

    Returns:
        True when the topic matches the filter.
    """
    want, have = pattern.split("/"), topic.split("/")
    for i, level in enumerate(want):
        if level == "#":
            return True
        if i >= len(have) or (level != "+" and level != have[i]):
            return False
    return len(want) == len(have)
