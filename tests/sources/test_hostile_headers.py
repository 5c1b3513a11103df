"""Small files whose headers lie (issue 36, items 2 and 3): each reader checks what its header declares against the
file's size and the memory cap, and refuses in one line, fast, without a big allocation.

The hostile files are read in a child process with its address space capped at 3 GB and a time limit: the readers
of main hung on them (laspy's VLR list growing 45 MB/s) or took 6 GB, which must not happen to the machine
running the tests."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from bim2rdt.sources import SourceError, SourcesConfig, memory_cap, read_cloud

BOXED = textwrap.dedent("""
    import json, resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))
    from bim2rdt.sources import SourceError, read_cloud
    results = {}
    for path in sys.argv[1:]:
        try:
            read_cloud(path)
            results[path] = "read"
        except SourceError as error:
            results[path] = str(error)
        except BaseException as error:
            results[path] = f"{type(error).__name__} (not a SourceError)"
    print(json.dumps(results))
""")


def _read_boxed(paths, timeout=120.0) -> dict:
    """{path: the one-line SourceError, or what else happened} of read_cloud on each, in a capped child."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", BOXED, *map(str, paths)], capture_output=True, text=True,
                          timeout=timeout, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.splitlines()[-1])


def _las_header(version=(1, 2), header_size=227, offset=227, vlrs=0, point_format=0, record_length=20,
                count=0, count64=0) -> bytes:
    head = bytearray(375 if version[1] >= 4 else 227)
    head[:4] = b"LASF"
    head[24:26] = bytes(version)
    struct.pack_into("<HIIBHI", head, 94, header_size, offset, vlrs, point_format, record_length, count)
    struct.pack_into("<3d", head, 131, 0.001, 0.001, 0.001)
    if version[1] >= 4:
        struct.pack_into("<QIQ", head, 235, 0, 0, count64)
    return bytes(head)


HOSTILE = {
    "vlrs.las": (_las_header(vlrs=0xFFFFFFFF), "declares 4294967295 VLRs"),
    "points_3e8.las": (_las_header(count=300_000_000) + bytes(40), "declares 3e+08 points of 20 bytes"),
    "points_1e15.las": (_las_header(version=(1, 4), header_size=375, offset=375, count64=10**15),
                        "declares 1e+15 points"),
    "points_1e15.laz": (_las_header(version=(1, 4), header_size=375, offset=375, point_format=0x80,
                                    count64=10**15), "over the memory cap"),
    "organised.pcd": (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 100000\n"
                      b"HEIGHT 100000\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 10000000000\nDATA ascii\n1 2 3\n",
                      "declares 100000 x 100000 points"),
    "truncated.pcd": (b"VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1000\nHEIGHT 1\n"
                      b"POINTS 1000\nDATA binary\n" + bytes(120), "truncated or damaged"),
    "vertices.ply": (b"ply\nformat ascii 1.0\nelement vertex 2000000000\nproperty float x\nproperty float y\n"
                     b"property float z\nend_header\n1 2 3\n", "declares 2e+09 vertex as text"),
    "binary.ply": (b"ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\n"
                   b"property float y\nproperty float z\nend_header\n" + bytes(12), "truncated or damaged"),
}


def test_hostile_scan_headers_are_refused_in_one_line_without_hanging_or_allocating(tmp_path):
    rng = np.random.default_rng(36)
    files = {name: (data, expected) for name, (data, expected) in HOSTILE.items()}
    for seed in range(3):  # 2 kB of random bytes after LASF, then the same with a readable version 1.2
        files[f"random_{seed}.las"] = (b"LASF" + rng.bytes(2044), "")
        files[f"random_1.2_{seed}.las"] = (b"LASF" + rng.bytes(20) + bytes([1, 2]) + rng.bytes(2022), "")
    for name, (data, _) in files.items():
        (tmp_path / name).write_bytes(data)
    results = _read_boxed([tmp_path / name for name in files])
    for name, (_, expected) in files.items():
        message = results[str(tmp_path / name)]
        assert message.startswith(str(tmp_path / name)) and "\n" not in message, (name, message)
        assert expected in message, (name, message)


def _write_las(path):
    import laspy

    las = laspy.create(point_format=3, file_version="1.2")
    las.header.scales, las.header.offsets = np.array([0.001] * 3), np.zeros(3)
    las.x, las.y, las.z = np.array([[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]])
    las.write(path)


