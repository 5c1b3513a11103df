"""What the HAV commands (`hav listen`, `sim wearables`) print and write: event lines, the day's table, the twin."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from bim2rdt.cli.common import console, print_table


def event_line(event) -> None:
    """One line per event: time (UTC, device clock), pseudonym, tool, what happened, running figures."""
    data = event.data
    stamp = time.strftime("%H:%M:%S", time.gmtime(event.time))
    figures = (f"a_hv {data.get('a_hv') or 0:4.1f} A(8) {data.get('day_a8') or 0:4.2f} "
               f"{data.get('day_points') or 0:3.0f}pt")
    extra = f" EAV in {data['seconds_to_eav'] / 60:.0f} min" if data.get("seconds_to_eav") else ""
    console.print(f"{stamp} {event.subject[:10]} {data.get('tool', ''):12.12s} {event.kind[4:]:17s} {figures}{extra}",
                  soft_wrap=True)


def print_summary(queries, devices) -> None:
    """The latest day of each device's worker (``queries``: a monitor's read side): A(8), points, trigger minutes,
    risk."""
    rows = []
    for device in devices:
        session = queries.session(device)
        if session is not None:
            days = queries.days_of(session.subject)
            day = queries.day(session.subject, days[-1] if days else None)
            rows.append((session.subject, device, day.a8, day.points, day.seconds / 60.0, day.risk))
    print_table("Daily exposure", ["worker (pseudonym)", "device", "A(8) m/s²", "points", "trigger min", "risk"], rows)


DEV_HELP = "Allow the shipped default secrets (a local trial only; never on a site)."


def require_own_secrets(settings, dev: bool, *needs: str) -> None:
    """Refuse the shipped default secrets outside ``--dev``, in one line saying how to set them. ``needs``:
    'site' (worker pseudonyms), 'devices' (dev-provisioned device passwords), 'monitor' (the monitor's own
    broker password)."""
    from bim2rdt.bus.credentials import CredentialError

    shipped = shipped_secrets(settings, *needs)
    if shipped and not dev:
        how = "to a secret of your own (e.g. $(openssl rand -hex 32)), or pass --dev for a local trial"
        raise CredentialError(f"{shipped[0][1]}; set it {how}")


def shipped_secrets(settings, *needs: str) -> list[tuple[str, str]]:
    """(variable, why it matters) of each secret among ``needs`` (see ``require_own_secrets``) that is still the
    shipped default."""
    from bim2rdt.config import HavSettings, MqttSettings

    found = []
    if "site" in needs and settings.hav.site_secret == HavSettings.model_fields["site_secret"].default:
        found.append(("BIM2RDT_HAV__SITE_SECRET", "BIM2RDT_HAV__SITE_SECRET is the shipped default: anyone could "
                      "derive every worker's pseudonym"))
    if "devices" in needs and settings.mqtt.device_secret == MqttSettings.model_fields["device_secret"].default:
        found.append(("BIM2RDT_MQTT__DEVICE_SECRET", "BIM2RDT_MQTT__DEVICE_SECRET is the shipped default: anyone "
                      "could derive every device's broker password"))
    if "monitor" in needs and not settings.mqtt.password:
        found.append(("BIM2RDT_MQTT__PASSWORD", "the monitor has no broker password of its own: "
                      "BIM2RDT_MQTT__PASSWORD is unset"))
    return found


def dev_banner(settings, *needs: str) -> str | None:
    """The line ``--dev`` prints when it lets shipped secrets through (None when none is in use)."""
    shipped = [variable for variable, _ in shipped_secrets(settings, *needs)]
    if not shipped:
        return None
    return (f"DEV MODE (--dev): shipped default secrets in use ({', '.join(shipped)}); pseudonyms and passwords "
            "can be derived by anyone: a local trial only, never on a site")


def check_twin_target(ifc: Path | None, out: Path | None) -> Path | None:
    """Where the twin goes (``out``, default <ifc>_hav.ifc), checked before a run that ends by writing it: not a
    folder, in a folder that takes a new file, no symlink, device node or FIFO (which the atomic write at the end
    refuses to replace). HavError or WriteError in one line otherwise (so no run is lost)."""
    import tempfile

    from bim2rdt.atomic import check_writable_file
    from bim2rdt.safety import HavError

    if ifc is None:
        if out is not None:
            raise HavError("--out names where the twin goes: give the site IFC with --ifc too")
        return None
    target = out if out is not None else ifc.with_name(ifc.stem + "_hav.ifc")
    if str(target) in ("", ".") or target.is_dir():
        raise HavError(f"--out {str(target)!r} is a folder, not an IFC file to write")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=target.parent).close()
    except OSError as error:
        raise HavError(f"cannot write the twin into {target.parent}: {error.strerror or error}") from None
    return check_writable_file(target)


def print_malformed(queries) -> None:
    """Refused messages per device (what a device sending garbage looks like), if there were any."""
    rows = [(device, m.count, m.last_reason) for device, m in queries.malformed_messages().items()]
    if rows:
        print_table("Refused messages (dead-lettered, never counted as exposure)",
                    ["device", "messages", "last reason"], rows)


def open_monitor(settings, sinks=(), data_dir: Path | None = None, **overrides):
    """The HAV monitor as configured: state under ``data_dir`` (default ``settings.data_dir/hav``), the
    ``settings.hav`` section (site = ``settings.mqtt.site``) with ``overrides``."""
    from bim2rdt.config import usable_folder
    from bim2rdt.safety import HavMonitor

    folder = data_dir if data_dir is not None else usable_folder(settings.data_dir / "hav", "BIM2RDT_DATA_DIR")
    return HavMonitor(folder, settings.hav.site_secret, list(sinks), settings.hav.monitor_config(**overrides))


@contextmanager
def twin_sink(ifc: Path | None, out: Path | None) -> Iterator:
    """An IfcSink writing into ``out`` (default <ifc>_hav.ifc) from ``ifc``; None when no IFC is asked for. The
    target is checked before the run (:func:`check_twin_target`), the twin written after it."""
    target = check_twin_target(ifc, out)
    if target is None:
        yield None
        return
    from bim2rdt.bim import TwinWriter, load_ifc
    from bim2rdt.safety.ifc_sink import IfcSink

    model = load_ifc(ifc, geometry=False)
    writer = TwinWriter(model)
    yield IfcSink(writer, model)
    writer.save(target)
    console.print(f"twin written to {target}")


@contextmanager
def progress(total: float, label: str) -> Iterator:
    """A transient rich progress bar; yields ``update(done)``, which redraws it. No refresh thread: the benchmarks
    time code between updates, and a thread waking 10 times a second on the same core took the GIL from it
    (`bench hav` read the monitor 1.51-1.54x the sosfilt floor through the CLI, 1.43-1.47x in a bare process)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TimeRemainingColumn(), console=console,
                  transient=True, auto_refresh=False) as bar:
        task = bar.add_task(label, total=total)
        bar.refresh()
        yield lambda done: bar.update(task, completed=done, refresh=True)


