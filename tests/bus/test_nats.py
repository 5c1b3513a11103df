"""The NATS path's broker: nats-server with JetStream and MQTT, per-device permissions pinned to the site and the
device's partition, and the partitions the server's subject mapping gives."""

from __future__ import annotations

import pytest

from bim2rdt.bus.partitions import partition_of
from bim2rdt.bus.topics import accel_topic, status_topic
from tests.bus.conftest import SITE
from tests.bus.nats_helpers import received, wearable


def test_each_device_lands_in_the_partition_computed_from_its_site_and_id(nats_server):
    devices = sorted(nats_server.layout.devices)
    for device in devices:
        bus = wearable(nats_server, device)
        bus.publish(accel_topic(SITE, device), device.encode(), qos=1, wait=True)
        bus.close()
    by_partition = received(nats_server, SITE)
    seen = {payload.decode(): k for k, messages in by_partition.items() for _, payload in messages}
    assert seen == {device: partition_of(SITE, device, 3) for device in devices}
    assert len(set(seen.values())) > 1  # the six devices do spread over the partitions


def test_a_device_publishing_as_another_device_or_another_site_is_refused_by_the_server(nats_server):
    w1 = wearable(nats_server, "w1")
    for topic in (accel_topic(SITE, "w2"), status_topic(SITE, "w2"), accel_topic("other", "w1"),
                  f"hav/{(partition_of(SITE, 'w1', 3) + 1) % 3}/site/{SITE}/wearable/w1/accel",
                  f"site/{SITE}/safety/events"):
        w1.publish(topic, b"forged", qos=1, wait=True)
    w1.publish(accel_topic(SITE, "w1"), b"own", qos=1, wait=True)
    w1.close()
    messages = [m for got in received(nats_server, SITE).values() for m in got]
    assert messages == [(accel_topic(SITE, "w1"), b"own")]
    assert len(nats_server.violations()) == 5


def test_a_wrong_password_or_an_unknown_device_cannot_connect(nats_server):
    from bim2rdt.bus.mqtt import BusError

    with pytest.raises(BusError):
        wearable(nats_server, "w1", password="w2-pw")
    with pytest.raises(BusError):
        wearable(nats_server, "w9", password="anything")


def test_hav_broker_nats_refuses_the_shipped_secrets_outside_dev(tmp_path):
    from tests.bus.test_broker import run_cli

    result = run_cli("hav", "broker", "--nats", "--duration", "1", env={"BIM2RDT_DATA_DIR": str(tmp_path)})
    assert result.returncode == 1 and "BIM2RDT_MQTT__DEVICE_SECRET" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_hav_broker_nats_with_dev_serves_nats_and_mqtt_then_leaves_no_folder():
    import glob
    import tempfile

    from bim2rdt.bus.broker import free_port
    from tests.bus.test_broker import run_cli

    before = set(glob.glob(f"{tempfile.gettempdir()}/bim2rdt-nats-*"))
    port, mqtt_port = free_port(), free_port()
    result = run_cli("hav", "broker", "--nats", "--dev", "--port", str(port), "--mqtt-port", str(mqtt_port),
                     "--partitions", "4", "--duration", "1")
    assert result.returncode == 0, result.stderr
    assert f"nats-server on nats://127.0.0.1:{port}" in result.stdout and f"127.0.0.1:{mqtt_port}" in result.stdout
    assert set(glob.glob(f"{tempfile.gettempdir()}/bim2rdt-nats-*")) == before


@pytest.mark.parametrize("partition", ["2/2", "x/3"])
def test_hav_listen_nats_refuses_a_partition_that_is_not_k_of_n_in_one_line(partition, tmp_path):
    from tests.bus.test_broker import run_cli

    result = run_cli("hav", "listen", "--nats", "nats://127.0.0.1:1", "--partition", partition, "--dev",
                     env={"BIM2RDT_DATA_DIR": str(tmp_path)})
    assert result.returncode == 1 and "--partition wants K/N" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_the_rendered_config_pins_each_device_to_its_partition_subjects_and_is_valid_for_nats_server(tmp_path):
    import subprocess

    from bim2rdt.bus.nats_broker import NATS_SERVER, NatsLayout, render_nats_config

    layout = NatsLayout("s", {"w1": "a", "w2": "b"}, {"monitor": "m"}, partitions=5, store_dir=str(tmp_path))
    text = render_nats_config(layout)
    for device in ("w1", "w2"):
        k = partition_of("s", device, 5)
        subjects = [f"hav.{k}.site.s.wearable.{device}.{leaf}" for leaf in ("accel", "status", "summary")]
        assert '"allow": ["' + '", "'.join(subjects) + '"]' in text
    (tmp_path / "n.conf").write_text(text)
    check = subprocess.run([NATS_SERVER, "-t", "-c", str(tmp_path / "n.conf")], capture_output=True, text=True)
    assert check.returncode == 0, check.stderr + check.stdout


def test_the_shipped_production_configs_are_rendered_by_the_code_hold_no_secret_and_nats_server_accepts_them():
    import os
    import subprocess
    from pathlib import Path

    from bim2rdt.bus.nats_broker import NATS_SERVER, NatsLayout, password_variable, render_nats_config

    folder = Path(__file__).resolve().parents[2] / "docs" / "deploy" / "nats"
    devices = {f"w{i}": "" for i in range(1, 4)}
    routes = [f"nats-route://nats-{i}.site.internal:6222" for i in range(1, 4)]
    for i in range(1, 4):
        layout = NatsLayout("demo", devices, {"monitor": ""}, partitions=3, port=4222, mqtt_port=1883,
                            host="0.0.0.0", store_dir="/var/lib/nats", max_file_store=200 * 2**30,
                            server_name=f"nats-{i}", cluster={"name": "bim2rdt-hav", "listen": "0.0.0.0:6222",
                                                              "routes": [r for r in routes if f"nats-{i}." not in r]})
        assert (folder / f"nats-{i}.conf").read_text() == render_nats_config(layout, passwords_from_env=True)
    env = {**os.environ, **{password_variable(user): "x" for user in ["monitor", *devices]}}
    for path in sorted(folder.glob("*.conf")):
        assert '"password": "' not in path.read_text()  # every password is a variable of the server's environment
        check = subprocess.run([NATS_SERVER, "-t", "-c", str(path)], capture_output=True, text=True, env=env)
        assert check.returncode == 0, check.stderr + check.stdout
        unset = subprocess.run([NATS_SERVER, "-t", "-c", str(path)], capture_output=True, text=True,
                               env={k: v for k, v in os.environ.items() if not k.startswith("BIM2RDT_NATS_")})
        assert unset.returncode != 0 and "BIM2RDT_NATS_PASSWORD_MONITOR" in unset.stderr + unset.stdout
