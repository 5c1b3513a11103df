"""Hand-arm vibration commands: `bim2rdt hav listen|analyze|broker` and `bim2rdt bench hav`."""

from __future__ import annotations

import os
import time
from pathlib import Path

import typer

from bim2rdt.cli.common import console, out_path, print_json, print_table, stop_requested
from bim2rdt.cli.hav_output import (DEV_HELP, _leave, _password, event_line, open_monitor, progress,  # noqa: F401
                                    require_own_secrets, twin_sink, watch)  # watch: tests import it from here

hav_app = typer.Typer(help="Hand-arm vibration (ISO 5349-1): live monitor, recorded files, a dev broker.",
                      no_args_is_help=True)


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.add_typer(hav_app, name="hav")
    bench_app.command("hav")(bench_hav)


def _configured_broker(settings) -> str:
    from bim2rdt.bus.credentials import CredentialError

    if settings.mqtt.host is None:
        raise CredentialError("no broker: give --mqtt HOST:PORT or set BIM2RDT_MQTT__HOST (for the in-process "
                              "bus, run `bim2rdt sim wearables` without --mqtt)")
    return f"{settings.mqtt.host}:{settings.mqtt.port}"


@hav_app.command("listen")
def hav_listen(
    mqtt: str | None = typer.Option(None, "--mqtt", help="Broker HOST:PORT (default: BIM2RDT_MQTT__HOST/PORT)."),
    duration: float = typer.Option(0.0, "--duration", min=0.0, help="Stop after this many seconds (0: Ctrl-C)."),
    ifc: Path | None = typer.Option(None, "--ifc", help="Site IFC to write IfcEvent/IfcTask records into."),
    out: Path | None = typer.Option(None, "--out", help="Where the twin IFC goes (default: <ifc>_hav.ifc)."),
    max_offline: float = typer.Option(300.0, "--max-offline", min=1.0, help="Exit non-zero after this many seconds "
                                      "without the broker (a supervisor restarts the monitor; nothing is lost)."),
    nats: str | None = typer.Option(None, "--nats", help="nats://HOST:PORT: consume one partition of the NATS path's "
                                    "wearable stream instead of MQTT (see --partition, --partitions)."),
    partition: str = typer.Option("0/1", "--partition", help="With --nats: the partition K/N this process serves."),
    partitions: int = typer.Option(0, "--partitions", min=0, max=1024, help="With --nats: start and supervise N "
                                   "monitor processes here, one per partition, restarting any that dies."),
    standby: bool = typer.Option(False, "--standby", hidden=True, help="With --nats: import, then wait for the "
                                 "partition K/N on stdin (the supervisor's warm standby)."),
    dev: bool = typer.Option(False, "--dev", help=DEV_HELP),
) -> None:
    """Run the HAV monitor against a broker: print events, publish them on site/<site>/safety/events. Ctrl-C, SIGTERM
    or SIGHUP commit what waits, print the day's summary and exit 0. Exits non-zero if the network thread dies, the
    broker stays away for --max-offline seconds, or the store fails. With --nats, each message is acknowledged to
    JetStream after its commit (BIM2RDT_HAV__ACK_WAIT_S, BIM2RDT_HAV__MAX_DELIVER)."""
    from bim2rdt.bus.credentials import parse_address
    from bim2rdt.bus.mqtt import MqttBus
    from bim2rdt.config import get_settings
    from bim2rdt.safety import BusSink, CallbackSink
    from bim2rdt.safety.heap import settle

    settings = get_settings()
    if nats is not None:
        require_own_secrets(settings, dev, "site", "monitor")
        _listen_nats(settings, nats, partition, partitions, duration, max_offline, ifc, out, dev, standby)
        return
    host, port = parse_address(mqtt or _configured_broker(settings))
    require_own_secrets(settings, dev, "site", "monitor")
    bus = MqttBus(host, port, client_id=settings.mqtt.username, username=settings.mqtt.username,
                  password=_password(settings, settings.mqtt.username), session_expiry_s=settings.mqtt.session_expiry_s,
                  manual_ack=True)
    with twin_sink(ifc, out) as ifc_sink, stop_requested() as stop:  # the twin's target is checked before the run
        sinks = [CallbackSink(event_line), BusSink(bus, settings.mqtt.site)] + ([ifc_sink] if ifc_sink else [])
        monitor = open_monitor(settings, sinks)
        monitor.attach(bus)  # before connecting: the broker may deliver what it queued for us at once
        settle()  # built: out of the collector's full passes (decision 0028)
        bus.connect()
        console.print(f"listening on {host}:{port} site {settings.mqtt.site!r}; state in {settings.data_dir / 'hav'}")
        try:
            watch(monitor, bus, duration, max_offline, stop=stop)
        finally:
            _leave(monitor, bus)


