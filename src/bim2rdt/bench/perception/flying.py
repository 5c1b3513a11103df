"""What time-of-flight mixed ("flying") pixels cost registration, and what the planarity-aware edge filter wins
back: scenario S1 (cone, drum, crate; low front view) registered with SG-ICP on corners whose depth is clean,
has flying pixels, has them filtered by :class:`~bim2rdt.perception.EdgeFilter`, or filtered the naive way
(every pixel next to a depth step dropped, slanted surfaces and all)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bim2rdt.evaluation.peers import SgIcp
from bim2rdt.evaluation.runs import upright_priors
from bim2rdt.evaluation.stats import MethodStats, run_scenario
from bim2rdt.perception import EdgeFilter
from bim2rdt.registration import IcpConfig
from bim2rdt.sim.scenarios import SCENARIOS, scenario
from bim2rdt.sim.tof import TofEffects, step_pixels


class NaiveEdgeFilter:
    """The filter a planarity test replaces: drop every pixel with a neighbour more than 2 cm + 2 % nearer or
    farther (a floor at grazing incidence loses its far rows, a silhouette loses a pixel each side)."""

    def apply(self, depth: np.ndarray) -> np.ndarray:
        out = np.array(depth, dtype=np.float32, copy=True)
        out[step_pixels(np.asarray(depth, dtype=float), 0.02, 0.02)] = np.nan
        return out


@dataclass(frozen=True)
class FlyingCondition:
    label: str
    tof: TofEffects | None
    edge_filter: object | None


CONDITIONS = (
    FlyingCondition("clean depth", None, None),
    FlyingCondition("flying pixels", TofEffects(dropouts=False), None),
    FlyingCondition("flying pixels + planarity filter", TofEffects(dropouts=False), EdgeFilter()),
    FlyingCondition("flying pixels + naive edge filter", TofEffects(dropouts=False), NaiveEdgeFilter()),
)


def flying_pixel_study(trials: int, seed: int, config: IcpConfig, name: str = "S1",
                       tick: Callable[[], None] = lambda: None) -> list[dict]:
    """SG-ICP on scenario ``name`` under each of :data:`CONDITIONS`, same seeds throughout: per condition the
    Hausdorff RMSE's mean (the paper's figure; a few flipped crates dominate it), median and 90th percentile,
    the success rate (< 2 deg, < 1 cm) and the number of registrations."""
    priors = upright_priors([family for family, *_ in SCENARIOS[name].layout])
    method = SgIcp(config, use_prior=True)
    out = []
    for condition in CONDITIONS:
        built = scenario(name, trials=trials, seed=seed, tof=condition.tof, edge_filter=condition.edge_filter)
        result = run_scenario(built, [method], priors, tick=tick)
        rmse = np.array([row[0] for row in result.rows[method.name]])
        stats: MethodStats = result.stats[method.name]
        out.append({"condition": condition.label, "rmse_mean": float(rmse.mean()),
                    "rmse_median": float(np.median(rmse)), "rmse_p90": float(np.percentile(rmse, 90)),
                    "success": stats.success, "registrations": stats.registrations})
    return out
