"""On-disk cache of LLM priors, one small JSON file per (model, family), so each family is asked once.

Files live in ``<cache_dir>/llm_priors/<key>.json`` where the key hashes the prompt version, the model and the
family name: changing the instruction or the model never serves a stale answer. Writes are atomic (temporary
file, fsync, rename), so a crash or two processes writing the same family never leave half a file; an
unreadable file counts as a miss and is overwritten on the next answer. Only real LLM answers are cached,
never knowledge-base fallbacks, so a failed request is retried on the next run.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from bim2rdt.atomic import write_bytes_atomic
from bim2rdt.semantics.priors import UprightPrior


class PriorCache:
    """Per-(model, family) prior cache in ``folder``; ``version`` is folded into every key."""

    def __init__(self, folder: Path, version: str) -> None:
        self.folder = Path(folder)
        self.version = version

    def path(self, model: str, family: str) -> Path:
        """The file that holds (or will hold) one family's answer."""
        key = hashlib.sha256(f"{self.version}\0{model}\0{family}".encode()).hexdigest()[:32]
        return self.folder / f"{key}.json"

    def get(self, model: str, family: str) -> UprightPrior | None:
        """The cached prior, or None on a miss (absent, unreadable, or another family's file)."""
        try:
            record = json.loads(self.path(model, family).read_text("utf-8"))
            if record.get("model") != model or record.get("family") != family:
                return None
            return UprightPrior(**record["prior"])
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def put(self, model: str, family: str, prior: UprightPrior) -> None:
        """Store one answer atomically."""
        record = {"version": self.version, "model": model, "family": family,
                  "prior": {key: value for key, value in prior.to_dict().items() if key != "known"}}
        write_text_atomic(self.path(model, family), json.dumps(record, ensure_ascii=False, indent=1))


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` via a temporary file in the same folder, fsync, then rename over it."""
    write_bytes_atomic(path, text.encode("utf-8"))
