"""Missing elements: a planned object whose place the robot looked at and saw empty.

No detection claiming an element is not evidence that it is gone: the robot may not have looked, a wall may
stand between, the detector may have missed it. The evidence is the depth. For each frame the mission took at a
station, the element's camera-facing surface at its BIM placement is projected into the frame
(:func:`bim2rdt.perception.visibility.look_at_place`): if enough of it falls in the image, and at nearly all of
the cells the camera measured a surface *beyond* where the element's surface should be, the camera saw through
its place, so it is not there (MISSING). A place with a nearer surface in front of it (a wall, a worker, a
neighbour) is occluded, not empty; a place outside every frame was simply not looked at (NOT OBSERVED)."""

from __future__ import annotations

from collections.abc import Mapping
from bim2rdt.mission.config import MissionConfig
from bim2rdt.mission.records import MissingElement, Target
from bim2rdt.perception import Frame
from bim2rdt.perception import DepthView, PlaceLook, look_at_place
from bim2rdt.registration import IcpConfig, sample_model
from bim2rdt.twin import JudgeConfig, PlaceEvidence, place_seen_empty


def depth_view(frame: Frame) -> DepthView:
    """The part of a station's frame the absence test reads: depth, intrinsics, camera pose."""
    return DepthView(frame.depth, frame.intrinsics, frame.T_world_camera)


def seen_empty(target: Target, views: Mapping[int, DepthView], config: MissionConfig,
               icp: IcpConfig = IcpConfig()) -> MissingElement | None:
    """The evidence that ``target``'s place was seen empty in the stations' ``views``, or None (not in view,
    occluded, or something is there)."""
    model_pts, model_normals = sample_model(target.mesh_body, icp.sample_count, seed=icp.seed)
    empty = {}
    for station, view in views.items():
        look = look_at_place(target.placement, model_pts, model_normals, view, config.missing_margin)
        if shows_empty(look, config):
            empty[station] = look
    if not empty:
        return None
    best = max(empty, key=lambda station: empty[station].through)
    open_cells = empty[best].seen - empty[best].blocked
    return MissingElement(target.global_id, target.family, best, tuple(sorted(empty)),
                          empty[best].through / open_cells, open_cells)


def shows_empty(look: PlaceLook, config: MissionConfig) -> bool:
    """The one judge's rule (:func:`bim2rdt.twin.place_seen_empty`, shared with ``verify``) on a station's look:
    in view (at least ``missing_in_view`` of its facing surface in the image, of the cells with a depth return at
    least ``min_points`` and half not occluded: nothing nearer in front) and seen through at
    ``missing_fraction`` of the cells not occluded."""
    return place_seen_empty(place_of(look), judge_rules(config))


def place_of(look: PlaceLook) -> PlaceEvidence:
    """A station's look at a place as the one judge's evidence: its open cells (a return, nothing nearer) in sight,
    its blocked ones hidden."""
    return PlaceEvidence(look.facing, look.seen - look.blocked, look.through, look.blocked, look.in_frame)


def judge_rules(config: MissionConfig) -> JudgeConfig:
    """The mission's settings of the place rules, as the one judge's."""
    return JudgeConfig(missing_fraction=config.missing_fraction, min_place_points=config.min_points,
                       min_in_view=config.missing_in_view, max_hidden=0.5)
