"""Where a cold start's compile time goes: each numba compile of the stand-in's kernels, timed.

A first episode on a fresh clone is mostly numba compiling (``bench/bench_cold_start.py``). This
compiles the walk's parts (``server_stub.kernels.WALK``, or the parts named) in one process with
an empty cache of its own, records numba's compile events, and prints each part's time and the
compiles that took longest: with their callees (inclusive) and without (exclusive), and for a
compile of numba's own (its error messages, say) the kernel of ours that asked for it.

    python -m bench.compile_profile                 # the walk's parts
    python -m bench.compile_profile robot sensors   # the parts named
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from numba.core import event


def compiles(recorder: event.RecordingListener) -> list[tuple[float, float, str]]:
    """(start, end, name) of every compile the recorder saw."""
    open_: dict[tuple[str, str], float] = {}
    out = []
    for stamp, ev in recorder.buffer:
        dispatcher = ev.data.get("dispatcher")
        func = dispatcher.py_func if dispatcher is not None else None
        name = f"{func.__module__}.{func.__qualname__}" if func is not None else "?"
        key = (name, str(ev.data.get("args")))
        if ev.is_start:
            open_[key] = stamp
        else:
            out.append((open_.pop(key, stamp), stamp, name))
    return out


def main(argv: list[str] | None = None) -> int:
    # cold: an empty cache of this run's own, set before numba is imported (here, not at the top)
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="gala-numba-")
    from numba.core import event

    from server_stub import kernels

    parser = argparse.ArgumentParser(
        prog="python -m bench.compile_profile",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("parts", nargs="*", help=f"parts to compile, of {', '.join(kernels.PARTS)} (default: a walk's)")
    parser.add_argument("--top", type=int, default=25, help="how many compiles to list (default 25)")
    args = parser.parse_args(argv)
    unknown = [part for part in args.parts if part not in kernels.PARTS]
    if unknown:
        parser.error(f"no part {', '.join(unknown)}: the parts are {', '.join(kernels.PARTS)}")
    recorder = event.RecordingListener()
    event.register("numba:compile", recorder)
    began = time.perf_counter()
    for part in args.parts or kernels.WALK:
        started = time.perf_counter()
        kernels.PARTS[part]()
        print(f"part {part}: {time.perf_counter() - started:.1f} s")
    print(f"all: {time.perf_counter() - began:.1f} s, one process")
    spans = compiles(recorder)
    rows = []
    for start, end, name in spans:
        inner = [(s, e) for s, e, _ in spans if start < s and e < end]
        direct = [(s, e) for s, e in inner if not any(s2 < s and e < e2 for s2, e2 in inner)]
        exclusive = (end - start) - sum(e - s for s, e in direct)
        outer = [(e - s, n) for s, e, n in spans if s < start and end < e and not n.startswith("numba")]
        asked_by = min(outer)[1] if outer and name.startswith("numba") else ""
        rows.append((exclusive, end - start, name, asked_by))
    print(f"{len(rows)} compiles; the longest by exclusive time (s):")
    for exclusive, inclusive, name, asked_by in sorted(rows, reverse=True)[: args.top]:
        by = f"  (for {asked_by})" if asked_by else ""
        print(f"{exclusive:7.2f} {inclusive:7.2f}  {name}{by}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
