"""The IFC benchmark: our load (parse + semantics + tessellation + cache write) against a bare ifcopenshell
geometry-iterator loop on the same file in the same run, and the cached reload.

Targets: overhead over the bare loop at most 15 %; a cached reload under 0.5 s. Each timing is the best of
``repeat`` interleaved runs (the machine is shared, so the minimum is the least noisy estimate).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom

from bim2rdt.bim.model import load_ifc
from bim2rdt.bim.tessellation import EXCLUDED, geometry_settings

OVERHEAD_TARGET = 0.15
CACHED_TARGET_S = 0.5


@dataclass(frozen=True)
class IfcBenchResult:
    """Seconds (best of ``repeat``), shapes of the bare loop and meshes we keep, the figures and their targets."""

    file: str
    repeat: int
    shapes: int
    meshes: int
    bare_loop_s: float
    load_s: float
    cached_s: float

    @property
    def overhead(self) -> float:
        """(our load - bare loop) / bare loop."""
        return self.load_s / self.bare_loop_s - 1.0

    def to_dict(self) -> dict:
        return {**self.__dict__, "overhead": self.overhead, "overhead_target": OVERHEAD_TARGET,
                "overhead_ok": self.overhead <= OVERHEAD_TARGET, "cached_target_s": CACHED_TARGET_S,
                "cached_ok": self.cached_s < CACHED_TARGET_S}


def bare_iterator_loop(path: Path) -> int:
    """The peer: what a user of ifcopenshell writes to get every mesh (same settings as ours)."""
    ifc = ifcopenshell.open(str(path))
    iterator = ifcopenshell.geom.iterator(geometry_settings(), ifc, num_threads=1, exclude=EXCLUDED)
    shapes = 0
    if iterator.initialize():
        while True:
            geometry = iterator.get().geometry
            geometry.verts_buffer, geometry.faces_buffer
            shapes += 1
            if not iterator.next():
                break
    return shapes


def run_ifc_bench(path: Path, repeat: int = 2, step: Callable[[str], None] | None = None) -> IfcBenchResult:
    """Interleave bare loop and our cold load ``repeat`` times, then time cached reloads."""
    bare, cold, cached, shapes = [], [], [], 0
    with tempfile.TemporaryDirectory(prefix="bim2rdt-bench-") as folder:
        for k in range(repeat):
            shapes = _timed(bare, lambda: bare_iterator_loop(path), step, "bare ifcopenshell loop")
            model = _timed(cold, lambda: load_ifc(path, cache_dir=Path(folder) / f"run{k}"), step, "load_ifc (cold)")
        for _ in range(max(3, repeat)):
            _timed(cached, lambda: load_ifc(path, cache_dir=Path(folder) / f"run{repeat - 1}"), step, "load_ifc (cached)")
    return IfcBenchResult(path.name, repeat, shapes, len(model.meshes.ids), min(bare), min(cold), min(cached))


def _timed(times: list[float], work: Callable, step: Callable[[str], None] | None, label: str):
    start = time.perf_counter()
    result = work()
    times.append(time.perf_counter() - start)
    if step is not None:
        step(label)
    return result
