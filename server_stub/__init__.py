"""A pybullet stand-in for rcssserver3d: the physics core (world, robot) and, on top, the server."""
