"""Seeds of a run's parts, derived from the run's one seed.

One seed fixes every random choice of a run (the GA, the automaton, the dither, the check starts):
each part draws from its own seed, named by what it is, so that a part replays the same whatever
the others draw and whichever process runs it.
"""

from __future__ import annotations

import hashlib


def stable_seed(run_seed: int, name: str) -> int:
    """A 32-bit seed for the part ``name`` of a run (an episode key, a worker, a crossover row):
    a hash, so it is the same in every process and every Python run (``hash()`` is salted)."""
    digest = hashlib.blake2b(f"{run_seed}/{name}".encode(), digest_size=4).digest()
    return int.from_bytes(digest, "big")
