"""The paper's model-conditioning check ("BIM readiness"): is this model good enough as the robot's a-priori map?

The paper asks for a quick conditioning pass: consistent categories (every element has a family and a storey),
true elevations (every storey has one), families the detector/prior table understands, off-limits areas
tagged, stray elements purged (geometry that does not tessellate), and a geo-reference tying the twin to the
site. A map must also be whole: references to entities the file does not declare (a wall whose placement is
missing loads at the origin) are reported. Each check here reports pass / warn (with the offending items) or
unavailable.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from bim2rdt.bim.integrity import DANGLING
from bim2rdt.bim.model import BimModel
from bim2rdt.bim.map_classes import in_map, map_elements

PASS, WARN, UNAVAILABLE = "pass", "warn", "unavailable"
EXAMPLES = 10


class _Prior(Protocol):
    known: bool


class PriorTable(Protocol):
    """What the check needs of ``bim2rdt.semantics.PriorProvider``: priors with a ``known`` flag."""

    def priors(self, families: Iterable[str], ifc_classes: Mapping[str, str] | None = None) -> Mapping[str, _Prior]:
        ...


@dataclass(frozen=True)
class ReadinessCheck:
    """One check: ``status`` pass/warn/unavailable, a one-line ``summary``, and up to 10 offending items."""

    name: str
    status: str
    summary: str
    count: int = 0
    examples: tuple[str, ...] = field(default_factory=tuple)


def check_readiness(model: BimModel, priors: PriorTable | None) -> list[ReadinessCheck]:
    """All checks on a read model; ``priors`` None reports the prior-table check as unavailable."""
    return [_no_family(model), _no_storey(model), _storeys_without_elevation(model), _unknown_families(model, priors),
            _off_limits_zones(model), _geometry_failures(model), _dangling_references(model), _geo_reference(model),
            _localization_map(model)]


def _check(name: str, offenders: list[str], what: str, total: int) -> ReadinessCheck:
    status = PASS if not offenders else WARN
    summary = f"{len(offenders)} of {total} {what}"
    return ReadinessCheck(name, status, summary, len(offenders), tuple(offenders[:EXAMPLES]))


def _objects(model: BimModel):
    return [el for el in model.elements if el.ifc_class != "IfcSpace"]


def _label(el) -> str:
    return f"{el.ifc_class} {el.name or el.global_id}"


def _no_family(model: BimModel) -> ReadinessCheck:
    objects = _objects(model)
    return _check("elements without family", [_label(el) for el in objects if not el.family], "elements", len(objects))


def _no_storey(model: BimModel) -> ReadinessCheck:
    return _check("elements without storey", [_label(el) for el in model.elements if not el.storey],
                  "elements and spaces", len(model.elements))


def _storeys_without_elevation(model: BimModel) -> ReadinessCheck:
    missing = [s.name or s.global_id for s in model.storeys if s.elevation is None]
    return _check("storeys without elevation", missing, "storeys", len(model.storeys))


def _unknown_families(model: BimModel, priors: PriorTable | None) -> ReadinessCheck:
    hints = {el.family: el.ifc_class for el in _objects(model) if el.family}
    if priors is None:
        return ReadinessCheck("families the prior table does not know", UNAVAILABLE,
                              "the prior table (bim2rdt.semantics.KnowledgeBasePriors) is not installed")
    table = priors.priors(list(hints), ifc_classes=hints)
    unknown = [family for family, prior in table.items() if not prior.known]
    return _check("families the prior table does not know", unknown, "families", len(table))


def _off_limits_zones(model: BimModel) -> ReadinessCheck:
    tagged = [z for z in model.zones if z.off_limits is not None]
    off_limits = [z.name or z.global_id for z in tagged if z.off_limits]
    summary = (f"{len(off_limits)} off-limits of {len(tagged)} tagged zones "
               f"({len(model.zones)} spaces/zones)")
    return ReadinessCheck("off-limits zones tagged", PASS if off_limits else WARN, summary, len(off_limits),
                          tuple(off_limits[:EXAMPLES]))


def _geometry_failures(model: BimModel) -> ReadinessCheck:
    if model.meshes is None:
        return ReadinessCheck("elements whose geometry fails", UNAVAILABLE, "not tessellated (--no-geometry)")
    failed = [f"{f.ifc_class} {f.global_id}: {f.reason}" for f in model.geometry_failures]
    return _check("elements whose geometry fails", failed, "elements", len(model.elements))


def _dangling_references(model: BimModel) -> ReadinessCheck:
    dangling = [w for w in model.warnings if w.kind == DANGLING]
    affected = {g for w in dangling for g in w.elements}
    return ReadinessCheck("references to missing entities", PASS if not dangling else WARN,
                          f"{len(dangling)} dangling references, {len(affected)} elements affected", len(dangling),
                          tuple(w.message for w in dangling[:EXAMPLES]))


def _geo_reference(model: BimModel) -> ReadinessCheck:
    frame = model.site_frame
    if frame.source == "IfcMapConversion":
        return ReadinessCheck("geo-reference", PASS, f"IfcMapConversion to {frame.crs_name or 'an unnamed CRS'}")
    if frame.georeferenced:
        return ReadinessCheck("geo-reference", PASS, f"IfcSite reference point {frame.latitude_deg:.6f}, "
                              f"{frame.longitude_deg:.6f}, true north {frame.true_north_deg:.1f} deg")
    return ReadinessCheck("geo-reference", WARN, "no IfcMapConversion and no IfcSite reference point")


def _localization_map(model: BimModel) -> ReadinessCheck:
    """The robot localizes on the permanent structure (walls, columns, slabs, stairs, door frames): a model
    without any gives it no map, and it would run on drifting odometry alone."""
    name = "permanent elements to localize on"
    if model.meshes is None:
        mapped = [el for el in model.elements if in_map(el)]
        if not mapped:
            return ReadinessCheck(name, WARN, "no walls, columns, slabs, stairs or doors: the robot has no map to "
                                  "localize on (odometry only)")
        return ReadinessCheck(name, UNAVAILABLE, f"{len(mapped)} permanent elements, bodies not checked "
                              "(--no-geometry)")
    mapped = map_elements(model)
    if not mapped:
        return ReadinessCheck(name, WARN, "no walls, columns, slabs, stairs or doors with a body: the robot has no "
                              "map to localize on (odometry only)")
    return ReadinessCheck(name, PASS, f"{len(mapped)} permanent elements with a body")
