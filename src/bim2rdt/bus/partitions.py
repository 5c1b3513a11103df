"""Wearable subjects on NATS and their partitions.

Wearables speak MQTT to nats-server's MQTT listener; the server turns the topic ``site/{site}/wearable/{device}/
{leaf}`` into the NATS subject ``site.{site}.wearable.{device}.{leaf}`` and its account mapping (see
:func:`partition_mapping`) prefixes the partition: ``hav.{k}.site.{site}.wearable.{device}.{leaf}``. ``k`` is
nats-server's ``partition(n, 1, 2)``: FNV-1a 32 of the site and device tokens, concatenated, modulo ``n``
(:func:`partition_of` computes the same number, so a device's permission can name its one partition subject).
Every message of a device lands in one partition, in order; one monitor consumes one partition.
"""

from __future__ import annotations

from bim2rdt.bus.topics import TopicError, check_level

STREAM = "HAV"
"""The JetStream stream holding every partition's wearable messages (subjects ``hav.>``)."""
PREFIX = "hav"


def check_subject_level(name: str, what: str) -> str:
    """``name`` if it is one MQTT topic level that stays one NATS subject token (no '.'), else TopicError."""
    check_level(name, what)
    if "." in name:
        raise TopicError(f"{what} {name!r}: on the NATS path ids must not contain '.' (it splits NATS subjects)")
    return name


def fnv1a_32(data: bytes) -> int:
    """The 32-bit FNV-1a hash (Go's hash/fnv New32a, which nats-server's partition() uses)."""
    value = 0x811C9DC5
    for byte in data:
        value = ((value ^ byte) * 0x01000193) & 0xFFFFFFFF
    return value


def partition_of(site: str, device: str, partitions: int) -> int:
    """The partition nats-server's ``partition(partitions, 1, 2)`` gives ``device`` of ``site``: FNV-1a 32 of the
    two ids concatenated, modulo ``partitions``.

    Args:
        site: The site id.
        device: The wearable's device id.
        partitions: How many partitions the site's devices are spread over.

    Returns:
        The partition, 0 <= k < ``partitions``.

    Raises:
        ValueError: ``partitions`` is less than 1.
    """
    if partitions < 1:
        raise ValueError("partitions must be at least 1")
    return fnv1a_32((site + device).encode()) % partitions


def partition_mapping(partitions: int) -> tuple[str, str]:
    """(source, destination) of the account's subject mapping that partitions every wearable subject."""
    return ("site.*.wearable.*.*",
            f"{PREFIX}.{{{{partition({partitions},1,2)}}}}.site.{{{{wildcard(1)}}}}.wearable.{{{{wildcard(2)}}}}."
            f"{{{{wildcard(3)}}}}")


def device_subjects(site: str, device: str, partitions: int) -> list[str]:
    """The subjects ``device`` may publish after the mapping: its accel, status and summary, in its one partition."""
    check_subject_level(site, "site")
    check_subject_level(device, "device")
    k = partition_of(site, device, partitions)
    return [f"{PREFIX}.{k}.site.{site}.wearable.{device}.{leaf}" for leaf in ("accel", "status", "summary")]


def partition_filter(site: str, partition: int) -> str:
    """The consumer filter of one partition of ``site``'s wearables."""
    return f"{PREFIX}.{partition}.site.{check_subject_level(site, 'site')}.wearable.>"


def topic_of(subject: str) -> tuple[int, str] | None:
    """(partition, MQTT topic) of a partitioned wearable subject, else None."""
    tokens = subject.split(".")
    if len(tokens) != 7 or tokens[0] != PREFIX or not tokens[1].isdigit():
        return None
    return int(tokens[1]), "/".join(tokens[2:])


def parse_partition(value: str) -> tuple[int, int]:
    """'K/N' as (K, N) with 0 <= K < N; TopicError in one line otherwise."""
    k, _, n = value.partition("/")
    if not (k.isdigit() and n.isdigit() and 0 <= int(k) < int(n)):
        raise TopicError(f"--partition wants K/N with 0 <= K < N, got {value!r}")
    return int(k), int(n)
