"""One judge of as planned vs deviating: the twin's tolerance presets. The mission measures the deviation the way
the twin does and classifies it by the element's preset, so its verdict, the twin's state and the BCF agree:
3 cm off is as planned for a temporary site object (5 cm / 5 degrees) and deviating for a column (1 cm / 0.5)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from bcf.v2.bcfxml import BcfXml

from bim2rdt.mission import MissionConfig, Target
from bim2rdt.mission.verdict import judge, tolerance_of
from bim2rdt.perception.observation import Observation
from bim2rdt.perception.library import element_body_mesh
from bim2rdt.twin import DigitalTwin, ElementStatus, TwinConfig


def _target(model, ifc_class: str) -> Target:
    element = next(el for el in model.elements if el.ifc_class == ifc_class and model.has_mesh(el.global_id))
    return Target(element.global_id, element.family or ifc_class, element.placement,
                  element_body_mesh(model, element.global_id), element.ifc_class)


def _three_cm_off(target: Target) -> np.ndarray:
    T = target.placement.copy()
    T[:3, 3] += (0.03, 0.0, 0.0)
    return T


def test_three_cm_off_is_as_planned_for_a_site_object_and_deviating_for_a_column_in_mission_twin_and_bcf(
        site_model, tmp_path):
    policy = TwinConfig().tolerance_policy()
    proxy, column = _target(site_model, "IfcBuildingElementProxy"), _target(site_model, "IfcColumn")
    verdicts = {}
    for target in (proxy, column):
        fit = SimpleNamespace(pose=_three_cm_off(target), fitness=0.95, rmse=0.004)
        verdicts[target.global_id] = judge(target, fit, 1, MissionConfig(), tolerance_of(target, policy))
    assert verdicts[proxy.global_id].status is ElementStatus.AS_PLANNED
    assert verdicts[column.global_id].status is ElementStatus.DEVIATING
    assert verdicts[column.global_id].shift == pytest.approx(0.03)
    with DigitalTwin.open(f"sqlite:///{tmp_path / 'twin.db'}", site_model, tolerances=policy) as twin:
        for target in (proxy, column):
            state = twin.record(Observation(target.family, target.global_id, _three_cm_off(target), 0.004, 0.95,
                                            200), 0.0)
            assert state.status is verdicts[target.global_id].status
            assert state.deviation.translation == pytest.approx(verdicts[target.global_id].shift)
        bcf = BcfXml.load(twin.export_bcf(tmp_path / "issues.bcf"))
        issues = [t.topic.title for t in bcf.topics.values()]
        bcf.close()
    assert len(issues) == 1 and column.family in issues[0]


def test_a_preset_set_in_the_twins_settings_is_what_the_mission_judges_by():
    """Tighten the temporary preset to 2 cm in Settings.twin: the same 3 cm crate is now deviating for the
    mission too (it has no threshold of its own left to disagree with)."""
    from bim2rdt.sim.meshes import mesh_for_family

    crate = Target("c", "Wooden_Crate_1200x800x600", np.eye(4), mesh_for_family("Wooden_Crate_1200x800x600"),
                   "IfcBuildingElementProxy")
    fit = SimpleNamespace(pose=_three_cm_off(crate), fitness=0.95, rmse=0.004)
    tight = TwinConfig(presets={"temporary": {"translation": 0.02, "rotation_deg": 5.0},
                                "structural": {"translation": 0.01, "rotation_deg": 0.5}}).tolerance_policy()
    assert judge(crate, fit, 2, MissionConfig()).status is ElementStatus.AS_PLANNED
    assert judge(crate, fit, 2, MissionConfig(), tolerance_of(crate, tight)).status is ElementStatus.DEVIATING


@pytest.mark.parametrize("fitness", [0.3, 0.49, 0.5, 0.7])
def test_the_mission_and_the_twin_trust_a_fit_by_the_same_fitness_setting(site_model, tmp_path, fitness):
    """Whether a fit can be judged at all is one rule with one setting (``Settings.twin.min_fitness``): the
    same fit is unverified for both under it and judged by both at or over it, at the default and at a raised
    setting; the mission has no threshold of its own left to disagree with."""
    proxy = _target(site_model, "IfcBuildingElementProxy")
    fit = SimpleNamespace(pose=proxy.placement.copy(), fitness=fitness, rmse=0.004)
    assert "min_fitness" not in MissionConfig.model_fields
    for config in (TwinConfig(), TwinConfig(min_fitness=0.6)):
        mission = judge(proxy, fit, 1, MissionConfig(), min_fitness=config.min_fitness).status
        with DigitalTwin.open(f"sqlite:///{tmp_path / f'twin-{config.min_fitness}.db'}", site_model,
                              min_fitness=config.min_fitness) as twin:
            state = twin.record(Observation(proxy.family, proxy.global_id, fit.pose, 0.004, fitness, 200), 0.0)
        expected = ElementStatus.AS_PLANNED if fitness >= config.min_fitness else ElementStatus.UNVERIFIED
        assert mission is state.status is expected


def test_verify_and_the_mission_judge_through_the_one_judge_with_the_twins_setting():
    """verify and the mission both judge by :func:`bim2rdt.twin.judge_evidence` (trust, missing, unverified, not
    observed in one place) with the twin's ``min_fitness``; neither keeps a comparison of its own."""
    import inspect

    from bim2rdt.mission import absence, run, verdict
    from bim2rdt.verify import chain, fusion

    assert chain.VerifyConfig().min_fitness == TwinConfig().min_fitness
    verify_source = inspect.getsource(chain) + inspect.getsource(fusion)
    mission_source = inspect.getsource(verdict) + inspect.getsource(run)
    assert "judge_evidence(" in verify_source and "judge_evidence(" in mission_source
    assert "place_seen_empty(" in inspect.getsource(absence)
    for source in (verify_source, mission_source):
        assert ">= config.min_fitness" not in source and "fit_trusted(" not in source
