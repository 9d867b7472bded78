"""The GALA optimizer, by concern:

- ``search/``: the GA, the learning automata, GALA and their settings (ask/tell searches);
- ``episode/``: one walk on one server: its settings, the runner, where it is scored, the
  monitor link and the servers it runs on (the stand-in, a real rcssserver3d; the fidelity
  comparison of the two is a benchmark, ``bench.fidelity``);
- ``evaluation/``: many episodes at once, on local worker processes or a Dask cluster;
- ``run/``: a run's folder and episode log, the driver that replays it, the stability check and
  the result files;
- ``cli/``: the commands; ``compare/``: the optimizer comparison.

Entry points: ``python -m optimizer.gala``, ``optimizer.ga``, ``optimizer.episode``,
``optimizer.transfer`` and ``optimizer.compare`` (also console scripts, see pyproject.toml).
"""
