"""Which optimizer finds the fastest stable walk? Search methods compared at equal episode budgets,
over many seeds, with statistics (``python -m optimizer.compare``).

- ``methods/``: one module per search method (or family); each is found by looking, so a new
  method is one new module and no edit to a list.
- ``budget``: a method as a search program held to an episode budget, and the drive that scores
  its candidates (one walk each, or a robust score over moved starts).
- ``statistics``: per-method summaries and pairwise tests.
- ``report``: the tables and the convergence plot.
"""
