"""The site frame: the one frame every device's data is expressed in, tied to the earth where the IFC says how.

The site frame *is* the model's world frame (project engineering coordinates, metres, z-up). Its tie to the
earth comes from, in order of preference:

* ``IfcMapConversion`` (IFC4+): world -> projected map coordinates (eastings, northings, orthometric height)
  by a scale, a rotation about z (``XAxisAbscissa``/``XAxisOrdinate``) and an offset;
* ``IfcSite.RefLatitude/RefLongitude/RefElevation`` plus the context's ``TrueNorth``: a geodetic anchor of the
  world origin and the direction of north, enough for a local east-north-up tangent frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.util.unit
import numpy as np


@dataclass(frozen=True)
class SiteFrame:
    """The world frame's geo-reference. ``T_map_world`` maps world metres to map metres (None without a map
    conversion); ``true_north_deg`` is the angle from world +y to true north, counter-clockwise."""

    source: str
    T_map_world: np.ndarray | None = None
    crs_name: str | None = None
    latitude_deg: float | None = None
    longitude_deg: float | None = None
    elevation_m: float | None = None
    true_north_deg: float = 0.0

    @property
    def georeferenced(self) -> bool:
        """True when the file ties its world frame to the earth at all."""
        return self.source != "none"

    def to_map(self, points_world: np.ndarray) -> np.ndarray:
        """Convert world points to projected map coordinates.

        Args:
            points_world: (N,3) points in the model's world frame, metres.

        Returns:
            (N,3) projected map coordinates (easting, northing, height), metres.

        Raises:
            ValueError: The file has no IfcMapConversion.
        """
        return _apply(self._require_map(), points_world)

    def to_world(self, points_map: np.ndarray) -> np.ndarray:
        """Convert projected map coordinates (e.g. a GNSS fix) to world points.

        Args:
            points_map: (N,3) projected map coordinates (easting, northing, height), metres.

        Returns:
            (N,3) points in the model's world frame, metres.

        Raises:
            ValueError: The file has no IfcMapConversion.
        """
        return _apply(np.linalg.inv(self._require_map()), points_map)

    def _require_map(self) -> np.ndarray:
        if self.T_map_world is None:
            raise ValueError(f"the site frame has no map conversion (source: {self.source})")
        return self.T_map_world


def read_site_frame(ifc: ifcopenshell.file, unit_scale: float) -> SiteFrame:
    """The site frame of a parsed file; ``unit_scale`` is metres per project length unit."""
    north = _true_north_deg(ifc)
    latitude, longitude, elevation = _site_reference(ifc, unit_scale)
    conversions = ifc.by_type("IfcMapConversion") if ifc.schema != "IFC2X3" else []
    if conversions:
        conversion = conversions[0]
        crs = getattr(conversion.TargetCRS, "Name", None)
        return SiteFrame("IfcMapConversion", _map_matrix(conversion, unit_scale), crs,
                         latitude, longitude, elevation, north)
    source = "IfcSite" if latitude is not None and longitude is not None else "none"
    return SiteFrame(source, None, None, latitude, longitude, elevation, north)


def _map_matrix(conversion: ifcopenshell.entity_instance, unit_scale: float) -> np.ndarray:
    """world metres -> map metres: map = k * R(theta) * (world / unit_scale) + (E, N, H), all in map units."""
    map_unit = getattr(conversion.TargetCRS, "MapUnit", None)
    map_scale = ifcopenshell.util.unit.get_unit_scale(map_unit) if map_unit else unit_scale
    scale = conversion.Scale if conversion.Scale is not None else 1.0
    theta = math.atan2(conversion.XAxisOrdinate or 0.0, conversion.XAxisAbscissa or 1.0)
    T = np.eye(4)
    c, s = math.cos(theta), math.sin(theta)
    T[:3, :3] = map_scale * scale / unit_scale * np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    T[:3, 3] = map_scale * np.array([conversion.Eastings, conversion.Northings, conversion.OrthogonalHeight])
    return T


def _site_reference(ifc: ifcopenshell.file, unit_scale: float) -> tuple[float | None, float | None, float | None]:
    sites = ifc.by_type("IfcSite")
    if not sites:
        return None, None, None
    site = sites[0]
    elevation = site.RefElevation * unit_scale if site.RefElevation is not None else None
    return _degrees(site.RefLatitude), _degrees(site.RefLongitude), elevation


def _degrees(compound: tuple[int, ...] | None) -> float | None:
    """IfcCompoundPlaneAngleMeasure (deg, min, sec, millionths of a second; one shared sign) -> degrees."""
    if not compound:
        return None
    parts = list(compound) + [0] * (4 - len(compound))
    return parts[0] + parts[1] / 60.0 + parts[2] / 3600.0 + parts[3] / 3.6e9


def _true_north_deg(ifc: ifcopenshell.file) -> float:
    for context in ifc.by_type("IfcGeometricRepresentationContext", include_subtypes=False):
        if context.TrueNorth is not None:
            x, y = context.TrueNorth.DirectionRatios[:2]
            return math.degrees(math.atan2(-x, y))
    return 0.0


def _apply(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    return points @ T[:3, :3].T + T[:3, 3]
