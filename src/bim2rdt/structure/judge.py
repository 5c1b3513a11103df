"""Each permanent element judged from the survey's evidence: as planned, deviating, not built or not observed.

- not built: its face in clear view (returns on it or beyond it) covers at least ``min_clear_area`` and is seen
  through over ``not_built_fraction`` of it (a door seen through is open, a window glazed: not observed instead);
- not observed: under ``min_coverage`` of its sensor-facing surface covered, or under ``min_points`` returns;
- deviating: seen through over ``partly_through`` of its face in clear view (partly built: its ``built_share`` is
  the share not seen through, which progress weighs its quantity by; a door or window seen through so far has an
  opening the model lacks), or its offset (where its faces pin one; else the median signed distance) beyond its
  class's tolerance, or a face tilted beyond it;
- as planned: within it.

The face in clear view counts only decisive returns (:mod:`~bim2rdt.structure.survey`): where an element ends at
a wall or the floor behind it, a return there lies on both and says neither built nor not built.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from bim2rdt.bim import BimModel
from bim2rdt.structure.config import StructureConfig, StructureTolerance
from bim2rdt.structure.records import (AS_PLANNED, DEVIATING, NOT_BUILT, NOT_OBSERVED, StructureJudgement,
                                       StructureView)
from bim2rdt.structure.scene import PERMANENT_CLASSES
from bim2rdt.structure.survey import ElementEvidence, FaceEvidence, StructureSurvey, tolerance_of

SEE_THROUGH_CLASSES = frozenset({"IfcDoor", "IfcDoorStandardCase", "IfcWindow", "IfcWindowStandardCase"})
"""Seen through, these are open or glazed, not unbuilt."""


def judge_structure(model: BimModel, views: Iterable[StructureView],
                    config: StructureConfig = StructureConfig()) -> list[StructureJudgement]:
    """Judge every permanent element of ``model`` (:data:`~bim2rdt.structure.scene.PERMANENT_CLASSES`) from the
    views that saw it.

    Args:
        model: The BIM, loaded with geometry.
        views: Each frame's or scan's returns (sensor frame) and BIM-fixed pose.
        config: Tolerances and thresholds (``Settings.structure``).

    Returns:
        One judgement per permanent element, in model order.
    """
    survey = StructureSurvey(model, config)
    for view in views:
        survey.add(view)
    return judgements(survey)


def judgements(survey: StructureSurvey) -> list[StructureJudgement]:
    """The judgement of every permanent element from a survey's evidence.

    Args:
        survey: The views' evidence.

    Returns:
        One judgement per permanent element, in model order.
    """
    out = []
    for element in survey.model.elements:
        if element.ifc_class not in PERMANENT_CLASSES:
            continue
        evidence = survey.evidence.get(element.global_id)
        if evidence is None:
            why = "no body" if not survey.model.has_mesh(element.global_id) else "not in view of any frame"
            out.append(StructureJudgement(element.global_id, element.ifc_class, NOT_OBSERVED, 0.0, reason=why))
            continue
        out.append(judge_element(element.global_id, element.ifc_class, evidence, survey.config))
    return out


def judge_element(global_id: str, ifc_class: str, evidence: ElementEvidence,
                  config: StructureConfig) -> StructureJudgement:
    """One element's judgement (see the module's note).

    Args:
        global_id: The element's GlobalId.
        ifc_class: Its IFC class.
        evidence: What the views said about it.
        config: Tolerances and thresholds.

    Returns:
        The judgement.
    """
    coverage = len(evidence.covered) / max(len(evidence.visible | evidence.covered), 1)
    rho = np.concatenate([r for f in evidence.faces.values() for r in f.rho]) if evidence.faces else np.zeros(0)
    median = float(np.median(rho)) if len(rho) else None
    offset, rotation = element_offset(evidence, config), element_rotation(evidence, config)
    status, reason, built = _status(ifc_class, evidence, coverage, len(rho), offset, median, rotation, config)
    return StructureJudgement(
        global_id, ifc_class, status, round(coverage, 3), _mm(median),
        _mm(float(np.percentile(np.abs(rho), 95)) if len(rho) else None),
        None if offset is None else tuple(round(float(v), 4) for v in offset),
        None if rotation is None else round(rotation, 2), sorted(evidence.frames), reason,
        None if built is None else round(built, 3))


def through_share(evidence: ElementEvidence) -> float:
    """The share (0-1) of the element's face in clear view that the views saw through (0 when none is in clear
    view): its cells with a return beyond the face over its cells with a decisive return, on it or beyond it.

    Args:
        evidence: What the views said about it.

    Returns:
        The share.
    """
    clear = len(evidence.clear)
    return len(evidence.through & evidence.clear) / clear if clear else 0.0


def _status(ifc_class: str, evidence: ElementEvidence, coverage: float, returns: int, offset: np.ndarray | None,
            median: float | None, rotation: float | None,
            config: StructureConfig) -> tuple[str, str, float | None]:
    """(status, reason, built share) by the module's rules, in their order."""
    clear_area, share = len(evidence.clear) * config.cell**2, through_share(evidence)
    if clear_area >= config.min_clear_area and share >= config.not_built_fraction:
        if ifc_class in SEE_THROUGH_CLASSES:
            return NOT_OBSERVED, f"seen through over {share:.0%} of its face in clear view: open, or glazed", None
        return NOT_BUILT, (f"its face in clear view ({clear_area:.2f} m2) is seen through over {share:.0%}, with "
                           f"returns on {1 - share:.0%}"), 0.0
    if coverage < config.min_coverage or returns < config.min_points:
        return NOT_OBSERVED, (f"coverage {coverage:.0%} of its sensor-facing surface, {returns} returns on it (need "
                              f"{config.min_coverage:.0%} and {config.min_points})"), None
    if share > config.partly_through and ifc_class not in SEE_THROUGH_CLASSES:
        return DEVIATING, (f"partly built: seen through over {share:.0%} of its face in clear view ({clear_area:.2f} "
                           f"m2), built on {1 - share:.0%}"), 1.0 - share
    if share > config.partly_through:
        return DEVIATING, f"seen through over {share:.0%} of its face in clear view: an opening the model lacks", 1.0
    status, reason = against(offset, median, rotation, tolerance_of(ifc_class, config))
    if evidence.unpinned:
        reason += "; along a face's normal the other elements in view did not pin the pose (measured from the fix)"
    return status, reason, 1.0


