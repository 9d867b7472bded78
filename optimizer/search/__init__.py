"""Searching the 7 TFS genes: the GA, learning automata, GALA and their settings, as ask/tell searches."""
