"""Simulator commands: `bim2rdt sim wearables` (other simulators add theirs to the same `sim` group)."""

from __future__ import annotations

from enum import Enum
from pathlib import Path

import typer

from bim2rdt.cli.common import console
from bim2rdt.cli.hav_output import (DEV_HELP, check_twin_target, event_line, open_monitor, print_summary, progress,
                                    require_own_secrets, twin_sink)

class DeviceClock(str, Enum):
    """What the simulated devices stamp their samples with."""

    wall = "wall"
    boot = "boot"


sim_app = typer.Typer(help="Simulators: wearables on the site bus.", no_args_is_help=True)


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.add_typer(sim_app, name="sim")


@sim_app.command("wearables")
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
    device_clock: DeviceClock = typer.Option(DeviceClock.wall, "--device-clock", help="wall: devices stamp UTC time; boot: seconds since power-up (no wall "
                                             "time; the monitor places them on its receive clock)."),
    reboot_after: float = typer.Option(0.0, "--reboot-after", min=0.0, help="Minutes into its plan at which each "
                                       "device restarts (last will, 10 s off, new boot id, seq from 0); 0: never."),
    summaries: bool = typer.Option(False, "--summaries", help="The devices weigh their own samples (ISO 5349-1 Wh) "
                                   "and send a 1 Hz summary (~200 B) instead of raw batches."),
    mqtt3: bool = typer.Option(False, "--mqtt3", help="Speak MQTT 3.1.1 (nats-server's MQTT listener: "
                               "`hav broker --nats`) instead of MQTT 5."),
    dev: bool = typer.Option(False, "--dev", help=DEV_HELP),
) -> None:
    """Publish simulated hammer drill / grinder / breaker sessions (realistic spectra and magnitudes)."""
    from dataclasses import replace

    from bim2rdt.config import get_settings
    from bim2rdt.sim.wearables import default_plans, plan_seconds, with_reboot

    require_own_secrets(get_settings(), dev, "devices" if mqtt else "site")
    if mqtt is not None and ifc is not None:
        raise typer.BadParameter("--ifc is for the in-process mode: with --mqtt, `hav listen --ifc` writes the twin")
    check_twin_target(ifc, out)  # before minutes of simulation, not after
    plans = [replace(plan, clock=device_clock.value) for plan in default_plans(workers, minutes, zone)]
    if reboot_after > 0:
        plans = [with_reboot(plan, reboot_after * 60.0) for plan in plans]
    if csv is not None:
        _write_csv(plans[0], fs, csv)
    total = max(plan_seconds(p) for p in plans)
    with progress(total, f"{workers} wearables, {total / 60:.0f} min each") as tick:
        if mqtt is None:
            _in_process(plans, fs, speed, tick, ifc, out, summaries)
        else:
            _over_mqtt(plans, fs, speed, tick, mqtt, summaries, 3 if mqtt3 else 5)


def _in_process(plans, fs: float, speed: float, tick, ifc: Path | None, out: Path | None,
                summaries: bool = False) -> None:
    from bim2rdt.config import get_settings
    from bim2rdt.safety import CallbackSink
    from bim2rdt.sim.wearables import run_in_process

    settings = get_settings()
    with twin_sink(ifc, out) as ifc_sink:
        monitor = open_monitor(settings, [CallbackSink(event_line)] + ([ifc_sink] if ifc_sink else []))
        run_in_process(plans, monitor, settings.mqtt.site, fs, speed, tick, summaries=summaries)
        print_summary(monitor.queries, [p.device for p in plans])
        monitor.close()


def _over_mqtt(plans, fs: float, speed: float, tick, mqtt: str, summaries: bool = False,
               mqtt_version: int = 5) -> None:
    from bim2rdt.bus.credentials import device_password, parse_address
    from bim2rdt.config import get_settings
    from bim2rdt.sim.wearables import run_over_mqtt

    settings = get_settings()
    host, port = parse_address(mqtt)
    sent = run_over_mqtt(plans, settings.mqtt.site, fs, host, port,
                         lambda device: device_password(settings.mqtt.device_secret, device), speed, tick,
                         mqtt_version=mqtt_version, summaries=summaries)
    console.print(f"published {sent} messages to {host}:{port}")


def _write_csv(plan, fs: float, path: Path) -> None:
    from bim2rdt.safety.recording import write_accel_csv
    from bim2rdt.sim.wearables import plan_signal

    write_accel_csv(path, plan_signal(plan, fs), fs)
    console.print(f"worker 1's samples written to {path}")
