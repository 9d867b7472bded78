"""A run: its folder and episode log, the driver that evaluates or replays a search against it, the
stability check of what it found, and its result files."""
