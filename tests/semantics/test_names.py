"""simplify_family and detector_prompt: verbose BIM family names -> short detector classes."""

from __future__ import annotations

import pytest

from bim2rdt.semantics import detector_prompt, simplify_family
from bim2rdt.semantics.names import family_parts, singular


@pytest.mark.parametrize(("family", "expected"), [
    ("Steel_I-Beam_W12x26_A992", "steel I-beam"),          # the paper's two examples
    ("Traffic_Cone_Orange_70cm", "traffic cone"),
    ("Wooden_Crate_1200x800x600", "wooden crate"),
    ("Steel_Drum_55gal", "steel drum"),
    ("Scaffold_Frame_1000x2000", "scaffold frame"),
    ("STEEL_DRUM", "steel drum"),                          # an all-caps name keeps its words
    ("TrafficCone", "traffic cone"),                       # CamelCase
    ("IfcWallStandardCase", "wall"),                       # an IFC entity name
])
def test_sizes_codes_and_colours_are_dropped_from_simple_names(family, expected):
    assert simplify_family(family) == expected


@pytest.mark.parametrize(("family", "expected"), [
    ("Pallet_Wood_EUR", "wooden pallet"),
    ("Survey_Tripod_Aluminium", "aluminium survey tripod"),
    ("Pilar de hormigón", "concrete column"),
])
def test_the_material_moves_before_the_noun(family, expected):
    assert simplify_family(family) == expected


@pytest.mark.parametrize(("family", "expected"), [
    ("Basic Wall:Exterior - Brick on Block:130892", "brick wall"),
    ("M_W-Wide Flange:W310X60:208816", "wide flange"),
    ("Floor:Finish Floor - Wood", "wooden floor"),
    ("Compound Ceiling:Gypsum Board", "gypsum ceiling"),
    ("Floor:常规 - 150mm", "floor"),
])
def test_revit_family_type_id_strings_give_the_family_with_the_types_material(family, expected):
    assert simplify_family(family) == expected


@pytest.mark.parametrize(("family", "expected"), [
    ("Wand-Int-ERDG-1", "wall"),
    ("EG-Fenster-1", "window"),
    ("Innentuer-1", "door"),                               # German compound: the head noun is last
    ("Wendeltreppe", "stair"),
    ("Geländer_horizontal 13", "railing"),
    ("Leichtbeton 102890359 240", "lightweight concrete"),
    ("Échelle", "ladder"),
    ("Poutre acier", "steel beam"),
    ("Andamio", "scaffold"),
])
def test_common_german_french_and_spanish_words_are_translated(family, expected):
    assert simplify_family(family) == expected


def test_abbreviations_are_spelled_out():
    assert simplify_family("Conc Col 300x300") == "concrete column"


def test_a_name_that_is_only_a_size_is_kept_rather_than_emptied():
    assert simplify_family("1000mm") == "1000mm"


def test_revit_parts_drop_element_ids_and_repeats():
    parts = family_parts("M_Single-Flush:0762 x 2032mm:0762 x 2032mm:150173")
    assert parts == ["M_Single-Flush", "0762 x 2032mm"]


@pytest.mark.parametrize(("plural", "expected"), [("bricks", "brick"), ("boxes", "box"), ("ladders", "ladder"),
                                                   ("glass", "glass"), ("gas", "gas")])
def test_plurals_fold_to_one_form(plural, expected):
    assert singular(plural) == expected


def test_prompts_put_the_class_on_a_construction_site_with_the_right_article():
    assert detector_prompt("traffic cone") == "a traffic cone on a construction site"
    assert detector_prompt("excavator") == "an excavator on a construction site"
    assert detector_prompt("concrete wall", context="in a building site") == "a concrete wall in a building site"
