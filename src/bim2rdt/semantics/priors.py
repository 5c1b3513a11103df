"""Upright priors: per BIM family, how strongly SG-ICP should pull the object upright.

In SG-ICP the bias weighs a soft upright term added to the rigid solve (``H <- H + lambda g_model g_world^T``
with ``lambda = bias * gamma0 * sum w |p|^2``; see docs and ``registration``). So 1.0 means "this object is
upright unless the data insist otherwise" (a column, a loaded crate), 0.0 means "no prior" (a hand tool lying
anywhere), and a tripod or a ladder sits low because it is tilted more often than not. ``yaw_only`` says the
object may only turn about gravity (permanent structure, a container set level). ``symmetry`` is the family's
rotational order about up: how many turns in 360 degrees show the same object (1 none, 2 a crate or pallet,
4 a square plate or a square-based cone, ``math.inf`` a drum): a turn by a symmetry is not a deviation.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from typing import Protocol, runtime_checkable

from bim2rdt.semantics.errors import SemanticsError

DEFAULT_UPRIGHT_BIAS = 0.5
"""The paper's beta_def: the bias of a family nobody knows, halfway between "no prior" and "always upright"."""

SOURCE_KNOWLEDGE_BASE = "knowledge-base"
SOURCE_DEFAULT = "default"
SOURCE_LLM = "llm"
FALLBACK_SUFFIX = " (llm fallback)"

AXIAL = math.inf
"""The symmetry order of a body of revolution about up (a drum, a bucket): any turn shows the same object."""
NO_SYMMETRY = 1.0
"""The symmetry order of a family nobody knows: no turn is taken for granted."""


def symmetry_order(value: object) -> float:
    """A rotational order about up as a float: a whole number >= 1, or ``math.inf`` (also spelt "inf").
    Raises :class:`SemanticsError` otherwise."""
    try:
        order = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        order = float("nan")
    if not (math.isinf(order) and order > 0) and not (order >= 1 and order == int(order)):
        raise SemanticsError(f"symmetry {value!r} is not a whole number >= 1 or inf")
    return order


@dataclass(frozen=True)
class UprightPrior:
    """The prior of one family: detector ``label``, ``upright_bias`` in [0, 1], ``yaw_only``, where it came
    from (``source``: knowledge-base, default, llm, or "... (llm fallback)"), why (``rationale``) and its
    rotational ``symmetry`` order about up (1, 2, 3, 4, ... or ``math.inf``)."""

    label: str
    upright_bias: float
    yaw_only: bool
    source: str
    rationale: str
    symmetry: float = NO_SYMMETRY

    def __post_init__(self) -> None:
        if not 0.0 <= self.upright_bias <= 1.0:
            raise SemanticsError(f"upright bias {self.upright_bias} of {self.label!r} is outside [0, 1]")
        object.__setattr__(self, "symmetry", symmetry_order(self.symmetry))

    @property
    def known(self) -> bool:
        """False when nothing recognised the family and the default bias was used (the family is flagged)."""
        return not self.source.startswith(SOURCE_DEFAULT)

    def to_dict(self) -> dict[str, object]:
        """The prior as JSON-ready data.

        Returns:
            Every field plus ``known``; an axial symmetry as the string "inf" (strict JSON has no infinity).
        """
        symmetry = "inf" if math.isinf(self.symmetry) else int(self.symmetry)
        return {**asdict(self), "symmetry": symmetry, "known": self.known}


@runtime_checkable
class PriorProvider(Protocol):
    """Anything that maps BIM family names to upright priors (offline knowledge base, an LLM, a fixed table).

    ``ifc_classes`` optionally gives each family's IFC entity (``IfcWall``): a hint for names that say nothing
    (ArchiCAD's ``Solid 397409098 200``, Revit's ``M_Fixed``)."""

    def priors(self, families: Iterable[str],
               ifc_classes: Mapping[str, str] | None = None) -> dict[str, UprightPrior]:
        """The upright priors of several families.

        Args:
            families: BIM family names (repeats allowed).
            ifc_classes: {family: IFC entity} hints for names that say nothing.

        Returns:
            One prior per distinct family, keyed by the family name as given.
        """
        ...


def families_by_label(priors: Mapping[str, UprightPrior]) -> dict[str, list[str]]:
    """Detector class -> the BIM families it stands for, in first-seen order.

    The labels are the detector's prompt list (["steel I-beam", "traffic cone", ...]); a detection's class
    name maps back to its families through this table, as the paper maps boxes to BIM families.

    Args:
        priors: {family: prior}.

    Returns:
        {detector class (the prior's label): [families]}, in first-seen order.
    """
    table: dict[str, list[str]] = {}
    for family, prior in priors.items():
        table.setdefault(prior.label, []).append(family)
    return table
