"""The HAV monitor's side of the NATS path: one partition of the wearable stream through a durable JetStream pull
consumer, with the same ``subscribe``/``publish`` interface as :class:`~bim2rdt.bus.mqtt.MqttBus`.

nats-py is asyncio; the bus runs its own event loop on a thread that fetches (one batch ahead) and a dispatcher
thread that calls handlers, one message at a time in stream order, as ``handler(topic, payload, ack)`` with the MQTT topic the wearable used. ``ack()`` (callable from
any thread, once) acknowledges the message to JetStream: the monitor calls it after its commit, so whatever a crash
interrupts is redelivered (after ``ack_wait_s``, up to ``max_deliver`` times) to the partition's next consumer.
A handler that raises leaves its message unacknowledged (it comes again); messages no handler takes are
acknowledged at once. The consumer is durable (``hav-<site>-<k>-of-<n>``): a restarted monitor resumes where the
last acknowledgement left off.

Last deliveries: a message delivered ``max_deliver`` times (JetStream's count, plus the deliveries to the
partition's earlier consumers, which each restart recreates: :class:`Earlier`) is not left to vanish. The bus
commits what waits before it, then hands it alone to ``on_last_delivery(topic, payload, deliveries)``, which
applies it or dead-letters it (the monitor's rules, with the reason) and returns True when it dead-lettered it;
the message is then acknowledged (applied) or terminated (dead-lettered): either way never delivered again.
"""

from __future__ import annotations

import asyncio
import logging
import queue
import re
import threading
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import TYPE_CHECKING

from bim2rdt.bus.mqtt import BusError
from bim2rdt.bus.partitions import PREFIX, STREAM, partition_filter, topic_of
from bim2rdt.bus.topics import topic_matches

if TYPE_CHECKING:
    from nats.aio.msg import Msg

Handler = Callable[..., object]
PREFETCH = 2
"""Fetched batches waiting for the dispatcher: the next fetch travels while the monitor commits the last."""
FOLLOW_S = 0.002
"""Seconds a fetch waits for the messages following one that came alone: the latency a lightly loaded stream adds
to every message, so kept short; what arrives while the monitor commits a group is taken by the next fetch anyway."""
FETCH_BATCH = 256
"""Messages one fetch takes at most (one group commit: the monitor's ``commit_batches`` should be at least this)."""
log = logging.getLogger(__name__)


SUBJECTS_PER_DEVICE = 3
"""A device publishes on three subjects: accel, status and summary (:func:`~bim2rdt.bus.partitions.device_subjects`)."""


@dataclass(frozen=True)
class StreamLimits:
    """How much of the wearable stream JetStream keeps: the oldest messages go first past either bound.

    One device must not evict the others' unread messages (decision 0037): no message is longer than
    ``max_msg_bytes`` (the stream refuses it), and each subject keeps at most :attr:`max_msgs_per_subject`, its own
    oldest going first. So a device holds at most ``max_bytes / devices`` of the stream, however it floods, and the
    stream's byte bound is reached only when more than ``devices`` devices send.
    """

    max_age_s: float = 24 * 3600.0
    max_bytes: int = 8 * 2**30
    replicas: int = 1
    max_msg_bytes: int = 64 * 1024
    devices: int = 32
    """The devices the stream's bytes are shared by (each one's share is ``max_bytes / devices``)."""

    def __post_init__(self) -> None:
        if self.max_msgs_per_subject < 1:
            raise ValueError(f"a stream of {self.max_bytes} bytes cannot hold one {self.max_msg_bytes}-byte message "
                             f"per subject for {self.devices} devices: raise stream_max_bytes")

    @property
    def max_msgs_per_subject(self) -> int:
        """Messages each device subject keeps: its share of the stream in messages of the largest size."""
        return self.max_bytes // (self.devices * SUBJECTS_PER_DEVICE * self.max_msg_bytes)

    def differences(self, config) -> list[str]:
        """What an existing stream's ``config`` (nats-py StreamConfig) has other than these limits."""
        wanted = {"max_age": self.max_age_s, "max_bytes": self.max_bytes, "max_msg_size": self.max_msg_bytes,
                  "max_msgs_per_subject": self.max_msgs_per_subject, "num_replicas": self.replicas}
        return [f"{name} {getattr(config, name)} (settings: {value:g})" for name, value in wanted.items()
                if getattr(config, name) is None or abs(float(getattr(config, name)) - float(value)) > 1e-6]


