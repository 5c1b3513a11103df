"""Saving is atomic: killing the writer in the middle of a save leaves the previous file whole and valid."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap

from bim2rdt.bim.source import open_ifc

# The child process stands in for a slow disk at the only boundary that matters: ifcopenshell's file write
# puts half the bytes on disk, tells the parent, and stalls, so the parent's SIGKILL lands mid-save every time.
_SAVE_AND_STALL = textwrap.dedent("""
    import os, sys, time
    import ifcopenshell
    from bim2rdt.bim import TwinWriter, load_ifc

    def stalling_write(self, path, *args, **kwargs):
        text = self.to_string()
        with open(path, "w") as stream:
            stream.write(text[: len(text) // 2])
            stream.flush()
            os.fsync(stream.fileno())
            print("halfway", flush=True)
            time.sleep(120)
            stream.write(text[len(text) // 2:])

    ifcopenshell.file.write = stalling_write
    model = load_ifc(sys.argv[1], cache_dir=sys.argv[3])
    writer = TwinWriter(model)
    pose = model.elements[0].placement.copy()
    pose[0, 3] += 1.0
    writer.move_element(model.elements[0].global_id, pose)
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
