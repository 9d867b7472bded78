"""``python -m optimizer.refine``: make a walk you have faster. Only the entry point: the command lives in
``optimizer.cli.refine_command``."""

from optimizer.cli.refine_command import main

if __name__ == "__main__":
    raise SystemExit(main())