@dataclass(frozen=True)
class Earlier:
    """Stream seqs ``first``..``through`` were delivered ``times`` times to the partition's earlier consumers and
    never acknowledged (each consumer life counts once). Kept in the description of the consumer a restart
    creates, so the count survives the next restart too (nats-server 2.9 has no consumer metadata)."""

    first: int = 0
    through: int = -1
    times: int = 0

    def of(self, stream_seq: int) -> int:
        """Deliveries of ``stream_seq`` to earlier consumers."""
        return self.times if self.first <= stream_seq <= self.through else 0

    def describe(self) -> str:
        return f"bim2rdt hav: stream seqs {self.first}..{self.through} delivered {self.times}x to earlier consumers"

    @classmethod
    def parse(cls, description: str | None) -> Earlier:
        found = re.search(r"stream seqs (\d+)\.\.(\d+) delivered (\d+)x", description or "")
        return cls(*map(int, found.groups())) if found else cls()

    def after_restart(self, start: int, delivered_through: int) -> Earlier:
        """The count for a consumer starting at ``start`` (the ack floor + 1) that replaces one which delivered
        through ``delivered_through``: one more life for the messages it delivered unacknowledged (and for those an
        earlier life left from ``start`` on); nothing when it left none."""
        if delivered_through < start:
            return Earlier()
        if self.first <= start <= self.through:
            return Earlier(start, max(self.through, delivered_through), self.times + 1)
        return Earlier(start, delivered_through, 1)


def probe(url: str, user: str | None, password: str | None, timeout_s: float = 5.0) -> None:
    """Log in to nats-server at ``url`` and leave; BusError in one line when it cannot be reached or refuses.

    Args:
        url: ``nats://HOST:PORT``.
        user: The user to log in as.
        password: Its password.
        timeout_s: How long to wait for the server, seconds.

    Raises:
        BusError: Nothing answers at ``url``, or it refused the login.
    """
    import nats

    async def quiet(error: Exception) -> None:  # nats-py would print each failed attempt's traceback
        pass

    async def login() -> None:
        connection = await nats.connect(url, user=user, password=password, connect_timeout=timeout_s,
                                        allow_reconnect=False, max_reconnect_attempts=0, error_cb=quiet)
        await connection.close()

    try:
        asyncio.run(asyncio.wait_for(login(), timeout_s * 2))
    except Exception as error:
        raise BusError(f"cannot use NATS at {url}: {type(error).__name__}: {error}".rstrip(": ")) from None


def consumer_name(site: str, partition: int, partitions: int) -> str:
    return f"hav-{site}-{partition}-of-{partitions}"


async def ensure_stream(js, limits: StreamLimits = StreamLimits()) -> None:
    """Create the HAV stream (file storage, bounded by age, size, message size and per-subject count; the oldest
    messages go first) if missing, else bring an existing one to ``limits``. BusError naming the difference when the
    server refuses the update (a replica count, say, cannot change on a single server)."""
    from nats.js.api import DiscardPolicy, RetentionPolicy, StorageType, StreamConfig
    from nats.js.errors import NotFoundError

    config = StreamConfig(name=STREAM, subjects=[f"{PREFIX}.>"], storage=StorageType.FILE,
                          retention=RetentionPolicy.LIMITS, discard=DiscardPolicy.OLD, max_age=limits.max_age_s,
                          max_bytes=limits.max_bytes, max_msg_size=limits.max_msg_bytes,
                          max_msgs_per_subject=limits.max_msgs_per_subject, num_replicas=limits.replicas)
    try:
        info = await js.stream_info(STREAM)
    except NotFoundError:
        await js.add_stream(config)
        return
    differences = limits.differences(info.config)
    if not differences:
        return
    try:
        await js.update_stream(config)
    except Exception as error:
        raise BusError(f"the {STREAM} stream has {', '.join(differences)} and the server refused to change it: "
                       f"{error}") from None
    log.warning("the %s stream had %s: updated to the settings", STREAM, ", ".join(differences))


