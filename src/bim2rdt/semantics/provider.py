"""Choose the prior provider: the offline knowledge base, or the LLM with it as fallback."""

from __future__ import annotations

from pathlib import Path

from bim2rdt.semantics.knowledge import KnowledgeBasePriors
from bim2rdt.semantics.llm import LlmPriorsConfig
from bim2rdt.semantics.priors import PriorProvider


def get_prior_provider(llm: LlmPriorsConfig | None = None, cache_dir: Path | None = None) -> PriorProvider:
    """``KnowledgeBasePriors()`` when ``llm`` is None; else the LLM it configures (``Settings.llm``), caching
    under ``cache_dir`` (unless ``llm.cache`` is off), with the knowledge base as fallback.

    Args:
        llm: The LLM endpoint's settings; None chooses the offline knowledge base.
        cache_dir: Where LLM answers are cached.

    Returns:
        The prior provider.
    """
    knowledge_base = KnowledgeBasePriors()
    if llm is None:
        return knowledge_base
    return llm.setup(cache_dir=cache_dir, fallback=knowledge_base)
