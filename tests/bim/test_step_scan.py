"""The scan of a STEP file's text before parsing: declarations, duplicates and line numbers."""

from __future__ import annotations

from bim2rdt.bim.step_scan import declared_ids, first_duplicate, has_repeated_ids, line_of, line_of_entity

TEXT = b"""ISO-10303-21;
HEADER;
FILE_NAME('a #9= in the header is text',$);
ENDSEC;
DATA;
#1=IFCPERSON($,'Smith #2=',$);
#2 = IFCDIRECTION((1.,0.,0.));/* #1= a comment */
#3=IFCLABEL('it''s #3=');#4=IFCDIRECTION((0.,1.,0.));
ENDSEC;
END-ISO-10303-21;
"""


def test_declarations_skip_strings_and_comments_and_keep_their_offsets():
    assert [entity_id for entity_id, _ in declared_ids(TEXT)] == [1, 2, 3, 4]
    assert [line_of(TEXT, offset) for _, offset in declared_ids(TEXT)] == [6, 7, 8, 8]


def test_the_fast_pass_flags_text_that_looks_like_a_repeat_and_the_exact_pass_clears_it():
    assert has_repeated_ids(TEXT)
    assert first_duplicate(declared_ids(TEXT)) is None


def test_a_real_duplicate_is_found_with_both_places_even_with_leading_zeros():
    text = TEXT.replace(b"#4=IFCDIRECTION", b"#02=IFCDIRECTION")
    assert has_repeated_ids(text)
    entity_id, first, second = first_duplicate(declared_ids(text))
    assert entity_id == 2 and (line_of(text, first), line_of(text, second)) == (7, 8)


def test_a_file_without_repeats_passes_the_fast_pass():
    assert not has_repeated_ids(b"DATA;\n#1=IFCA();\n#2=IFCB(#1);\n#10=IFCC(#2);\nENDSEC;")


def test_line_of_entity_finds_the_declaration_not_a_reference():
    assert line_of_entity(TEXT, 2) == 7 and line_of_entity(TEXT, 4) == 8 and line_of_entity(TEXT, 7) is None