def _listen_nats(settings, url: str, partition: str, partitions: int, duration: float, max_offline: float,
                 ifc: Path | None, out: Path | None, dev: bool, standby: bool = False) -> None:
    from bim2rdt.bus.partitions import parse_partition
    from bim2rdt.cli.hav_nats import listen_partition, supervise, wait_for_partition
    from bim2rdt.safety import CallbackSink

    if not url.startswith(("nats://", "tls://")):
        raise typer.BadParameter(f"--nats wants nats://HOST:PORT, got {url!r}")
    if partitions:
        if ifc is not None:
            raise typer.BadParameter("--ifc takes one monitor: run one `--partition K/N` per process for it")
        supervise(["--nats", url, "--max-offline", str(max_offline)] + (["--dev"] if dev else []), partitions,
                  duration)
        return
    if standby:
        import bim2rdt.bus.nats_bus  # noqa: F401  the heavy imports now, not when a partition needs us
        import bim2rdt.safety.monitor  # noqa: F401

        partition = wait_for_partition()
        if partition is None:
            return
    k, n = parse_partition(partition)
    with twin_sink(ifc, out) as ifc_sink:
        listen_partition(settings, url, k, n, duration, max_offline,
                         [CallbackSink(event_line)] + ([ifc_sink] if ifc_sink else []))


