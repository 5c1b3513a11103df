"""Word lists that turn BIM family names into plain English detector words.

Keys are *folded* (lower case, umlauts spelled out as ae/oe/ue, accents stripped), so ``Tür``, ``tuer`` and
``TÜR`` all look up ``tuer``. The lists are deliberately small: common words of German, French and Spanish
(and a few of the Chinese words Revit templates write) that name building parts and site objects. Anything
not listed passes through unchanged; the knowledge base's synonyms catch the rest.
"""

from __future__ import annotations

DROP_WORDS: frozenset[str] = frozenset({
    # colours: a detector class never needs them ("Traffic_Cone_Orange_70cm" -> "traffic cone")
    "orange", "red", "yellow", "blue", "green", "white", "black", "grey", "gray", "silver", "brown",
    # template noise of Revit, ArchiCAD and IFC exports
    "basic", "generic", "standard", "default", "typical", "existing", "new", "compound", "type", "family",
    "ifc", "object", "element", "proxy", "case", "elemented", "instance", "copy", "mod", "rev",
    # position qualifiers that say where, not what
    "interior", "exterior", "int", "ext", "inner", "outer",
    # stop words of the four languages
    "a", "an", "the", "of", "on", "with", "and", "for", "in", "over", "w", "de", "du", "des", "la", "le", "les",
    "el", "los", "las", "y", "et", "und", "mit", "fuer", "von", "ein", "eine", "zwei", "drei", "teilig",
    "horizontal", "vertikal",
    # Chinese Revit templates: "常规" = generic
    "常规",
})
"""Words that never help a detector: colours, template noise, stop words."""

ABBREVIATIONS: dict[str, str] = {
    "conc": "concrete", "rc": "reinforced concrete", "stl": "steel", "col": "column", "bm": "beam",
    "flr": "floor", "clg": "ceiling", "wdw": "window", "fdn": "foundation", "ftg": "footing",
    "scaf": "scaffold", "scaff": "scaffold", "alu": "aluminium", "alum": "aluminium", "aluminum": "aluminium",
    "wd": "wood", "gyp": "gypsum", "gwb": "gypsum board", "cmu": "concrete block", "ibc": "IBC tote",
    "mewp": "aerial work platform", "ahu": "air handling unit", "strl": "structural", "temp": "temporary",
    "pallette": "pallet", "europalette": "pallet", "europallet": "pallet", "epal": "pallet", "ply": "plywood",
    "wc": "toilet", "osb": "plywood",
}
"""Abbreviations and spelling variants seen in family names, expanded to plain words."""

TRANSLATIONS: dict[str, str] = {
    # German
    "wand": "wall", "waende": "wall", "stuetze": "column", "saeule": "column", "traeger": "beam",
    "unterzug": "beam", "pfette": "purlin", "sparren": "rafter", "decke": "slab", "bodenplatte": "floor slab",
    "dach": "roof", "tuer": "door", "fenster": "window", "treppe": "stair", "gelaender": "railing",
    "fundament": "footing", "leiter": "ladder", "geruest": "scaffold", "leitkegel": "traffic cone",
    "pylone": "traffic cone", "kegel": "cone", "fass": "drum", "kiste": "crate", "palette": "pallet",
    "schubkarre": "wheelbarrow", "bagger": "excavator", "kran": "crane", "stativ": "tripod",
    "bauzaun": "site fence", "absperrung": "barrier", "beton": "concrete", "stahlbeton": "reinforced concrete",
    "leichtbeton": "lightweight concrete", "stahl": "steel", "holz": "wood", "ziegel": "brick",
    "glas": "glass", "rohr": "pipe", "schalung": "formwork",
    # French
    "mur": "wall", "poteau": "column", "colonne": "column", "poutre": "beam", "dalle": "slab", "toit": "roof",
    "toiture": "roof", "porte": "door", "fenetre": "window", "escalier": "stair", "echelle": "ladder",
    "echafaudage": "scaffold", "cone": "cone", "fut": "drum", "tonneau": "drum", "caisse": "crate",
    "brouette": "wheelbarrow", "grue": "crane", "trepied": "tripod", "acier": "steel", "bois": "wood",
    "brique": "brick", "verre": "glass", "coffrage": "formwork",
    # Spanish
    "muro": "wall", "pared": "wall", "columna": "column", "pilar": "column", "viga": "beam", "losa": "slab",
    "cubierta": "roof", "puerta": "door", "ventana": "window", "escalera": "stair", "andamio": "scaffold",
    "cono": "cone", "bidon": "drum", "barril": "drum", "caja": "crate", "palet": "pallet", "pale": "pallet",
    "carretilla": "wheelbarrow", "grua": "crane", "tripode": "tripod", "acero": "steel", "madera": "wood",
    "hormigon": "concrete", "ladrillo": "brick", "vidrio": "glass", "encofrado": "formwork",
    # Chinese words written by Revit's Chinese templates
    "墙": "wall", "门": "door", "窗": "window", "楼梯": "stair", "梁": "beam", "柱": "column", "单扇": "door",
    "圆管": "round pipe", "固定": "fixed",
}
"""Common construction words of German, French, Spanish (and a few Chinese) in English."""

COMPOUND_HEADS: dict[str, str] = {
    "treppe": "stair", "tuer": "door", "fenster": "window", "wand": "wall", "stuetze": "column",
    "traeger": "beam", "platte": "slab", "dach": "roof", "gelaender": "railing", "leiter": "ladder",
    "geruest": "scaffold", "kiste": "crate", "palette": "pallet", "kran": "crane", "fass": "drum",
    "bagger": "excavator", "beton": "concrete",
}
"""German compounds put the noun last: "Wendeltreppe" (spiral stair) -> "stair", "Haustuer" -> "door"."""

MATERIALS: dict[str, str] = {
    "steel": "steel", "wood": "wooden", "wooden": "wooden", "timber": "timber", "aluminium": "aluminium",
    "concrete": "concrete", "brick": "brick", "glass": "glass", "plastic": "plastic", "gypsum": "gypsum",
    "stone": "stone", "masonry": "masonry", "metal": "metal", "rubber": "rubber",
}
"""Material words (folded -> adjective form); simplification puts them before the noun: "pallet wood" ->
"wooden pallet"."""

SHAPE_LETTERS = "IHTULCZ"
"""Single capitals that name a steel section when hyphenated to a noun: I-beam, H-beam, T-section, U-channel."""
