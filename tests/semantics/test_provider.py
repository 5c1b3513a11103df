"""get_prior_provider: the knowledge base by default, or the LLM that ``Settings.llm`` configures."""

from __future__ import annotations

import pytest

from bim2rdt.config import Settings
from bim2rdt.semantics import KnowledgeBasePriors, LlmPriors, LlmPriorsConfig, get_prior_provider


def test_the_default_provider_is_the_offline_knowledge_base():
    assert isinstance(get_prior_provider(), KnowledgeBasePriors)


def test_the_llm_provider_takes_its_endpoint_timeouts_and_cache_from_settings(tmp_path):
    settings = Settings(cache_dir=tmp_path, llm={"base_url": "http://127.0.0.1:1/v1", "model": "m",
                                                   "timeout_s": 1.5, "max_retries": 4, "batch_size": 7})
    provider = get_prior_provider(settings.llm, settings.cache_dir)
    assert isinstance(provider, LlmPriors)
    assert provider.config is settings.llm
    assert (provider.config.base_url, provider.model, provider.config.timeout_s, provider.config.max_retries,
            provider.config.batch_size) == ("http://127.0.0.1:1/v1", "m", 1.5, 4, 7)
    assert provider.cache.folder == tmp_path / "llm_priors"
    assert isinstance(provider.fallback, KnowledgeBasePriors)


def test_the_llm_cache_can_be_switched_off(tmp_path):
    settings = Settings(llm={"cache": False})
    assert get_prior_provider(settings.llm, tmp_path).cache is None


def test_settings_llm_comes_from_the_environment_and_rejects_unknown_keys(monkeypatch):
    from pydantic import ValidationError

    monkeypatch.setenv("BIM2RDT_LLM__MODEL", "local-model")
    monkeypatch.setenv("BIM2RDT_LLM__BATCH_SIZE", "5")
    settings = Settings()
    assert isinstance(settings.llm, LlmPriorsConfig)
    assert settings.llm.setup().model == "local-model" and settings.llm.batch_size == 5
    monkeypatch.setenv("BIM2RDT_LLM__BATCH_SIZ", "5")
    with pytest.raises(ValidationError):
        Settings()
