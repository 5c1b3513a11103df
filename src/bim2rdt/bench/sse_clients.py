"""SSE clients for ``bench server``, run as a separate process (``python -m bim2rdt.bench.sse_clients``) so
their parsing does not share the server's interpreter: N raw HTTP/1.1 connections to /api/stream (chunked
transfer), each recording the delivery latency of every ``hav.bench`` safety event until the ``bench-end`` message.

Prints one JSON document: {"clients": [[[seq, latency_ms], ...], ...], "errors": [...]}.
"""

from __future__ import annotations

import asyncio
import json
import sys
import time


async def listen(host: str, port: int, token: str, timeout_s: float) -> list[list[float]]:
    reader, writer = await asyncio.open_connection(host, port)
    writer.write((f"GET /api/stream HTTP/1.1\r\nHost: {host}:{port}\r\nAuthorization: Bearer {token}\r\n"
                  "Accept: text/event-stream\r\n\r\n").encode())
    await writer.drain()
    status = await reader.readline()
    if b" 200 " not in status:
        raise RuntimeError(f"stream refused: {status!r}")
    while (await reader.readline()) not in (b"\r\n", b""):
        pass
    got, buffer = [], b""
    deadline = time.monotonic() + timeout_s
    try:
        while time.monotonic() < deadline:
            size = int((await asyncio.wait_for(reader.readline(), deadline - time.monotonic())).strip() or b"0", 16)
            if size == 0:
                break
            buffer += (await reader.readexactly(size + 2))[:-2]
            now = time.time()
            *blocks, buffer = buffer.split(b"\n\n")
            for block in blocks:
                for line in block.split(b"\n"):
                    if not line.startswith(b"data: "):
                        continue
                    message = json.loads(line[6:])
                    if message["kind"] == "bench-end":
                        return got
                    event = message["data"]
                    if message["kind"] == "safety" and event["kind"] == "hav.bench":
                        got.append([event["data"]["seq"], 1000.0 * (now - event["data"]["emitted"])])
    finally:
        writer.close()
    return got


async def main(host: str, port: int, token: str, clients: int, timeout_s: float) -> dict:
    results = await asyncio.gather(*[listen(host, port, token, timeout_s) for _ in range(clients)],
                                   return_exceptions=True)
    return {"clients": [r for r in results if not isinstance(r, BaseException)],
            "errors": [repr(r) for r in results if isinstance(r, BaseException)]}


if __name__ == "__main__":
    host, port, token, clients, timeout_s = sys.argv[1:6]
    print(json.dumps(asyncio.run(main(host, int(port), token, int(clients), float(timeout_s)))))
