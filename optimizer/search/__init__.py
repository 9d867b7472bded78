"""Searching a gait family's genes (the paper's 7 TFS genes by default): the GA, learning automata,
GALA, CMA-ES and their settings, as ask/tell searches."""
