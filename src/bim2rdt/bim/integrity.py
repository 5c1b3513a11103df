"""What is wrong inside a parsed file, said with the elements it affects, so the reader never lies quietly.

* ``parser_warnings``: the parser's non-fatal messages (a reference to a missing entity, an entity with the wrong
  number of attributes) as ``BimWarning`` records naming the attribute and the elements that depend on it. A wall
  whose ObjectPlacement points at a missing entity still loads (at the origin), but the warning says so.
* ``schema_violations``: attribute values of the wrong type (a string where a placement belongs, a direction
  where a placement belongs). ifcopenshell accepts them; checking every attribute costs ~1.5 s on Office_A, so
  it runs on request (``load_ifc(..., validate=True)``) and to explain a failed read.
* ``explain_read_failures``: a read that trips over such a value becomes a one-line ``BimError`` naming the
  entity, attribute and line, instead of an AttributeError traceback from deep inside the reader.
"""

from __future__ import annotations

import re
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper as wrapper
import ifcopenshell.validate

from bim2rdt.bim.errors import BimError
from bim2rdt.bim.parser_log import ParserMessage
from bim2rdt.bim.records import BimWarning
from bim2rdt.bim.step_scan import line_of_entity

DANGLING, PARSER, SCHEMA = "dangling reference", "parser", "schema"
DETAILED = 200
"""Warnings beyond this many of one kind are counted in one summary, not traced to their elements."""
WALK_LIMIT = 2000
"""Entities visited at most when tracing one problem to the elements that depend on it."""
_INSTANCE = re.compile(r"#(\d+)")
READ_ERRORS = (AttributeError, TypeError, RuntimeError, ValueError, IndexError, KeyError)
"""What reading a malformed entity graph raises from inside ifcopenshell's utilities and our readers."""


def parser_warnings(ifc: ifcopenshell.file, messages: list[ParserMessage]) -> list[BimWarning]:
    """The parser's non-fatal messages as warnings with the elements they affect, each kind capped at
    ``DETAILED`` (the rest summed up in one more warning)."""
    warnings, counts = [], {DANGLING: 0, PARSER: 0}
    for message in messages:
        kind = DANGLING if message.dangling else PARSER
        counts[kind] += 1
        if counts[kind] <= DETAILED:
            warnings.append(_dangling(ifc, message) if kind == DANGLING else _parser(ifc, message))
    for kind, count in counts.items():
        if count > DETAILED:
            warnings.append(BimWarning(kind, f"... and {count - DETAILED} more {kind} warnings"))
    return warnings


def schema_violations(ifc: ifcopenshell.file, *, unset: bool = False, limit: int = DETAILED) -> list[BimWarning]:
    """Attribute values whose type the schema does not allow (and, with ``unset``, required attributes left
    ``$``), in file order, at most ``limit``."""
    schema = wrapper.schema_by_name(ifc.schema_identifier)
    found: list[BimWarning] = []
    for instance in ifc:
        declaration = schema.declaration_by_name(instance.is_a())
        derived = declaration.derived()
        for index, attribute in enumerate(declaration.all_attributes()):
            problem = _attribute_problem(instance, index, attribute, derived[index], schema, unset)
            if problem is not None:
                elements = affected_elements(ifc, instance)
                text = f"#{instance.id()} {instance.is_a()}.{attribute.name()} {problem}{_affects(ifc, elements)}"
                found.append(BimWarning(SCHEMA, text, (instance.id(),), elements))
                if len(found) >= limit:
                    return found
    return found


@contextmanager
def explain_read_failures(path: Path, ifc: ifcopenshell.file, warnings: list[BimWarning]) -> Iterator[None]:
    """Turn a read that fails on a malformed entity graph into a BimError naming the likely culprit: an entity
    the parser already flagged, else the first attribute value of the wrong type (or a required one left unset).
    A failure nothing in the file explains is a bug of ours and propagates unchanged."""
    try:
        yield
    except READ_ERRORS as error:
        culprit = locate_malformed(path, ifc, warnings)
        if culprit is None:
            raise
        raise BimError(f"{path.name}: {culprit} (reading failed with {type(error).__name__})") from None


