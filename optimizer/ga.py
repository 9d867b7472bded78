"""``python -m optimizer.ga``: one GA with fixed rates. Only the entry point: the command lives in
``optimizer.cli.ga``."""

from optimizer.cli.ga import main

if __name__ == "__main__":
    raise SystemExit(main())
