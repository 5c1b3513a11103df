"""BIM family names -> short detector classes and prompts, the paper's first semantic step.

Family names carry sizes, standards and export noise: ``Steel_I-Beam_W12x26_A992``, Revit's
``Family:Type:ElementId`` (``Basic Wall:Exterior - Brick on Block:130892``), ArchiCAD/German type names
(``Wand-Int-ERDG-1``, ``Leichtbeton 102890359 240``). An open-vocabulary detector wants the object class
("steel I-beam", "brick wall"). This module cleans names without any model: it splits separators and
CamelCase, drops sizes/codes/colours/template words, spells out abbreviations, translates common German,
French and Spanish words, and puts the material before the noun.
"""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass

from bim2rdt.semantics.vocabulary import (
    ABBREVIATIONS,
    COMPOUND_HEADS,
    DROP_WORDS,
    MATERIALS,
    SHAPE_LETTERS,
    TRANSLATIONS,
)

_SHAPE_HYPHEN = re.compile(rf"\b([{SHAPE_LETTERS}])-(?=[^\W\d_])")
_NON_BREAKING = "\u2011"
_WORD = re.compile(rf"[{SHAPE_LETTERS}]{_NON_BREAKING}[^\W_]+|[^\W_]+")
_CAMEL = re.compile(r"(?<=[a-z])(?=[A-Z])")
_SEGMENT_SPLIT = re.compile(r"[-\u2013\u2014/|()\[\],;]+")
_UMLAUTS = str.maketrans({"ä": "ae", "ö": "oe", "ü": "ue", "ß": "ss"})


@dataclass(frozen=True)
class Token:
    """One matchable word of a family name: folded, singular, with where it stood.

    ``part`` is the index of the Revit ``Family:Type`` part (0 = family), ``segment`` the hyphen-separated
    group inside that part (Revit writes ``Table-Coffee``: the noun comes first), ``position`` the running
    word index inside the part.
    """

    text: str
    part: int
    segment: int
    position: int


def fold(word: str) -> str:
    """Lower case, umlauts spelled out (ü -> ue), other accents stripped: the key form of every word list."""
    lowered = word.lower().translate(_UMLAUTS)
    decomposed = unicodedata.normalize("NFKD", lowered)
    return "".join(char for char in decomposed if not unicodedata.combining(char))


def singular(word: str) -> str:
    """A crude English singular (bricks -> brick, boxes -> box, scaffolies -> scaffoly); applied to both the
    family and the knowledge-base synonyms, so it only has to be consistent, not correct."""
    if len(word) <= 3 or not word.isascii():
        return word
    if word.endswith("ies"):
        return word[:-3] + "y"
    if word.endswith(("ches", "shes", "sses", "xes", "zes")):
        return word[:-2]
    if word.endswith("s") and not word.endswith(("ss", "us", "is", "as", "os")):
        return word[:-1]
    return word


def family_parts(name: str) -> list[str]:
    """The meaningful parts of a family name: Revit's ``Family:Type:ElementId`` split at colons, numeric
    element ids and repeated parts dropped. A name without colons is one part."""
    parts: list[str] = []
    for part in name.split(":"):
        part = part.strip()
        if part and not part.isdigit() and part not in parts:
            parts.append(part)
    return parts or [name.strip()]


@dataclass(frozen=True)
class Word:
    """A cleaned word: its English ``display`` phrase, and the folded original when that was a German
    compound translated by its head (``Rüttelplatte`` shows as "slab" but still matches "ruettelplatte")."""

    display: str
    compound: str | None = None


def part_segments(part: str, shouting: bool = False) -> list[list[Word]]:
    """The cleaned words of one part, grouped by hyphen segment. A display phrase may have two words (an
    abbreviation or translation such as ``reinforced concrete``)."""
    text = _CAMEL.sub(" ", part.replace("_", " "))
    text = _SHAPE_HYPHEN.sub(rf"\1{_NON_BREAKING}", text)
    segments = []
    for raw_segment in _SEGMENT_SPLIT.split(text):
        words = [word for raw in _WORD.findall(raw_segment) for word in _clean_word(raw, shouting)]
        if words:
            segments.append(words)
    return segments


