"""The offline, deterministic prior provider: a curated table of construction classes and a name matcher.

The table (``knowledge_base.json``, package data) lists permanent elements, temporary works, site materials,
equipment and tools, each with a detector label, an upright bias, a yaw-only flag, its rotational symmetry about
up, synonyms (English plus common German/French/Spanish words) and the IFC entities it stands for. A family
matches a class when every token of one of its synonyms occurs in the family name (so word order does not matter;
plurals, accents and abbreviations are normalised on both sides by :mod:`bim2rdt.semantics.names`). Among matches
the winner is: in Revit's family part before its type part; in the earliest hyphen segment (Revit writes
``Table-Coffee``); the longest synonym; then the last word (English puts the noun last: "steel drum", "brick wall").
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError, field_validator

from bim2rdt.semantics.errors import SemanticsError
from bim2rdt.semantics.names import Token, family_tokens, material_of, phrase_tokens, simplify_family
from bim2rdt.semantics.priors import (
    DEFAULT_UPRIGHT_BIAS,
    SOURCE_DEFAULT,
    SOURCE_KNOWLEDGE_BASE,
    UprightPrior,
    symmetry_order,
)


class KnowledgeClass(BaseModel, frozen=True):
    """One row of the table."""

    label: str = Field(min_length=1, description="Detector class, e.g. 'traffic cone'.")
    category: str = Field(description="permanent, temporary works, material, equipment, tool, furnishing.")
    bias: float = Field(ge=0.0, le=1.0, description="Upright bias: weight of SG-ICP's soft upright term.")
    yaw_only: bool = Field(description="Only rotation about gravity is free.")
    symmetry: float = Field(description="Rotational order about up: turns in 360 degrees that show the same "
                                        "object (1 none, 2 a crate, 4 a square plate, inf a drum).")
    synonyms: tuple[str, ...] = Field(default=(), description="Other names, any language, any word order.")
    ifc: tuple[str, ...] = Field(default=(), description="IFC entities this class stands for, e.g. IfcWall.")
    why: str = Field(description="One line: the physical reason for the bias.")

    @field_validator("symmetry", mode="before")
    @classmethod
    def _whole_or_axial(cls, value: object) -> float:
        try:
            return symmetry_order(value)
        except SemanticsError as error:
            raise ValueError(str(error)) from None


class KnowledgeTable(BaseModel, frozen=True):
    """The whole table file."""

    version: int
    default_bias: float = Field(DEFAULT_UPRIGHT_BIAS, ge=0.0, le=1.0)
    classes: tuple[KnowledgeClass, ...]


@dataclass(frozen=True)
class Match:
    """Why a family matched a class: the synonym and the rank used to pick the best match."""

    entry: KnowledgeClass
    synonym: str
    rank: tuple[int, int, int, int]


def load_table(path: Path | None = None) -> KnowledgeTable:
    """Load the knowledge-base table of upright priors.

    Args:
        path: A user table in the same JSON format; None loads the curated table shipped with the package.

    Returns:
        The validated table.

    Raises:
        SemanticsError: The file cannot be read, is not JSON, or does not validate; one line saying where.
    """
    try:
        if path is None:
            text = resources.files("bim2rdt.semantics").joinpath("knowledge_base.json").read_text("utf-8")
        else:
            text = Path(path).read_text("utf-8")
        return KnowledgeTable.model_validate(json.loads(text))
    except (OSError, json.JSONDecodeError, ValidationError) as error:
        raise SemanticsError(f"knowledge-base table {path or 'knowledge_base.json'} is unusable: {_reason(error)}")


def _reason(error: Exception) -> str:
    """One line: where and what for a validation error ("classes.0.symmetry: Field required"), else the first."""
    if isinstance(error, ValidationError):
        first = error.errors()[0]
        return f"{'.'.join(str(part) for part in first['loc'])}: {first['msg']}"
    return str(error).splitlines()[0]


def _rank(phrase: tuple[str, ...], tokens: Sequence[Token]) -> tuple[int, int, int, int] | None:
    """How well a family contains a synonym (higher is better), or None when some word is missing."""
    best = None
    for part in sorted({token.part for token in tokens}):
        in_part = {token.text: token for token in reversed([t for t in tokens if t.part == part])}
        if all(word in in_part for word in phrase):
            hits = [in_part[word] for word in phrase]
            rank = (-part, -min(hit.segment for hit in hits), len(phrase), max(hit.position for hit in hits))
            best = rank if best is None or rank > best else best
    return best


class KnowledgeBasePriors:
    """Upright priors from the curated table; unknown families get the default bias and ``known=False``.

    Deterministic and offline: the default provider, and the fallback of :class:`LlmPriors`.

    Args:
        table: The knowledge-base table; None loads the curated one shipped with the package.
        default_bias: The upright bias (0-1) of an unknown family; None takes the table's.
    """

    def __init__(self, table: KnowledgeTable | None = None, default_bias: float | None = None) -> None:
        self.table = table or load_table()
        self.default_bias = self.table.default_bias if default_bias is None else default_bias
        self._phrases = [(entry, synonym, phrase_tokens(synonym))
                         for entry in self.table.classes for synonym in (entry.label, *entry.synonyms)]
        self._by_ifc = {name.lower(): entry for entry in self.table.classes for name in entry.ifc}

    @property
    def classes(self) -> tuple[KnowledgeClass, ...]:
        """The table's classes."""
        return self.table.classes

    def match(self, family: str) -> Match | None:
        """Find the best class for a family name (the synonym it contains best).

        Args:
            family: A BIM family name (e.g. "M_Drum 200L:Standard").

        Returns:
            The match (class, synonym, rank), or None when no synonym's words all occur in the name.
        """
        tokens = family_tokens(family)
        best: Match | None = None
        for entry, synonym, phrase in self._phrases:
            rank = _rank(phrase, tokens) if phrase else None
            if rank is not None and (best is None or rank > best.rank):
                best = Match(entry, synonym, rank)
        return best

    def match_ifc_class(self, ifc_class: str) -> KnowledgeClass | None:
        """The class an IFC entity stands for.

        Args:
            ifc_class: An IFC entity name (``IfcWallStandardCase`` -> wall; a ``...Type`` suffix is ignored).

        Returns:
            The class, or None.
        """
        name = ifc_class.strip().lower()
        return self._by_ifc.get(name) or self._by_ifc.get(name.removesuffix("type"))

    def prior(self, family: str, ifc_class: str | None = None) -> UprightPrior:
        """The upright prior of one family: by name, else by IFC entity, else the default bias (flagged unknown).

        Args:
            family: The BIM family name.
            ifc_class: The IFC entity of the family's elements, when known.

        Returns:
            The prior with its bias (0-1), yaw-only flag, symmetry and the reason it was chosen.
        """
        match = self.match(family)
        if match is not None:
            reason = f"matched {match.entry.category} class {match.entry.label!r} via {match.synonym!r}"
            return self._prior(family, match.entry, reason)
        entry = self.match_ifc_class(ifc_class) if ifc_class else None
        if entry is not None:
            return self._prior(family, entry, f"name unknown; IFC entity {ifc_class} is a {entry.label!r}")
        label = simplify_family(family)
        reason = f"no knowledge-base class matches {family!r}; default bias {self.default_bias}"
        return UprightPrior(label, self.default_bias, False, SOURCE_DEFAULT, reason)

    def priors(self, families: Iterable[str],
               ifc_classes: Mapping[str, str] | None = None) -> dict[str, UprightPrior]:
        """The upright priors of several families.

        Args:
            families: BIM family names (repeats allowed).
            ifc_classes: {family: IFC entity} hints for families whose name matches no class.

        Returns:
            {family: prior}, one per distinct name, order kept.
        """
        hints = ifc_classes or {}
        return {family: self.prior(family, hints.get(family)) for family in dict.fromkeys(families)}

    @staticmethod
    def _prior(family: str, entry: KnowledgeClass, reason: str) -> UprightPrior:
        return UprightPrior(_label(family, entry.label), entry.bias, entry.yaw_only, SOURCE_KNOWLEDGE_BASE,
                            f"{reason}: {entry.why}", entry.symmetry)


def _label(family: str, class_label: str) -> str:
    """The class label, with the family's material in front when the label names none ("brick wall")."""
    material = material_of(family)
    if material is None or material_of(class_label) is not None or material in class_label:
        return class_label
    return f"{material} {class_label}"
