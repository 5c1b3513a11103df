"""The mission's knobs (lengths in metres, angles in degrees): ``Settings.mission`` (``BIM2RDT_MISSION__*``).

How densely models are sampled is the registration's ``IcpConfig.sample_count``, one field for both. How far an
element may sit from its BIM pose and still be as planned is the twin's tolerance preset (``Settings.twin``), the
one judge the mission, the twin and the reports share; so is the fitness under which a fit cannot be judged
(``Settings.twin.min_fitness``)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.perception import SLAB_CLEARANCE


class MissionConfig(BaseModel):
    """Knobs of one mission. Lengths in metres, angles in degrees."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    standoff: float = Field(2.6, gt=0.5, description="Camera distance from each object it is sent to look at.")
    camera_height: float = Field(1.1, gt=0.1, description="Camera height above the slab (quadruped with a mast).")
    slab_height: float = Field(0.0, description="World height of the floor the objects stand on, m: the storey's "
                                                "slab top (planning.find_floor), not a constant.")
    min_points: int = Field(30, ge=6, description="Fewer ROI points than this and the object is 'not seen'.")
    slab_contact: float = Field(0.05, ge=0.0, description="A BIM element whose lowest point is this close to the "
                                                          "slab stands on it (registration pulls it onto the slab).")
    ground_clearance: float = Field(SLAB_CLEARANCE, ge=0.0, description="ROI points below this height are slab, not object.")
    association_radius: float = Field(1.5, gt=0.0, description="Farthest a detection may be from its BIM element.")
    tie_ratio: float = Field(1.15, ge=1.0, description="A fit from the BIM pose within this factor of the best "
                                                        "score wins (the BIM is the prior).")
    merge_distance: float = Field(0.05, gt=0.0, description="A point this close to a registered object's surface "
                                                           "is explained by it (merging views, no truth needed).")
    merge_fraction: float = Field(0.5, gt=0.0, le=1.0, description="A detection whose points above the slab are "
                                  "at least this much explained by registered objects is another view of them.")
    max_see_through: float = Field(0.1, ge=0.0, le=1.0, description="A fit whose camera-facing surface stands "
                                   "where the station's camera saw through at more than this share of its cells is "
                                   "implausible (free space, as perception.visibility tests it).")
    explained_distance: float = Field(0.02, gt=0.0, description="A point this close to a known surface (the BIM's "
                                      "permanent elements, objects registered before) lies on it, m.")
    explained_fraction: float = Field(0.5, gt=0.0, le=1.0, description="A fit whose inliers lie at least this "
                                      "much on one known surface shows that surface, not an object: unverified, "
                                      "with the surface named (mission.explained).")
    missing_margin: float = Field(0.10, gt=0.0, description="A depth this much beyond a planned element's surface "
                                  "means the camera saw through its place, m.")
    missing_fraction: float = Field(0.8, gt=0.0, le=1.0, description="An element is missing when the camera saw "
                                    "through at least this share of its place's cells in one frame.")
    missing_in_view: float = Field(0.5, gt=0.0, le=1.0, description="Share of an element's camera-facing surface "
                                   "that must be in the image for its place to count as looked at.")
