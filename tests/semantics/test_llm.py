"""LlmPriors: the real openai SDK against a local OpenAI-compatible server that answers valid, malformed,
partial, slow, rate-limited, failing and refusing responses."""

from __future__ import annotations

import json
import math

import pytest
from fake_llm_server import Reply, asked_families, completion, error

from bim2rdt.semantics import KnowledgeBasePriors, LlmPriors, LlmPriorsConfig
from bim2rdt.semantics.llm_answer import PAPER_INSTRUCTION

KB = KnowledgeBasePriors()
CONE, CRATE, TRIPOD = "Traffic_Cone_Orange_70cm", "Wooden_Crate_1200x800x600", "Survey_Tripod_Aluminium"


def make_priors(server, tmp_path=None, **options) -> LlmPriors:
    settings = {"model": "test-model", "base_url": server.url, "api_key": "sk-test", "timeout_s": 2.0,
                "max_retries": 2, "backoff_s": 0.01, "backoff_max_s": 0.05}
    return LlmPriorsConfig(**{**settings, **options}).setup(cache_dir=tmp_path)


def _item(family: str, label: str, bias, symmetry=1) -> dict:
    """One answer item as the schema wants it."""
    return {"family": family, "label": label, "upright_bias": bias, "yaw_only": False, "symmetry": symmetry,
            "rationale": "r"}


def test_a_valid_answer_gives_the_models_labels_and_biases(llm_server):
    llm_server.answers = {CONE: ("traffic cone", 0.35, False), CRATE: ("wooden crate", 0.95, False)}
    priors = make_priors(llm_server).priors([CONE, CRATE])
    assert priors[CONE].label == "traffic cone" and priors[CONE].upright_bias == 0.35
    assert priors[CRATE].upright_bias == 0.95
    assert {prior.source for prior in priors.values()} == {"llm"}
    assert priors[CONE].rationale == f"test server on {CONE}"


def test_the_request_carries_the_papers_instruction_the_families_and_a_strict_schema(llm_server):
    make_priors(llm_server).priors([CONE, "Wand-Int-ERDG-1"], ifc_classes={"Wand-Int-ERDG-1": "IfcWall"})
    request = llm_server.requests[0]
    assert request["model"] == "test-model"
    assert request["messages"][0]["role"] == "system"
    assert PAPER_INSTRUCTION in request["messages"][0]["content"]
    assert asked_families(request) == [CONE, "Wand-Int-ERDG-1"]
    assert '"ifc_class": "IfcWall"' in request["messages"][1]["content"]
    schema_format = request["response_format"]
    assert schema_format["type"] == "json_schema" and schema_format["json_schema"]["strict"] is True
    item = schema_format["json_schema"]["schema"]["properties"]["priors"]["items"]
    assert set(item["required"]) == {"family", "label", "upright_bias", "yaw_only", "symmetry", "rationale"}


def test_malformed_json_falls_back_to_the_knowledge_base_for_every_family(llm_server):
    llm_server.then(Reply(body=completion("Sure! Here are the priors: {priors: [")))
    priors = make_priors(llm_server).priors([CONE, TRIPOD])
    for family, prior in priors.items():
        assert prior.source == "knowledge-base (llm fallback)"
        assert prior.upright_bias == KB.prior(family).upright_bias
        assert prior.rationale.startswith("LLM test-model: invalid JSON answer")


def test_a_partial_answer_keeps_good_items_clamps_small_overshoots_and_falls_back_for_the_rest(llm_server):
    items = [_item(CONE, "traffic cone", 0.4), _item(CRATE, "crate", 7.0), _item("Ladder", "ladder", 1.03),
             _item("Zzyzx", "zzyzx", "high"), _item("Not asked", "x", 0.5)]
    llm_server.then(Reply(body=completion(json.dumps({"priors": items}))))
    priors = make_priors(llm_server).priors([CONE, CRATE, "Ladder", "Zzyzx", TRIPOD])
    assert priors[CONE].source == "llm" and priors[CONE].upright_bias == 0.4
    assert priors["Ladder"].source == "llm" and priors["Ladder"].upright_bias == 1.0
    assert "clamped" in priors["Ladder"].rationale
    assert priors[CRATE].source == "knowledge-base (llm fallback)" and "out of range" in priors[CRATE].rationale
    assert priors[CRATE].upright_bias == KB.prior(CRATE).upright_bias
    assert priors["Zzyzx"].source == "default (llm fallback)" and "invalid item" in priors["Zzyzx"].rationale
    assert "missing from the answer" in priors[TRIPOD].rationale
    assert "Not asked" not in priors


def test_the_answers_symmetry_is_the_priors_and_zero_means_any_turn(llm_server):
    llm_server.answers = {"Steel_Drum": ("steel drum", 0.8, False, 0), CRATE: ("crate", 0.9, False, 2),
                          TRIPOD: ("tripod", 0.3, False, 3)}
    priors = make_priors(llm_server).priors(["Steel_Drum", CRATE, TRIPOD])
    assert priors["Steel_Drum"].symmetry == math.inf
    assert (priors[CRATE].symmetry, priors[TRIPOD].symmetry) == (2, 3)


