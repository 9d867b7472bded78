"""Flags of the commands that walk gaits without a search (``optimizer.episode``,
``optimizer.transfer``), taken from the settings' table (``optimizer.settings``) so that each flag
has one help and one type whichever command takes it.
"""

from __future__ import annotations

import argparse
import dataclasses

from optimizer import settings


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
