"""A local OpenAI-compatible chat server for the LLM tests: the real openai SDK talks HTTP to it.

Each test scripts the server's replies (valid, malformed, partial, slow, rate-limited, refusing); unscripted
requests get a valid answer built from ``server.answers`` for exactly the families asked.
"""

from __future__ import annotations

import json
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


@dataclass
class Reply:
    """What the server sends for one request."""

    status: int = 200
    body: dict | str = ""
    headers: dict[str, str] = field(default_factory=dict)
    delay_s: float = 0.0


def completion(content: str | None, refusal: str | None = None, finish_reason: str = "stop") -> dict:
    """A chat.completion object as the OpenAI API returns it."""
    message = {"role": "assistant", "content": content, "refusal": refusal}
    return {"id": "chatcmpl-test", "object": "chat.completion", "created": 0, "model": "test-model",
            "choices": [{"index": 0, "message": message, "finish_reason": finish_reason, "logprobs": None}],
            "usage": {"prompt_tokens": 10, "completion_tokens": 10, "total_tokens": 20}}


def error(status: int, message: str, **headers: str) -> Reply:
    return Reply(status, {"error": {"message": message, "type": "test", "code": str(status)}}, headers)


def asked_families(request: dict) -> list[str]:
    """The family names in the request's attached JSON document."""
    attached = request["messages"][1]["content"].split("\n", 1)[1]
    return [item["family"] for item in json.loads(attached)["families"]]


class FakeLlmServer:
    """The server state: scripted replies, answers for valid replies, and every request received."""

    def __init__(self) -> None:
        self.script: deque[Callable[[dict], Reply]] = deque()
        self.answers: dict[str, tuple] = {}  # family -> (label, bias, yaw_only[, symmetry])
        self.requests: list[dict] = []
        self._lock = threading.Lock()
        self._http = ThreadingHTTPServer(("127.0.0.1", 0), self._handler())
        self._http.daemon_threads = True
        self.url = f"http://127.0.0.1:{self._http.server_address[1]}/v1"

    def then(self, *replies: Reply | Callable[[dict], Reply]) -> FakeLlmServer:
        for reply in replies:
            self.script.append(reply if callable(reply) else (lambda _request, fixed=reply: fixed))
        return self

    def valid(self, request: dict) -> Reply:
        items = []
        for family in asked_families(request):
            label, bias, yaw_only, symmetry = (*self.answers.get(family, ("thing", 0.5, False)), 1)[:4]
            items.append({"family": family, "label": label, "upright_bias": bias, "yaw_only": yaw_only,
                          "symmetry": symmetry, "rationale": f"test server on {family}"})
        return Reply(body=completion(json.dumps({"priors": items})))

    def _reply_to(self, request: dict) -> Reply:
        with self._lock:
            self.requests.append(request)
            behaviour = self.script.popleft() if self.script else self.valid
        return behaviour(request)

    def _handler(self) -> type[BaseHTTPRequestHandler]:
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 (http.server's name)
                request = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
                reply = server._reply_to(request) if self.path.endswith("/chat/completions") else error(404, "no")
                time.sleep(reply.delay_s)
                payload = (reply.body if isinstance(reply.body, str) else json.dumps(reply.body)).encode()
                try:
                    self.send_response(reply.status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(payload)))
                    for name, value in reply.headers.items():
                        self.send_header(name, value)
                    self.end_headers()
                    self.wfile.write(payload)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client timed out and hung up: exactly what the slow test wants

            def log_message(self, *args) -> None:
                pass

        return Handler

    def __enter__(self) -> FakeLlmServer:
        threading.Thread(target=self._http.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True).start()
        return self

    def __exit__(self, *exc) -> None:
        self._http.shutdown()
        self._http.server_close()
