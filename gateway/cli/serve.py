"""``rc233-gateway serve``: the REST/WebSocket API on the loops of a configuration file.

``serve --config cell.toml`` runs the loops the file describes; ``serve --simulate`` needs no
file: an in-process simulated loop (``sim``) with three controllers whose axes are named
(gateway/service/simulated.py), taking the simulator's options. A configuration can equally
point a loop at ``rc233-gateway sim --pty`` or ``--tcp`` through its device path or
``socket://`` URL: the path a real site uses.

Authentication: with tokens in the configuration every request needs one. Without tokens
(or with ``--no-auth``) the API is open, which is refused unless it is bound to loopback,
and said loudly in the log when it is.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import logging
import socket
import sys
from pathlib import Path
from types import FrameType
from typing import Any

import uvicorn

from gateway.api.app import create_app
from gateway.api.security import AuthConfig, is_loopback
from gateway.api.ws import uvicorn_ws_options
from gateway.cli.logs import configure_logging
from gateway.cli.notify import notify
from gateway.mqtt.commands import DeviceCommands
from gateway.mqtt.edge_node import EdgeNode
from gateway.protocol.framing import Series
from gateway.service.config import ConfigError, GatewayConfig, load_config
from gateway.service.gateway import Gateway
from gateway.service.simulated import SIM_LOOP, simulated_config
from gateway.service.state_log import StateLog
from gateway.sim.cli import build_loop, default_eeprom_dir, host_port, parse_bodies, positive
from gateway.sim.clock import SimClock
from gateway.sim.control import Controls, serve_control
from gateway.sim.loop import SimLoop
from gateway.sim.scene import SceneError, load_scene
from gateway.sim.serve import SimPort
from gateway.transport.base import Transport
from gateway.transport.pipe import PipeTransport

__all__ = ["add_serve_parser"]

log = logging.getLogger("gateway")

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8233


class _Server(uvicorn.Server):
    """uvicorn's server, ending with exit code 0 on SIGINT/SIGTERM like ``rc233-gateway sim``.

    uvicorn shuts down gracefully on a signal and then raises the signal again, which would
    kill the process before the simulator and the ports are closed here.
    """

    def handle_exit(self, sig: int, frame: FrameType | None) -> None:
        super().handle_exit(sig, frame)
        self._captured_signals.clear()

    async def startup(self, sockets: list[socket.socket] | None = None) -> None:
        """Start, then tell systemd (``Type=notify``) that HTTP requests are served."""
        await super().startup(sockets=sockets)
        if self.started:
            notify("READY=1")

    async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
        """Tell systemd the service is stopping, then stop."""
        notify("STOPPING=1")
        await super().shutdown(sockets=sockets)


def add_serve_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``serve`` to the subcommands of ``rc233-gateway``; it sets ``func``."""
    serve: argparse.ArgumentParser = subparsers.add_parser(
        "serve",
        help="serve the REST/WebSocket API",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    what = serve.add_mutually_exclusive_group(required=True)
    what.add_argument("--config", type=Path, metavar="FILE", help="the cell's TOML file")
    what.add_argument("--simulate", action="store_true", help="an in-process simulated loop")
    serve.add_argument("--host", default=DEFAULT_HOST, help=f"default {DEFAULT_HOST}")
    serve.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"default {DEFAULT_PORT}")
    serve.add_argument(
        "--no-auth", action="store_true", help="no tokens asked (loopback only; logged loudly)"
    )
    sim = serve.add_argument_group("with --simulate (as `rc233-gateway sim`)")
    sim.add_argument("--bodies", type=parse_bodies, default=["1", "2", "3"], help="default 1,2,3")
    sim.add_argument("--scene", type=Path, metavar="FILE", help="sensor layout (TOML)")
    sim.add_argument("--eeprom-dir", type=Path, metavar="DIR", help="the controllers' EEPROM")
    sim.add_argument("--time-scale", type=positive, default=1.0, metavar="X", help="speed-up")
    sim.add_argument("--control", type=host_port, metavar="HOST:PORT", help="control surface")
    serve.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    serve.add_argument(
        "--log-format",
        choices=["text", "json"],
        default="text",
        help="text lines (default) or JSON lines with loop/controller context",
    )
    serve.set_defaults(func=_main)
    return serve