def against(offset: np.ndarray | None, median: float | None, rotation: float | None,
            tolerance: StructureTolerance) -> tuple[str, str]:
    """As planned or deviating: the offset's length (else the median's magnitude) against ``translation``, the
    tilt against ``rotation_deg``.

    Args:
        offset: (3,) m, or None.
        median: Median signed distance, m, or None.
        rotation: Tilt, degrees, or None.
        tolerance: The class's tolerance.

    Returns:
        (status, reason).
    """
    size, what = (float(np.linalg.norm(offset)), "offset") if offset is not None else (abs(median or 0.0), "median")
    tilt = rotation or 0.0
    limits = f"{1000 * tolerance.translation:.0f} mm / {tolerance.rotation_deg:g} deg"
    measured = f"{what} {1000 * size:.0f} mm, tilt {tilt:.1f} deg"
    if size > tolerance.translation or tilt > tolerance.rotation_deg:
        return DEVIATING, f"{measured}: beyond {limits}"
    return AS_PLANNED, f"{measured}: within {limits}"


def element_offset(evidence: ElementEvidence, config: StructureConfig) -> np.ndarray | None:
    """The element's translation (3,) m from its faces' median signed distances (``n . o = median``, each face
    weighted by the square root of its returns; directions no face pins are zero), or None when no face has
    ``min_face_points`` returns.

    Args:
        evidence: What the views said about it.
        config: The judge's settings.

    Returns:
        The offset, or None.
    """
    faces = [f for f in evidence.faces.values() if f.count >= config.min_face_points]
    if not faces:
        return None
    weights = np.sqrt([f.count for f in faces])
    A = np.array([f.normal for f in faces]) * weights[:, None]
    b = np.array([np.median(np.concatenate(f.rho)) for f in faces]) * weights
    U, sigma, Vt = np.linalg.svd(A, full_matrices=False)
    pinned = sigma > 0.3 * sigma.max()
    return Vt[pinned].T @ ((U[:, pinned].T @ b) / sigma[pinned])


def element_rotation(evidence: ElementEvidence, config: StructureConfig) -> float | None:
    """The mean tilt (degrees, weighted by returns) of the element's faces whose returns span ``min_face_extent``
    both ways: each face's plane fitted (PCA) against the model's normal; None when no face is that large.

    Args:
        evidence: What the views said about it.
        config: The judge's settings.

    Returns:
        The tilt, or None.
    """
    tilts, weights = [], []
    for face in evidence.faces.values():
        if face.count < config.min_face_points:
            continue
        tilt = face_tilt(face, config.min_face_extent)
        if tilt is not None:
            tilts.append(tilt)
            weights.append(face.count)
    return float(np.average(tilts, weights=weights)) if tilts else None


def face_tilt(face: FaceEvidence, extent: float) -> float | None:
    """The tilt (degrees) of a face's returns against its model plane: the signed distances regressed on the
    in-plane coordinates (a robust fit: returns beyond 3 MADs of it, clutter on the face, left out twice). A
    vertical face's tilt is its lean out of plumb (the slope up the face; a turn about up is the localization's
    yaw as much as the wall's, and its offset judges its line); a horizontal one's, its slope either way. None
    when the returns span less than ``extent`` m either way in the plane."""
    points, rho = np.concatenate(face.points), np.concatenate(face.rho)
    up = np.array([0.0, 0.0, 1.0]) - face.normal[2] * face.normal
    if np.linalg.norm(up) < 0.5:  # a horizontal face: any two axes in its plane
        basis = np.linalg.svd(np.eye(3) - np.outer(face.normal, face.normal))[0][:, :2]
    else:
        up /= np.linalg.norm(up)
        basis = np.column_stack([np.cross(face.normal, up), up])
    uv = (points - points.mean(axis=0)) @ basis
    spans = np.percentile(uv, 95, axis=0) - np.percentile(uv, 5, axis=0)
    if np.min(spans) < extent:
        return None
    design = np.column_stack([uv, np.ones(len(uv))])
    keep = np.ones(len(rho), bool)
    for _ in range(3):
        coef = np.linalg.lstsq(design[keep], rho[keep], rcond=None)[0]
        residual = rho - design @ coef
        spread = 1.4826 * np.median(np.abs(residual[keep] - np.median(residual[keep])))
        keep = np.abs(residual) <= max(3 * spread, 0.005)
    slope = coef[1] if np.linalg.norm(face.normal[:2]) > 0.5 else np.hypot(coef[0], coef[1])
    return float(np.degrees(np.arctan(abs(slope))))


def _mm(value: float | None) -> float | None:
    return None if value is None else round(1000 * value, 1)
