"""Expected failures of an agent run, reported as one line without a traceback."""


class AgentError(RuntimeError):
    """The server could not be reached, closed early, or sent something unusable."""
