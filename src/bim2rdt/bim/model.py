"""``load_ifc`` and ``BimModel``: an IFC file read once into plain records and world-metre meshes.

Reading = parse (``source``: bad bytes, duplicate ids and parser errors stop here), the parser's warnings traced to
the elements they affect (``integrity``), semantics (``elements``, ``processes``, ``site_frame``), geometry
(``tessellation``), then one fix-up: an element whose ObjectPlacement is the identity while its tessellated
body lies away from the origin (Revit exports do this) takes its location from the geometry. The result is
cached on disk by file hash (``model_cache``).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.unit
import numpy as np

from bim2rdt.bim import model_cache
from bim2rdt.bim.elements import read_elements, read_storeys, read_zones
from bim2rdt.bim.integrity import explain_read_failures, parser_warnings, schema_violations
from bim2rdt.bim.psets import read_all_psets
from bim2rdt.bim.spatial import SpatialIndex
from bim2rdt.bim.errors import BimError
from bim2rdt.bim.processes import read_events, read_tasks
from bim2rdt.bim.records import BimElement, BimProcess, BimStorey, BimWarning, BimZone, GeometryFailure
from bim2rdt.bim.site_frame import SiteFrame, read_site_frame
from bim2rdt.bim.source import check_bytes, file_digest, read_source
from bim2rdt.bim.tessellation import MeshSet, Progress, has_body, tessellate

ORIGIN_MARGIN_M = 0.01
"""An identity-placed element whose bounding box (grown by 1 cm) still misses the origin is located by geometry."""


@dataclass
class BimModel:
    """A read IFC file. Lengths in metres, poses 4x4 model-to-world; ``meshes`` is None if not tessellated.
    ``warnings`` lists what the reader read past (dangling references, malformed entities), with the elements
    each one affects."""

    path: Path
    digest: str
    schema: str
    unit_scale: float
    unit_name: str
    elements: list[BimElement]
    storeys: list[BimStorey]
    zones: list[BimZone]
    events: list[BimProcess]
    tasks: list[BimProcess]
    site_frame: SiteFrame
    geometry_failures: list[GeometryFailure] = field(default_factory=list)
    warnings: list[BimWarning] = field(default_factory=list)
    meshes: MeshSet | None = None
    from_cache: bool = False

    def __post_init__(self) -> None:
        self._by_id = {el.global_id: el for el in self.elements}

    def element(self, global_id: str) -> BimElement:
        """The element with this GlobalId.

        Args:
            global_id: The IFC GlobalId (22 characters).

        Returns:
            The element.

        Raises:
            BimError: The model has no such element; the message names the file.
        """
        try:
            return self._by_id[global_id]
        except KeyError:
            raise BimError(f"{self.path.name}: no element with GlobalId {global_id}") from None

    def mesh(self, global_id: str) -> tuple[np.ndarray, np.ndarray]:
        """The tessellated body of an element.

        Args:
            global_id: The IFC GlobalId of the element.

        Returns:
            (vertices (N,3) world metres, faces (M,3) int32); both empty when it has no body (see ``has_mesh``;
                failed ones are listed in ``geometry_failures``).

        Raises:
            BimError: The model was loaded without geometry, or has no such element.
        """
        if self.meshes is None:
            raise BimError(f"{self.path.name}: loaded without geometry (load_ifc(..., geometry=True))")
        if global_id not in self.meshes:
            self.element(global_id)
            return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32)
        return self.meshes.get(global_id)

    def has_mesh(self, global_id: str) -> bool:
        """Whether an element has a tessellated body.

        Args:
            global_id: The IFC GlobalId of the element.

        Returns:
            True when the model was loaded with geometry and the element has a mesh.
        """
        return self.meshes is not None and global_id in self.meshes

    def counts_by_class(self) -> dict[str, int]:
        """Count the elements per IFC class.

        Returns:
            {IFC class: number of elements}, most common first.
        """
        return dict(Counter(el.ifc_class for el in self.elements).most_common())

    def families(self) -> dict[str, int]:
        """Count the elements per family (elements without one are not counted).

        Returns:
            {family: number of elements}, most common first.
        """
        return dict(Counter(el.family for el in self.elements if el.family).most_common())


def load_ifc(path: str | Path, *, geometry: bool = True, cache_dir: Path | None = None,
             progress: Progress | None = None, validate: bool = False) -> BimModel:
    """Read an IFC2X3/IFC4/IFC4X3 file. Bad input raises ``BimError`` with a one-line reason; what the reader
    could read past is listed in ``model.warnings``.

    With ``geometry`` the file is tessellated (world metres) and, given a ``cache_dir``, the result cached there
    (the CLI passes ``config.ifc_cache_dir``: ``$BIM2RDT_CACHE_DIR/ifc``). With ``validate``
    every attribute value is also checked against the schema (~1.5 s on Office_A); violations become warnings.
    A cache hit skips parsing: those bytes were checked and parsed when the cache was written, and their
    warnings were cached with them.

    Args:
        path: The .ifc file.
        geometry: Tessellate every element's body into world-metre meshes.
        cache_dir: Folder for the tessellation cache, keyed by the file's hash; None caches nothing.
        progress: Reports reading and tessellation progress; None reports nothing.
        validate: Also check every attribute value against the schema.

    Returns:
        The model: elements, storeys, meshes (with ``geometry``), site frame and warnings.

    Raises:
        BimError: The file is missing, empty, not IFC-SPF, truncated, declares an entity twice, has an
            unsupported schema or not exactly one IfcProject, or cannot be read; one line naming the file.
    """
    path = Path(path)
    if geometry and cache_dir is not None and not validate and (cached := _cached(path, cache_dir)) is not None:
        return cached
    source = read_source(path)
    ifc, digest = source.ifc, source.digest
    warnings = parser_warnings(ifc, source.messages) if source.messages else []
    cache_path = model_cache.cache_file(cache_dir, digest) if geometry and cache_dir is not None else None
    if cache_path is not None and (cached := model_cache.read_cache(cache_path)) is not None:
        model = _from_cache(path, digest, *cached)
    else:
        with explain_read_failures(path, ifc, warnings):
            model = _read(path, digest, ifc, warnings)
            if geometry:
                _add_geometry(model, ifc, progress)
        if cache_path is not None:
            model_cache.write_cache(cache_path, _meta(model), model.meshes)
    if validate:
        model.warnings = model.warnings + schema_violations(ifc)
    return model


def _cached(path: Path, cache_dir: Path) -> BimModel | None:
    check_bytes(path)
    digest = file_digest(path)
    cached = model_cache.read_cache(model_cache.cache_file(cache_dir, digest))
    return _from_cache(path, digest, *cached) if cached is not None else None


def _read(path: Path, digest: str, ifc: ifcopenshell.file, warnings: list[BimWarning]) -> BimModel:
    unit_scale = ifcopenshell.util.unit.calculate_unit_scale(ifc)
    psets, index = read_all_psets(ifc), SpatialIndex(ifc)
    return BimModel(path=path, digest=digest, schema=ifc.schema, unit_scale=unit_scale,
                    unit_name=_unit_name(ifc), elements=read_elements(ifc, unit_scale, psets, index),
                    storeys=read_storeys(ifc, unit_scale), zones=read_zones(ifc, psets, index), events=read_events(ifc),
                    tasks=read_tasks(ifc), site_frame=read_site_frame(ifc, unit_scale), warnings=warnings)


def _add_geometry(model: BimModel, ifc: ifcopenshell.file, progress: Progress | None) -> None:
    expected = [el.global_id for el in model.elements if has_body(ifc.by_guid(el.global_id))]
    model.meshes, model.geometry_failures = tessellate(ifc, expected, progress)
    _locate_by_geometry(model)


def _locate_by_geometry(model: BimModel) -> None:
    """Revit-style elements (identity placement, geometry elsewhere) get the bottom centre of their bbox."""
    for el in model.elements:
        if not np.allclose(el.placement, np.eye(4)) or not model.has_mesh(el.global_id):
            continue
        vertices, _ = model.meshes.get(el.global_id)
        low, high = vertices.min(axis=0), vertices.max(axis=0)
        if np.all(low - ORIGIN_MARGIN_M <= 0.0) and np.all(high + ORIGIN_MARGIN_M >= 0.0):
            continue
        el.placement = np.eye(4)
        el.placement[:3, 3] = [(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]]
        el.placement_from_geometry = True


def _unit_name(ifc: ifcopenshell.file) -> str:
    unit = ifcopenshell.util.unit.get_project_unit(ifc, "LENGTHUNIT")
    return ifcopenshell.util.unit.get_full_unit_name(unit).lower() if unit is not None else "metre"


def _meta(model: BimModel) -> dict:
    return {"schema": model.schema, "unit_scale": model.unit_scale, "unit_name": model.unit_name,
            **model_cache.dump_records(elements=model.elements, storeys=model.storeys, zones=model.zones,
                                       events=model.events, tasks=model.tasks,
                                       geometry_failures=model.geometry_failures, site_frame=model.site_frame,
                                       warnings=model.warnings)}


def _from_cache(path: Path, digest: str, meta: dict, meshes: MeshSet) -> BimModel:
    return BimModel(path=path, digest=digest, schema=meta["schema"], unit_scale=meta["unit_scale"],
                    unit_name=meta["unit_name"], elements=model_cache.load_elements(meta["elements"]),
                    storeys=model_cache.load_storeys(meta["storeys"]), zones=model_cache.load_zones(meta["zones"]),
                    events=model_cache.load_processes(meta["events"]), tasks=model_cache.load_processes(meta["tasks"]),
                    site_frame=model_cache.load_site_frame(meta["site_frame"]),
                    geometry_failures=model_cache.load_failures(meta["geometry_failures"]),
                    warnings=model_cache.load_warnings(meta["warnings"]), meshes=meshes,
                    from_cache=True)
