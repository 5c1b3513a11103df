"""The on-disk cache of a read model, keyed by the file's sha256: a second load of the same bytes skips both
parsing and tessellation (Office_A: ~7 s of tessellation becomes a ~0.1 s read).

One ``.npz`` per file: the packed meshes as arrays plus everything else as one JSON document. Written
atomically (temp file + rename), so a crash never leaves a half cache; a cache that fails to read is ignored.
"""

from __future__ import annotations

import io
import json
import zipfile
from dataclasses import fields
from pathlib import Path
from typing import Any

import ifcopenshell
import numpy as np

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.bim.processes import parse_ifc_datetime
from bim2rdt.bim.records import BimElement, BimProcess, BimStorey, BimWarning, BimZone, GeometryFailure
from bim2rdt.bim.site_frame import SiteFrame
from bim2rdt.bim.tessellation import MeshSet

CACHE_FORMAT = 4
"""4: an unnamed storey is named by its GlobalId (was None)."""


def cache_file(cache_dir: Path, digest: str) -> Path:
    """Where the cache of a file with this sha256 lives (the ifcopenshell version is part of the key)."""
    return Path(cache_dir) / f"{digest}-f{CACHE_FORMAT}-ios{ifcopenshell.version}.npz"


def write_cache(path: Path, meta: dict[str, Any], meshes: MeshSet) -> None:
    """Atomically write the model's metadata and meshes."""
    buffer = io.BytesIO()
    np.savez(buffer, meta=np.array(json.dumps(meta, default=_json_default)), ids=np.array(meshes.ids),
             vertices=meshes.vertices, faces=meshes.faces,
             vertex_offsets=meshes.vertex_offsets, face_offsets=meshes.face_offsets)
    write_bytes_atomic(path, buffer.getvalue())


def read_cache(path: Path) -> tuple[dict[str, Any], MeshSet] | None:
    """(metadata, meshes) from a cache file, or None when absent or unreadable."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            meshes = MeshSet([str(i) for i in data["ids"]], data["vertices"], data["faces"],
                             data["vertex_offsets"], data["face_offsets"])
    except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile):  # EOFError: an empty file
        return None
    return meta, meshes


def dump_records(**records: Any) -> dict[str, Any]:
    """Dataclass records -> JSON-ready dict (numpy arrays become lists, datetimes ISO strings)."""
    return {key: _dump(value) for key, value in records.items()}


def load_elements(items: list[dict]) -> list[BimElement]:
    return [BimElement(**{**item, "placement": np.array(item["placement"], dtype=float)}) for item in items]


def load_processes(items: list[dict]) -> list[BimProcess]:
    return [BimProcess(**{**item, "start": parse_ifc_datetime(item["start"]),
                          "finish": parse_ifc_datetime(item["finish"]),
                          "related": tuple(item["related"]), "after": tuple(item["after"])}) for item in items]


def load_storeys(items: list[dict]) -> list[BimStorey]:
    return [BimStorey(**item) for item in items]


def load_zones(items: list[dict]) -> list[BimZone]:
    return [BimZone(**{**item, "member_ids": tuple(item["member_ids"])}) for item in items]


def load_failures(items: list[dict]) -> list[GeometryFailure]:
    return [GeometryFailure(**item) for item in items]


def load_warnings(items: list[dict]) -> list[BimWarning]:
    return [BimWarning(**{**item, "instances": tuple(item["instances"]), "elements": tuple(item["elements"])})
            for item in items]


def load_site_frame(item: dict) -> SiteFrame:
    matrix = item["T_map_world"]
    return SiteFrame(**{**item, "T_map_world": np.array(matrix, dtype=float) if matrix is not None else None})


def _dump(value: Any) -> Any:
    if isinstance(value, list):
        return [_dump(v) for v in value]
    if hasattr(value, "__dataclass_fields__"):  # shallow: fields hold plain values and arrays (json_default)
        return {f.name: getattr(value, f.name) for f in fields(value)}
    return value


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if hasattr(value, "isoformat"):
        return value.isoformat()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot cache a {type(value).__name__}")
