"""BIM family names -> detector prompts and upright priors (the paper's agentic semantic step).

``simplify_family`` and ``detector_prompt`` turn verbose family names into open-vocabulary detector classes;
a ``PriorProvider`` turns family names into ``UprightPrior``s for SG-ICP: ``KnowledgeBasePriors`` (offline,
deterministic, the default) or ``LlmPriors`` (an OpenAI-compatible endpoint, extra ``llm``, falling back to the
knowledge base per family).
"""

from bim2rdt.semantics.errors import SemanticsError
from bim2rdt.semantics.knowledge import KnowledgeBasePriors, KnowledgeClass, load_table
from bim2rdt.semantics.names import detector_prompt, simplify_family
from bim2rdt.semantics.priors import DEFAULT_UPRIGHT_BIAS, PriorProvider, UprightPrior

__all__ = [
    "DEFAULT_UPRIGHT_BIAS",
    "KnowledgeBasePriors",
    "KnowledgeClass",
    "PriorProvider",
    "SemanticsError",
    "UprightPrior",
    "detector_prompt",
    "load_table",
    "simplify_family",
]
