"""The detectors a robot's frames can be read with, by name: the one registry the demo and the CLI share.

- ``geometric`` (the default): scan-vs-BIM, no weights (:class:`~bim2rdt.perception.GeometricDetector`);
- ``yoloe``: YOLOE on local weights and prompt embeddings (extra ``yoloe``; nothing is downloaded);
- ``ideal``: a simulator's own masks with the true families, the upper bound, for comparison only. Perception
  never sees simulated truth, so the simulation hands in its factory (``ideal``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from bim2rdt.bim import BimModel
from bim2rdt.perception.detector import Detector
from bim2rdt.perception.errors import PerceptionError
from bim2rdt.perception.geometric import GeometricConfig, GeometricDetector
from bim2rdt.semantics import UprightPrior

DEFAULT_DETECTOR = "geometric"
DETECTORS = ("geometric", "yoloe", "ideal")
"""Every detector name, the default first."""


class UnknownDetectorError(PerceptionError, ValueError):
    """A detector name not in :data:`DETECTORS`."""


def check_detector(name: str, yoloe: tuple[Path, Path] | None = None) -> None:
    """PerceptionError (one line) when ``name`` is no detector, or is ``yoloe`` without its local files
    (``yoloe``: weights, prompt embeddings); the edge calls it before a long run starts."""
    if name not in DETECTORS:
        raise UnknownDetectorError(f"unknown detector {name!r}; choose one of {', '.join(DETECTORS)}")
    if name == "yoloe" and (yoloe is None or None in yoloe):
        raise PerceptionError("--detector yoloe needs --yoloe-weights and --yoloe-embeddings (local files: nothing "
                              "is downloaded)")


def make_detector(name: str, model: BimModel, priors: dict[str, UprightPrior],
                  yoloe: tuple[Path, Path] | None = None, ideal: Callable[[], Detector] | None = None,
                  geometric: GeometricConfig | None = None) -> Detector:
    """The detector called ``name`` for ``model``'s site objects (``priors`` name the families): ``yoloe`` gives
    its local weights and prompt embeddings, ``ideal`` builds the simulator's (a simulation only has one),
    ``geometric`` the geometric detector's settings (``Settings.perception.geometric``; None: the defaults)."""
    check_detector(name, yoloe)
    if name == "geometric":
        return GeometricDetector(model, priors, geometric or GeometricConfig())
    if name == "yoloe":
        from bim2rdt.perception.yoloe import YoloeDetector

        return YoloeDetector(yoloe[0], yoloe[1], sorted(priors))
    if ideal is None:
        raise PerceptionError("the ideal detector reads a simulator's masks: it runs only on a simulated site")
    return ideal()
