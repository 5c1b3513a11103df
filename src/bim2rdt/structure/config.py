"""The structure judge's settings (``Settings.structure``, ``BIM2RDT_STRUCTURE__*``): the tolerance of each class of
permanent element and the thresholds of coverage, "not built" and the deviation bands.

Default tolerances are the upper bounds of USIBD Level of Accuracy bands (USIBD LOA Specification v3.0, 2019;
each band is a range of the standard deviation at 95 % confidence, i.e. 2 sigma):

- LOA30 (5-15 mm): walls, slabs, columns, beams, stairs and ramps, 15 mm: a structural element's line, level or
  plumb; a wall built 4 cm off its line is deviating, a Kinect's centimetre of noise averages out in a median;
- LOA20 (15-50 mm): doors and windows, 50 mm: a leaf or frame set in its opening;
- anything else judged: LOA20's 50 mm.

The tolerance applies to the element's offset (where its faces pin it) or, where they do not, to the median of its
signed distances; ``rotation_deg`` to a face's lean (a vertical face's out of plumb, a horizontal one's out of level:
a column out of plumb): 1 degree for structure (15 mm over the first metre of face, LOA30's bound again), 2 for
doors and windows. The bands are not angular; on office1's Kinect frame (depth corrected, verify's fix) the walls
built plumb lean 0.7 degrees or less and the floor 0.3, so 1 degree stays above the sensor's own.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

LOA30 = 0.015
"""USIBD LOA30's upper bound, m (5-15 mm at 2 sigma)."""
LOA20 = 0.050
"""USIBD LOA20's upper bound, m (15-50 mm at 2 sigma)."""


class StructureTolerance(BaseModel):
    """How far a permanent element may be from the model and still be "as planned"."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    translation: float = Field(gt=0, description="Largest offset of the element (or median signed distance of its "
                               "faces), metres.")
    rotation_deg: float = Field(gt=0, description="Largest lean of a face against the model's (out of plumb or "
                                "level), degrees.")


def _loa30() -> StructureTolerance:
    return StructureTolerance(translation=LOA30, rotation_deg=1.0)


def _default_tolerances() -> dict[str, StructureTolerance]:
    structural = ("IfcWall", "IfcWallStandardCase", "IfcWallElementedCase", "IfcSlab", "IfcSlabStandardCase",
                  "IfcSlabElementedCase", "IfcColumn", "IfcColumnStandardCase", "IfcBeam", "IfcBeamStandardCase",
                  "IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight")
    openings = ("IfcDoor", "IfcDoorStandardCase", "IfcWindow", "IfcWindowStandardCase")
    return ({c: _loa30() for c in structural}
            | {c: StructureTolerance(translation=LOA20, rotation_deg=2.0) for c in openings})


class StructureConfig(BaseModel):
    """Parameters of :func:`bim2rdt.structure.judge_structure` (lengths in metres, angles in degrees)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    tolerances: dict[str, StructureTolerance] = Field(
        default_factory=_default_tolerances,
        description="IFC class -> tolerance (USIBD LOA30 15 mm for structure, LOA20 50 mm for doors and windows).")
    default_tolerance: StructureTolerance = Field(
        default_factory=lambda: StructureTolerance(translation=LOA20, rotation_deg=2.0),
        description="Tolerance of a judged class the table does not name.")
    min_coverage: float = Field(
        0.1, ge=0.0, le=1.0,
        description="Under this share of its sensor-facing surface covered by data, an element is not observed.")
    cell: float = Field(0.1, gt=0.0, description="Surface cells of this size count coverage, m.")
    sphere_step_deg: float = Field(
        0.5, gt=0.0, le=5.0,
        description="Spacing of the rays that find each element's sensor-facing surface from where the sensor stood, "
                    "degrees (0.5 deg: 7 cm at 8 m, under a cell).")
    min_range: float = Field(0.3, gt=0.0, description="Returns nearer than this are ignored, m.")
    max_range: float = Field(8.0, gt=0.0, description="Returns and surfaces farther than this are ignored, m.")
    on_band: float = Field(
        0.1, gt=0.0,
        description="A return within this of its ray's model face (along the normal) lies on it, m: the largest "
                    "deviation measured; beyond it in front it is something before the face (clutter).")
    through_margin: float = Field(
        0.15, gt=0.0, description="A return this far beyond its ray's model face (along the normal) was seen through "
                                  "it, m.")
    not_built_fraction: float = Field(
        0.9, gt=0.0, le=1.0,
        description="An element whose face in clear view (returns on it or through it) is seen through over this "
                    "share, and covered nowhere else, is not built.")
    min_clear_area: float = Field(
        0.25, gt=0.0, description="Less of the face in clear view than this, m^2, and nothing says it is not built.")
    partly_through: float = Field(
        0.3, gt=0.0, le=1.0,
        description="An observed element seen through over more than this share of its face in clear view is "
                    "deviating (a wall partly built, its built_share the rest; a door or window with an opening the "
                    "model lacks); seen through so in one view, it takes no part in that view's consensus pose.")
    min_points: int = Field(30, ge=3, description="Fewer returns on an element than this, and it is not observed.")
    min_face_points: int = Field(30, ge=3, description="A face (one normal) pins an offset with this many returns.")
    min_face_extent: float = Field(
        0.3, gt=0.0, description="A face's tilt is measured where its returns span this much both ways, m.")
    huber: float = Field(0.02, gt=0.0, description="Huber scale of the leave-one-out pose refit, m.")
    min_pin_points: float = Field(
        30.0, gt=0.0,
        description="The other elements pin the pose along a face's normal when this many of their returns (each "
                    "weighted by the cosine squared of its normal with it) face that way.")
    points_per_view: int = Field(60_000, ge=1000, description="At most this many returns of a view are used.")
    colour_limit: float = Field(
        0.05, gt=0.0, description="Deviation maps run their colour scale over +- this, m (beyond: the end colour).")
    far: float = Field(
        0.2, gt=0.0, description="A return farther than this from every permanent face is not the structure's "
                                 "(furniture, people): grey in the deviation maps, m.")
    sample_spacing: float = Field(
        0.02, gt=0.0, description="The permanent faces are sampled this densely to find each return's nearest, m "
                                  "(coarser on a large model: at most 2 million samples).")
    ply_points: int = Field(2_000_000, ge=1000, description="deviation.ply holds at most this many points.")
