"""``python -m optimizer.transfer``: a run's gaits walked on a real server. Only the entry point: the command lives in
``optimizer.cli.transfer_command``."""

from optimizer.cli.transfer_command import main

if __name__ == "__main__":
    raise SystemExit(main())
