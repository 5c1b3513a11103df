"""UprightPrior and the PriorProvider protocol."""

from __future__ import annotations

import json
import math

import pytest

from bim2rdt.errors import Bim2RdtError
from bim2rdt.semantics import KnowledgeBasePriors, PriorProvider, UprightPrior


def test_a_bias_outside_zero_one_is_refused_with_a_typed_error():
    with pytest.raises(Bim2RdtError, match=r"outside \[0, 1\]"):
        UprightPrior("cone", 1.2, False, "llm", "x")


def test_a_prior_serialises_with_its_known_flag():
    prior = UprightPrior("cone", 0.4, False, "default", "no class")
    assert prior.to_dict() == {"label": "cone", "upright_bias": 0.4, "yaw_only": False, "source": "default",
                               "rationale": "no class", "symmetry": 1, "known": False}


def test_an_axial_symmetry_serialises_as_inf_and_reads_back():
    prior = UprightPrior("drum", 0.8, False, "llm", "round", math.inf)
    record = prior.to_dict()
    assert record["symmetry"] == "inf" and json.loads(json.dumps(record))["symmetry"] == "inf"
    assert UprightPrior(**{k: v for k, v in record.items() if k != "known"}) == prior


@pytest.mark.parametrize("order", [0, -2, 2.5, "round", None, float("nan"), -math.inf])
def test_a_symmetry_that_is_not_a_whole_order_or_inf_is_refused(order):
    with pytest.raises(Bim2RdtError, match="symmetry"):
        UprightPrior("thing", 0.5, False, "llm", "x", order)


def test_the_knowledge_base_is_a_prior_provider():
    assert isinstance(KnowledgeBasePriors(), PriorProvider)


def test_families_group_under_their_detector_label_in_first_seen_order():
    from bim2rdt.semantics import families_by_label

    priors = KnowledgeBasePriors().priors(["Wand-Int-ERDG-1", "Traffic_Cone_Orange_70cm", "Wall #2", "Cone"])
    assert families_by_label(priors) == {"wall": ["Wand-Int-ERDG-1", "Wall #2"],
                                         "traffic cone": ["Traffic_Cone_Orange_70cm", "Cone"]}
