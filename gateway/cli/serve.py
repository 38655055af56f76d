"""``rc233-gateway serve``: the REST/WebSocket API on the loops of a configuration file.

``serve --config cell.toml`` runs the loops the file describes, once every problem
``rc233-gateway check-config`` finds in it is fixed, each in a line worker process (grouped by
``[engine] workers``; a worker that dies is started again, its loops down meanwhile); a loop
whose device is not there (yet) starts down and comes up when it appears. ``serve --simulate``
runs simulated loops (``simulated_lines``) through the same line workers, each worker holding
its loops' simulators: without a file one loop (``sim``) with three controllers whose axes are
named (gateway/service/runtime/simulated.py); with ``--config`` the file's loops, controllers,
names, units, tokens and audit log, each loop's port replaced by a simulated loop (9600 bps). Either
takes the simulator's options. A configuration can equally point a loop at ``rc233-gateway sim
--pty`` or ``--tcp`` through its device path or ``socket://`` URL: the path a real site uses.

Authentication, one rule: every request needs a token of the configuration unless the API is
started with ``--no-auth``, which is accepted only on loopback and said loudly in the log.
A configuration without tokens therefore needs ``--no-auth`` (``make run`` gives it).
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import logging
import shutil
import socket
import sys
import tempfile
from pathlib import Path
from types import FrameType
from typing import Any

import uvicorn

from gateway.api.app import create_app
from gateway.api.security import AuthConfig, is_loopback
from gateway.api.ws.endpoint import uvicorn_ws_options
from gateway.cli.check_config import NO_TOKENS, check_report, problems_error
from gateway.cli.connection_guard import uvicorn_connection_options
from gateway.cli.logs import configure_logging
from gateway.cli.notify import notify
from gateway.cli.simulated_lines import SimulatedCell, sim_line, simulated_lines
from gateway.compose import compose
from gateway.mqtt.dcmd import DeviceCommands
from gateway.mqtt.edge_node import EdgeNode
from gateway.opcua.face import OpcUaFace
from gateway.service.config import ConfigError, GatewayConfig
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.state_log import StateLog
from gateway.service.services import Services
from gateway.service.store import StateStore, default_state_dir
from gateway.sim.cli import add_loop_options
from gateway.sim.scene import SceneError
from gateway.transport.base import Transport
from gateway.transport.factory import open_transport

__all__ = ["add_serve_parser", "open_lines", "sim_line"]

log = logging.getLogger("gateway")

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8233


def freeze_heap() -> None:
    """Move everything alive now out of the collector's sight (``gc.freeze``).

    Called once the app has started (its lifespan ran: loops open, poller, feed, routes):
    what exists then lives as long as the process, and a full collection that walks it again
    and again paused the WebSocket fan-out by ~140 ms (bench/README.md). Objects made later
    are collected as usual.
    """
    gc.collect()
    gc.freeze()


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
            freeze_heap()
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
    serve.add_argument("--config", type=Path, metavar="FILE", help="the cell's TOML file")
    serve.add_argument(
        "--simulate",
        action="store_true",
        help="simulated loops, in the line workers (the --config file's, or one loop `sim`)",
    )
    serve.add_argument("--host", default=DEFAULT_HOST, help=f"default {DEFAULT_HOST}")
    serve.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"default {DEFAULT_PORT}")
    serve.add_argument(
        "--no-auth",
        action="store_true",
        help="no token asked: the API is open (loopback only; logged loudly)",
    )
    sim = serve.add_argument_group(
        "with --simulate (as `rc233-gateway sim`)",
        "With --config, the loops and bodies are the file's;\n"
        "--control is the first loop's, served by its line worker.",
    )
    add_loop_options(sim, bodies="1,2,3")
    serve.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    serve.add_argument(
        "--log-format",
        choices=["text", "json"],
        default="text",
        help="text lines (default) or JSON lines with loop/controller context",
    )
    serve.set_defaults(func=_main)
    return serve


def open_lines(config: GatewayConfig) -> dict[str, Transport]:
    """The transport of every loop of ``config``: its ``port`` at its ``baud`` (not opened
    yet: each loop's scheduler opens it, and opens it again after a loss)."""
    return {loop.name: open_transport(loop.port, loop.baud) for loop in config.loops}


def _auth(args: argparse.Namespace, config: GatewayConfig) -> AuthConfig:
    """Tokens, or open with ``--no-auth`` on loopback (``AuthConfig.decide``)."""
    try:
        auth = AuthConfig.decide(args.host, config.security.tokens, no_auth=args.no_auth)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    if not auth.no_auth and not len(auth.book):
        raise ConfigError(
            NO_TOKENS
            if is_loopback(args.host)
            else f"--host {args.host}: no API token is configured, so nobody could use the "
            "API; add one (`rc233-gateway token`), or run it open on 127.0.0.1 with --no-auth"
        )
    return auth


def _edge_node(services: Services, config: GatewayConfig, auth: AuthConfig) -> EdgeNode | None:
    """The Sparkplug B edge node of ``[mqtt]`` (None without the section) over ``services``;
    its DCMDs are authorised by the API's tokens (always: no-auth mode is for loopback, a
    broker is not) and written to the shared audit record."""
    if config.mqtt is None:
        return None
    commands = DeviceCommands.serving(services, auth.book.principal)
    mqtt = config.mqtt
    print(f"rc233-gateway serve: Sparkplug B edge node {mqtt.group}/{mqtt.edge_node} on "
          f"{mqtt.host}:{mqtt.port}", flush=True)  # fmt: skip
    return EdgeNode(services.runtime, mqtt, commands=commands)


def _opcua_face(
    services: Services, config: GatewayConfig, auth: AuthConfig, store: StateStore
) -> OpcUaFace | None:
    """The OPC UA server of ``[opcua]`` (None without the section) over ``services``: its
    users are the API's tokens (always, as for MQTT: no-auth mode is for loopback), its calls
    go to the shared services and audit record; its certificate, when made, is kept in the
    state directory."""
    if config.opcua is None:
        return None
    print(f"rc233-gateway serve: OPC UA server {config.opcua.endpoint}", flush=True)
    return OpcUaFace(
        services, config.opcua, identify=auth.book.principal, state_dir=store.directory
    )


def _configured(args: argparse.Namespace) -> GatewayConfig | None:
    """The ``--config`` file, once ``check-config`` finds no problem in it (None: no file)."""
    if args.config is None:
        return None
    report = check_report(args.config, no_auth=args.no_auth, ports=not args.simulate)
    if report.problems:
        raise problems_error(args.config, report.problems)
    # A port not there yet (an adapter unplugged) is one loop down, not a gateway that cannot
    # start: its scheduler opens it with back-off and the loop is up once the device appears.
    for warning in report.warnings:
        log.warning("%s: %s", args.config, warning)
    return report.config


async def serve(args: argparse.Namespace) -> int:
    """Run the API until SIGINT/SIGTERM; the exit code."""
    # None: every loop's worker opens its port; else each worker builds its simulators
    cell: SimulatedCell | None = None
    config = _configured(args)
    if args.simulate:
        cell = simulated_lines(args, config)
        config = cell.config
    assert config is not None
    try:
        auth = _auth(args, config)
        state_dir, scratch = _state_dir(config, simulated=args.simulate)
        try:
            store = await StateStore.open(state_dir)
        except BaseException:
            if scratch:
                shutil.rmtree(state_dir, ignore_errors=True)
            raise
        try:
            return await _serve(args, config, cell, auth, store)
        finally:
            if scratch:
                shutil.rmtree(state_dir, ignore_errors=True)
    finally:
        if cell is not None:
            cell.close()


def _state_dir(config: GatewayConfig, *, simulated: bool) -> tuple[Path, bool]:
    """The state directory, and whether it is this process's own scratch directory: the
    configuration's ``state_dir``; with ``--simulate`` and none, a new temporary directory
    (a simulated loop starts from nothing each time); else ``default_state_dir()``."""
    if config.state_dir is not None:
        return config.state_dir, False
    if simulated:
        return Path(tempfile.mkdtemp(prefix="rc233-gateway-state-")), True
    return default_state_dir(), False


async def _serve(
    args: argparse.Namespace,
    config: GatewayConfig,
    cell: SimulatedCell | None,
    auth: AuthConfig,
    store: StateStore,
) -> int:
    """Run the API on the loops of ``config`` in line workers (``cell``: simulated loops,
    each built by its worker) with the opened state ``store`` until a signal."""
    lines = None if cell is None else cell.lines
    runtime = Runtime(config, time_scale=args.time_scale, store=store, worker_lines=lines)
    StateLog(runtime).start()
    services = compose(runtime)  # built once: the app, the edge node and OPC UA share them
    app = create_app(services, auth=auth)
    if auth.no_auth:
        log.warning(
            "AUTHENTICATION IS OFF: anyone who can reach http://%s:%d may move the machines "
            "(loopback only; started with --no-auth)",
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
            access_log=False,  # written by the app, cheaply (gateway.api.middleware.access_log)
            server_header=False,  # no "Server: uvicorn": the software is nobody's business
            **uvicorn_ws_options(config.ws),
            **uvicorn_connection_options(config.connections),
            timeout_graceful_shutdown=10,
        )
    )
    loops = ", ".join(f"{ref.name} ({ref.settings.port})" for ref in runtime.topology.loops())
    print(
        f"rc233-gateway serve: dashboard http://{args.host}:{args.port}/ "
        f"API http://{args.host}:{args.port}/api/v1 loops {loops}"
        + (" [simulated]" if cell is not None else "")
        + f" line workers {workers_text(runtime)}"
        + f" state {store.directory}",
        flush=True,
    )
    edge_node = _edge_node(services, config, auth)
    node_task = asyncio.create_task(edge_node.run()) if edge_node is not None else None
    opcua = _opcua_face(services, config, auth, store)
    opcua_started = False
    try:
        if opcua is not None:
            await opcua.start()
            opcua_started = True
        await server.serve()
    finally:
        if opcua is not None and opcua_started:
            await opcua.stop()
        if node_task is not None and edge_node is not None:
            node_task.cancel()
            await asyncio.gather(node_task, return_exceptions=True)
            edge_node.close()
    return 0


