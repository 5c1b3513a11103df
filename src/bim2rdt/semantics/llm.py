"""LLM upright priors, as in the paper: an OpenAI-compatible chat model reads the family names and returns a
label, an upright bias, a yaw-only flag and a rationale per family (extra ``llm``: the ``openai`` SDK).

The step must never stop a mission: every family the model cannot answer usably (timeouts, HTTP 429/5xx after
the retries, a refusal, invalid JSON, a missing or out-of-range item) falls back to the knowledge base, and
the prior says so: ``source="knowledge-base (llm fallback)"`` and the reason first in ``rationale``. Good
answers are cached on disk per (model, family), so a site's families are asked once.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from bim2rdt.semantics.cache import PriorCache
from bim2rdt.semantics.errors import SemanticsError
from bim2rdt.semantics.knowledge import KnowledgeBasePriors
from bim2rdt.semantics.llm_answer import PROMPT_VERSION, RESPONSE_FORMAT, build_messages, parse_answer
from bim2rdt.semantics.priors import FALLBACK_SUFFIX, PriorProvider, UprightPrior

SOURCE_LLM_CACHE = "llm-cache"
_PLACEHOLDER_KEY = "not-needed"  # local OpenAI-compatible servers (vLLM, Ollama, llama.cpp) ignore the key


class _RequestFailed(Exception):
    """A request gave no usable answer; the message is the reason recorded in the fallback priors."""


class LlmPriorsConfig(BaseModel):
    """The OpenAI-compatible endpoint that assigns upright priors (extra ``llm``); ``Settings.llm``
    (``BIM2RDT_LLM__*``). :meth:`setup` builds the :class:`LlmPriors` it describes."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    base_url: str | None = Field(None, description="OpenAI-compatible endpoint; None means the SDK default.")
    model: str = Field("gpt-4o-mini", description="Model name; the paper used gpt-4o-mini.")
    api_key: str | None = Field(None, description="API key; falls back to OPENAI_API_KEY.")
    timeout_s: float = Field(30.0, gt=0, description="Per-request timeout, seconds.")
    max_retries: int = Field(3, ge=0, description="Retries with backoff on 429/5xx/timeouts.")
    backoff_s: float = Field(0.5, ge=0, description="First retry delay, seconds; doubles per retry.")
    backoff_max_s: float = Field(8.0, ge=0, description="Longest retry delay (also caps a server's Retry-After), s.")
    batch_size: int = Field(40, ge=1, description="Families per request.")
    cache: bool = Field(True, description="Cache answers per (model, family) under cache_dir/llm_priors.")

    def setup(self, cache_dir: Path | None = None, fallback: PriorProvider | None = None) -> LlmPriors:
        """Build the provider this config describes.

        Args:
            cache_dir: Where answers are cached (under ``llm_priors``), when given and ``cache`` is on.
            fallback: Where families the LLM does not answer get their prior; None uses the knowledge base.

        Returns:
            The LLM prior provider.
        """
        return LlmPriors(self, cache_dir=cache_dir if self.cache else None, fallback=fallback)


