"""What the LLM is told and what it must answer: the paper's instruction, the strict JSON schema, and the
validation that turns an answer into per-family priors (or per-family reasons to fall back).

Pure functions, no network: :mod:`bim2rdt.semantics.llm` does the requests.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence

from pydantic import BaseModel, ValidationError

from bim2rdt.semantics.priors import AXIAL, SOURCE_LLM, UprightPrior

PAPER_INSTRUCTION = (
    "You return BIM alignment priors. For each label, output: upright bias \u2208 [0,1] (fraction of tilt "
    "corrected per ICP iteration). Only include labels given. No extra text. Take gravity into account, how "
    "likely is this to not be upright? If it is not likely we need a smaller value. JSON that matches the "
    "provided schema strictly."
)
"""The instruction of the BIM2RDT paper (Methodology, SG-ICP, Semantic Alignment), verbatim."""

FIELD_INSTRUCTION = (
    "The attached JSON lists BIM family names (with their IFC entity when known). For every family give: "
    "`family` (the name exactly as given), `label` (the short object class an open-vocabulary detector "
    "should look for, e.g. \"Steel_I-Beam_W12x26_A992\" -> \"steel I-beam\", \"Traffic_Cone_Orange_70cm\" -> "
    "\"traffic cone\"), `upright_bias` (high for heavy or fixed objects such as crates, drums, columns and "
    "walls; lower for cones; lower still for tripods and ladders; near 0 for hand tools), `yaw_only` (true "
    "when the object can only turn about the vertical, e.g. permanent structure), `symmetry` (how many turns "
    "about the vertical within 360 degrees show the same object: 1 for none, e.g. a wheelbarrow; 2 for a "
    "rectangular crate, pallet or I-beam; 3 for a tripod; 4 for a square plate or a square-based cone; 0 for "
    "a round object that looks the same after any turn, e.g. a drum or a bucket) and a one-sentence "
    "`rationale`."
)
"""Our addition: the paper's LLM also simplified names; SG-ICP here also takes a yaw-only flag, and the verdict
the symmetry (a drum turned about its axis has not moved)."""

ROUND = 0
"""The answer's ``symmetry`` for "any turn" (JSON has no infinity): :data:`~bim2rdt.semantics.priors.AXIAL`."""

PROMPT_VERSION = "bim2rdt-priors-v2"
"""Changes whenever the instruction or schema changes, so cached answers of an old prompt are not reused."""

CLAMP_TOLERANCE = 0.05
"""A bias within this distance outside [0, 1] (rounding, 1.02) is clamped; farther out (7, 85 as a percent,
-1) means the model misread the task, and that family falls back to the knowledge base."""

RESPONSE_SCHEMA: dict = {
    "type": "object",
    "properties": {
        "priors": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "family": {"type": "string"},
                    "label": {"type": "string"},
                    "upright_bias": {"type": "number"},
                    "yaw_only": {"type": "boolean"},
                    "symmetry": {"type": "integer"},
                    "rationale": {"type": "string"},
                },
                "required": ["family", "label", "upright_bias", "yaw_only", "symmetry", "rationale"],
                "additionalProperties": False,
            },
        },
    },
    "required": ["priors"],
    "additionalProperties": False,
}

RESPONSE_FORMAT: dict = {
    "type": "json_schema",
    "json_schema": {"name": "bim_alignment_priors", "strict": True, "schema": RESPONSE_SCHEMA},
}
"""OpenAI structured outputs: the server must answer exactly this schema."""


class AnswerItem(BaseModel):
    """One family of the answer, as the schema defines it."""

    family: str
    label: str
    upright_bias: float
    yaw_only: bool
    symmetry: int
    rationale: str = ""


def build_messages(families: Sequence[str], ifc_classes: Mapping[str, str]) -> list[dict[str, str]]:
    """The chat messages: the instruction as system message, the families as an attached JSON document."""
    attached = [{"family": family, "ifc_class": ifc_classes.get(family)} for family in families]
    return [
        {"role": "system", "content": f"{PAPER_INSTRUCTION}\n\n{FIELD_INSTRUCTION}"},
        {"role": "user", "content": "families.json:\n" + json.dumps({"families": attached}, ensure_ascii=False)},
    ]


def parse_answer(content: str, families: Sequence[str]) -> tuple[dict[str, UprightPrior], dict[str, str]]:
    """Split an answer into valid priors and, for every other asked family, the reason it is unusable.

    Invalid JSON or a wrong top-level shape fails the whole batch; a bad item fails only its family; a family
    the model left out is "missing from the answer"; families nobody asked for are ignored."""
    try:
        items = json.loads(content)["priors"]
        if not isinstance(items, list):
            raise TypeError("priors is not a list")
    except (ValueError, KeyError, TypeError) as error:
        return {}, dict.fromkeys(families, f"invalid JSON answer ({type(error).__name__}: {error})"[:200])
    priors: dict[str, UprightPrior] = {}
    reasons: dict[str, str] = {}
    asked = set(families)
    for raw in items:
        family = raw.get("family") if isinstance(raw, dict) else None
        if family in asked and family not in priors:
            prior, reason = _item_prior(raw)
            if prior is not None:
                priors[family] = prior
                reasons.pop(family, None)
            else:
                reasons[family] = reason
    for family in families:
        if family not in priors and family not in reasons:
            reasons[family] = "missing from the answer"
    return priors, reasons


def _item_prior(raw: dict) -> tuple[UprightPrior | None, str]:
    """One item -> a prior (bias clamped within tolerance), or None and why."""
    try:
        item = AnswerItem.model_validate(raw)
    except ValidationError as error:
        return None, f"invalid item ({error.errors()[0]['loc'][0]}: {error.errors()[0]['msg']})"
    bias = item.upright_bias
    if not math.isfinite(bias) or not -CLAMP_TOLERANCE <= bias <= 1 + CLAMP_TOLERANCE:
        return None, f"upright_bias {bias} out of range [0, 1]"
    if not item.label.strip():
        return None, "empty label"
    if item.symmetry < ROUND:
        return None, f"symmetry {item.symmetry} is negative"
    clamped = min(1.0, max(0.0, bias))
    note = f" (bias {bias} clamped to {clamped})" if clamped != bias else ""
    symmetry = AXIAL if item.symmetry == ROUND else item.symmetry
    return UprightPrior(item.label.strip(), clamped, item.yaw_only, SOURCE_LLM, item.rationale + note, symmetry), ""