def _password(settings, user: str) -> str:
    from bim2rdt.bus.credentials import user_password

    return user_password(user, settings.mqtt.username, settings.mqtt.password, settings.mqtt.device_secret)


def watch(monitor, bus, duration: float, max_offline: float, period_s: float = 1.0,
          stop: threading.Event | None = None) -> None:
    """Tick the monitor until ``duration`` (0: until stopped), ``stop`` is set (a signal) or Ctrl-C; BusError
    (exit 1) when paho's network thread died, the broker has been away ``max_offline`` seconds, or the monitor
    failed (its store)."""
    from bim2rdt.bus.mqtt import BusError

    deadline = time.monotonic() + duration if duration else float("inf")
    offline_since, stop = None, stop or threading.Event()
    try:
        while time.monotonic() < deadline and not stop.wait(min(period_s, max(deadline - time.monotonic(), 0.0))):
            monitor.tick()
            if monitor.failure:
                raise BusError(f"the monitor stopped: {monitor.failure}")
            if not bus.alive:
                raise BusError("the MQTT network thread died; exiting so that a supervisor restarts the monitor "
                               "(unacknowledged messages wait at the broker)")
            offline_since = None if bus.connected else offline_since or time.monotonic()
            if offline_since is not None and time.monotonic() - offline_since >= max_offline:
                raise BusError(f"no broker for {max_offline:g} s; exiting so that a supervisor restarts the monitor")
    except KeyboardInterrupt:
        pass


def _leave(monitor, bus) -> None:
    """Commit (and acknowledge) what waits, leave the broker, show the day and the refused messages."""
    if not monitor.failure:
        monitor.flush()
    bus.close()
    print_summary(monitor.queries, monitor.queries.devices())
    print_malformed(monitor.queries)
    monitor.close()
