"""Hand-arm vibration commands: `bim2rdt hav listen|analyze|broker`, `bim2rdt sim wearables`, `bim2rdt bench hav`."""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from pathlib import Path

import typer

from bim2rdt.cli.common import console, print_json, print_table

hav_app = typer.Typer(help="Hand-arm vibration (ISO 5349-1): live monitor, recorded files, a dev broker.",
                      no_args_is_help=True)


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.add_typer(hav_app, name="hav")
    _group(app, "sim", "Simulators: wearables on the site bus.").command("wearables")(sim_wearables)
    bench_app.command("hav")(bench_hav)


def _group(app: typer.Typer, name: str, help_text: str) -> typer.Typer:
    """The app's sub-group ``name`` (shared with other modules that add commands to it), created if absent."""
    for info in app.registered_groups:
        if info.name == name:
            return info.typer_instance
    group = typer.Typer(help=help_text, no_args_is_help=True)
    app.add_typer(group, name=name)
    return group


def _broker_address(value: str) -> tuple[str, int]:
    from bim2rdt.bus.mqtt import BusError

    host, _, port = value.rpartition(":")
    if not host or not port.isdigit():
        raise BusError(f"--mqtt wants HOST:PORT, got {value!r}")
    return host, int(port)


def _configured_broker(settings) -> str:
    from bim2rdt.bus.mqtt import BusError

    if settings.mqtt.host is None:
        raise BusError("no broker: give --mqtt HOST:PORT or set BIM2RDT_MQTT__HOST (for the in-process bus, "
                       "run `bim2rdt sim wearables` without --mqtt)")
    return f"{settings.mqtt.host}:{settings.mqtt.port}"


def _password(settings, user: str) -> str:
    from bim2rdt.bus.broker import device_password

    if user == settings.mqtt.username and settings.mqtt.password:
        return settings.mqtt.password
    return device_password(settings.mqtt.device_secret, user)


def _event_line(event) -> None:
    """One line per event: time (UTC, device clock), pseudonym, tool, what happened, running figures."""
    data = event.data
    stamp = time.strftime("%H:%M:%S", time.gmtime(event.time))
    figures = (f"a_hv {data.get('a_hv') or 0:4.1f} A(8) {data.get('day_a8') or 0:4.2f} "
               f"{data.get('day_points') or 0:3.0f}pt")
    extra = f" EAV in {data['seconds_to_eav'] / 60:.0f} min" if data.get("seconds_to_eav") else ""
    console.print(f"{stamp} {event.subject[:10]} {data.get('tool', ''):12.12s} {event.kind[4:]:17s} {figures}{extra}",
                  soft_wrap=True)


def _summary(monitor, devices) -> None:
    rows = []
    for device in devices:
        session = monitor.session(device)
        if session is not None:
            day = monitor.day(session.subject, _last_day(monitor, session.subject))
            rows.append((session.subject, device, day.a8, day.points, day.seconds / 60.0, day.risk))
    print_table("Daily exposure", ["worker (pseudonym)", "device", "A(8) m/s²", "points", "trigger min", "risk"], rows)


def _last_day(monitor, subject: str) -> str | None:
    days = monitor.days_of(subject)
    return days[-1] if days else None


@contextmanager
def _twin(ifc: Path | None, out: Path | None):
    """An IfcSink writing into ``out`` from ``ifc`` (None when no IFC is asked for)."""
    if ifc is None:
        yield None
        return
    from bim2rdt.bim import TwinWriter, load_ifc
    from bim2rdt.safety.ifc_sink import IfcSink

    model = load_ifc(ifc, geometry=False)
    writer = TwinWriter(model)
    yield IfcSink(writer, model)
    target = out or ifc.with_name(ifc.stem + "_hav.ifc")
    writer.save(target)
    console.print(f"twin written to {target}")


@hav_app.command("listen")
def hav_listen(
    mqtt: str | None = typer.Option(None, "--mqtt", help="Broker HOST:PORT (default: BIM2RDT_MQTT__HOST/PORT)."),
    duration: float = typer.Option(0.0, "--duration", min=0.0, help="Stop after this many seconds (0: Ctrl-C)."),
    ifc: Path | None = typer.Option(None, "--ifc", help="Site IFC to write IfcEvent/IfcTask records into."),
    out: Path | None = typer.Option(None, "--out", help="Where the twin IFC goes (default: <ifc>_hav.ifc)."),
) -> None:
    """Run the HAV monitor against a broker: print events, publish them on site/<site>/safety/events."""
    from bim2rdt.bus.mqtt import MqttBus
    from bim2rdt.config import get_settings
    from bim2rdt.safety import BusSink, CallbackSink
    from bim2rdt.safety.setup import open_monitor

    settings = get_settings()
    host, port = _broker_address(mqtt or _configured_broker(settings))
    bus = MqttBus(host, port, client_id=f"bim2rdt-hav-monitor-{settings.mqtt.site}", username=settings.mqtt.username,
                  password=_password(settings, settings.mqtt.username), session_expiry_s=settings.mqtt.session_expiry_s)
    with _twin(ifc, out) as ifc_sink:
        sinks = [CallbackSink(_event_line), BusSink(bus, settings.mqtt.site)] + ([ifc_sink] if ifc_sink else [])
        monitor = open_monitor(settings, sinks)
        monitor.attach(bus)  # before connecting: the broker may deliver what it queued for us at once
        bus.connect()
        console.print(f"listening on {host}:{port} site {settings.mqtt.site!r}; state in {settings.data_dir / 'hav'}")
        deadline = time.monotonic() + duration if duration else float("inf")
        try:
            while time.monotonic() < deadline:
                time.sleep(min(1.0, max(deadline - time.monotonic(), 0.0)))
                monitor.tick()
        except KeyboardInterrupt:
            pass
        bus.close()
        _summary(monitor, monitor.devices())
        monitor.close()


