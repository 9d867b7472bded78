"""The benchmarks: measurements of the agent, the stand-in server and the optimizer, and of the
stand-in against a real rcssserver3d (its fidelity, ``bench.fidelity``), with the tools that made
their stored data (the fidelity gait sets in ``bench/fidelity_gaits/``, the physics hashes, the
referee recordings under ``tests/data/referee/``).

Each benchmark is a module run from the repository root, its name the file's stem::

    python -m bench.bench_episodes --episodes 60
    python -m bench.bench_fidelity --set all --real-repeats 3 --out /tmp/fidelity
    python -m bench.bench_stub --help

``bench`` is part of the source checkout, not of the installed packages (pyproject.toml installs
agent, protocol, gait, optimizer and server_stub only), so it is found because ``python -m`` puts
the current directory, the repository root, first on the path. The results and how they were
reached are in ``bench/RESULTS.md`` (their history: ``docs/history/``).
"""
