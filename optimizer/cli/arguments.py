"""Flags of the commands that walk gaits without a search (``optimizer.episode``,
``optimizer.transfer``), taken from the settings' table (``optimizer.settings``) so that each flag
has one help and one type whichever command takes it.
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Sequence

from optimizer import settings
from optimizer.episode.real_server import RealServerProcess
from optimizer.episode.servers import ManagedServer, ServerAddress
from optimizer.run.session import check_start_for_real_server, real_server_command


def add_episode_arguments(parser: argparse.ArgumentParser) -> None:
    """How one episode is run: ``--walk-time``, ``--start`` and ``--agent-mode``."""
    for name in ("walk_time", "start", "agent_mode"):
        settings.setting(name).add_to(parser)


def add_server_arguments(parser: argparse.ArgumentParser, *, repeatable: bool = True) -> None:
    """Where episodes run: ``--real N`` (real rcssserver3d servers started here) or ``--server``
    (servers run elsewhere); neither: the embedded stub. Not ``repeatable``: one server."""
    where = parser.add_mutually_exclusive_group()
    real, server = settings.setting("real"), settings.setting("server")
    if not repeatable:
        real = dataclasses.replace(real, help="start a real rcssserver3d (N must be 1) and stop it at the end")
        help_one = "evaluate on this running rcssserver3d instead of the embedded stub"
        server = dataclasses.replace(server, action=None, help=help_one)
    real.add_to(where)
    server.add_to(where)


def one_server(
    parser: argparse.ArgumentParser, args: argparse.Namespace, start: Sequence[float], what: str
) -> ServerAddress | ManagedServer | None:
    """The one server a command that walks one episode at a time was given (``add_server_arguments``
    not ``repeatable``): ``--server``'s, a real server to start for ``--real 1``, or None for the
    embedded stub. Refuses ``--real`` other than 1, and a ``start`` a real server would not allow
    (the parser's error: ``what`` says which command walks one at a time)."""
    server: ServerAddress | ManagedServer | None = args.server
    if args.real is not None:
        if args.real != 1:
            parser.error(f"--real {args.real}: {what} walks one episode at a time on one server; use --real 1")
        server = RealServerProcess(real_server_command(parser))
    if server is not None:
        check_start_for_real_server(parser, start, "--real" if args.real else "--server")
    return server