async def _resume_from(js, durable: str) -> tuple[int | None, Earlier]:
    """Where a (re)starting partition consumer begins: just after its acknowledgement floor, in stream order; and
    what the consumers before it delivered there unacknowledged.

    The durable consumer is recreated there (with the current ack_wait and max_deliver): what a killed monitor
    had fetched but not acknowledged comes again at once and in order, not after ``ack_wait`` behind newer
    messages (which the monitor's reorder window would have declared a gap). None: no consumer yet, start at
    the stream's beginning. The monitor drops what it had committed as duplicates. Recreating resets
    JetStream's delivery counts, so the earlier deliveries are carried over (:class:`Earlier`)."""
    from nats.js.errors import NotFoundError

    try:
        info = await js.consumer_info(STREAM, durable)
    except NotFoundError:
        return None, Earlier()
    floor = (info.ack_floor.stream_seq if info.ack_floor is not None else 0) or 0
    delivered = (info.delivered.stream_seq if info.delivered is not None else 0) or 0
    await js.delete_consumer(STREAM, durable)
    return floor + 1, Earlier.parse(info.config.description).after_restart(floor + 1, delivered)


class NatsBus:
    """A connection to nats-server; with ``partition`` (k of ``partitions``) a durable pull consumer of the site's
    wearable messages in that partition; :meth:`connect` connects it.

    Args:
        url: ``nats://HOST:PORT``.
        user: The user to log in as; None logs in anonymously.
        password: Its password.
        site: The site whose wearable stream the consumer reads.
        partition: The partition k (0-based) to consume; None only publishes (no consumer).
        partitions: How many partitions the site's devices are spread over.
        ack_wait_s: How long JetStream waits for a message's acknowledgement before it redelivers it, seconds.
        max_deliver: The consumer's JetStream delivery limit; a message whose deliveries, counting those to the
            partition's earlier consumers, reach it goes to ``on_last_delivery`` when that is set.
        limits: How much of the stream JetStream keeps (the stream is created or brought to these on connect).
        fetch_batch: Messages one fetch takes at most.
        timeout_s: How long to wait for the server (connecting, publishing with ``wait``, closing), seconds.
    """

    def __init__(self, url: str, user: str | None, password: str | None, site: str, partition: int | None = None,
                 partitions: int = 1, ack_wait_s: float = 30.0, max_deliver: int = 20,
                 limits: StreamLimits = StreamLimits(), fetch_batch: int = FETCH_BATCH, timeout_s: float = 10.0):
        self.url, self.user, self.password, self.site = url, user, password, site
        self.partition, self.partitions = partition, partitions
        self.ack_wait_s, self.max_deliver, self.limits = ack_wait_s, max_deliver, limits
        self.fetch_batch, self.timeout_s = fetch_batch, timeout_s
        self.handler_errors, self.delivered, self.redelivered, self.disconnects = 0, 0, 0, 0
        self.fetch_errors, self.last_deliveries, self.terminated = 0, 0, 0
        self.earlier = Earlier()
        """Deliveries to the partition's earlier consumers (set on connect)."""
        self._handlers: list[tuple[str, Handler, bool]] = []
        self._routes: dict[str, list[tuple[Handler, bool]]] = {}
        """The handlers of each topic seen (a device's topics come thousands of times: matched once)."""
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="nats-bus", daemon=True)
        self._nc = None
        self._fetcher: Future | None = None
        self._dispatcher: threading.Thread | None = None
        self._fetched: queue.Queue = queue.Queue(maxsize=PREFETCH)
        self._closing = False
        self._acks: set = set()
        self._unsent: list = []
        """(message, terminate) acknowledgements made since the last send: sent together, in one hop to the loop."""
        self._unsent_lock = threading.Lock()
        self.on_fetched: Callable[[], object] | None = None
        """Called after each fetched batch of messages was handed to the handlers: ``monitor.flush`` makes every
        fetch one group commit (as large as the backlog, a single message when idle: no waiting for a group)."""
        self.accepting: Callable[[], bool] = lambda: True
        """False stops dispatching (and fetching): set it to ``lambda: monitor.failure is None``, so a monitor whose
        store failed handles and acknowledges nothing more; what it had not committed comes again to its restart."""
        self.on_last_delivery: Callable[[str, bytes, int], bool] | None = None
        """``(topic, payload, deliveries) -> dead-lettered``: a message on its last delivery (see the module
        docstring), alone; True terminates it, False acknowledges it, raising leaves it unacknowledged. None: such a
        message goes to the handlers like any other (and JetStream drops it after its last delivery)."""

    # --- the MqttBus interface ------------------------------------------------------------------------------
    def connect(self) -> NatsBus:
        """Connect, make sure the stream (and this partition's consumer) exist, start fetching.

        Returns:
            This bus, connected.

        Raises:
            BusError: The server cannot be reached, refuses the login, or refuses the stream or consumer.
        """
        self._thread.start()
        try:
            self._run(self._connect(), self.timeout_s * 2)
        except Exception as error:
            self.close()
            raise BusError(f"cannot use NATS at {self.url}: {type(error).__name__}: {error}") from None
        if self.partition is not None:
            self._fetcher = asyncio.run_coroutine_threadsafe(self._fetch_loop(), self._loop)
            self._dispatcher = threading.Thread(target=self._dispatch_loop, name="nats-dispatch", daemon=True)
            self._dispatcher.start()
        return self

    def subscribe(self, pattern: str, handler: Handler, qos: int = 1, manual_ack: bool = False) -> int:
        """Call ``handler(topic, payload)`` for this partition's messages whose MQTT topic matches ``pattern`` (on
        the dispatcher thread, in stream order); with ``manual_ack``, ``handler(topic, payload, ack)``.

        Args:
            pattern: An MQTT topic filter (``+`` and ``#`` wildcards) matched against the topic the wearable used.
            handler: Called with (topic, payload), or (topic, payload, ack) with ``manual_ack``.
            qos: Accepted for :class:`~bim2rdt.bus.mqtt.MqttBus`'s interface; JetStream delivers at least once
                whatever it is.
            manual_ack: The handler acknowledges by calling ``ack`` (after its commit); without it, the message is
                acknowledged once every handler returned without raising.

        Returns:
            0 (there is no SUBACK on NATS).
        """
        self._handlers.append((pattern, handler, manual_ack))
        self._routes.clear()
        return 0

    def publish(self, topic: str, payload: bytes, qos: int = 0, retain: bool = False, wait: bool = False) -> int:
        """Publish on the subject of ``topic`` ('/' -> '.').

        Args:
            topic: The MQTT topic.
            payload: The message.
            qos: Accepted for :class:`~bim2rdt.bus.mqtt.MqttBus`'s interface; unused.
            retain: Accepted for :class:`~bim2rdt.bus.mqtt.MqttBus`'s interface; unused.
            wait: Return only after the server has the message (at most ``timeout_s``).

        Returns:
            0 (there is no PUBACK reason code on NATS).
        """
        future = asyncio.run_coroutine_threadsafe(self._publish(topic.replace("/", "."), payload, wait), self._loop)
        if wait:
            future.result(self.timeout_s)
        return 0

    @property
    def alive(self) -> bool:
        """The event loop runs and the fetch loop has not died."""
        return self._thread.is_alive() and not (self._fetcher is not None and self._fetcher.done()) and not (
            self._dispatcher is not None and not self._dispatcher.is_alive())

    @property
    def connected(self) -> bool:
        """Whether the client is connected to the server now."""
        return self._nc is not None and self._nc.is_connected

    def close(self) -> None:
        """Stop fetching, send the acknowledgements made so far, close the connection and the loop."""
        if not self._thread.is_alive():
            return
        self._closing = True
        if self._dispatcher is not None:
            self._dispatcher.join(self.timeout_s)
        self._send_acks()
        if self._fetcher is not None:
            try:
                self._fetcher.result(self.timeout_s)
            except Exception:
                pass
        try:
            self._run(self._close(), self.timeout_s)
        except Exception as error:
            log.warning("closing NATS: %s", error)
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(self.timeout_s)

    def __enter__(self) -> NatsBus:
        return self.connect()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- internals ----------------------------------------------------------------------------------------
    def _run(self, coroutine, timeout: float):
        return asyncio.run_coroutine_threadsafe(coroutine, self._loop).result(timeout)

    async def _connect(self) -> None:
        import nats
        from nats.js.api import AckPolicy, ConsumerConfig, DeliverPolicy

        async def on_disconnect() -> None:
            self.disconnects += 1

        async def on_error(error: Exception) -> None:
            log.warning("NATS: %s", error)

        self._nc = await nats.connect(self.url, user=self.user, password=self.password, name=self.user or "bim2rdt",
                                      connect_timeout=self.timeout_s, max_reconnect_attempts=-1,
                                      reconnect_time_wait=0.5, allow_reconnect=True, disconnected_cb=on_disconnect,
                                      error_cb=on_error)
        js = self._nc.jetstream(timeout=self.timeout_s)
        await ensure_stream(js, self.limits)
        if self.partition is None:
            return
        subject = partition_filter(self.site, self.partition)
        durable = consumer_name(self.site, self.partition, self.partitions)
        start, self.earlier = await _resume_from(js, durable)
        config = ConsumerConfig(ack_policy=AckPolicy.EXPLICIT, ack_wait=self.ack_wait_s, max_deliver=self.max_deliver,
                                max_ack_pending=max(4 * self.fetch_batch, 1024), filter_subject=subject,
                                deliver_policy=DeliverPolicy.ALL if start is None else DeliverPolicy.BY_START_SEQUENCE,
                                opt_start_seq=start, description=self.earlier.describe() if self.earlier.times
                                else None)
        self._sub = await js.pull_subscribe(subject, durable=durable, stream=STREAM, config=config)

    async def _fetch_loop(self) -> None:
        """Fetch while the dispatcher handles what came before (up to ``PREFETCH`` batches ahead)."""
        import nats.errors

        backlog = False
        while not self._closing and self.accepting():
            if self._fetched.full():
                await asyncio.sleep(0.001)
                continue
            try:
                messages = await self._take(backlog)
            except (nats.errors.ConnectionClosedError, nats.errors.ConnectionReconnectingError,
                    nats.errors.NoRespondersError):
                await asyncio.sleep(0.2)
                continue
            except Exception as error:  # never let the fetch loop die: what it fetched and lost comes again
                self.fetch_errors += 1  # (unacknowledged) after ack_wait
                log.warning("fetching from %s failed: %s: %s", self.url, type(error).__name__, error)
                await asyncio.sleep(0.2)
                continue
            backlog = len(messages) >= self.fetch_batch
            if messages:
                self._fetched.put_nowait(messages)

    async def _take(self, backlog: bool) -> list:
        """The next messages. A fetch of many that finds the stream idle lingers until its batch fills or it
        expires; so, without a backlog, wait for ONE message (returned as it arrives), then take what follows
        it within ``FOLLOW_S``; with a backlog, full batches."""
        import nats.errors

        timeouts = (nats.errors.TimeoutError, asyncio.TimeoutError)  # nats-py raises either
        try:
            first = await self._sub.fetch(self.fetch_batch if backlog else 1, timeout=FOLLOW_S if backlog else 0.5)
        except timeouts:
            return []
        if backlog:
            return first
        try:
            return first + await self._sub.fetch(self.fetch_batch - 1, timeout=FOLLOW_S)
        except timeouts:
            return first

    def _dispatch_loop(self) -> None:
        """Hand each fetched batch to the handlers in order, then ``on_fetched`` (one group commit per fetch)."""
        while not self._closing and self.accepting():
            try:
                messages = self._fetched.get(timeout=0.1)
            except queue.Empty:
                self._send_acks()  # those a background commit made
                continue
            for message in messages:
                if self._closing or not self.accepting():
                    return  # the rest stays unacknowledged: the partition's next start gets it again
                deliveries = self.deliveries(message)
                if deliveries >= self.max_deliver and self.on_last_delivery is not None:
                    self._last_delivery(message, deliveries)
                else:
                    self._dispatch(message)
            self._commit_fetched()
            self._send_acks()

    def deliveries(self, message: Msg) -> int:
        """How often a message was delivered: JetStream's count for this consumer, this delivery included, plus
        the deliveries to the partition's earlier consumers (:class:`Earlier`).

        Args:
            message: A JetStream message this consumer fetched.

        Returns:
            The deliveries, 1 or more.
        """
        return message.metadata.num_delivered + self.earlier.of(message.metadata.sequence.stream)

    def _commit_fetched(self) -> bool:
        """``on_fetched``: commit (and acknowledge) what the handlers hold; False when that failed."""
        if self.on_fetched is None:
            return True
        try:
            self.on_fetched()
            return True
        except Exception:  # e.g. the store failed: the monitor reports it; the messages stay unacknowledged
            self.handler_errors += 1
            log.exception("committing a fetched batch failed")
            return False

    def _last_delivery(self, message, deliveries: int) -> None:
        """Commit what waits, then the message alone through ``on_last_delivery``; acknowledge it when applied,
        terminate it when dead-lettered (never delivered again), leave it when that failed too."""
        found = topic_of(message.subject)
        self.delivered += 1
        self.redelivered += 1
        if found is None or found[0] != self.partition:
            _Ack(self, message)()
            return
        if not self._commit_fetched() or not self.accepting():
            return
        self.last_deliveries += 1
        try:
            dead_lettered = self.on_last_delivery(found[1], message.data, deliveries)
        except Exception:
            self.handler_errors += 1
            log.exception("the last delivery of %s failed; it stays unacknowledged", found[1])
            return
        if dead_lettered:
            self.terminated += 1
        _Ack(self, message, terminate=bool(dead_lettered))()

    def _dispatch(self, message) -> None:
        found = topic_of(message.subject)
        self.delivered += 1
        if message.metadata.num_delivered > 1:
            self.redelivered += 1
        ack = _Ack(self, message)
        if found is None or found[0] != self.partition:  # not ours: nothing to do with it
            ack()
            return
        topic, handed_over, failed = found[1], False, False
        routes = self._routes.get(topic)
        if routes is None:
            routes = self._routes[topic] = [(handler, takes_ack) for pattern, handler, takes_ack in self._handlers
                                            if topic_matches(pattern, topic)]
        for handler, takes_ack in routes:
            try:
                handler(topic, message.data, ack) if takes_ack else handler(topic, message.data)
                handed_over |= takes_ack
            except Exception:  # unacknowledged: JetStream redelivers it after ack_wait
                self.handler_errors += 1
                failed = True
                log.exception("handler for %s failed; the message stays unacknowledged", topic)
        if not handed_over and not failed:
            ack()

    def _queue_ack(self, message, terminate: bool) -> None:
        with self._unsent_lock:
            self._unsent.append((message, terminate))

    def _send_acks(self) -> None:
        """Hand the acknowledgements made so far to the loop at once (one wake-up, one task, not one per message)."""
        with self._unsent_lock:
            unsent, self._unsent = self._unsent, []
        if unsent:
            self._loop.call_soon_threadsafe(self._start_acks, unsent)

    def _start_acks(self, unsent: list) -> None:
        task = self._loop.create_task(_acknowledge(unsent))
        self._acks.add(task)
        task.add_done_callback(self._acks.discard)

    async def _publish(self, subject: str, payload: bytes, wait: bool) -> None:
        await self._nc.publish(subject, payload)
        if wait:
            await self._nc.flush(self.timeout_s)

    async def _close(self) -> None:
        if self._acks:
            await asyncio.gather(*list(self._acks), return_exceptions=True)
        if self._nc is not None and not self._nc.is_closed:
            try:
                await self._nc.flush(self.timeout_s)
            finally:
                await self._nc.close()


class _Ack:
    """Acknowledges one JetStream message once, from any thread."""

    __slots__ = ("_bus", "_message", "_done", "_terminate")

    def __init__(self, bus: NatsBus, message, terminate: bool = False):
        self._bus, self._message, self._done, self._terminate = bus, message, False, terminate

    def __call__(self) -> None:
        if not self._done:
            self._done = True
            self._bus._queue_ack(self._message, self._terminate)


async def _acknowledge(unsent: list) -> None:
    """Acknowledge (or terminate) each message, in order; one that fails is logged (it comes again)."""
    for message, terminate in unsent:
        try:
            await (message.term() if terminate else message.ack())
        except Exception as error:
            log.warning("acknowledging a message failed: %s: %s", type(error).__name__, error)
