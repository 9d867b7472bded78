"""One episode (paper eq. 9) on one server: its settings (``config``), the runner (``runner``),
where it is scored (``scoring``), the trainer's monitor link (``monitor_link``), the servers it
runs on (``servers``: the embedded stand-in; ``real_server``: a real rcssserver3d). The stand-in
measured against the real server is a benchmark of the source checkout (``bench.fidelity``).

``python -m optimizer.episode`` walks one gait from the command line (``optimizer.cli.episode_command``).
"""

from optimizer.episode.config import (
    CALIBRATED_COMMAND_NOISE,
    DEFAULT_START,
    EpisodeConfig,
    EpisodeResult,
    Start,
    start_problem_on_real_server,
)
from optimizer.episode.runner import EpisodeRunner
from optimizer.episode.scoring import Judge, TracePoint
from optimizer.episode.servers import ServerAddress

__all__ = [
    "CALIBRATED_COMMAND_NOISE",
    "DEFAULT_START",
    "EpisodeConfig",
    "EpisodeResult",
    "EpisodeRunner",
    "Judge",
    "ServerAddress",
    "Start",
    "TracePoint",
    "start_problem_on_real_server",
]
