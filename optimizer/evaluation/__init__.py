"""Evaluating many episodes: a pool of local worker processes (``pool``) or a Dask cluster
(``dask_cluster``), behind one ``Evaluator`` interface."""
