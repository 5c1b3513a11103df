"""Which family an IFC element belongs to: the name the detector prompt and the upright prior are keyed on.

Authoring tools put it in different places. ArchiCAD and clean IFC4 exports give a type object; Revit's IFC2X3
exports often have no type object and write ``Family:Type:ElementId`` into ``Name`` and ``ObjectType``. The
family here is the first non-empty of: type object name, ``ObjectType``, the Revit family part of ``Name``,
``Name``; a trailing Revit element id (``:128360``) is dropped so every instance of one type shares a family.
"""

from __future__ import annotations

import re

_REVIT_ELEMENT_ID = re.compile(r"^(?P<family>[^:]+:[^:]+?)(?::\d+)+$")


def resolve_family(type_name: str | None, object_type: str | None, name: str | None) -> str | None:
    """The family of an element from its type object name, ObjectType and Name (any may be None)."""
    for candidate in (type_name, object_type):
        if candidate and candidate.strip():
            return strip_revit_id(candidate.strip())
    if name and name.strip():
        return strip_revit_id(name.strip())
    return None


def strip_revit_id(label: str) -> str:
    """'Basic Wall:Interior - Partition (92mm Stud):128360' -> 'Basic Wall:Interior - Partition (92mm Stud)'."""
    match = _REVIT_ELEMENT_ID.match(label)
    return match.group("family") if match else label
