"""Typed IFC property sets from Python values, shared by the writer and the site generator.

Python type -> IFC measure: bool -> IfcBoolean, int -> IfcInteger, float -> IfcReal, str -> IfcLabel
(IfcText past 255 characters), datetime -> IfcDateTime (ISO 8601, UTC). Readers get the same Python types back.
"""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime, timezone
from typing import Any

import ifcopenshell
import ifcopenshell.api.root
import numpy as np

from bim2rdt.bim.errors import BimError

LABEL_MAX = 255


def ifc_value(ifc: ifcopenshell.file, value: Any) -> ifcopenshell.entity_instance:
    """The typed IfcValue of a Python value; BimError for types IFC has no measure for here."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):
        return ifc.create_entity("IfcBoolean", value)
    if isinstance(value, int):
        return ifc.create_entity("IfcInteger", value)
    if isinstance(value, float):
        return ifc.create_entity("IfcReal", value)
    if isinstance(value, datetime):
        return ifc.create_entity("IfcDateTime", ifc_datetime(value))
    if isinstance(value, str):
        return ifc.create_entity("IfcLabel" if len(value) <= LABEL_MAX else "IfcText", value)
    raise BimError(f"property value {value!r} of type {type(value).__name__} has no IFC type "
                   "(use bool, int, float, str or datetime)")


def ifc_datetime(when: datetime | float) -> str:
    """IfcDateTime text in UTC with offset; a naive datetime is taken as UTC, a float as Unix seconds."""
    if isinstance(when, int | float) and not isinstance(when, bool):
        when = datetime.fromtimestamp(float(when), tz=timezone.utc)
    if not isinstance(when, datetime):
        raise BimError(f"a time must be a datetime or Unix seconds, got {type(when).__name__}")
    if when.tzinfo is None:
        when = when.replace(tzinfo=timezone.utc)
    return when.astimezone(timezone.utc).isoformat()


def add_typed_pset(ifc: ifcopenshell.file, entity: ifcopenshell.entity_instance, name: str,
                   properties: Mapping[str, Any]) -> ifcopenshell.entity_instance:
    """Attach a property set of typed single values to an object (IfcRelDefinesByProperties)."""
    values = [ifc.create_entity("IfcPropertySingleValue", Name=str(key), NominalValue=ifc_value(ifc, value))
              for key, value in properties.items() if value is not None]
    pset = ifcopenshell.api.root.create_entity(ifc, "IfcPropertySet", name=name)
    pset.HasProperties = values
    relation = ifcopenshell.api.root.create_entity(ifc, "IfcRelDefinesByProperties")
    relation.RelatedObjects = [entity]
    relation.RelatingPropertyDefinition = pset
    return pset
