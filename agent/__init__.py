"""The NAO agent: connects to rcssserver3d (or the stub), beams, and walks with a gait (the paper's TFS by default).

Public API for programs that run agents in-process (the optimizer's fast path)::

    from agent import AgentConfig, NaoAgent
    report = NaoAgent(AgentConfig(port=3100, sync=True, duration=15.0)).run()
"""

from agent.config import AgentConfig
from agent.errors import AgentError
from agent.nao_agent import AgentReport, NaoAgent

__all__ = ["AgentConfig", "AgentError", "AgentReport", "NaoAgent"]
