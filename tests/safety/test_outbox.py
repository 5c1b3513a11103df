"""Durable sinks: the monitor's events reach a sink that fails for a while in order and once, and the monitor never
waits for it."""

from __future__ import annotations

import time

import pytest

from bim2rdt.safety import HavMonitor, MonitorConfig

from hav_helpers import Clock, feed, plan_batches

PLAN = [("idle", 2), ("grinder", 12), ("idle", 4), ("grinder", 8), ("idle", 4)]


class FlakySink:
    """A durable sink that refuses ``fail`` deliveries, and once takes a group but raises after it (its commit
    went through, the answer was lost): the outbox must not send that group again."""

    outbox = "test"

    def __init__(self, fail: int = 0, lose_answer: bool = False):
        self.fail, self.lose_answer, self.events, self.calls = fail, lose_answer, [], 0

    def emit_many(self, events) -> None:
        self.calls += 1
        if self.fail > 0:
            self.fail -= 1
            raise ConnectionError("the sink is down")
        self.events += events
        if self.lose_answer:
            self.lose_answer = False
            raise TimeoutError("the answer was lost")

    def emit(self, event) -> None:
        self.emit_many([event])

    def delivered(self, events) -> set[int]:
        held = {e.data["outbox_id"] for e in self.events}
        return {e.data["outbox_id"] for e in events} & held


def _config(url=None) -> MonitorConfig:
    return MonitorConfig(store_url=url, predict_every_s=2.0, outbox_retry_s=0.05)


def test_a_failing_durable_sink_gets_every_event_in_order_once(store_url, tmp_path):
    clock = Clock()
    sink = FlakySink(fail=4, lose_answer=True)
    monitor = HavMonitor(tmp_path / "m", "s", [sink], _config(store_url), clock)
    monitor.start_session("dev-1", "eva", "grinder")
    started = time.monotonic()
    feed(monitor, plan_batches("dev-1", PLAN), clock, chunk=4)
    fed_s = time.monotonic() - started
    assert monitor.drain_outbox(10.0)
    status = monitor.queries.outbox_status()["test"]
    committed = [(e.kind, e.time) for e in monitor.queries.reads.events()]
    monitor.close()
    assert [(e.kind, e.time) for e in sink.events] == committed and len(committed) > 10  # in order, none doubled
    assert status["failures"] == 5 and status["pending"] == 0
    assert fed_s < 5.0


def test_events_queued_when_the_monitor_stopped_are_delivered_at_the_next_start(tmp_path):
    clock = Clock()
    down = FlakySink(fail=10**6)
    first = HavMonitor(tmp_path / "m", "s", [down], _config().model_copy(update={"outbox_drain_s": 0.2}), clock)
    first.start_session("dev-1", "eva", "grinder")
    feed(first, plan_batches("dev-1", PLAN), clock)
    queued = first.queries.outbox_status()["test"]["pending"]
    first.close()
    up = FlakySink()
    second = HavMonitor(tmp_path / "m", "s", [up], _config(), clock)
    assert second.drain_outbox(10.0)
    second.close()
    assert queued > 0 and len(up.events) == queued and down.events == []


@pytest.mark.postgres
def test_monitors_sharing_a_postgresql_store_deliver_its_outbox_once(postgres_admin_url, tmp_path):
    from postgres_server import fresh_database

    with fresh_database(postgres_admin_url) as url:
        clock = Clock()
        sinks = [FlakySink(), FlakySink()]
        monitors = [HavMonitor(tmp_path / f"m{k}", "s", [sinks[k]], _config(url), clock) for k in range(2)]
        for k, monitor in enumerate(monitors):
            monitor.start_session(f"dev-{k}", f"w{k}", "grinder")
        for k, monitor in enumerate(monitors):
            feed(monitor, plan_batches(f"dev-{k}", PLAN), clock)
        assert all(m.drain_outbox(10.0) for m in monitors)
        committed = len(monitors[0].queries.reads.events())
        for monitor in monitors:
            monitor.close()
    delivered = [e.data["outbox_id"] for sink in sinks for e in sink.events]
    assert sorted(delivered) == sorted(set(delivered)) and len(delivered) == committed  # each event once
    assert min(len(sink.events) for sink in sinks) == 0  # one process delivers, the other stands by