def _clean_word(raw: str, shouting: bool) -> list[Word]:
    """One raw word -> zero or one cleaned word. Sizes and codes (anything with a digit: 70cm, W12x26,
    A992), single letters, and all-caps codes (EUR, ERDG) in a mixed-case name are dropped."""
    key = fold(raw.replace(_NON_BREAKING, "-"))
    if any(char.isdigit() for char in raw) or key in DROP_WORDS:
        return []
    if key in ABBREVIATIONS:
        return [Word(ABBREVIATIONS[key])]
    if key in TRANSLATIONS:
        return [Word(TRANSLATIONS[key])]
    if (len(raw) == 1 and raw.isascii()) or (raw.isupper() and raw.isascii() and not shouting):
        return []
    head = next((COMPOUND_HEADS[h] for h in COMPOUND_HEADS if key.endswith(h) and len(key) > len(h) + 2), None)
    if head is not None:
        return [Word(head, compound=key)]
    if _NON_BREAKING in raw:
        return [Word(raw[0].upper() + "-" + fold(raw[2:]))]
    return [Word(key)]


def _display_words(part: str, shouting: bool) -> list[str]:
    return [word.display for segment in part_segments(part, shouting) for word in segment]


def _is_shouting(name: str) -> bool:
    letters = [char for char in name if char.isalpha() and char.isascii()]
    return bool(letters) and all(char.isupper() for char in letters)


def _material(phrase: str) -> str | None:
    """The adjective form if the phrase names a material ("wood" -> "wooden"), else None."""
    words = phrase.split()
    if len(words) == 1:
        return MATERIALS.get(fold(phrase))
    return phrase if fold(words[-1]) in MATERIALS else None


def _materials_first(words: list[str]) -> list[str]:
    """English puts the material before the noun: ["pallet", "wood"] -> ["wooden", "pallet"]."""
    for index, word in enumerate(words):
        adjective = _material(word)
        if adjective is not None:
            return [adjective, *words[:index], *words[index + 1:]]
    return words


def _unique(words: list[str]) -> list[str]:
    seen: list[str] = []
    for word in words:
        if word not in seen:
            seen.append(word)
    return seen


def simplify_family(name: str) -> str:
    """A short detector class for a BIM family name.

    ``"Steel_I-Beam_W12x26_A992"`` -> ``"steel I-beam"``, ``"Traffic_Cone_Orange_70cm"`` -> ``"traffic cone"``,
    ``"Basic Wall:Exterior - Brick on Block:130892"`` -> ``"brick wall"`` (the Revit family names the object,
    its type may add the material), ``"Wand-Int-ERDG-1"`` -> ``"wall"``. Falls back to the trimmed name when
    nothing survives the cleaning (e.g. ``"1000mm"``).

    Args:
        name: A BIM family name.

    Returns:
        The short class name.
    """
    parts = family_parts(name)
    shouting = _is_shouting(name)
    words = _display_words(parts[0], shouting)
    if words and not any(_material(word) for word in words) and len(parts) > 1:
        type_words = _display_words(parts[1], shouting)
        words = [*[word for word in type_words if _material(word)][:1], *words]
    words = _unique(_materials_first(words))
    return " ".join(words) if words else name.strip()


def family_tokens(name: str) -> list[Token]:
    """Every matchable token of a family name, folded and singular, with its part, segment and position."""
    shouting = _is_shouting(name)
    tokens: list[Token] = []
    for part_index, part in enumerate(family_parts(name)):
        position = 0
        for segment_index, segment in enumerate(part_segments(part, shouting)):
            for word in segment:
                texts = re.split(r"[\s-]+", word.display) + ([word.compound] if word.compound else [])
                for text in texts:
                    tokens.append(Token(singular(fold(text)), part_index, segment_index, position))
                    position += 1
    return tokens


def phrase_tokens(phrase: str) -> tuple[str, ...]:
    """A synonym as the tuple of tokens a family must contain to match it (same cleaning as names)."""
    return tuple(dict.fromkeys(token.text for token in family_tokens(phrase.replace(":", " "))))


def material_of(name: str) -> str | None:
    """The first material a family name mentions, as an adjective ("Pallet_Wood_EUR" -> "wooden")."""
    for part in family_parts(name):
        for word in _display_words(part, _is_shouting(name)):
            adjective = _material(word)
            if adjective is not None:
                return adjective
    return None


def detector_prompt(label: str, context: str = "on a construction site") -> str:
    """The open-vocabulary detector prompt for a class: ``"a traffic cone on a construction site"``.

    The paper biases YOLOE with the class plus a site context ("a concrete wall in a building site").

    Args:
        label: The detector class (e.g. "traffic cone").
        context: Words appended after the class.

    Returns:
        The prompt, with "a" or "an" in front.
    """
    label = label.strip()
    article = "an" if label[:1].lower() in "aeiou" else "a"
    return f"{article} {label} {context}".strip()
