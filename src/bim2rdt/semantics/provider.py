"""Choose the prior provider from settings: the offline knowledge base, or the LLM with it as fallback."""

from __future__ import annotations

from bim2rdt.config import Settings
from bim2rdt.semantics.knowledge import KnowledgeBasePriors
from bim2rdt.semantics.priors import PriorProvider


def get_prior_provider(settings: Settings, llm: bool = False) -> PriorProvider:
    """``KnowledgeBasePriors()`` by default; with ``llm`` an ``LlmPriors`` built from ``settings.llm``, caching
    under ``settings.cache_dir`` (unless ``settings.llm.cache`` is off)."""
    knowledge_base = KnowledgeBasePriors()
    if not llm:
        return knowledge_base
    from bim2rdt.semantics.llm import LlmPriors

    options = settings.llm
    return LlmPriors(model=options.model, base_url=options.base_url, api_key=options.api_key,
                     timeout_s=options.timeout_s, max_retries=options.max_retries, backoff_s=options.backoff_s,
                     backoff_max_s=options.backoff_max_s, batch_size=options.batch_size,
                     cache_dir=settings.cache_dir if options.cache else None, fallback=knowledge_base)
