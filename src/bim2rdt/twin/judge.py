"""The one judge of what a view says about a planned element, for ``verify`` and the mission alike.

Two pieces of evidence: the element's planned place as the sensor saw it (:class:`PlaceEvidence`: of its
sensor-facing surface, how much was in sight, how much the sensor saw past, how much a nearer surface hid), and
a fit of the element's body to the points near it (:class:`FitEvidence`), if any. In this order:

1. **by its pose** (status None: the twin's tolerance preset decides as planned or deviating) when a fit of that
   object is trusted: it explains enough of its points (``min_fitness``, the twin's) and the observer found
   nothing wrong with it (the fit stands where the sensor saw through, on another element's surface, on no
   point at all);
2. **missing** when the sensor saw through where the object should be: at least ``missing_fraction`` of its
   place's surface in sight (and at least ``min_place_points`` of it), the return beyond it;
3. **unverified**, always with a reason, when a fit was made but is not trusted;
4. **not observed**, with a reason, when the view was not enough: too little of its place in sight (out of the
   image, or behind something nearer).
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.twin.status import ElementStatus
from bim2rdt.twin.verdict import fit_trusted


class JudgeConfig(BaseModel):
    """Thresholds of the one judge (shares are fractions): ``Settings.judge`` (``BIM2RDT_JUDGE__*``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    missing_fraction: float = Field(0.8, gt=0.0, le=1.0, description="A place is seen empty when the sensor saw "
                                    "past at least this share of its surface in sight (the mission's rule).")
    min_place_points: int = Field(30, ge=1, description="Fewer samples (or image cells) of a place in sight than "
                                  "this and the view was not enough to call it empty.")
    min_in_view: float = Field(0.25, gt=0.0, le=1.0, description="... nor when less than this share of its facing "
                               "surface was in the image (a return on its ray, nearer or not). office1's desk moved "
                               "1.5 m towards the camera in the IFC: 38 % in the image, all of it seen through. The "
                               "mission passes its own ``missing_in_view`` (0.5: a station faces its target).")
    max_hidden: float = Field(0.5, ge=0.0, le=1.0, description="... nor when more than this share of its place in "
                              "the image was hidden behind something nearer (a worker, a neighbour).")
    min_fit_on: float = Field(0.1, ge=0.0, le=1.0, description="A fit counts as one of that object only when the "
                              "sensor measured on its posed surface at this share of the surface in the image "
                              "(in sight or hidden): office1's desk, a table seen as a box, 15 %; a cabinet added "
                              "to the IFC on empty floor, fitted onto the chair 56 cm away, 5 %.")


@dataclass(frozen=True)
class PlaceEvidence:
    """A planned place as one view saw it, in samples (or image cells) of its sensor-facing surface: ``facing``
    in all, ``in_sight`` with a return on or past it, ``through`` of those past it by the margin, ``hidden``
    with a nearer return (occluded)."""

    facing: int
    in_sight: int
    through: int
    hidden: int = 0
    in_frame: int | None = None
    """Facing samples inside the image (a camera's frustum); None: those with a return (in sight or hidden)."""

    @property
    def in_image(self) -> int:
        """Facing samples inside the image."""
        return self.in_sight + self.hidden if self.in_frame is None else self.in_frame

    @property
    def on_share(self) -> float:
        """Share of the place in the image (in sight or hidden) where the sensor measured on its surface."""
        seen = self.in_sight + self.hidden
        return (self.in_sight - self.through) / seen if seen else 0.0

    @property
    def through_share(self) -> float:
        """Share of the place in sight that the sensor saw past (0 when nothing was in sight)."""
        return self.through / self.in_sight if self.in_sight else 0.0

    def combined(self, other: PlaceEvidence) -> PlaceEvidence:
        """This view's evidence and another's, summed (several frames of one place).

        Args:
            other: The other view's evidence of the same place.

        Returns:
            The counts of both views added.
        """
        return PlaceEvidence(self.facing + other.facing, self.in_sight + other.in_sight,
                             self.through + other.through, self.hidden + other.hidden,
                             self.in_image + other.in_image)


@dataclass(frozen=True)
class FitEvidence:
    """A fit of the element: the share of its points on the posed body (``fitness``), and ``problem``, what its
    observer found wrong with it ("" when nothing), phrased to follow "unverified"."""

    fitness: float
    problem: str = ""


@dataclass(frozen=True)
class Judgement:
    """``status`` None means: judge the fit's pose against the element's tolerance (the twin does); ``reason``
    says why a status other than that was given."""

    status: ElementStatus | None
    reason: str = ""


def judge_evidence(place: PlaceEvidence | None, fit: FitEvidence | None, min_fitness: float,
                   config: JudgeConfig = JudgeConfig()) -> Judgement:
    """The verdict the evidence supports (see the module's note for the order of the rules).

    Args:
        place: The planned place as the view saw it; None when the observer did not look at it (a mission's
            detection, associated to its element, without its frame's depth).
        fit: The fit of the element's body; None when nothing was fitted (too few points of its own).
        min_fitness: The twin's ``min_fitness``: under it a fit cannot be judged.
        config: The judge's thresholds.

    Returns:
        The status (None: by the fit's pose against the tolerance) and the reason for any other.
    """
    if fit is not None and not fit.problem and fit_trusted(fit.fitness, min_fitness):
        return Judgement(None)
    if place is not None and place_seen_empty(place, config):
        return Judgement(ElementStatus.MISSING, f"(the sensor saw through {place.through_share:.0%} of its place)")
    if fit is not None:
        return Judgement(ElementStatus.UNVERIFIED, fit.problem or (f"(the fit explains {fit.fitness:.0%} of its "
                                                                   f"points, under {min_fitness:.0%})"))
    if place is None:
        return Judgement(ElementStatus.NOT_OBSERVED, "(not looked at)")
    return Judgement(ElementStatus.NOT_OBSERVED, _not_enough(place, config))


def place_seen_empty(place: PlaceEvidence, config: JudgeConfig = JudgeConfig()) -> bool:
    """Whether the view shows the place empty.

    Args:
        place: The place as the view saw it.
        config: The judge's thresholds.

    Returns:
        True when enough of it was in view (``min_in_view`` of its facing surface in the image, at most
            ``max_hidden`` of that hidden, ``min_place_points`` in sight) and it was seen through at
            ``missing_fraction`` of what was in sight.
    """
    in_view = place.facing > 0 and place.in_image >= config.min_in_view * place.facing
    shown = place.in_sight + place.hidden
    return (in_view and place.in_sight >= config.min_place_points and place.hidden <= config.max_hidden * shown
            and place.through >= config.missing_fraction * place.in_sight)


def _not_enough(place: PlaceEvidence, config: JudgeConfig) -> str:
    """Why a place without a fit was not judged empty: which of :func:`place_seen_empty`'s conditions failed."""
    shown = place.in_sight + place.hidden
    if place.facing == 0 or place.in_image < config.min_in_view * place.facing:
        why = f"{place.in_image} of its {place.facing} facing samples in the image"
    elif place.hidden > config.max_hidden * shown:
        why = f"{place.hidden} of its {shown} samples in the image hidden behind something nearer"
    elif place.in_sight < config.min_place_points:
        why = f"{place.in_sight} samples of its place in sight, under {config.min_place_points}"
    else:
        return (f"(in sight, but too few points of its own to fit, and seen through at only "
                f"{place.through_share:.0%} of its place, under {config.missing_fraction:.0%})")
    return f"(the view was not enough: {why}; too few points of its own to fit)"
