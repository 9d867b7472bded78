"""``python -m optimizer.ga``: one GA with fixed rates. Only the entry point: the command lives in
``optimizer.cli.ga_command``."""

from optimizer.cli.ga_command import main

if __name__ == "__main__":
    raise SystemExit(main())