def workers_text(runtime: Runtime) -> str:
    """The line workers and their loops, for the start line (``[a, b] [c]``)."""
    assert runtime.workers is not None
    return " ".join(f"[{', '.join(s.client.proxies)}]" for s in runtime.workers.supervisors)


def event_loop_runner() -> asyncio.Runner:
    """A runner on uvloop where it is installed (``uvicorn[standard]``), else asyncio's own.

    uvloop's loop is libuv's: the scheduler, the HTTP server and the WebSocket fan-out each
    spend less CPU a callback there (docs/performance.md). Everything the gateway does on
    the loop is public asyncio API (readers on the serial port's descriptor, signal
    handlers, sockets), which uvloop implements.
    """
    try:
        import uvloop
    except ImportError:  # a platform without it (Windows): the stock loop
        return asyncio.Runner()
    return asyncio.Runner(loop_factory=uvloop.new_event_loop)


def _main(args: argparse.Namespace) -> int:
    if args.config is None and not args.simulate:
        print("rc233-gateway serve: give --config FILE, --simulate, or both", file=sys.stderr)
        return 2
    configure_logging(args.log_format, verbose=args.verbose)
    try:
        with event_loop_runner() as runner:
            return runner.run(serve(args))
    except (ConfigError, SceneError, OSError) as exc:
        print(f"rc233-gateway serve: {exc}", file=sys.stderr)
        return 2
