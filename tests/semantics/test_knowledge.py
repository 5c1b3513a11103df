"""KnowledgeBasePriors: the curated table and the family-name matcher."""

from __future__ import annotations

import json
import math
from collections import Counter, defaultdict

import pytest

from bim2rdt.semantics import DEFAULT_UPRIGHT_BIAS, KnowledgeBasePriors, SemanticsError, load_table
from bim2rdt.semantics.names import phrase_tokens


@pytest.fixture(scope="module")
def kb() -> KnowledgeBasePriors:
    return KnowledgeBasePriors()


def test_the_table_covers_at_least_80_classes_in_every_category(kb):
    categories = Counter(entry.category for entry in kb.classes)
    assert len(kb.classes) >= 80
    assert {"permanent", "temporary works", "material", "equipment", "tool"} <= set(categories)
    assert len({entry.label for entry in kb.classes}) == len(kb.classes)


def test_every_label_and_synonym_matches_its_own_class(kb):
    wrong = []
    for entry in kb.classes:
        for synonym in (entry.label, *entry.synonyms):
            match = kb.match(synonym)
            if match is None or match.entry.label != entry.label:
                wrong.append((entry.label, synonym, match and match.entry.label))
    assert wrong == []


def test_no_synonym_belongs_to_two_classes(kb):
    owners = defaultdict(set)
    for entry in kb.classes:
        for synonym in (entry.label, *entry.synonyms):
            owners[frozenset(phrase_tokens(synonym))].add(entry.label)
    assert {tuple(words): labels for words, labels in owners.items() if len(labels) > 1} == {}


def test_biases_follow_the_physics_heavy_high_cone_lower_tripod_and_ladder_lowest(kb):
    bias = {family: prior.upright_bias for family, prior in kb.priors(
        ["Wooden_Crate_1200x800x600", "Steel_Drum_55gal", "Traffic_Cone_Orange_70cm",
         "Survey_Tripod_Aluminium", "Ladder", "Concrete Column", "Angle grinder"]).items()}
    assert bias["Concrete Column"] == 1.0
    assert bias["Wooden_Crate_1200x800x600"] > bias["Traffic_Cone_Orange_70cm"]
    assert bias["Steel_Drum_55gal"] > bias["Traffic_Cone_Orange_70cm"]
    assert bias["Traffic_Cone_Orange_70cm"] > bias["Survey_Tripod_Aluminium"] > bias["Ladder"]
    assert bias["Angle grinder"] < bias["Ladder"]


def test_permanent_structure_may_only_turn_about_gravity_and_loose_objects_may_tilt(kb):
    priors = kb.priors(["Basic Wall:Exterior - Brick on Block:130892", "Slab #1", "Traffic_Cone_Orange_70cm"])
    assert priors["Basic Wall:Exterior - Brick on Block:130892"].yaw_only
    assert priors["Slab #1"].yaw_only
    assert not priors["Traffic_Cone_Orange_70cm"].yaw_only


@pytest.mark.parametrize(("family", "label"), [
    ("Traffic_Cone_Orange_70cm", "traffic cone"),
    ("Cone Traffic", "traffic cone"),                      # word order
    ("cones, traffic", "traffic cone"),                    # plural
    ("Pallets of bricks", "brick stack"),                  # plural + stop word + word order
    ("Conc Col 300x300", "concrete column"),               # abbreviations
    ("Scaffold Ladder", "ladder"),                         # English: the noun is last
    ("Concrete Mixer Truck", "concrete mixer"),            # the longer synonym wins over "truck"
    ("Cable_Drum_500kg", "cable reel"),                    # ... and over "drum"
    ("Steel_I-Beam_W12x26_A992", "steel I-beam"),
    ("Pallet_Wood_EUR", "wooden pallet"),
    ("Escalera de mano", "ladder"),                        # Spanish: "escalera" alone is a stair
    ("Escalera", "stair"),
    ("Rüttelplatte", "plate compactor"),                   # German compound known as a whole ...
    ("Wendeltreppe", "stair"),                             # ... or by its head noun
])
def test_the_matcher_is_robust_to_order_plurals_abbreviations_and_languages(kb, family, label):
    assert kb.prior(family).label == label


@pytest.mark.parametrize(("family", "label"), [
    ("Basic Wall:Exterior - Brick on Block:130892", "brick wall"),     # family part beats type part
    ("M_W-Wide Flange:W310X60:208816", "steel I-beam"),
    ("M_Table-Coffee:0610 x 0610 x 0610mm:0610 x 0610 x 0610mm:161", "table"),   # Revit: noun first
    ("M_Vanity Cabinet-Double Door Sink Unit:450 x 450 mm:450 x 450 mm:7", "cabinet"),
    ("M_Single-Flush:0762 x 2032mm:0762 x 2032mm:150173", "door"),
    ("Wall Foundation:Bearing Footing - 900 x 300:12", "footing"),
    ("Compound Ceiling:Gypsum Board:1", "gypsum ceiling"),
])
def test_revit_family_type_id_strings_match_by_their_family_part(kb, family, label):
    assert kb.prior(family).label == label


