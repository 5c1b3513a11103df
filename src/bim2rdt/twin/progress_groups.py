"""Progress without a schedule: the permanent elements grouped by storey and by class, each group's observed
percentage (built quantity over total quantity) and its elements counted by state."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from bim2rdt.bim import BimModel, Quantities
from bim2rdt.perception import permanent_elements
from bim2rdt.twin.progress import NOT_OBSERVED, PRODUCT_STATES, built_share, product_state


@dataclass(frozen=True)
class GroupProgress:
    """One group of elements: ``by`` ("storey" or "class"), its name, observed percentage (0-100; None when
    none of its elements was observed) and its elements counted by state."""

    by: str
    name: str
    observed_percent: float | None
    products: dict[str, int]

    def to_dict(self) -> dict:
        """The group as JSON-ready data.

        Returns:
            {by, name, observed_percent, products: {state: count}}.
        """
        observed = round(self.observed_percent, 1) if self.observed_percent is not None else None
        return {"by": self.by, "name": self.name, "observed_percent": observed, "products": dict(self.products)}


def group_progress(model: BimModel, statuses: Mapping[str, str], quantities: Quantities) -> list[GroupProgress]:
    """The permanent elements' progress by storey, then by class.

    Args:
        model: The BIM, loaded with geometry.
        statuses: {GlobalId: status} of the elements (absent: not observed).
        quantities: Their quantities (see ``bim.quantities.product_quantities``).

    Returns:
        One group per storey (elements in none: "no storey"), then one per IFC class, in name order.
    """
    groups: dict[tuple[str, str], list[str]] = {}
    for element in permanent_elements(model):
        groups.setdefault(("storey", element.storey or "no storey"), []).append(element.global_id)
        groups.setdefault(("class", element.ifc_class), []).append(element.global_id)
    return [_group(by, name, ids, statuses, quantities) for (by, name), ids in
            sorted(groups.items(), key=lambda item: (item[0][0] != "storey", item[0][1]))]


def _group(by: str, name: str, ids: list[str], statuses: Mapping[str, str], quantities: Quantities) -> GroupProgress:
    states = [product_state(statuses.get(global_id)) for global_id in ids]
    counts = {state: states.count(state) for state in PRODUCT_STATES}
    total = quantities.total(ids)
    built = float(sum(quantities.values.get(g, 0.0) * built_share(state) for g, state in zip(ids, states)))
    seen = len(ids) - counts[NOT_OBSERVED]
    return GroupProgress(by, name, 100.0 * built / total if seen and total > 0 else None, counts)
