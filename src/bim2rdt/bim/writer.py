"""``TwinWriter``: writes the live twin back into the IFC file the model was read from.

What it writes (IFC4 / IFC4X3):

* moves: an element's ObjectPlacement so that its reader pose becomes the given world pose (metres; the file's
  own unit is handled). Elements located by geometry (identity placement, Revit) are first re-based: their
  body is wrapped in a mapped item offset by the old location, so the placement can carry the pose;
* observed objects: an ``IfcBuildingElementProxy`` with a triangulated body, a type object named after the
  family, storey containment and a ``BIM2RDT_Observation`` property set;
* safety/4D processes: ``IfcEvent`` (trigger type + ``IfcEventTime``) and ``IfcTask`` (``IfcTaskTime`` with
  ActualStart/ActualFinish set directly: ``sequence.edit_task_time`` snaps times to 09:00/17:00), linked to
  products (``IfcRelAssignsToProduct`` / ``IfcRelAssignsToProcess``) and to each other (``IfcRelSequence``,
  built directly: ``sequence.assign_sequence`` crashes on IfcEvent).

IFC2X3 is refused with a clear error: it has no IfcEvent and no IfcTaskTime, and ifcopenshell's schema
migrator adds schema errors on real Revit files (measured: 28 new errors on Duplex_A), so an upgrade on write
would break the "no new validation errors" promise. Re-export as IFC4 from the authoring tool instead.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from datetime import datetime
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.util.representation
import numpy as np

from bim2rdt.bim.atomic import atomic_write_ifc
from bim2rdt.frames import rigid_problem
from bim2rdt.bim.spatial import placement_matrix
from bim2rdt.bim.errors import BimError
from bim2rdt.bim.ifc_values import add_typed_pset, ifc_datetime
from bim2rdt.bim.model import BimModel, load_ifc
from bim2rdt.bim.source import file_digest, open_ifc

OBSERVATION_PSET = "BIM2RDT_Observation"
EVENT_PSET = "BIM2RDT_Event"
TASK_PSET = "BIM2RDT_Task"
EVENT_KINDS = {"start": "STARTEVENT", "end": "ENDEVENT", "intermediate": "INTERMEDIATEEVENT"}
WRITABLE_SCHEMAS = ("IFC4", "IFC4X3")


class TwinWriter:
    """Collects twin updates on a private copy of the model's IFC file; ``save`` writes them atomically.

    Args:
        model: A loaded model, or the path of an IFC file to load.

    Raises:
        BimError: The file is not IFC4/IFC4X3 (IFC2X3 has no IfcEvent or IfcTaskTime), or it changed on disk
            since it was loaded.
    """

    def __init__(self, model: BimModel | str | Path):
        self.model = model if isinstance(model, BimModel) else load_ifc(model)
        name = self.model.path.name
        if not self.model.schema.upper().startswith(WRITABLE_SCHEMAS):
            raise BimError(f"{name}: TwinWriter writes IFC4/IFC4X3 only; this file is {self.model.schema}, which "
                           "has no IfcEvent or IfcTaskTime (re-export it as IFC4 from the authoring tool)")
        if file_digest(self.model.path) != self.model.digest:
            raise BimError(f"{name}: the file changed on disk since it was loaded; load it again")
        self.ifc = open_ifc(self.model.path)
        self._scale = self.model.unit_scale
        self._poses = {el.global_id: el.placement.copy() for el in self.model.elements}
        self._located_by_geometry = {el.global_id for el in self.model.elements if el.placement_from_geometry}

    # ---- geometry ---------------------------------------------------------------------------------------------

    def move_element(self, global_id: str, pose: np.ndarray) -> None:
        """Move an element so that its (reader) pose becomes ``pose``.

        Args:
            global_id: The element's IFC GlobalId.
            pose: The new pose, 4x4 model-to-world, metres (``T_world_element``).

        Raises:
            BimError: The pose is not a finite rigid transform, or there is no such element.
        """
        pose = _checked_pose(pose)
        product = self._product(global_id)
        if self.model.meshes is None:
            self._adopt_geometry()
        if global_id in self._located_by_geometry:
            self._rebase_body(product, self._poses[global_id])
            self._located_by_geometry.discard(global_id)
        current = placement_matrix(product, self._scale)
        target = pose @ np.linalg.inv(self._poses[global_id]) @ current
        ifcopenshell.api.geometry.edit_object_placement(self.ifc, product=product, matrix=target, is_si=True,
                                                        should_transform_children=True)
        self._poses[global_id] = pose

    def add_object(self, family: str, vertices: np.ndarray, faces: np.ndarray, pose: np.ndarray,
                   storey: str | None = None, properties: Mapping[str, Any] | None = None,
                   global_id: str | None = None) -> str:
        """Add an observed object as an IfcBuildingElementProxy; returns its GlobalId.

        ``vertices`` (N,3) are in the object's body frame, metres; ``faces`` (M,3) index them; ``pose`` (4x4)
        maps body to world. ``storey`` is a storey name or GlobalId (default: the highest storey at or below
        the object). ``properties`` go into the ``BIM2RDT_Observation`` property set. ``global_id`` keeps an
        identity the object already has (the twin's, so BCF topics point at it); default: a new one.

        Args:
            family: The object's family (IFC Name and ObjectType, and its proxy type).
            vertices: (N,3) body-frame vertices, metres.
            faces: (M,3) vertex indices of triangles.
            pose: 4x4 body-to-world pose, metres.
            storey: Storey name or GlobalId to contain it; None picks the highest storey at or below it.
            properties: Values for the ``BIM2RDT_Observation`` property set.
            global_id: GlobalId to give the object; None makes a new one.

        Returns:
            The object's GlobalId.

        Raises:
            BimError: A bad pose or mesh, a GlobalId that is malformed or taken, or no such storey.
        """
        pose = _checked_pose(pose)
        vertices, faces = _checked_mesh(vertices, faces)
        proxy = ifcopenshell.api.root.create_entity(self.ifc, "IfcBuildingElementProxy", name=family,
                                                    predefined_type="NOTDEFINED")
        proxy.ObjectType = family
        if global_id is not None:
            self._check_new_guid(global_id)
            proxy.GlobalId = global_id
        ifcopenshell.api.type.assign_type(self.ifc, related_objects=[proxy], relating_type=self._proxy_type(family),
                                          should_map_representations=False)
        body = ifcopenshell.api.geometry.add_mesh_representation(
            self.ifc, context=self._body_context(), vertices=[vertices.tolist()], faces=[faces.tolist()])
        ifcopenshell.api.geometry.assign_representation(self.ifc, product=proxy, representation=body)
        ifcopenshell.api.spatial.assign_container(self.ifc, products=[proxy],
                                                  relating_structure=self._storey(storey, pose[2, 3]))
        ifcopenshell.api.geometry.edit_object_placement(self.ifc, product=proxy, matrix=pose, is_si=True)
        if properties:
            add_typed_pset(self.ifc, proxy, OBSERVATION_PSET, properties)
        self._poses[proxy.GlobalId] = pose
        return proxy.GlobalId

    def add_properties(self, global_id: str, properties: Mapping[str, Any], pset: str = OBSERVATION_PSET) -> None:
        """Attach a property set of typed values to an existing product.

        Args:
            global_id: The product's GlobalId.
            properties: {name: value}; bool, int, float, str and datetime map to IFC value types.
            pset: The property set's name.

        Raises:
            BimError: No such product, or a value with no IFC type.
        """
        add_typed_pset(self.ifc, self._product(global_id), pset, properties)

    # ---- processes --------------------------------------------------------------------------------------------

    def add_event(self, name: str, when: datetime | float, kind: str = "start", related: Iterable[str] = (),
                  properties: Mapping[str, Any] | None = None, trigger: str = "EVENTMESSAGE") -> str:
        """Add an IfcEvent with a measured occurrence time, assigned to products.

        Args:
            name: The event's name.
            when: When it happened: an aware datetime or Unix seconds (UTC).
            kind: ``start``, ``end`` or ``intermediate`` (the IfcEventTypeEnum).
            related: GlobalIds of the products it concerns.
            properties: Values for the event's property set.
            trigger: IfcEventTriggerTypeEnum value; a sensor message by default.

        Returns:
            The event's GlobalId.

        Raises:
            BimError: An unknown ``kind``, a bad time, or no such related product.
        """
        if kind not in EVENT_KINDS:
            raise BimError(f"event kind {kind!r} is not one of {', '.join(EVENT_KINDS)}")
        event = ifcopenshell.api.root.create_entity(self.ifc, "IfcEvent", name=name,
                                                    predefined_type=EVENT_KINDS[kind])
        event.EventTriggerType = trigger
        event.EventOccurenceTime = self.ifc.create_entity("IfcEventTime", Name=name, DataOrigin="MEASURED",
                                                          ActualDate=ifc_datetime(when))
        for global_id in related:
            relation = ifcopenshell.api.root.create_entity(self.ifc, "IfcRelAssignsToProduct")
            relation.RelatedObjects = [event]
            relation.RelatingProduct = self._product(global_id)
        return self._declare(event, EVENT_PSET, properties)

    def add_task(self, name: str, start: datetime | float, finish: datetime | float | None = None,
                 related: Iterable[str] = (), properties: Mapping[str, Any] | None = None,
                 after: str | None = None) -> str:
        """Add an IfcTask with measured ActualStart/ActualFinish, operating on products.

        Args:
            name: The task's name.
            start: When it started: an aware datetime or Unix seconds (UTC).
            finish: When it finished, or None while it runs.
            related: GlobalIds of the products it operates on.
            properties: Values for the task's property set.
            after: GlobalId of a process (e.g. the triggering event) that precedes it through an IfcRelSequence.

        Returns:
            The task's GlobalId.
        """
        task = ifcopenshell.api.root.create_entity(self.ifc, "IfcTask", name=name, predefined_type="NOTDEFINED")
        task.IsMilestone = False
        task.TaskTime = self.ifc.create_entity(
            "IfcTaskTime", Name=name, DataOrigin="MEASURED", ActualStart=ifc_datetime(start),
            ActualFinish=ifc_datetime(finish) if finish is not None else None)
        products = [self._product(global_id) for global_id in related]
        if products:
            relation = ifcopenshell.api.root.create_entity(self.ifc, "IfcRelAssignsToProcess")
            relation.RelatedObjects = products
            relation.RelatingProcess = task
        global_id = self._declare(task, TASK_PSET, properties)
        if after is not None:
            self.add_sequence(after, global_id)
        return global_id

    def add_sequence(self, before: str, after: str, sequence_type: str = "FINISH_START") -> str:
        """Add an IfcRelSequence: process ``before`` precedes process ``after``.

        Args:
            before: GlobalId of the earlier process.
            after: GlobalId of the later process.
            sequence_type: IfcSequenceEnum value.

        Returns:
            The relation's GlobalId.
        """
        relation = ifcopenshell.api.root.create_entity(self.ifc, "IfcRelSequence")
        relation.RelatingProcess = self._process(before)
        relation.RelatedProcess = self._process(after)
        relation.SequenceType = sequence_type
        return relation.GlobalId

    # ---- output -----------------------------------------------------------------------------------------------

    def save(self, path: str | Path) -> Path:
        """Write the updated IFC file atomically (temp file in the target folder, fsync, rename).

        Args:
            path: The output .ifc file.

        Returns:
            The written path.

        Raises:
            BimError: The target folder is missing, or the serialised file is incomplete.
        """
        return atomic_write_ifc(self.ifc, Path(path))

    # ---- helpers ----------------------------------------------------------------------------------------------

    def _declare(self, process: ifcopenshell.entity_instance, pset: str,
                 properties: Mapping[str, Any] | None) -> str:
        project = self.ifc.by_type("IfcProject")[0]
        ifcopenshell.api.project.assign_declaration(self.ifc, definitions=[process], relating_context=project)
        if properties:
            add_typed_pset(self.ifc, process, pset, properties)
        return process.GlobalId

    def _adopt_geometry(self) -> None:
        """Before the first move of a model read without geometry: read it with geometry, since
        identity-placed Revit elements only get their true placement from their tessellated body."""
        model = load_ifc(self.model.path)
        if model.digest != self.model.digest:
            raise BimError(f"{model.path.name}: the file changed on disk since it was loaded; load it again")
        for el in model.elements:  # nothing has moved yet, so the geometry model's poses are the current ones
            self._poses[el.global_id] = el.placement.copy()
            if el.placement_from_geometry:
                self._located_by_geometry.add(el.global_id)
        self.model = model

    def _check_new_guid(self, global_id: str) -> None:
        try:
            self.ifc.by_guid(global_id)
        except RuntimeError:
            if len(global_id) == 22:
                return
            raise BimError(f"{global_id!r} is not an IFC GlobalId (22 characters)") from None
        raise BimError(f"{self.model.path.name}: GlobalId {global_id} is already taken")

    def _product(self, global_id: str) -> ifcopenshell.entity_instance:
        return self._entity(global_id, "IfcProduct", "element")

    def _process(self, global_id: str) -> ifcopenshell.entity_instance:
        return self._entity(global_id, "IfcProcess", "IfcEvent/IfcTask")

    def _entity(self, global_id: str, ifc_class: str, what: str) -> ifcopenshell.entity_instance:
        try:
            entity = self.ifc.by_guid(global_id)
        except RuntimeError:
            raise BimError(f"{self.model.path.name}: no {what} with GlobalId {global_id}") from None
        if not entity.is_a(ifc_class):
            raise BimError(f"{global_id} is an {entity.is_a()}, not an {what}")
        return entity

    def _body_context(self) -> ifcopenshell.entity_instance:
        context = ifcopenshell.util.representation.get_context(self.ifc, "Model", "Body", "MODEL_VIEW")
        if context is None:
            model = ifcopenshell.util.representation.get_context(self.ifc, "Model")
            model = model or ifcopenshell.api.context.add_context(self.ifc, context_type="Model")
            context = ifcopenshell.api.context.add_context(self.ifc, context_type="Model", context_identifier="Body",
                                                           target_view="MODEL_VIEW", parent=model)
        return context

    def _proxy_type(self, family: str) -> ifcopenshell.entity_instance:
        for existing in self.ifc.by_type("IfcBuildingElementProxyType"):
            if existing.Name == family:
                return existing
        return ifcopenshell.api.root.create_entity(self.ifc, "IfcBuildingElementProxyType", name=family,
                                                   predefined_type="NOTDEFINED")

    def _storey(self, storey: str | None, z: float) -> ifcopenshell.entity_instance:
        storeys = self.ifc.by_type("IfcBuildingStorey")
        if storey is not None:
            for candidate in storeys:
                if storey in (candidate.Name, candidate.GlobalId):
                    return candidate
            raise BimError(f"{self.model.path.name}: no storey named {storey!r}")
        if not storeys:
            structures = self.ifc.by_type("IfcBuilding") or self.ifc.by_type("IfcSite")
            if not structures:
                raise BimError(f"{self.model.path.name}: no storey, building or site to contain a new object")
            return structures[0]
        def elevation(candidate: ifcopenshell.entity_instance) -> float:
            return (candidate.Elevation or 0.0) * self._scale

        below = [s for s in storeys if elevation(s) <= z + 1e-6]
        return max(below, key=elevation) if below else min(storeys, key=elevation)

    def _rebase_body(self, product: ifcopenshell.entity_instance, located: np.ndarray) -> None:
        """Wrap every representation in a mapped item shifted by -location, then place the product at it."""
        if product.Representation is not None:
            offset = (-located[:3, 3] / self._scale).tolist()
            operator = self.ifc.create_entity("IfcCartesianTransformationOperator3D",
                                              LocalOrigin=self.ifc.create_entity("IfcCartesianPoint", offset))
            origin = self.ifc.create_entity("IfcAxis2Placement3D",
                                            Location=self.ifc.create_entity("IfcCartesianPoint", (0.0, 0.0, 0.0)))
            wrapped = []
            for rep in product.Representation.Representations:
                mapping = self.ifc.create_entity("IfcRepresentationMap", MappingOrigin=origin, MappedRepresentation=rep)
                item = self.ifc.create_entity("IfcMappedItem", MappingSource=mapping, MappingTarget=operator)
                wrapped.append(self.ifc.create_entity("IfcShapeRepresentation", ContextOfItems=rep.ContextOfItems,
                                                      RepresentationIdentifier=rep.RepresentationIdentifier,
                                                      RepresentationType="MappedRepresentation", Items=[item]))
            shape = product.Representation
            if len(shape.ShapeOfProduct) > 1:  # shared with other products: give this one its own
                product.Representation = self.ifc.create_entity("IfcProductDefinitionShape", Representations=wrapped)
            else:
                shape.Representations = wrapped
        ifcopenshell.api.geometry.edit_object_placement(self.ifc, product=product, matrix=located.copy(),
                                                        is_si=True)


def _checked_pose(pose: np.ndarray) -> np.ndarray:
    problem = rigid_problem(pose)
    if problem is not None:
        raise BimError(f"a pose must be a finite 4x4 rigid pose: {problem}")
    return np.asarray(pose, dtype=float)


def _checked_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    vertices = np.asarray(vertices, dtype=float).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0 or faces.min() < 0 or faces.max() >= len(vertices):
        raise BimError(f"a mesh needs faces indexing its {len(vertices)} vertices")
    return vertices, faces
