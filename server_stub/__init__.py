"""A stand-in for rcssserver3d that takes ODE's physics step itself (pybullet holds the bodies' shapes):
the physics core (``physics``), the game without sockets (``simulation``) and, on top, the server (``net``)."""