class LlmPriors:
    """Upright priors from an OpenAI-compatible chat endpoint, with knowledge-base fallback and a disk cache.

    ``config.timeout_s`` bounds each request; 429, 5xx, timeouts and connection errors are retried
    ``max_retries`` times after ``backoff_s * 2**attempt`` seconds (capped at ``backoff_max_s``, which also caps
    a server's Retry-After). ``cache_dir=None`` disables the cache.

    Args:
        config: The endpoint, model, timeouts and retries; None uses the defaults.
        cache_dir: Where answers are cached (under ``llm_priors``); None disables the cache.
        fallback: Where unanswered families get their prior; None uses the knowledge base.
    """

    def __init__(self, config: LlmPriorsConfig | None = None, cache_dir: Path | None = None,
                 fallback: PriorProvider | None = None) -> None:
        self.config = config or LlmPriorsConfig()
        self.cache = PriorCache(Path(cache_dir) / "llm_priors", PROMPT_VERSION) if cache_dir else None
        self.fallback = fallback or KnowledgeBasePriors()
        self.requests_sent = 0
        self._client = None

    @property
    def model(self) -> str:
        """The LLM's model name (part of the cache key)."""
        return self.config.model

    def priors(self, families: Iterable[str],
               ifc_classes: Mapping[str, str] | None = None) -> dict[str, UprightPrior]:
        """The upright priors of several families: cached, asked in batches, or fallen back.

        Args:
            families: BIM family names (repeats allowed).
            ifc_classes: {family: IFC entity} hints for the LLM and the fallback.

        Returns:
            {family: prior}, one per distinct name, order kept.
        """
        hints = dict(ifc_classes or {})
        wanted = list(dict.fromkeys(families))
        found = self._cached(wanted)
        missing = [family for family in wanted if family not in found]
        for start in range(0, len(missing), self.config.batch_size):
            found.update(self._ask(missing[start:start + self.config.batch_size], hints))
        return {family: found[family] for family in wanted}

    def _cached(self, families: Sequence[str]) -> dict[str, UprightPrior]:
        if self.cache is None:
            return {}
        hits = {family: self.cache.get(self.model, family) for family in families}
        return {family: replace(prior, source=SOURCE_LLM_CACHE) for family, prior in hits.items() if prior}

    def _ask(self, batch: Sequence[str], hints: Mapping[str, str]) -> dict[str, UprightPrior]:
        """One request for a batch; good answers are cached, the rest fall back with their reason."""
        try:
            answered, reasons = parse_answer(self._request(batch, hints), batch)
        except _RequestFailed as failure:
            answered, reasons = {}, dict.fromkeys(batch, str(failure))
        if self.cache is not None:
            for family, prior in answered.items():
                self.cache.put(self.model, family, prior)
        return {**answered, **self._fall_back(reasons, hints)}

    def _fall_back(self, reasons: Mapping[str, str], hints: Mapping[str, str]) -> dict[str, UprightPrior]:
        if not reasons:
            return {}
        priors = self.fallback.priors(list(reasons), {f: hints[f] for f in reasons if f in hints})
        return {family: replace(prior, source=prior.source + FALLBACK_SUFFIX,
                                rationale=f"LLM {self.model}: {reasons[family]}; fallback: {prior.rationale}")
                for family, prior in priors.items()}

    def _request(self, batch: Sequence[str], hints: Mapping[str, str]) -> str:
        """The answer text of one chat completion, retrying transient failures with backoff."""
        import openai

        attempt = 0
        while True:
            try:
                return self._complete(batch, hints)
            except (openai.RateLimitError, openai.InternalServerError, openai.APITimeoutError,
                    openai.APIConnectionError) as error:
                if attempt >= self.config.max_retries:
                    raise _RequestFailed(f"{_describe(error)} after {self.config.max_retries} retries") from error
                time.sleep(self._delay(attempt, error))
                attempt += 1
            except openai.APIStatusError as error:  # 400/401/404...: retrying will not help
                raise _RequestFailed(_describe(error)) from error

    def _complete(self, batch: Sequence[str], hints: Mapping[str, str]) -> str:
        self.requests_sent += 1
        completion = self._get_client().chat.completions.create(
            model=self.model, messages=build_messages(batch, hints), response_format=RESPONSE_FORMAT,
            temperature=0)
        if not completion.choices:
            raise _RequestFailed("answer without choices")
        choice = completion.choices[0]
        if getattr(choice.message, "refusal", None):
            raise _RequestFailed(f"model refused: {choice.message.refusal}"[:200])
        if choice.finish_reason == "length":
            raise _RequestFailed("answer cut off at the token limit")
        if not choice.message.content:
            raise _RequestFailed("empty answer")
        return choice.message.content

    def _delay(self, attempt: int, error: Exception) -> float:
        """Exponential backoff; a server's Retry-After wins when it is shorter than the cap."""
        delay = self.config.backoff_s * 2 ** attempt
        retry_after = _retry_after_s(error)
        if retry_after is not None:
            delay = retry_after
        return min(delay, self.config.backoff_max_s)

    def _get_client(self):
        if self._client is None:
            self._client = make_client(self.config.base_url, self.config.api_key, self.config.timeout_s)
        return self._client


def make_client(base_url: str | None, api_key: str | None, timeout_s: float):
    """An ``openai.OpenAI`` client with its own retries off (LlmPriors retries, to record why)."""
    try:
        import openai
    except ImportError:
        raise SemanticsError("LLM priors need the openai SDK: pip install 'bim2rdt[llm]'") from None
    key = api_key or os.environ.get("OPENAI_API_KEY")
    if key is None and base_url is None:
        raise SemanticsError("no API key for the OpenAI API: set BIM2RDT_LLM__API_KEY or OPENAI_API_KEY")
    return openai.OpenAI(base_url=base_url, api_key=key or _PLACEHOLDER_KEY, timeout=timeout_s, max_retries=0)


def _describe(error: Exception) -> str:
    """A short reason for the rationale: "HTTP 429 (RateLimitError)", "request timed out"."""
    status = getattr(error, "status_code", None)
    if status:
        return f"HTTP {status} ({type(error).__name__})"
    return {"APITimeoutError": "request timed out", "APIConnectionError": "connection failed"}.get(
        type(error).__name__, type(error).__name__)


def _retry_after_s(error: Exception) -> float | None:
    response = getattr(error, "response", None)
    value = response.headers.get("retry-after") if response is not None else None
    try:
        return max(0.0, float(value)) if value is not None else None
    except ValueError:
        return None
