"""``rc233-gateway sim``: run the simulated RC-233 loop on a pseudo-terminal or a TCP port.

``gateway.cli`` adds the subcommand with ``add_sim_parser``. The simulator prints one line,
``rc233-gateway sim: listening on WHERE ...``, once it accepts connections (WHERE is the device
path for ``--pty``, ``socket://HOST:PORT`` for ``--tcp``), and stops cleanly, with exit code 0,
on SIGINT or SIGTERM.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import os
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from gateway.protocol.framing import BODY_NUMBERS, Series
from gateway.sim.clock import SimClock
from gateway.sim.control import UART_RATES, Controls, serve_control
from gateway.sim.controller import Controller
from gateway.sim.eeprom import Eeprom
from gateway.sim.faults import FaultKind, FaultRule, Faults
from gateway.sim.loop import SimLoop
from gateway.sim.scene import Scene, SceneError, load_scene
from gateway.sim.serve import PtyLine, serve_tcp

__all__ = [
    "add_clock_option",
    "add_loop_options",
    "add_sim_parser",
    "build_loop",
    "default_eeprom_dir",
    "host_port",
    "main",
    "parse_bodies",
    "positive",
    "run_sim",
]

log = logging.getLogger("gateway.sim")


def default_eeprom_dir() -> Path:
    """The per-user data directory: $XDG_DATA_HOME/rc233-gateway/sim (~/.local/share/...)."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "rc233-gateway" / "sim"


def parse_bodies(text: str) -> list[str]:
    """``1,2,3`` -> ['1', '2', '3']: 1-15 different body numbers 0-E (§3-III)."""
    bodies = [b.strip().upper() for b in text.split(",") if b.strip()]
    bad = [b for b in bodies if len(b) != 1 or b not in BODY_NUMBERS]
    if bad:
        raise argparse.ArgumentTypeError(f"body numbers are 0-9 or A-E (F is inspection): {bad}")
    if not 1 <= len(bodies) <= len(BODY_NUMBERS) or len(set(bodies)) != len(bodies):
        raise argparse.ArgumentTypeError("give 1-15 different body numbers, e.g. 1,2,3")
    return bodies


def host_port(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (an argparse type)."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, e.g. 127.0.0.1:5233, not {text!r}")
    return host, int(port)


