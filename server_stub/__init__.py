"""A stand-in for rcssserver3d that takes ODE's physics step itself (pybullet holds the bodies' shapes):
the physics core (``physics``), the game without sockets (``simulation``) and, on top, the server (``net``)."""

from server_stub.kernel_cache import use_source_keyed_cache

# before any kernel of the package is defined: numba picks each kernel's cache folder then
use_source_keyed_cache()