@hav_app.command("analyze")
def hav_analyze(
    file: Path = typer.Argument(..., help="CSV with a time column t (s) and ax, ay, az (m/s²)."),
    out: Path = typer.Option(Path("out/hav"), "--out", help="Folder for the plot (PNG)."),
    tool: str = typer.Option("unknown", "--tool", help="Tool label for the report."),
    position: str = typer.Option("handle", "--position", help="Where the sensor sat (handle = ISO 5349-1)."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Exposure of a recorded file: activities, A(8), HSE points, time to EAV/ELV, and a plot of the day."""
    from bim2rdt.safety.analysis import analyze_recording, plot_day, read_accel_csv

    recording = read_accel_csv(file)
    with console.status(f"weighing {recording.xyz.shape[0] / recording.fs / 60:.1f} min at {recording.fs:g} Hz"):
        report = analyze_recording(recording, tool, position)
    plot = plot_day(report, out / f"{file.stem}_a8.png", title=f"Daily vibration exposure: {file.name}")
    summary = {"file": str(file), "fs": recording.fs, "a8": report.a8, "points": report.points,
               "trigger_s": report.trigger_s, "seconds_to_eav": report.seconds_to_eav,
               "seconds_to_elv": report.seconds_to_elv, "band_hz": [report.band.low_hz, report.band.high_hz],
               "band_limited": not report.band.complete, "estimate": position != "handle",
               "rejected_s": report.rejected_s, "rejected_kinds": report.rejected_kinds,
               "activities": report.activities, "plot": str(plot)}
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


@hav_app.command("broker")
def hav_broker(
    port: int = typer.Option(18830, "--port", help="Loopback port (never 1883: a system broker may own it)."),
    devices: int = typer.Option(3, "--devices", min=1, help="Provision devices w1..wN (dev passwords)."),
    duration: float = typer.Option(0.0, "--duration", min=0.0, help="Stop after this many seconds (0: Ctrl-C)."),
) -> None:
    """Run the shipped Mosquitto config (password per device, per-device ACL) on 127.0.0.1 for local runs."""
    import signal

    from bim2rdt.bus.broker import MosquittoBroker
    from bim2rdt.config import get_settings

    signal.signal(signal.SIGTERM, _interrupt)  # a terminated command stops its mosquitto instead of orphaning it
    settings = get_settings()
    names = [settings.mqtt.username, "dashboard"] + [f"w{i + 1}" for i in range(devices)]
    with MosquittoBroker({name: _password(settings, name) for name in names}, port=port) as broker:
        console.print(f"mosquitto on 127.0.0.1:{broker.port}; users {', '.join(names)}; config in {broker.folder}")
        try:
            time.sleep(duration) if duration else _wait_forever()
        except KeyboardInterrupt:
            pass


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _wait_forever() -> None:
    while True:
        time.sleep(3600)


def sim_wearables(
    mqtt: str | None = typer.Option(None, "--mqtt", help="Broker HOST:PORT; without it an in-process bus and "
                                    "monitor run here."),
    workers: int = typer.Option(3, "--workers", min=1, help="Simulated workers (devices w1..wN)."),
    minutes: float = typer.Option(45.0, "--minutes", min=1.0, help="Minutes of work per worker."),
    fs: float = typer.Option(5000.0, "--fs", min=200.0, help="Sensor sampling rate, Hz."),
    speed: float = typer.Option(0.0, "--speed", min=0.0, help="1 = real time, 0 = as fast as possible."),
    zone: str | None = typer.Option("Work Zone A - Drilling", "--zone", help="Work zone name or GlobalId."),
    csv: Path | None = typer.Option(None, "--csv", help="Also write worker 1's samples as CSV (for hav analyze)."),
    ifc: Path | None = typer.Option(None, "--ifc", help="In-process mode: site IFC to write the twin records into."),
    out: Path | None = typer.Option(None, "--out", help="Where the twin IFC goes (default: <ifc>_hav.ifc)."),
) -> None:
    """Publish simulated hammer drill / grinder / breaker sessions (realistic spectra and magnitudes)."""
    from bim2rdt.sim.wearables import default_plans, plan_seconds

    plans = default_plans(workers, minutes, zone)
    if csv is not None:
        _write_csv(plans[0], fs, csv)
    total = max(plan_seconds(p) for p in plans)
    with _progress(total, f"{workers} wearables, {total / 60:.0f} min each") as tick:
        if mqtt is None:
            _simulate_in_process(plans, fs, speed, tick, ifc, out)
        else:
            _simulate_over_mqtt(plans, fs, speed, tick, mqtt)


def _simulate_in_process(plans, fs, speed, tick, ifc, out) -> None:
    from bim2rdt.bus import LocalBus
    from bim2rdt.config import get_settings
    from bim2rdt.safety import CallbackSink
    from bim2rdt.safety.setup import open_monitor
    from bim2rdt.sim.wearables import publish_plans

    settings = get_settings()
    bus = LocalBus().connect()
    with _twin(ifc, out) as ifc_sink:
        monitor = open_monitor(settings, [CallbackSink(_event_line)] + ([ifc_sink] if ifc_sink else []))
        monitor.attach(bus)
        publish_plans(lambda device: bus, plans, settings.mqtt.site, fs, speed=speed, tick=tick)
        _summary(monitor, [p.device for p in plans])
        monitor.close()


def _simulate_over_mqtt(plans, fs, speed, tick, mqtt) -> None:
    from bim2rdt.bus.mqtt import MqttBus
    from bim2rdt.bus.topics import status_topic
    from bim2rdt.config import get_settings
    from bim2rdt.sim.wearables import publish_plans, status_payload

    settings = get_settings()
    host, port = _broker_address(mqtt)
    buses = {}
    for plan in plans:
        will = (status_topic(settings.mqtt.site, plan.device), status_payload(plan, "", False))
        buses[plan.device] = MqttBus(host, port, client_id=plan.device, username=plan.device,
                                     password=_password(settings, plan.device), will=will).connect()
    try:
        sent = publish_plans(buses.__getitem__, plans, settings.mqtt.site, fs, speed=speed, tick=tick)
    finally:
        for bus in buses.values():
            bus.close()
    console.print(f"published {sent} messages to {host}:{port}")


def _write_csv(plan, fs: float, path: Path) -> None:
    import numpy as np

    from bim2rdt.safety import HavError
    from bim2rdt.sim.wearables import plan_signal

    signal = plan_signal(plan, fs)
    t = np.arange(signal.shape[0]) / fs
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(path, np.column_stack([t, signal]), delimiter=",", header="t,ax,ay,az", comments="",
                   fmt=["%.6f", "%.4f", "%.4f", "%.4f"])
    except OSError as error:
        raise HavError(f"cannot write {path}: {error.strerror or error}") from None
    console.print(f"worker 1's samples written to {path}")


@contextmanager
def _progress(total: float, label: str):
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TimeRemainingColumn(), console=console,
                  transient=True) as progress:
        task = progress.add_task(label, total=total)
        yield lambda done: progress.update(task, completed=done)


def bench_hav(
    streams: int = typer.Option(2000, "--streams", min=1, help="Simulated wearable streams (3 axes each)."),
    seconds: int = typer.Option(6, "--seconds", min=1, help="Seconds of samples per stream (timed rounds)."),
    fs: float = typer.Option(5000.0, "--fs", help="Sampling rate, Hz."),
    messages: int = typer.Option(200, "--messages", min=10, help="Messages for the Mosquitto latency run."),
    keep_raw: bool = typer.Option(False, "--keep-raw", help="Keep raw batches in SQLite (7-day retention)."),
    latency: bool = typer.Option(True, "--latency/--no-latency", help="Measure latency through Mosquitto."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of tables."),
) -> None:
    """Streams processed in real time on one core vs the bare sosfilt floor; publish-to-event latency."""
    from bim2rdt.bench.hav import run_latency, run_throughput

    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    with _progress(seconds + 1, f"{streams} streams x {seconds + 1} s") as tick:
        counter = iter(range(1, seconds + 2))
        result = {"throughput": run_throughput(streams, seconds, fs, keep_raw, lambda: tick(next(counter)))}
    if latency:
        with _progress(messages, f"{messages} messages through Mosquitto") as tick:
            counter = iter(range(1, messages + 1))
            result["latency"] = run_latency(messages, tick=lambda: tick(next(counter)))
    throughput = result["throughput"]
    result["targets"] = {"streams_ge_2000": throughput["monitor_streams_realtime"] >= 2000,
                         "within_1_5x_floor": throughput["ratio_to_floor"] <= 1.5}
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
    if "latency" in result:
        lat = result["latency"]
        print_table("Publish-to-event latency through Mosquitto (QoS 1)",
                    ["messages", "p50 ms", "p99 ms", "max ms", "with events", "events p50 ms", "events p99 ms"],
                    [(lat["messages"], lat["p50_ms"], lat["p99_ms"], lat["max_ms"], lat["event_messages"],
                      lat["event_p50_ms"], lat["event_p99_ms"])])
    for name, ok in result["targets"].items():
        console.print(f"{name}: {'[green]PASS[/green]' if ok else '[red]FAIL[/red]'}")
