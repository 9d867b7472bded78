"""``python -m optimizer.gala``: the paper's Table I protocol. Only the entry point: the command lives in
``optimizer.cli.gala_command``."""

from optimizer.cli.gala_command import main

if __name__ == "__main__":
    raise SystemExit(main())
