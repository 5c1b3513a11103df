"""`bim2rdt serve` (the dashboard and API), `bim2rdt token` (a new bearer token and its settings entry) and
`bim2rdt bench server` (SSE delivery under load)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from bim2rdt.cli.common import console, print_json, print_table, writable_folder
from bim2rdt.cli.hav_output import DEV_HELP, dev_banner, require_own_secrets


DEMO_OUT = Path("out/demo")
"""The embedded demo's folder (``make demo`` writes it)."""


def register(app: typer.Typer, bench_app: typer.Typer) -> None:
    app.command("serve")(serve_command)
    app.command("token")(token_command)
    bench_app.command("server")(bench_server_command)


def serve_command(
    twin_url: str | None = typer.Option(None, "--twin", help="Serve this twin: sqlite:///path/twin.db or "
                                        "postgresql+psycopg://user:password@host/db (needs --ifc). Default: the "
                                        "embedded demo (its site day runs first if --out lacks it)."),
    ifc: Path | None = typer.Option(None, "--ifc", help="The BIM the --twin is kept over."),
    mqtt: str | None = typer.Option(None, "--mqtt", help="Take real wearables from this broker, HOST:PORT "
                                    "(default: simulated wearables for the demo, none for --twin)."),
    nats: str | None = typer.Option(None, "--nats", help="The NATS path (nats://HOST:PORT): show every partition's "
                                    "workers from the monitors' shared store (BIM2RDT_HAV__STORE_URL)."),
    host: str | None = typer.Option(None, "--host", help="Address to bind (default BIM2RDT_SERVER__HOST, "
                                    "127.0.0.1: this machine only)."),
    port: int | None = typer.Option(None, "--port", min=0, max=65535, help="Port (default BIM2RDT_SERVER__PORT, "
                                    "8000; 0 = any free port)."),
    out: Path | None = typer.Option(None, "--out", help="The embedded demo's folder (default out/demo); not used, "
                                    "nor created, with --twin."),
    speed: float = typer.Option(20.0, "--speed", min=0.1, max=1000.0, help="Device seconds per wall second of "
                                "the demo's simulated wearables."),
    all_roles: bool = typer.Option(False, "--all-roles", help="Also generate and print a safety and an admin "
                                   "token (to try the roles on the demo)."),
    duration: float = typer.Option(0.0, "--duration", min=0.0, help="Stop after this many seconds (0: Ctrl-C)."),
    dev: bool = typer.Option(False, "--dev", help="With --mqtt: " + DEV_HELP),
) -> None:
    """Serve the dashboard and its API: the live twin and HAV warnings in the browser. Prints the URL and the
    viewer token it generated (tokens from the settings work too). With --mqtt (real workers) the shipped default
    secrets are refused unless --dev."""
    from bim2rdt.config import get_settings

    if twin_url and ifc is None:
        raise typer.BadParameter("--twin needs --ifc: the BIM the twin is kept over", param_hint="--ifc")
    address = _host_port(mqtt) if mqtt is not None else None
    settings = get_settings()
    if address is not None:  # real wearables, real people: the pseudonym key and the monitor's password are ours
        require_own_secrets(settings, dev, "site", "monitor")
        if dev and (banner := dev_banner(settings, "site", "monitor")):
            console.print(f"[bold red]{banner}[/]")
    config = settings.server.model_copy(update={k: v for k, v in (("host", host), ("port", port)) if v is not None})
    from bim2rdt.demo.serve import LiveServe

    status = console.status("starting the server")
    status.start()
    if nats is not None and mqtt is not None:
        raise typer.BadParameter("give --mqtt or --nats, not both", param_hint="--nats")
    if nats is not None and not settings.hav.store_url:
        from bim2rdt.safety import HavError

        raise HavError("serve --nats reads the partitions' shared store: set BIM2RDT_HAV__STORE_URL to the URL "
                       "their monitors use")
    out = writable_folder(out or DEMO_OUT) if twin_url is None else (out or DEMO_OUT)
    live = LiveServe(settings, config, out, twin_url, ifc, address, speed, all_roles,
                     progress=lambda stage: status.update(stage), nats=nats)
    try:
        live.start()
    finally:
        status.stop()
    with live:
        console.print(f"bim2rdt dashboard: {live.url}/#token={live.tokens['viewer']}")
        console.print(f"viewer token: {live.tokens['viewer']}")
        for role in ("safety", "admin"):
            if role in live.tokens:
                console.print(f"{role} token: {live.tokens[role]}")
        console.print(f"API: {live.url}/docs (OpenAPI at {live.url}/openapi.json); {live.source}. Ctrl-C stops.")
        live.wait(duration)


def token_command(
    role: str = typer.Option("viewer", "--role", help="viewer, safety or admin."),
    name: str = typer.Option(..., "--name", help="Who holds it (written into the audit log)."),
) -> None:
    """Make a new bearer token: prints the token (give it to its holder) and the settings entry that stores only
    its SHA-256 digest (add it to BIM2RDT_SERVER__TOKENS, a JSON list)."""
    from bim2rdt.server import ROLES, TokenEntry, new_token, token_digest

    if role not in ROLES:
        raise typer.BadParameter(f"role must be one of {', '.join(ROLES)}", param_hint="--role")
    from pydantic import ValidationError

    token = new_token()
    try:
        entry = TokenEntry(name=name, role=role, sha256=token_digest(token))
    except ValidationError:
        raise typer.BadParameter(f"{name[:70]!r}: a holder's name is 1 to 64 letters, digits, spaces or _ . @ -",
                                 param_hint="--name") from None
    console.print(f"token: {token}")
    console.print(f"settings entry: {json.dumps(entry.model_dump())}")


def bench_server_command(
    clients: int = typer.Option(50, "--clients", min=1, max=500, help="SSE clients on 127.0.0.1."),
    seconds: float = typer.Option(30.0, "--seconds", min=1.0, max=600.0, help="How long they listen."),
    rate: float = typer.Option(20.0, "--rate", min=0.1, max=1000.0, help="Monitor events published per second."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON document instead of a table."),
    out: Path | None = typer.Option(None, "--out", help="Also write the results JSON here."),
) -> None:
    """Live-stream delivery under load: ``--clients`` SSE clients (a separate process) on a real server for
    ``--seconds`` while events reach it through the HAV monitor's sink; counts lost events and reports delivery
    latency percentiles against the 1 s target, and the same events' latency with one client as the floor."""
    from bim2rdt.bench.server import run_server_bench

    result = run_server_bench(clients=clients, seconds=seconds, rate=rate)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result, indent=2))
    if as_json:
        print_json(result)
        return
    rows = [(r["clients"], r["events"], r["delivered"], r["lost"], r["p50_ms"], r["p99_ms"], r["max_ms"])
            for r in result["runs"]]
    print_table("SSE delivery: events published through the monitor's sink -> every client",
                ("clients", "events", "deliveries", "lost", "p50 ms", "p99 ms", "max ms"), rows)
    for target in result["targets"]:
        console.print(f"{'PASS' if target['passed'] else 'FAIL'}: {target['name']} ({target['value']})")


def _host_port(text: str) -> tuple[str, int]:
    from bim2rdt.bus.credentials import CredentialError, parse_address

    try:
        return parse_address(text)
    except CredentialError as error:
        raise typer.BadParameter(str(error), param_hint="--mqtt") from None
