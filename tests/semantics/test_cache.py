"""PriorCache: one atomic JSON file per (model, family)."""

from __future__ import annotations

import json

from bim2rdt.semantics import UprightPrior
from bim2rdt.semantics.cache import PriorCache

PRIOR = UprightPrior("traffic cone", 0.4, False, "llm", "light")


def test_a_stored_prior_reads_back_equal(tmp_path):
    cache = PriorCache(tmp_path, "v1")
    cache.put("m", "Traffic_Cone", PRIOR)
    assert cache.get("m", "Traffic_Cone") == PRIOR
    assert cache.get("other-model", "Traffic_Cone") is None
    assert cache.get("m", "Crate") is None


def test_writes_leave_no_temporary_files(tmp_path):
    cache = PriorCache(tmp_path, "v1")
    for index in range(5):
        cache.put("m", f"family {index}", PRIOR)
    assert sorted(path.suffix for path in tmp_path.iterdir()) == [".json"] * 5


def test_a_corrupt_file_is_a_miss_and_the_next_answer_replaces_it(tmp_path):
    cache = PriorCache(tmp_path, "v1")
    cache.path("m", "Cone").write_text('{"model": "m", "fam')
    assert cache.get("m", "Cone") is None
    cache.put("m", "Cone", PRIOR)
    assert cache.get("m", "Cone") == PRIOR


def test_a_file_recording_another_family_is_a_miss(tmp_path):
    cache = PriorCache(tmp_path, "v1")
    cache.put("m", "Crate", PRIOR)
    cache.path("m", "Cone").write_text(cache.path("m", "Crate").read_text())
    assert cache.get("m", "Cone") is None


def test_a_new_prompt_version_does_not_reuse_old_answers(tmp_path):
    PriorCache(tmp_path, "v1").put("m", "Cone", PRIOR)
    assert PriorCache(tmp_path, "v2").get("m", "Cone") is None
    record = json.loads(PriorCache(tmp_path, "v1").path("m", "Cone").read_text())
    assert record["prior"]["upright_bias"] == 0.4 and record["family"] == "Cone"