def locate_malformed(path: Path, ifc: ifcopenshell.file, warnings: list[BimWarning] = ()) -> str | None:
    """Where a file that broke a read is malformed, as 'line N: #id Class.Attribute ...', or None: an entity the
    parser flagged, else the first value of the wrong type, else the first required attribute left unset."""
    suspects = [w for w in warnings if w.kind == PARSER and w.instances]
    suspects = suspects or schema_violations(ifc, limit=1) or schema_violations(ifc, unset=True, limit=1)
    if not suspects:
        return None
    with open(path, "rb") as stream:
        line = line_of_entity(stream.read(), suspects[0].instances[0])
    return f"line {line}: {suspects[0].message}" if line else suspects[0].message


def affected_elements(ifc: ifcopenshell.file, start: ifcopenshell.entity_instance) -> tuple[str, ...]:
    """GlobalIds of the products that depend on an entity, nearest first: found by walking its inverse references
    breadth-first up to the first product (placements, representations, property sets ...), and through
    relationships to what they relate."""
    products: dict[str, None] = {}
    queue, seen = deque([start]), set()
    while queue and len(seen) < WALK_LIMIT:
        instance = queue.popleft()
        if instance.id() in seen:
            continue
        seen.add(instance.id())
        if instance.is_a("IfcProduct"):
            products[instance.GlobalId] = None
        elif instance.is_a("IfcRelationship"):
            products.update((p.GlobalId, None) for p in _entities(list(instance)) if p.is_a("IfcProduct"))
        else:
            queue.extend(ifc.get_inverse(instance))
    return tuple(g for g in products if isinstance(g, str))


def _dangling(ifc: ifcopenshell.file, message: ParserMessage) -> BimWarning:
    missing, referrer_id, index = message.dangling
    referrer = ifc.by_id(referrer_id)
    elements = affected_elements(ifc, referrer)
    text = (f"#{referrer_id} {referrer.is_a()}.{referrer.attribute_name(index)} refers to #{missing}, which the "
            f"file does not declare (read as unset){_affects(ifc, elements)}")
    return BimWarning(DANGLING, text, (referrer_id, missing), elements)


def _parser(ifc: ifcopenshell.file, message: ParserMessage) -> BimWarning:
    ids = [int(i) for i in _INSTANCE.findall(message.text)]
    instances = [instance for instance in map(_by_id(ifc), ids) if instance is not None]
    elements = affected_elements(ifc, instances[0]) if instances else ()
    label = f"#{instances[0].id()} {instances[0].is_a()}: " if instances else ""
    text = re.sub(r"\s*for instance #\d+", "", message.text) if instances else message.text
    return BimWarning(PARSER, f"{label}{text}{_affects(ifc, elements)}", tuple(ids), elements)


def _by_id(ifc: ifcopenshell.file):
    def find(entity_id: int) -> ifcopenshell.entity_instance | None:
        try:
            return ifc.by_id(entity_id)
        except RuntimeError:  # "Instance #n not found"
            return None

    return find


def _affects(ifc: ifcopenshell.file, elements: tuple[str, ...]) -> str:
    if not elements:
        return ""
    first = ifc.by_guid(elements[0])
    label = f"{first.is_a()} '{first.Name}'" if getattr(first, "Name", None) else f"{first.is_a()} {elements[0]}"
    return f"; affects {label}" + (f" and {len(elements) - 1} more" if len(elements) > 1 else "")


def _attribute_problem(instance, index: int, attribute, derived: bool, schema, unset: bool) -> str | None:
    try:
        value = instance[index]
    except (RuntimeError, IndexError) as error:
        return f"cannot be decoded ({' '.join(str(error).split())})"
    if value is None:
        return "is unset ($) but required" if unset and not attribute.optional() and not derived else None
    try:
        valid = ifcopenshell.validate.assert_valid(attribute.type_of_attribute(), value, schema, no_throw=True)
    except (ifcopenshell.validate.ValidationError, *READ_ERRORS):
        valid = False
    if valid:
        return None
    shown = f"{value.is_a()} #{value.id()}" if isinstance(value, ifcopenshell.entity_instance) else repr(value)
    return f"is {shown[:80]}, which is not a valid {_type_name(attribute.type_of_attribute())}"


def _type_name(attribute_type) -> str:
    name = getattr(attribute_type, "declared_type", None)
    declared = name() if callable(name) else attribute_type
    return getattr(declared, "name", lambda: str(declared))()


def _entities(values) -> Iterator[ifcopenshell.entity_instance]:
    for value in values:
        if isinstance(value, ifcopenshell.entity_instance):
            yield value
        elif isinstance(value, tuple | list):
            yield from _entities(value)