def _simulated(args: argparse.Namespace) -> tuple[GatewayConfig, SimLoop, Transport]:
    scene = load_scene(args.scene) if args.scene else None
    sim = build_loop(
        args.bodies,
        series=Series.DOLLAR,
        scene=scene,
        eeprom_dir=args.eeprom_dir or default_eeprom_dir(),
        clock=SimClock(args.time_scale),
    )
    return simulated_config(args.bodies), sim, PipeTransport(lambda: SimPort(sim))


def _auth(args: argparse.Namespace, config: GatewayConfig) -> AuthConfig:
    """Tokens or not (``AuthConfig.decide``); a server nobody could use is refused."""
    try:
        auth = AuthConfig.decide(
            args.host, config.security.tokens, no_auth=args.no_auth, simulate=args.simulate
        )
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    if not auth.no_auth and not len(auth.book):
        raise ConfigError(
            f"--host {args.host}: no API tokens are configured, so nobody could use the API; "
            "add [[security.tokens]] (`rc233-gateway token`)"
            + (" or give --no-auth" if is_loopback(args.host) else " or bind to 127.0.0.1")
        )
    return auth


def _edge_node(
    gateway: Gateway, config: GatewayConfig, auth: AuthConfig, app: Any
) -> EdgeNode | None:
    """The Sparkplug B edge node of ``[mqtt]`` (None without the section); its DCMDs are
    authorised by the API's tokens (always: no-auth mode is for loopback, a broker is not)
    and written to the API's audit log."""
    if config.mqtt is None:
        return None
    commands = DeviceCommands(app.state.axes, auth.book.lookup, app.state.audit.record)
    mqtt = config.mqtt
    print(f"rc233-gateway serve: Sparkplug B edge node {mqtt.group}/{mqtt.edge_node} on "
          f"{mqtt.host}:{mqtt.port}", flush=True)  # fmt: skip
    return EdgeNode(gateway, mqtt, commands=commands)


async def serve(args: argparse.Namespace) -> int:
    """Run the API until SIGINT/SIGTERM; the exit code."""
    sim: SimLoop | None = None
    transports: dict[str, Transport] = {}
    if args.simulate:
        config, sim, transport = _simulated(args)
        transports[SIM_LOOP] = transport
    else:
        config = load_config(args.config)
    auth = _auth(args, config)
    gateway = Gateway(config, transports=transports, time_scale=args.time_scale)
    StateLog(gateway).start()
    app = create_app(gateway, auth=auth)
    control: asyncio.Server | None = None
    if sim is not None and args.control:
        control = await serve_control(Controls(sim), *args.control)
    if auth.no_auth:
        log.warning(
            "AUTHENTICATION IS OFF: anyone who can reach http://%s:%d may move the machines "
            "(loopback only; add tokens to the configuration to turn it on)",
            args.host,
            args.port,
        )
    server = _Server(
        uvicorn.Config(
            app,
            host=args.host,
            port=args.port,
            log_level="debug" if args.verbose else "info",
            log_config=None,  # uvicorn's lines go through the one handler (text or JSON)
            **uvicorn_ws_options(config.ws),
            timeout_graceful_shutdown=10,
        )
    )
    loops = ", ".join(f"{ref.name} ({ref.settings.port})" for ref in gateway.topology.loops())
    print(
        f"rc233-gateway serve: dashboard http://{args.host}:{args.port}/ "
        f"API http://{args.host}:{args.port}/api/v1 loops {loops}"
        + (" [simulated]" if sim is not None else ""),
        flush=True,
    )
    edge_node = _edge_node(gateway, config, auth, app)
    # Everything built so far lives as long as the process: keep the collector from walking
    # it again and again (a full pass paused WebSocket fan-out by ~140 ms, bench/README.md).
    gc.collect()
    gc.freeze()
    node_task = asyncio.create_task(edge_node.run()) if edge_node is not None else None
    try:
        await server.serve()
    finally:
        if node_task is not None and edge_node is not None:
            node_task.cancel()
            await asyncio.gather(node_task, return_exceptions=True)
            edge_node.close()
        if control is not None:
            control.close()
        if sim is not None:
            sim.close()
    return 0


def _main(args: argparse.Namespace) -> int:
    configure_logging(args.log_format, verbose=args.verbose)
    try:
        return asyncio.run(serve(args))
    except (ConfigError, SceneError, OSError) as exc:
        print(f"rc233-gateway serve: {exc}", file=sys.stderr)
        return 2
