"""BIM family names -> detector prompts and upright priors (the paper's agentic semantic step).

``simplify_family`` and ``detector_prompt`` turn verbose family names into open-vocabulary detector classes;
a ``PriorProvider`` turns family names into ``UprightPrior``s for SG-ICP: ``KnowledgeBasePriors`` (offline,
deterministic, the default) or ``LlmPriors`` (an OpenAI-compatible endpoint, extra ``llm``, falling back to the
knowledge base per family).
"""

from bim2rdt.semantics.errors import SemanticsError
from bim2rdt.semantics.knowledge import KnowledgeBasePriors, KnowledgeClass, load_table
from bim2rdt.semantics.llm import LlmPriors, LlmPriorsConfig
from bim2rdt.semantics.names import detector_prompt, simplify_family
from bim2rdt.semantics.priors import DEFAULT_UPRIGHT_BIAS, PriorProvider, UprightPrior, families_by_label
from bim2rdt.semantics.provider import get_prior_provider

__all__ = [
    "DEFAULT_UPRIGHT_BIAS",
    "KnowledgeBasePriors",
    "KnowledgeClass",
    "LlmPriors",
    "LlmPriorsConfig",
    "PriorProvider",
    "SemanticsError",
    "UprightPrior",
    "detector_prompt",
    "families_by_label",
    "get_prior_provider",
    "load_table",
    "simplify_family",
]
