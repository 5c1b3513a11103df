"""Family resolution: type object name, else ObjectType, else Revit's Family:Type:ElementId, else Name."""

from bim2rdt.bim.family import resolve_family, strip_revit_id


def test_the_type_object_name_wins_over_everything_else():
    assert resolve_family("Leichtbeton 102890359 300", "ignored", "Wand-Ext-ERDG-1") == "Leichtbeton 102890359 300"


def test_object_type_is_used_when_there_is_no_type_object_and_its_revit_id_is_dropped():
    family = resolve_family(None, "Basic Wall:Interior - Partition (92mm Stud):128360", "whatever:139783")
    assert family == "Basic Wall:Interior - Partition (92mm Stud)"


def test_a_revit_name_gives_its_family_and_type_without_the_element_id():
    assert resolve_family(None, None, "M_W-Wide Flange:W310X60:207325") == "M_W-Wide Flange:W310X60"
    assert resolve_family("", "  ", "M_W-Wide Flange:W310X60:207325") == "M_W-Wide Flange:W310X60"


def test_a_plain_name_is_the_family_when_nothing_else_exists():
    assert resolve_family(None, None, "Traffic_Cone_Orange_70cm") == "Traffic_Cone_Orange_70cm"
    assert resolve_family(None, None, None) is None


def test_labels_that_are_not_revit_ids_are_kept_verbatim():
    assert strip_revit_id("Compound Ceiling:ACT 600 x 600mm Grid") == "Compound Ceiling:ACT 600 x 600mm Grid"
    assert strip_revit_id("Column 400x400") == "Column 400x400"
