"""get_prior_provider: settings choose the knowledge base or the LLM."""

from __future__ import annotations

from bim2rdt.config import Settings
from bim2rdt.semantics import KnowledgeBasePriors, LlmPriors, get_prior_provider


def test_the_default_provider_is_the_offline_knowledge_base():
    assert isinstance(get_prior_provider(Settings()), KnowledgeBasePriors)


def test_the_llm_provider_takes_its_endpoint_timeouts_and_cache_from_settings(tmp_path):
    settings = Settings(cache_dir=tmp_path, llm={"base_url": "http://127.0.0.1:1/v1", "model": "m",
                                                   "timeout_s": 1.5, "max_retries": 4, "batch_size": 7})
    provider = get_prior_provider(settings, llm=True)
    assert isinstance(provider, LlmPriors)
    assert (provider.base_url, provider.model, provider.timeout_s, provider.max_retries, provider.batch_size) == (
        "http://127.0.0.1:1/v1", "m", 1.5, 4, 7)
    assert provider.cache.folder == tmp_path / "llm_priors"
    assert isinstance(provider.fallback, KnowledgeBasePriors)


def test_the_llm_cache_can_be_switched_off():
    settings = Settings(llm={"cache": False})
    assert get_prior_provider(settings, llm=True).cache is None