def test_an_unknown_family_gets_the_default_bias_and_is_flagged(kb):
    prior = kb.prior("Radial Gradient Fill 1515460218 200 x 240")
    assert prior.upright_bias == DEFAULT_UPRIGHT_BIAS
    assert prior.source == "default"
    assert not prior.known
    assert prior.label == "radial gradient fill"
    assert "no knowledge-base class" in prior.rationale


def test_an_ifc_entity_names_the_class_when_the_family_name_says_nothing(kb):
    priors = kb.priors(["Solid 397409098 200", "Leichtbeton 102890359 240"],
                       ifc_classes={"Solid 397409098 200": "IfcSlab", "Leichtbeton 102890359 240": "IfcWallType"})
    assert priors["Solid 397409098 200"].label == "slab"
    assert priors["Leichtbeton 102890359 240"].label == "lightweight concrete wall"
    assert all(prior.known and prior.yaw_only for prior in priors.values())
    assert "IFC entity IfcSlab" in priors["Solid 397409098 200"].rationale


def test_the_name_beats_the_ifc_entity(kb):
    prior = kb.prior("Traffic_Cone_Orange_70cm", ifc_class="IfcBuildingElementProxy")
    assert prior.label == "traffic cone"


def test_priors_keep_one_entry_per_distinct_family_in_order(kb):
    priors = kb.priors(["Ladder", "Traffic Cone", "Ladder"])
    assert list(priors) == ["Ladder", "Traffic Cone"]


def test_a_custom_default_bias_is_used_for_unknown_families():
    assert KnowledgeBasePriors(default_bias=0.2).prior("Zzyzx").upright_bias == 0.2


def test_a_broken_table_file_raises_a_one_line_typed_error(tmp_path):
    path = tmp_path / "kb.json"
    path.write_text(json.dumps({"version": 1, "classes": [{"label": "cone", "category": "temporary works",
                                                           "bias": 1.5, "yaw_only": False, "symmetry": 4,
                                                           "why": "x"}]}))
    with pytest.raises(SemanticsError, match="unusable") as caught:
        load_table(path)
    assert "\n" not in str(caught.value)


def test_a_user_table_replaces_the_curated_one(tmp_path):
    path = tmp_path / "kb.json"
    path.write_text(json.dumps({"version": 1, "default_bias": 0.3, "classes": [
        {"label": "widget", "category": "equipment", "bias": 0.7, "yaw_only": False, "symmetry": "inf",
         "synonyms": ["gizmo"], "why": "test"}]}))
    kb = KnowledgeBasePriors(load_table(path))
    assert kb.prior("Gizmo_12").upright_bias == 0.7 and kb.prior("Gizmo_12").symmetry == math.inf
    assert kb.prior("Traffic cone").upright_bias == 0.3


def test_building_services_entities_of_ifc2x3_are_fixed_permanent_elements(kb):
    prior = kb.prior("8370-001300", ifc_class="IfcFlowTerminal")
    assert prior.known and prior.yaw_only and prior.upright_bias == 1.0


@pytest.mark.parametrize("family, order", [
    ("Steel_Drum_55gal", math.inf), ("Gas cylinder 50 l", math.inf), ("Bucket", math.inf),
    ("Wooden_Crate_1200x800x600", 2), ("Pallet_Wood_EUR", 2), ("Steel_I-Beam_W12x26_A992", 2),
    ("Survey_Tripod_Aluminium", 3), ("Traffic_Cone_Orange_70cm", 4), ("Wheelbarrow", 1), ("Zorblax_Q7", 1),
])
def test_each_family_gets_its_rotational_symmetry_about_up(kb, family, order):
    assert kb.prior(family).symmetry == order


def test_every_class_of_the_table_states_a_whole_order_or_inf(kb):
    for entry in kb.classes:
        assert math.isinf(entry.symmetry) or (entry.symmetry >= 1 and entry.symmetry == int(entry.symmetry))


def test_a_table_class_without_a_symmetry_is_refused(tmp_path):
    path = tmp_path / "kb.json"
    path.write_text(json.dumps({"version": 2, "classes": [{"label": "cone", "category": "temporary works",
                                                           "bias": 0.5, "yaw_only": False, "why": "x"}]}))
    with pytest.raises(SemanticsError, match="symmetry"):
        load_table(path)
