"""``python -m optimizer.episode``: the command lives in ``optimizer.cli.episode``."""

from optimizer.cli.episode import main

raise SystemExit(main())
