"""``bim2rdt bench ingest``: reading ROS bags.

- **decode**: frames/s of ``open_source(bag)`` (deserialize, pair colour and depth, TF prior, build the checked
  frame) against bare ``rosbags`` iteration over the same messages (``AnyReader.messages`` + ``deserialize``),
  in the same run; target <= 1.2x the bare read's time;
- **verify**: seconds per frame of the whole ``verify`` chain on a bag and its IFC (``--bag``/``--ifc``, e.g.
  a ``demo --record`` run);
- **memory**: peak RSS of a subprocess streaming a 10-station and a 40-station bag (target: flat, <= 1.2x).

Without ``--bag`` the bags are written here in the demo recorder's format (640x480 rgb8 + 16UC1, CameraInfo,
/tf, /imu; ``FRAMES_PER_STATION`` frames a station).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

FRAMES_PER_STATION = 2
DECODE_TARGET, MEMORY_TARGET = 1.2, 1.2


def synthetic_bag(path: Path, stations: int, seed: int = 0) -> Path:
    """A bag like ``demo --record``'s: ``stations`` x FRAMES_PER_STATION RealSense frames walking along x."""
    from bim2rdt.perception.camera import Intrinsics
    from bim2rdt.sources.bag_writer import COLOUR, DEPTH, IMU, IMU_FRAME, INFO, OPTICAL, BagWriter, bag_folder

    rng = np.random.default_rng(seed)
    intrinsics = Intrinsics()
    rgb = rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)
    depth = (1.0 + 3.0 * rng.random((480, 640))).astype(np.float32)
    with BagWriter(path) as bag:
        bag.write_tf([("camera_link", OPTICAL, np.eye(4)), ("camera_link", IMU_FRAME, np.eye(4))], 0.0, static=True)
        for k in range(stations * FRAMES_PER_STATION):
            t = 1.0 + k
            T = np.eye(4)
            T[0, 3] = 0.5 * k
            bag.write_tf([("map", "odom", np.eye(4)), ("odom", "base_link", T),
                          ("base_link", "camera_link", np.eye(4))], t)
            bag.write_camera_info(INFO, OPTICAL, t, intrinsics)
            bag.write_colour(COLOUR, OPTICAL, t, rgb)
            bag.write_depth(DEPTH, OPTICAL, t, depth)
            bag.write_imu(IMU, IMU_FRAME, t, (0.0, -1.0, 0.0))
    return bag_folder(path)


def bare_read(bag: Path, topics) -> tuple[int, float, float]:
    """(messages, wall seconds, CPU seconds): rosbags alone over ``topics``, every message deserialized."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    start, cpu = time.perf_counter(), time.process_time()
    count = 0
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        wanted = [c for c in reader.connections if c.topic in topics]
        for connection, _, raw in reader.messages(wanted):
            reader.deserialize(raw, connection.msgtype)
            count += 1
    return count, time.perf_counter() - start, time.process_time() - cpu


def source_read(bag: Path) -> tuple[int, float, float, set]:
    """(frames, wall seconds, CPU seconds, topics read) of ``open_source(bag)``."""
    from bim2rdt.sources import open_source

    start, cpu = time.perf_counter(), time.process_time()
    source = open_source(bag)
    frames = sum(1 for _ in source)
    topics = {t for t in source.topics.as_dict().values()} | {"/tf", "/tf_static"}
    return frames, time.perf_counter() - start, time.process_time() - cpu, topics


def decode_row(bag: Path, repeats: int = 7) -> dict:
    """The best of ``repeats`` for both readers, alternated: wall time (``ratio``, the target's) and CPU time
    (``cpu_ratio``: what the process itself spent, steadier when other work shares the cores)."""
    ours, bare, ours_cpu, bare_cpu = [], [], [], []
    frames, topics = 0, set()
    for _ in range(repeats):
        frames, seconds, cpu, topics = source_read(bag)
        ours.append(seconds)
        ours_cpu.append(cpu)
        _, seconds, cpu = bare_read(bag, topics)
        bare.append(seconds)
        bare_cpu.append(cpu)
    return {"frames": frames, "ours_fps": frames / min(ours), "bare_fps": frames / min(bare),
            "ratio": min(ours) / min(bare), "cpu_ratio": min(ours_cpu) / min(bare_cpu), "target": DECODE_TARGET}


def peak_rss_mb(bag: Path) -> float:
    """Peak RSS (MB) of a fresh interpreter streaming every frame of ``bag``."""
    code = ("import resource, sys\nfrom bim2rdt.sources import open_source\n"
            "for _ in open_source(sys.argv[1]): pass\n"
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)")
    done = subprocess.run([sys.executable, "-c", code, str(bag)], capture_output=True, text=True, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def memory_row(folder: Path, small: int = 10, large: int = 40) -> dict:
    rss = {}
    for stations in (small, large):
        bag = synthetic_bag(folder / f"stations{stations}.mcap", stations)
        rss[stations] = peak_rss_mb(bag)
    return {"stations": [small, large], "peak_rss_mb": [round(rss[small], 1), round(rss[large], 1)],
            "ratio": rss[large] / rss[small], "target": MEMORY_TARGET}


def verify_row(bag: Path, ifc: Path, out: Path) -> dict:
    """Seconds per frame of the verify chain (localize, depth check, planned, new) on ``bag``."""
    from bim2rdt.bim import load_ifc
    from bim2rdt.sources import open_source
    from bim2rdt.verify import VerifyConfig, verify_frames

    model = load_ifc(ifc)
    start = time.perf_counter()
    result = verify_frames(open_source(bag), model, None, VerifyConfig())
    seconds = time.perf_counter() - start
    frames = len(result.frames)
    return {"frames": frames, "localized": sum(f.accepted for f in result.frames),
            "seconds_per_frame": seconds / frames}


def run_bench(folder: Path, bag: Path | None = None, ifc: Path | None = None, stations: int = 10) -> dict:
    folder.mkdir(parents=True, exist_ok=True)
    decode_bag = bag if bag is not None else synthetic_bag(folder / "decode.mcap", stations)
    result = {"bag": str(decode_bag), "decode": decode_row(decode_bag), "memory": memory_row(folder)}
    if bag is not None and ifc is not None:
        result["verify"] = verify_row(bag, ifc, folder)
    return result


def as_json(result: dict) -> str:
    return json.dumps(result, indent=2)
