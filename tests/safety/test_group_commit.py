"""Group commits on the bus: fewer transactions, the same exposure, and a stated loss window on a crash."""

from __future__ import annotations

import pytest

from bim2rdt.bus import LocalBus, accel_topic, encode_accel
from bim2rdt.safety import HavMonitor, MonitorConfig

from hav_helpers import DAY, T0, feed, plan_batches

PLAN = [("idle", 2), ("hammer_drill", 20), ("idle", 3)]


def _publish(bus, batches) -> None:
    for batch in batches:
        bus.publish(accel_topic("demo", batch.device), encode_accel(batch), qos=1)


def test_group_commits_give_the_exposure_of_one_commit_per_batch_in_far_fewer_transactions(make_monitor, clock):
    items = plan_batches("dev-1", PLAN)
    alone, _ = make_monitor("alone", commit_batches=1, commit_delay_s=0.0)
    grouped, sink = make_monitor("grouped", commit_batches=16, commit_delay_s=10.0)
    for monitor in (alone, grouped):
        monitor.start_session("dev-1", "ana", "hammer_drill")
        bus = LocalBus().connect()
        monitor.attach(bus)
        _publish(bus, items)
        monitor.flush()
    subject = alone.queries.session("dev-1").subject
    assert grouped.queries.day(subject, DAY).energy == pytest.approx(alone.queries.day(subject, DAY).energy, rel=1e-9)
    assert alone.store.commits >= len(items)
    assert grouped.store.commits <= len(items) // 16 + 3
    assert "hav.activity_started" in sink.kinds()


def test_a_crash_on_the_in_process_bus_loses_at_most_the_waiting_group(make_monitor, clock, tmp_path):
    items = plan_batches("dev-1", PLAN)
    reference, _ = make_monitor("reference")
    subject = reference.start_session("dev-1", "ben", "hammer_drill")
    feed(reference, items, clock)

    config = MonitorConfig(commit_batches=10, commit_delay_s=10.0)  # the clock stands still: no timed commit
    first = HavMonitor(tmp_path / "crash", "test-secret", [], config, clock)
    first.start_session("dev-1", "ben", "hammer_drill")
    bus = LocalBus().connect()
    first.attach(bus)
    _publish(bus, items[:27])  # two groups of 10 committed, 7 batches waiting
    first._subscriber.stop()  # the process dies: nothing flushed, nothing closed cleanly
    first.store.close()
    first.identity.close()

    second, _ = make_monitor("crash")
    assert second.queries.stream_status("dev-1")["next_seq"] == 20  # lost: the 7 waiting, fewer than commit_batches
    second.ingest_many(items[27:], now=items[-1].device_time + 1.0)  # the device goes on; 7 batches stay lost
    lost = second.queries.stream_status("dev-1")["gap_s"]
    assert lost == pytest.approx(7 * 0.5)
    energy_lost = reference.queries.day(subject, DAY).energy - second.queries.day(subject, DAY).energy
    assert 0 < energy_lost < 10 * 0.5 * 12.0**2  # at most commit_batches x 0.5 s at the drill's a_hv (10 m/s^2)


class GroupSink:
    """A sink that takes groups: each ``emit_many`` call's events, and each lone ``emit`` as a group of one."""

    def __init__(self) -> None:
        self.groups: list[list] = []

    def emit(self, event) -> None:
        self.groups.append([event])

    def emit_many(self, events) -> None:
        self.groups.append(list(events))


class EventsPerCommit:
    """A sink that takes events one by one: how many came after each commit of ``monitor``'s store."""

    def __init__(self, monitor) -> None:
        self.monitor, self.counts = monitor, {}

    def emit(self, event) -> None:
        commit = self.monitor.store.commits
        self.counts[commit] = self.counts.get(commit, 0) + 1


def test_a_sink_that_takes_groups_gets_each_commits_events_in_one_call(make_monitor, clock):
    monitor, events = make_monitor(commit_batches=16, commit_delay_s=10.0, predict_every_s=2.0)
    groups, per_commit = GroupSink(), EventsPerCommit(monitor)
    monitor.sinks += [groups, per_commit]
    monitor.start_session("dev-1", "ana", "hammer_drill")
    bus = LocalBus().connect()
    monitor.attach(bus)
    _publish(bus, plan_batches("dev-1", PLAN))
    monitor.flush()
    assert [e for group in groups.groups for e in group] == events.events  # every event, in order
    assert [len(group) for group in groups.groups] == list(per_commit.counts.values())  # one call per commit
    assert max(len(group) for group in groups.groups) >= 2, groups.groups  # (else this test shows nothing)