def _probability(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError("a probability is 0-1")
    return value


def positive(text: str) -> float:
    """A number > 0 (an argparse type)."""
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return value


def add_sim_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``sim`` to the subcommands of ``rc233-gateway``; it sets ``func``."""
    sim: argparse.ArgumentParser = subparsers.add_parser(
        "sim",
        help="run simulated RC-233 controllers on a pseudo-terminal or TCP port",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    where = sim.add_mutually_exclusive_group(required=True)
    where.add_argument("--pty", action="store_true", help="serve on a pseudo-terminal")
    where.add_argument("--tcp", type=host_port, metavar="HOST:PORT", help="serve on TCP")
    add_loop_options(sim, bodies="1")
    sim.add_argument(
        "--baud", type=int, default=9600, choices=sorted(UART_RATES), metavar="BPS",
        help="the line's (the host's) baud rate; default 9600 (§10 ES factory setting)",
    )  # fmt: skip
    sim.add_argument("--series", choices=["$", "#"], default="$", help="start mark (§9-1)")
    sim.add_argument("--turnaround-ms", type=float, default=1.0, help="controller reply delay")
    for kind in ("nak", "drop", "garble", "late"):
        sim.add_argument(
            f"--fault-{kind}", type=_probability, default=0.0, metavar="P",
            help=f"probability of a {kind} fault per reply",
        )  # fmt: skip
    sim.add_argument("--late-delay", type=float, default=1.0, help="seconds a late reply waits")
    sim.add_argument("--seed", type=int, default=None, help="seed of the fault generator")
    sim.add_argument("-v", "--verbose", action="store_true", help="log connections")
    sim.set_defaults(func=_main)
    return sim


def add_loop_options(parser: Any, *, bodies: str) -> None:
    """The options of a simulated loop, declared once for ``sim`` and ``serve --simulate``:
    ``--bodies`` (default ``bodies``, e.g. ``"1,2,3"``), ``--scene``, ``--eeprom-dir``,
    ``--time-scale``, ``--clock`` and ``--control``."""
    # A string default goes through ``type`` like a command-line value: a list of bodies.
    parser.add_argument(
        "--bodies", type=parse_bodies, default=bodies, help="e.g. 1,2,3 (default %(default)s)"
    )
    parser.add_argument("--scene", type=Path, metavar="FILE", help="sensor layout (TOML)")
    parser.add_argument(
        "--eeprom-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help=f"where the controllers keep their EEPROM (default {default_eeprom_dir()})",
    )
    parser.add_argument("--time-scale", type=positive, default=1.0, metavar="X", help="speed-up")
    add_clock_option(parser)
    parser.add_argument("--control", type=host_port, metavar="HOST:PORT", help="control surface")


def add_clock_option(parser: Any) -> None:
    """``--clock precise|coarse`` (see ``SimClock``): replies on time to some 0.05 ms, or
    asyncio's timers (up to a millisecond and more late, no timer thread)."""
    parser.add_argument(
        "--clock", choices=["precise", "coarse"], default="precise",
        help="precise (default): replies within some 0.05 ms of their wire time; coarse: "
        "asyncio's timers (a millisecond or so late)",
    )  # fmt: skip


def build_loop(
    bodies: Sequence[str],
    *,
    series: Series = Series.DOLLAR,
    scene: Scene | None = None,
    eeprom_dir: Path | None = None,
    clock: SimClock | None = None,
    **kwargs: Any,
) -> SimLoop:
    """A loop of real ``Controller``s; ``kwargs`` go to ``SimLoop`` (baud, turnaround...)."""
    clock = clock or SimClock()
    now = clock.now()
    scene = scene or Scene()
    controllers = [
        Controller(
            body,
            series=series,
            scene={m: scene.axis(body, m) for m in (1, 2)},
            eeprom=Eeprom.for_body(eeprom_dir, series.value, body),
            now=now,
        )
        for body in bodies
    ]
    return SimLoop(controllers, clock=clock, **kwargs)


def _faults(args: argparse.Namespace) -> Faults:
    faults = Faults(seed=args.seed)
    for kind in ("nak", "drop", "garble", "late"):
        p = getattr(args, f"fault_{kind}")
        if p > 0:
            faults.add(FaultRule(FaultKind(kind), probability=p, delay=args.late_delay))
    return faults


async def run_sim(args: argparse.Namespace) -> int:
    """Serve until SIGINT/SIGTERM; the exit code."""
    scene = load_scene(args.scene) if args.scene else None
    eeprom_dir = args.eeprom_dir or default_eeprom_dir()
    loop = build_loop(
        args.bodies,
        series=Series(args.series),
        scene=scene,
        eeprom_dir=eeprom_dir,
        clock=SimClock(args.time_scale, precise=args.clock == "precise"),
        baud=args.baud,
        turnaround=args.turnaround_ms / 1000,
        faults=_faults(args),
    )
    stop = asyncio.Event()
    aio = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        aio.add_signal_handler(sig, stop.set)
    servers: list[asyncio.Server] = []
    pty: PtyLine | None = None
    try:
        if args.pty:
            pty = PtyLine(loop)
            where = pty.start()
        else:
            server = await serve_tcp(loop, *args.tcp)
            servers.append(server)
            host, port = server.sockets[0].getsockname()[:2]
            where = f"socket://{host}:{port}"
        extra = ""
        if args.control:
            control = await serve_control(Controls(loop), *args.control)
            servers.append(control)
            host, port = control.sockets[0].getsockname()[:2]
            extra = f" control {host}:{port}"
        print(
            f"rc233-gateway sim: listening on {where} bodies {','.join(args.bodies)}"
            f" series {args.series} baud {args.baud} time-scale {args.time_scale:g}"
            f" eeprom {eeprom_dir}{extra}",
            flush=True,
        )
        await stop.wait()
    finally:
        for server in servers:
            server.close()
            close_clients = getattr(server, "close_clients", None)  # Python 3.13+
            if close_clients is not None:
                close_clients()
        for server in servers:
            with contextlib.suppress(Exception):
                await asyncio.wait_for(server.wait_closed(), 2.0)
        if pty is not None:
            pty.close()
        loop.close()
        for sig in (signal.SIGINT, signal.SIGTERM):
            aio.remove_signal_handler(sig)
    return 0


def _main(args: argparse.Namespace) -> int:
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="rc233-gateway sim: %(message)s",
        stream=sys.stderr,
    )
    try:
        return asyncio.run(run_sim(args))
    except (OSError, SceneError, ValueError) as exc:
        print(f"rc233-gateway sim: {exc}", file=sys.stderr)
        return 2


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m gateway.sim.cli ...``: the ``sim`` subcommand on its own."""
    parser = argparse.ArgumentParser(prog="rc233-gateway")
    sub = parser.add_subparsers(dest="cmd", required=True)
    add_sim_parser(sub)
    args = parser.parse_args(["sim", *(sys.argv[1:] if argv is None else argv)])
    code: int = args.func(args)
    return code


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
