"""examples/ run against `rc233-gateway serve --simulate`, as an integrator would run them.

The MES client goes through a TCP proxy that drops the connection of its first move after
the gateway has answered (the answer never arrives): the client sends the move again with the
same Idempotency-Key and must get the first answer replayed, the axis moving once.
"""

from __future__ import annotations

import asyncio
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import httpx

from tests.support.serve_process import serve

EXAMPLES = Path(__file__).parents[1] / "examples"


@asynccontextmanager
async def dropping_proxy(target_port: int, marker: bytes) -> AsyncIterator[tuple[int, list[str]]]:
    """A TCP proxy to the gateway; on the first connection that sends ``marker`` the answer
    is swallowed and the connection closed. Yields its port and what it did."""
    did: list[str] = []
    dropped = False

    async def pipe(  # server -> client, swallowing the answer once ``state["drop"]`` is set
        reader: asyncio.StreamReader, writer: asyncio.StreamWriter, state: dict[str, bool]
    ) -> None:
        try:
            while chunk := await reader.read(65536):
                if state.get("drop") and state.get("from_server"):
                    did.append("dropped the answer")
                    break
                writer.write(chunk)
                await writer.drain()
        except ConnectionError:
            pass
        finally:
            writer.close()

    async def handle(client_r: asyncio.StreamReader, client_w: asyncio.StreamWriter) -> None:
        nonlocal dropped
        server_r, server_w = await asyncio.open_connection("127.0.0.1", target_port)
        to_client: dict[str, bool] = {"from_server": True}

        async def upstream() -> None:
            nonlocal dropped
            try:
                while chunk := await client_r.read(65536):
                    if marker in chunk and not dropped:
                        dropped = True
                        to_client["drop"] = True
                        did.append("forwarded the move")
                    server_w.write(chunk)
                    await server_w.drain()
            except ConnectionError:
                pass
            finally:
                server_w.close()

        await asyncio.gather(upstream(), pipe(server_r, client_w, to_client))

    server = await asyncio.start_server(handle, "127.0.0.1", 0)
    try:
        yield server.sockets[0].getsockname()[1], did
    finally:
        server.close()


async def test_the_mes_client_homes_moves_retries_and_resumes(tmp_path: Path) -> None:
    async with serve(tmp_path) as gateway:
        async with dropping_proxy(gateway.port, b"POST /api/v1/axes/x/move") as (port, did):
            process = await asyncio.create_subprocess_exec(
                sys.executable, str(EXAMPLES / "mes_client.py"),
                "--url", f"http://127.0.0.1:{port}",
                stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
            )  # fmt: skip
            out, err = await asyncio.wait_for(process.communicate(), 50)
        assert process.returncode == 0, out.decode() + err.decode()
        lines = out.decode().splitlines()
        async with httpx.AsyncClient(base_url=gateway.url + "/api/v1") as client:
            operations = (await client.get("/operations")).json()
    assert did == ["forwarded the move", "dropped the answer"]
    assert lines[0] == "home x: done at 0 pulses"
    assert lines[1].startswith("retry /axes/x/move (attempt 1): ")
    assert lines[2] == "replayed /axes/x/move: the gateway answered the first request again"
    assert lines[3] == "move x: done at 12.5 (1250 pulses)"
    assert lines[4].startswith("watch x: snapshot at seq ") and lines[4].endswith("position 1250")
    assert lines[5] == "move x: done at 20.0 (2000 pulses)"
    assert lines[6].startswith("resume x: ") and lines[6].endswith("position 2000")
    assert "missed messages replayed" in lines[6]
    # The dropped move was made once: one home and two moves in all.
    kinds = sorted(op["kind"] for op in operations)
    assert kinds == ["home", "move", "move"], operations
