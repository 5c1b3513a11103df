"""A message whose commit keeps failing on the NATS path: after ``max_deliver`` deliveries (counted across the
monitor's restarts, which recreate the partition's consumer) it is dead-lettered under its device with the reason,
and terminated: never delivered again, and the rest of the stream is counted."""

from __future__ import annotations

import time

from bim2rdt.bus.nats_bus import Earlier
from bim2rdt.bus.partitions import partition_of
from bim2rdt.safety.last_delivery import UNDELIVERABLE, apply_last_delivery
from bim2rdt.sim.wearables import default_plans, timed_messages
from tests.bus.conftest import SITE
from tests.bus.test_nats_monitor import FS, partition_monitor, publish_over_mqtt

POISON_SEQ = 5
MAX_DELIVER = 3


def test_earlier_deliveries_grow_by_one_per_restart_while_the_ack_floor_stays_and_reset_once_it_moves():
    first = Earlier().after_restart(start=11, delivered_through=40)
    assert (first.first, first.through, first.times) == (11, 40, 1)
    again = Earlier.parse(first.describe()).after_restart(start=11, delivered_through=25)
    assert (again.first, again.through, again.times) == (11, 40, 2)
    assert again.of(11) == again.of(40) == 2 and again.of(10) == again.of(41) == 0
    moved = again.after_restart(start=41, delivered_through=50)
    assert (moved.first, moved.through, moved.times) == (41, 50, 1)
    assert again.after_restart(start=60, delivered_through=59) == Earlier()  # nothing was left unacknowledged
    assert Earlier.parse("someone else's consumer") == Earlier()


def _poisoned(monitor):
    """The monitor's commits fail whenever they hold the batch ``POISON_SEQ`` (an injected, permanent fault)."""
    real_commit = monitor._journal.commit

    def commit(engine, batches, *args, **kwargs):
        if any(batch.seq == POISON_SEQ for batch in batches):
            raise OSError("disk full (injected for this batch)")
        return real_commit(engine, batches, *args, **kwargs)

    monitor._journal.commit = commit


def _life(server, k, folder, poisoned: bool, until, timeout_s: float = 20.0):
    """One monitor process's life (as ``hav listen --nats --partition``): until its store failed or ``until``."""
    monitor, bus = partition_monitor(server, k, folder, ack_wait_s=1.0, max_deliver=MAX_DELIVER)
    bus.on_last_delivery = lambda topic, payload, n: apply_last_delivery(monitor, topic, payload, n)
    if poisoned:
        _poisoned(monitor)
    deadline = time.monotonic() + timeout_s
    while monitor.failure is None and not until(monitor, bus) and time.monotonic() < deadline:
        time.sleep(0.05)
    if monitor.failure is None:
        monitor.flush()
    bus.close()
    return monitor, bus


def test_a_message_whose_commit_always_fails_is_dead_lettered_after_max_deliver_and_never_comes_again(
        nats_server, tmp_path):
    plans = default_plans(1, 0.5)
    device = plans[0].device
    k = partition_of(SITE, device, 3)
    t0 = time.time()
    publish_over_mqtt(nats_server, plans, t0)
    accel = sum(1 for _, _, topic, _, _ in timed_messages(plans, SITE, FS, t0) if topic.endswith("/accel"))

    def all_taken(monitor, bus):
        return monitor.store.applied_count() >= accel - 1

    failed_lives = 0
    for _ in range(MAX_DELIVER + 2):
        monitor, bus = _life(nats_server, k, tmp_path, poisoned=True, until=all_taken)
        if monitor.failure is None:
            break
        failed_lives += 1
        monitor.store.close()
    assert failed_lives == MAX_DELIVER - 1  # two lives fail on it; the third is its last delivery
    assert bus.terminated == 1 and bus.last_deliveries >= 1
    dead = monitor.queries.malformed_messages()[device]
    assert dead.count == 1
    assert f"not committed after {MAX_DELIVER} deliveries" in dead.last_reason and "disk full" in dead.last_reason
    assert monitor.queries.stats[UNDELIVERABLE] == 1
    assert monitor.store.applied_count() == accel - 1  # every other batch counted, once
    monitor.close()

    quiet, bus = _life(nats_server, k, tmp_path, poisoned=False, until=lambda m, b: False, timeout_s=2.5)
    assert bus.delivered == 0  # terminated: neither JetStream (ack_wait 1 s) nor a restart delivers it again
    assert quiet.queries.malformed_messages()[device].count == 1  # the dead letter was committed
    assert quiet.store.applied_count() == accel - 1
    quiet.close()