def test_a_negative_or_fractional_symmetry_falls_back_for_that_family(llm_server):
    items = [_item(CONE, "cone", 0.4, symmetry=-2), _item(CRATE, "crate", 0.9, symmetry=2.5),
             _item(TRIPOD, "tripod", 0.3, symmetry=3)]
    llm_server.then(Reply(body=completion(json.dumps({"priors": items}))))
    priors = make_priors(llm_server).priors([CONE, CRATE, TRIPOD])
    assert priors[CONE].source == "knowledge-base (llm fallback)" and "symmetry -2" in priors[CONE].rationale
    assert priors[CONE].symmetry == KB.prior(CONE).symmetry
    assert priors[CRATE].source == "knowledge-base (llm fallback)" and "invalid item" in priors[CRATE].rationale
    assert priors[TRIPOD].source == "llm" and priors[TRIPOD].symmetry == 3


def test_a_rate_limit_is_retried_and_then_answered(llm_server):
    llm_server.then(error(429, "slow down", **{"retry-after": "0"}))
    priors = make_priors(llm_server).priors([CONE])
    assert len(llm_server.requests) == 2
    assert priors[CONE].source == "llm"


def test_persistent_server_errors_fall_back_after_the_configured_retries(llm_server):
    llm_server.then(*[error(503, "overloaded")] * 3)
    priors = make_priors(llm_server, max_retries=2).priors([CONE])
    assert len(llm_server.requests) == 3
    assert priors[CONE].source == "knowledge-base (llm fallback)"
    assert "HTTP 503" in priors[CONE].rationale and "after 2 retries" in priors[CONE].rationale


def test_a_client_error_is_not_retried(llm_server):
    llm_server.then(error(400, "bad schema"))
    priors = make_priors(llm_server).priors([CONE])
    assert len(llm_server.requests) == 1
    assert "HTTP 400" in priors[CONE].rationale


def test_a_slow_server_times_out_and_falls_back(llm_server):
    llm_server.then(*[lambda request: Reply(body=completion("{}"), delay_s=1.0)] * 2)
    priors = make_priors(llm_server, timeout_s=0.2, max_retries=1).priors([CONE])
    assert len(llm_server.requests) == 2
    assert priors[CONE].source == "knowledge-base (llm fallback)"
    assert "request timed out after 1 retries" in priors[CONE].rationale


def test_a_refusal_falls_back_and_says_so(llm_server):
    llm_server.then(Reply(body=completion(None, refusal="I cannot help with that.")))
    priors = make_priors(llm_server).priors([CONE])
    assert "model refused: I cannot help with that." in priors[CONE].rationale
    assert priors[CONE].upright_bias == KB.prior(CONE).upright_bias


def test_an_answer_cut_at_the_token_limit_falls_back(llm_server):
    llm_server.then(Reply(body=completion('{"priors": [{"family": "Traf', finish_reason="length")))
    priors = make_priors(llm_server).priors([CONE])
    assert "cut off" in priors[CONE].rationale


def test_families_are_asked_in_batches(llm_server):
    families = [f"Thing {name}" for name in "abcde"]
    priors = make_priors(llm_server, batch_size=2).priors(families)
    assert [len(asked_families(request)) for request in llm_server.requests] == [2, 2, 1]
    assert list(priors) == families


def test_a_cached_family_is_not_asked_again_even_by_a_new_instance(llm_server, tmp_path):
    llm_server.answers = {CONE: ("traffic cone", 0.35, False)}
    make_priors(llm_server, tmp_path).priors([CONE])
    priors = make_priors(llm_server, tmp_path).priors([CONE, CRATE])
    assert [asked_families(request) for request in llm_server.requests] == [[CONE], [CRATE]]
    assert priors[CONE].source == "llm-cache" and priors[CONE].upright_bias == 0.35
    assert priors[CRATE].source == "llm"


def test_fallbacks_are_not_cached_so_the_next_run_asks_again(llm_server, tmp_path):
    llm_server.then(Reply(body=completion("not json")))
    make_priors(llm_server, tmp_path).priors([CONE])
    priors = make_priors(llm_server, tmp_path).priors([CONE])
    assert len(llm_server.requests) == 2
    assert priors[CONE].source == "llm"


def test_the_cache_is_per_model(llm_server, tmp_path):
    make_priors(llm_server, tmp_path).priors([CONE])
    make_priors(llm_server, tmp_path, model="other-model").priors([CONE])
    assert [request["model"] for request in llm_server.requests] == ["test-model", "other-model"]


def test_an_unreachable_endpoint_falls_back_without_raising():
    config = LlmPriorsConfig(base_url="http://127.0.0.1:9/v1", api_key="k", timeout_s=0.5, max_retries=1,
                             backoff_s=0.01)
    priors = LlmPriors(config).priors([CONE])
    assert priors[CONE].source == "knowledge-base (llm fallback)"
    assert "connection failed" in priors[CONE].rationale


def test_the_real_openai_endpoint_without_a_key_is_a_typed_error(monkeypatch):
    from bim2rdt.semantics import SemanticsError

    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    with pytest.raises(SemanticsError, match="no API key"):
        LlmPriors(LlmPriorsConfig(base_url=None)).priors([CONE])