@hav_app.command("analyze")
def hav_analyze(
    file: Path = typer.Argument(..., help="CSV with a time column t (s) and ax, ay, az."),
    out: Path = typer.Option(Path("out/hav"), "--out", parser=out_path, help="Folder for the plot (PNG)."),
    tool: str = typer.Option("unknown", "--tool", help="Tool label for the report."),
    position: str = typer.Option("handle", "--position", help="Where the sensor sat (handle = ISO 5349-1)."),
    units: str = typer.Option("auto", "--units", help="auto (checked by gravity), m/s2 or g."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Exposure of a recorded file: activities, A(8), HSE points, time to EAV/ELV, and a plot of the day. The
    monitor's settings are the live monitor's (BIM2RDT_HAV__*)."""
    from bim2rdt.config import get_settings
    from bim2rdt.safety.analysis import analyze_recording, plot_day
    from bim2rdt.safety.recording import read_accel_csv

    config = get_settings().hav.monitor_config()  # the live monitor's trigger and artefact limits
    recording = read_accel_csv(file, units)
    with console.status(f"weighing {recording.xyz.shape[0] / recording.fs / 60:.1f} min at {recording.fs:g} Hz"):
        report = analyze_recording(recording, tool, position, config=config)
    plot = plot_day(report, out / f"{file.stem}_a8.png", title=f"Daily vibration exposure: {file.name}")
    summary = {"file": str(file), "fs": recording.fs, "units": recording.units, "a8": report.a8,
               "points": report.points, "trigger_s": report.trigger_s, "seconds_to_eav": report.seconds_to_eav,
               "seconds_to_elv": report.seconds_to_elv, "band_hz": [report.band.low_hz, report.band.high_hz],
               "band_limited": not report.band.complete, "estimate": position != "handle",
               "rejected_s": report.rejected_s, "rejected_kinds": report.rejected_kinds,
               "untriggered_s": report.untriggered_s, "untriggered_a8": report.untriggered_a8,
               "notes": report.notes, "activities": report.activities, "plot": str(plot)}
    if as_json:
        print_json(summary)
        return
    _print_day(report, file.name, recording.fs, plot)


def _print_day(report, name: str, fs: float, plot: Path) -> None:
    """The analyzed day as a table of activities, a summary line and warnings on what limits it."""
    rows = [(time.strftime("%H:%M:%S", time.gmtime(a["started"])), a["trigger_s"] / 60.0, a["a_hv"],
             a["activity_a8"], a["activity_points"]) for a in report.activities]
    print_table(f"Activities in {name}", ["start (UTC)", "minutes", "a_hv m/s²", "A(8) share", "points"], rows)
    console.print(f"day: A(8) {report.a8:.2f} m/s², {report.points:.0f} points, trigger time "
                  f"{report.trigger_s / 60:.1f} min; plot {plot}")
    if report.rejected_s:
        console.print(f"[yellow]rejected {report.rejected_s:.1f} s of samples as artefacts "
                      f"({', '.join(report.rejected_kinds)}): not counted as exposure[/yellow]")
    if not report.band.complete:
        console.print(f"[yellow]band-limited: {fs:g} Hz covers {report.band.low_hz:.1f}-"
                      f"{report.band.high_hz:.0f} Hz of the 8-1000 Hz range[/yellow]")
    for note in report.notes:
        console.print(f"[yellow]note: {note}[/yellow]")


@hav_app.command("broker")
def hav_broker(
    port: int | None = typer.Option(None, "--port", help="Loopback port (default 18830 for Mosquitto, 14222 for "
                                    "NATS; never 1883: a system broker may own it)."),
    devices: int = typer.Option(3, "--devices", min=1, help="Provision devices w1..wN (dev passwords)."),
    duration: float = typer.Option(0.0, "--duration", min=0.0, help="Stop after this many seconds (0: Ctrl-C)."),
    nats: bool = typer.Option(False, "--nats", help="Run nats-server (JetStream + its MQTT 3.1.1 listener) for the "
                              "scaled path instead of Mosquitto."),
    mqtt_port: int = typer.Option(18831, "--mqtt-port", help="With --nats: the wearables' MQTT 3.1.1 port."),
    partitions: int = typer.Option(1, "--partitions", min=1, max=1024, help="With --nats: partitions of the "
                                   "wearable stream (one monitor each: `hav listen --nats URL --partition K/N`)."),
    dev: bool = typer.Option(False, "--dev", help=DEV_HELP),
) -> None:
    """Run the shipped Mosquitto config (password per device, per-device ACL pinned to the site) on 127.0.0.1 for
    local runs, or with --nats a nats-server with JetStream whose per-device permissions pin each device to its
    site and partition; exits non-zero if the broker does not start or dies."""
    from bim2rdt.config import get_settings

    settings = get_settings()
    require_own_secrets(settings, dev, "devices", "monitor")
    names = [settings.mqtt.username, "dashboard"] + [f"w{i + 1}" for i in range(devices)]
    broker, banner = _broker(settings, names, port, nats, mqtt_port, partitions)
    with stop_requested() as stop, broker:
        console.print(banner)
        deadline = time.monotonic() + duration if duration else float("inf")
        while time.monotonic() < deadline and not stop.wait(min(0.5, max(deadline - time.monotonic(), 0.0))):
            broker.check()  # terminated, interrupted or its terminal closed: the with stops the broker, no orphan


def _broker(settings, names: list[str], port: int | None, nats: bool, mqtt_port: int, partitions: int):
    """The broker `hav broker` runs (not started yet) and the line that says what it is."""
    from bim2rdt.bus.broker import MosquittoBroker

    passwords = {name: _password(settings, name) for name in names}
    if not nats:
        broker = MosquittoBroker(passwords, port=port or 18830, site=settings.mqtt.site,
                                 monitors=(settings.mqtt.username,))
        return broker, f"mosquitto on 127.0.0.1:{broker.port} for site {settings.mqtt.site!r}; users {', '.join(names)}"
    from bim2rdt.bus.nats_broker import NatsServer

    monitor = settings.mqtt.username
    devices = {name: password for name, password in passwords.items() if name not in (monitor, "dashboard")}
    broker = NatsServer(settings.mqtt.site, devices, {monitor: passwords[monitor]}, partitions=partitions,
                        port=port or 14222, mqtt_port=mqtt_port, limits=settings.hav.stream_limits())
    limits = broker.limits
    return broker, (f"nats-server on {broker.url} (wearables: MQTT 3.1.1 on 127.0.0.1:{broker.mqtt_port}) for site "
                    f"{settings.mqtt.site!r}, {partitions} partition(s); monitor {monitor!r}, devices "
                    f"{', '.join(devices)}; stream HAV keeps {limits.max_bytes} bytes for {limits.max_age_s:g} s, "
                    f"messages of {limits.max_msg_bytes} bytes at most, {limits.max_msgs_per_subject} per subject")


def bench_hav(
    streams: int = typer.Option(2000, "--streams", min=1, help="Simulated wearable streams (3 axes each)."),
    seconds: int = typer.Option(6, "--seconds", min=1, help="Seconds of samples per stream (timed rounds)."),
    fs: float = typer.Option(5000.0, "--fs", help="Sampling rate, Hz."),
    messages: int = typer.Option(200, "--messages", min=10, help="Messages for the Mosquitto latency run."),
    keep_raw: bool = typer.Option(False, "--keep-raw", help="Keep raw batches in SQLite (7-day retention)."),
    latency: bool = typer.Option(True, "--latency/--no-latency", help="Measure latency through Mosquitto."),
    store: bool = typer.Option(True, "--store/--no-store", help="Measure the exposure store over a shift."),
    store_minutes: float = typer.Option(10.0, "--store-minutes", min=1.0, help="Minutes of the store's shift."),
    scale: bool = typer.Option(False, "--scale", help="The NATS path instead: raw batches/s through nats-server to 1 "
                               "and 2 monitor processes, publish-to-commit latency, summaries/s per process."),
    devices: int = typer.Option(100, "--devices", min=2, help="With --scale: simulated wearables."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Streams processed in real time on one core vs the bare sosfilt floor; the store's commits and reads per
    batch vs a bare SQLite insert; publish-to-event latency. With --scale, the NATS path's monitor processes."""
    from bim2rdt.bench.hav import run_latency, run_store, run_throughput, targets
    from bim2rdt.config import get_settings, settings_record

    if scale:
        _bench_scale(devices, fs, as_json)
        return

    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    with progress(seconds + 1, f"{streams} streams x {seconds + 1} s") as tick:
        counter = iter(range(1, seconds + 2))
        result = {"throughput": run_throughput(streams, seconds, fs, keep_raw, lambda: tick(next(counter)))}
    if store:
        with progress(2, f"the store over {store_minutes:g} min of 2 wearables") as tick:
            counter = iter(range(1, 3))
            result["store"] = run_store(store_minutes, tick=lambda: tick(next(counter)))
    if latency:
        with progress(messages, f"{messages} messages through Mosquitto") as tick:
            counter = iter(range(1, messages + 1))
            result["latency"] = run_latency(messages, tick=lambda: tick(next(counter)))
    result["targets"] = targets(result)
    result["settings"] = settings_record(get_settings())  # what ran (secrets masked)
    if as_json:
        print_json(result)
        return
    _show_bench(result)


def _show_bench(result: dict) -> None:
    t = result["throughput"]
    print_table(f"HAV throughput, one core: {t['streams']} streams, 3 axes at {t['fs']:g} Hz, median of "
                f"{t['seconds']} one-second rounds", ["pipeline", "s per round", "streams in real time", "x floor"],
                [("HavMonitor.ingest_many" + (" (raw kept)" if t["keep_raw"] else ""), t["monitor_round_s"],
                  f"{t['monitor_streams_realtime']:.0f}", t["ratio_to_floor"]),
                 ("floor: bare scipy.signal.sosfilt", t["floor_round_s"], f"{t['floor_streams_realtime']:.0f}", 1.0)])
    if "store" in result:
        s = result["store"]
        rows = [(name.replace("_", " "), m["commits_per_s"], m["batches_per_commit"], m["batches_per_s"],
                 m["cost_per_batch_x_floor"], m["reads_per_batch_first_quarter"], m["reads_per_batch_last_quarter"])
                for name, m in s["modes"].items()]
        rows.append(("floor: bare INSERT per transaction", s["floor_commits_per_s"], 1, s["floor_commits_per_s"], 1.0,
                     "", ""))
        print_table(f"Exposure store over {s['minutes']:g} min of {s['devices']} wearables (0.5 s int16 batches at "
                    f"{s['fs']:g} Hz, raw kept)", ["mode", "commits/s", "batches/commit", "batches/s",
                                                   "x floor per batch", "reads/batch, 1st quarter",
                                                   "reads/batch, last quarter"], rows)
    if "latency" in result:
        lat = result["latency"]
        print_table("Publish-to-event latency through Mosquitto (QoS 1)",
                    ["messages", "p50 ms", "p99 ms", "max ms", "with events", "events p50 ms", "events p99 ms"],
                    [(lat["messages"], lat["p50_ms"], lat["p99_ms"], lat["max_ms"], lat["event_messages"],
                      lat["event_p50_ms"], lat["event_p99_ms"])])
    for name, ok in result["targets"].items():
        console.print(f"{name}: {'[green]PASS[/green]' if ok else '[red]FAIL[/red]'}")


def _bench_scale(devices: int, fs: float, as_json: bool) -> None:
    from bim2rdt.bench.hav_scale import run_scale, targets
    from bim2rdt.config import get_settings, settings_record

    with progress(4, f"{devices} wearables through nats-server: 1 and 2 monitors, summaries, latency") as tick:
        counter = iter(range(1, 5))
        result = run_scale(devices=devices, fs=fs, tick=lambda: tick(next(counter)))
    result["targets"] = targets(result)
    result["settings"] = settings_record(get_settings())
    if as_json:
        print_json(result)
        return
    t, s, lat, pub = result["throughput"], result["summaries"], result["latency"], result["publisher"]
    runs = t["per_process"]
    print_table(f"NATS path: {t['messages']} raw batches ({t['bytes_per_message'] / 1000:.1f} kB, 0.5 s at "
                f"{t['fs']:g} Hz) from {t['devices']} wearables, one backlog drained on {result['cpus']} CPUs",
                ["", "msgs/s (median round)", "x one process", "each round, msgs/s", "msgs per CPU-s per process",
                 "load before"],
                [("publisher (MQTT 3.1.1 QoS 1 into the stream)", pub["msgs_per_s"], "", "", "", ""),
                 *[(f"{k} monitor process{'es' if k > 1 else ''}", runs[k]["msgs_per_s"],
                    runs[k]["msgs_per_s"] / runs[1]["msgs_per_s"],
                    " ".join(f"{v:,.0f}" for v in runs[k]["rounds_msgs_per_s"]), runs[k]["msgs_per_cpu_s_per_process"],
                    runs[k]["load_average_1min_before"]) for k in (1, 2)]])
    print_table("On-device summaries (1 Hz), one process", ["messages", "bytes each", "msgs/s", "msgs per CPU-s"],
                [(s["messages"], s["bytes_per_message"], s["msgs_per_s_per_process"], s["msgs_per_cpu_s"])])
    print_table(f"Publish-to-commit latency, 2 processes, offered {lat['offered_msgs_per_s']:.0f} msgs/s "
                f"({lat['offered_fraction_of_one_process']:.0%} of one process's throughput)",
                ["messages", "committed", "p50 ms", "p99 ms", "max ms"],
                [(lat["messages"], lat["committed"], lat["p50_ms"], lat["p99_ms"], lat["max_ms"])])
    if lat.get("stages_ms"):
        print_table("Where the latency goes", ["stage", "p50 ms", "p99 ms"],
                    [(name.replace("_", " "), v["p50"], v["p99"]) for name, v in lat["stages_ms"].items()])
    for name, ok in result["targets"].items():
        console.print(f"{name}: {'[green]PASS[/green]' if ok else '[red]FAIL[/red]'}")
