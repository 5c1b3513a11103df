"""Saving is atomic: killing the writer in the middle of a save leaves the previous file whole and valid."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap

from bim2rdt.bim.source import open_ifc

# The child process stands in for a slow disk at every place bytes can leave Python: ifcopenshell's file writer
# and any file opened for writing (open / os.fdopen) put half the bytes on disk, tell the parent, and stall, so
# the parent's SIGKILL lands in the middle of the save every time, whichever way the save writes.
_SAVE_AND_STALL = textwrap.dedent("""
    import builtins, os, sys, time
    import ifcopenshell
    from bim2rdt.bim import TwinWriter, load_ifc

    def stall(stream, data):
        half = len(data) // 2
        stream.write(data[:half])
        stream.flush()
        os.fsync(stream.fileno())
        print("halfway", flush=True)
        time.sleep(120)
        stream.write(data[half:])

    class Stalling:
        def __init__(self, stream):
            self.stream = stream
        def write(self, data):
            stall(self.stream, data)
            return len(data)
        def __getattr__(self, name):
            return getattr(self.stream, name)
        def __enter__(self):
            return self
        def __exit__(self, *exc):
            self.stream.close()

    def stalling(opener):
        def wrapped(file, mode="r", *args, **kwargs):
            stream = opener(file, mode, *args, **kwargs)
            return Stalling(stream) if any(flag in mode for flag in "wax") else stream
        return wrapped

    def stalling_ifc_write(self, path, *args, **kwargs):
        with real_open(path, "w") as stream:
            stall(stream, self.to_string())

    model = load_ifc(sys.argv[1], cache_dir=sys.argv[3])
    writer = TwinWriter(model)
    pose = model.elements[0].placement.copy()
    pose[0, 3] += 1.0
    writer.move_element(model.elements[0].global_id, pose)
    real_open = builtins.open
    builtins.open, os.fdopen = stalling(builtins.open), stalling(os.fdopen)
    ifcopenshell.file.write = stalling_ifc_write
    writer.save(sys.argv[2])
""")


def test_killing_the_process_during_save_leaves_the_old_file_valid(site_ifc, tmp_path):
    target = tmp_path / "twin.ifc"
    shutil.copy(site_ifc, target)
    before = target.read_bytes()
    child = subprocess.Popen([sys.executable, "-c", _SAVE_AND_STALL, str(target), str(target),
                              str(tmp_path / "cache")], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "halfway"
    finally:
        child.kill()
        child.wait(timeout=30)
    assert target.read_bytes() == before
    assert open_ifc(target).by_type("IfcProject")
