"""Shared pieces of the server tests: a twin with a day's records, a HAV monitor fed synthetic vibration, tokens
for each role, and the app served over real HTTP."""

from __future__ import annotations

import time

import numpy as np

from bim2rdt.bus.payloads import AccelBatch
from bim2rdt.perception.observation import Observation
from bim2rdt.server import ServerConfig, TokenEntry, new_token, token_digest
from bim2rdt.sim.meshes import mesh_for_family

FS = 800.0
"""Hz: enough for the Wh weighting's lower bands, cheap to weigh."""
SITE_SECRET = "test-site-secret"
T_TWIN = 1_780_000_000.0
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--no-first-run"]


def family_mesh(family: str):
    """The simulator's mesh of a family; None (the twin's stand-in box) for one it lacks, as `serve` does."""
    from bim2rdt.sim.meshes import UnknownFamilyError

    try:
        mesh = mesh_for_family(family)
    except UnknownFamilyError:
        return None
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def config_with_tokens(tmp_path, **overrides) -> tuple[ServerConfig, dict[str, str]]:
    """A ServerConfig holding one token per role; returns it and {role: token}."""
    tokens = {role: new_token() for role in ("viewer", "safety", "admin")}
    entries = [TokenEntry(name=f"{role}-user", role=role, sha256=token_digest(token)) for role, token in tokens.items()]
    settings = {"exposure_period_s": 0.2, "twin_poll_s": 0.1, "audit_log": tmp_path / "audit.jsonl", **overrides}
    return ServerConfig(tokens=entries, **settings), tokens


def moved(placement: np.ndarray, dx: float = 0.0, dy: float = 0.0) -> np.ndarray:
    pose = placement.copy()
    pose[0, 3] += dx
    pose[1, 3] += dy
    return pose


def record_day(twin, model) -> dict[str, str]:
    """Records of a short mission: one proxy as planned, one moved 0.4 m, one seen missing and an unplanned drum,
    each with the station camera it was seen from. Returns {role in the test: GlobalId}."""
    proxies = [el for el in model.elements if el.ifc_class == "IfcBuildingElementProxy"]
    planned, shifted, gone = proxies[0], proxies[1], proxies[2]
    camera = np.eye(4)
    for station, (element, pose) in enumerate([(planned, planned.placement),
                                               (shifted, moved(shifted.placement, 0.4))]):
        camera[:2, 3] = (1.0 + 2 * station, 1.0)
        twin.record(Observation(element.family, element.global_id, pose, 0.004, 0.9, 200, station=station,
                                frames=(station,)), T_TWIN + 30 * station, camera=camera.copy())
    camera[:2, 3] = (5.0, 2.0)
    twin.mark_missing(gone.global_id, T_TWIN + 60, station=2, camera=camera.copy())
    drum = np.eye(4)
    drum[:3, 3] = (12.0, 9.0, 0.0)
    new = twin.record(Observation("Steel_Drum_55gal", None, drum, 0.01, 0.9, 120, station=3), T_TWIN + 90,
                      camera=camera.copy())
    return {"planned": planned.global_id, "moved": shifted.global_id, "missing": gone.global_id,
            "new": new.global_id}


def vibration(device: str, seconds: float, a_hv: float, start: float, seq0: int = 0,
              batch_s: float = 0.5) -> list[AccelBatch]:
    """Tri-axial 12.5 Hz vibration (inside the Wh plateau, weighting ~1) of about ``a_hv`` m/s^2 total value,
    as batches of ``batch_s`` seconds from device time ``start``."""
    n = int(round(batch_s * FS))
    amplitude = a_hv / np.sqrt(3) * np.sqrt(2)
    out = []
    for k in range(int(round(seconds / batch_s))):
        t = start + k * batch_s + np.arange(n) / FS
        phase = 2 * np.pi * 12.5 * t
        xyz = amplitude * np.stack([np.sin(phase), np.sin(phase + 2.1), np.sin(phase + 4.2)], axis=1)
        out.append(AccelBatch(device, seq0 + k, float(t[0]), FS, xyz.astype(np.float32), 200.0, time.time()))
    return out


def feed(monitor, batches, chunk: int = 40) -> None:
    for i in range(0, len(batches), chunk):
        monitor.ingest_many(batches[i:i + chunk])


def auth(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def today_since(seconds_back: float, needed: float) -> float:
    """``time.time() - seconds_back``, but not before today's UTC midnight: A(8) is a daily exposure, and samples
    fed from before midnight count for yesterday (a test run at 00:30 UTC saw a worker 'an hour into the day'
    at A(8) 0). Waits until ``needed`` seconds of today have passed, so samples fed over that span from the
    returned start are not in the future."""
    now = time.time()
    midnight = now - now % 86400.0
    if now - midnight < needed:
        time.sleep(needed - (now - midnight) + 0.5)
        now = time.time()
    return max(now - seconds_back, midnight)
