"""rcssserver3d 0.7.3's referee for the stand-in (its SoccerRuleAspect and BallStateAspect):
kick-offs, goals and the score, the ball out of the field (kick-in, corner, goal kick), drop balls,
halves and the end of the game, and where robots and the ball are put in each play mode.

``Referee`` runs once a cycle around the physics step (``server_stub.simulation``); the rules and
what was left out, with their sources: docs/robot_and_server.md section 8.
"""

from server_stub.referee.referee import Referee

__all__ = ["Referee"]
