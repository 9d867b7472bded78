"""``python -m optimizer.calibrate``: make a steerable walk walk the speeds it is commanded. Only
the entry point: the command lives in ``optimizer.cli.calibrate_command``."""

from optimizer.cli.calibrate_command import main

if __name__ == "__main__":
    raise SystemExit(main())