def _write_e57(path):
    import pye57

    e57 = pye57.E57(str(path), mode="w")
    e57.write_scan_raw({"cartesianX": np.array([0.0, 1.0]), "cartesianY": np.array([0.0, 1.0]),
                        "cartesianZ": np.array([0.0, 1.0])})
    e57.close()


def _write_pcd(path):
    import pypcd4

    pypcd4.PointCloud.from_xyz_points(np.array([[0.0, 0.0, 1.0], [1.0, 1.0, 2.0]], np.float32)).save(path)


def _write_ply(path):
    import trimesh

    trimesh.PointCloud(np.array([[0.0, 0.0, 1.0], [1.0, 1.0, 2.0]])).export(path)


@pytest.mark.parametrize("suffix, write", [(".las", _write_las), (".laz", _write_las), (".e57", _write_e57),
                                           (".pcd", _write_pcd), (".ply", _write_ply)])
def test_every_scan_reader_refuses_what_the_memory_cap_does_not_hold(tmp_path, suffix, write):
    path = tmp_path / f"scan{suffix}"
    write(path)
    assert len(read_cloud(path)) == 2  # honest files still read
    with memory_cap(100), pytest.raises(SourceError) as error:
        read_cloud(path)
    assert "over the memory cap of 100 bytes" in str(error.value) and "\n" not in str(error.value)


def test_the_memory_cap_is_a_stated_fraction_of_the_ram_unless_set():
    from bim2rdt.sources.budget import DEFAULT_MEMORY_FRACTION, current_cap, total_memory

    assert DEFAULT_MEMORY_FRACTION == 0.5
    assert current_cap() == int(0.5 * total_memory())
    assert SourcesConfig(max_memory_fraction=0.25).memory_cap_bytes() == int(0.25 * total_memory())
    assert SourcesConfig(max_memory_bytes=10**9).memory_cap_bytes() == 10**9
    with memory_cap(1234):
        assert current_cap() == 1234
    assert current_cap() == int(0.5 * total_memory())


def test_the_memory_cap_comes_from_the_environment_to_verify(tmp_path, monkeypatch, capsys, sensors):
    """``BIM2RDT_SOURCES__MAX_MEMORY_BYTES`` reaches verify's readers: office1 refused in one line, exit 1."""
    from bim2rdt.cli import main
    from bim2rdt.config import get_settings

    monkeypatch.setenv("BIM2RDT_SOURCES__MAX_MEMORY_BYTES", "1000")
    get_settings.cache_clear()
    monkeypatch.setattr(sys, "argv", ["bim2rdt", "verify", str(sensors / "pcl" / "office1.ifc"),
                                      str(sensors / "pcl" / "office1.pcd"), "--prior", "1.3,-4.5,1.4,82",
                                      "--out", str(tmp_path / "out")])
    try:
        with memory_cap(10**12), pytest.raises(SystemExit) as done:  # the block undoes the cap verify sets
            main()
    finally:
        get_settings.cache_clear()
    message = capsys.readouterr().err.strip()
    assert done.value.code == 1 and len(message.splitlines()) == 1, message
    assert "over the memory cap of 1 kB" in message and "BIM2RDT_SOURCES__MAX_MEMORY_FRACTION" in message


def test_an_mkv_whose_tracks_declare_huge_images_is_refused_before_any_map(tmp_path):
    """The Azure Kinect reader checks its tracks' declared sizes (sides, one raw depth image in the file, the
    memory cap) before it builds its undistortion maps (8 bytes a pixel)."""
    from types import SimpleNamespace

    from bim2rdt.sources.azure_kinect import AzureKinectMkv

    (tmp_path / "huge.mkv").write_bytes(bytes(1000))

    def reader(width, height):
        mkv = AzureKinectMkv.__new__(AzureKinectMkv)
        mkv.path, mkv.depth_size, mkv.color_index = tmp_path / "huge.mkv", (width, height), None
        return mkv

    container = SimpleNamespace(streams=[])
    for (width, height), expected in [((60000, 60000), "declares 60000x60000 pixels"),
                                      ((640, 576), "640x576 16-bit depth images")]:
        with pytest.raises(SourceError) as error:
            reader(width, height)._check_sizes(container)
        assert expected in str(error.value) and "\n" not in str(error.value)
