"""``python -m optimizer.episode``: the command lives in ``optimizer.cli.episode_command``."""

from optimizer.cli.episode_command import main

raise SystemExit(main())
