"""``server_stub.kernels``: every kernel compiled before it is needed, in two processes on a cold
numba cache."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from server_stub import kernels

ROOT = Path(__file__).resolve().parents[1]


def test_an_unknown_part_is_refused_with_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown kernel parts \['physics'\].*robot"):
        kernels.warm_up(["motors", "physics"])


def test_the_walks_parts_are_a_servers_and_each_has_a_probe():
    assert set(kernels.WALK) <= set(kernels.SERVER) == set(kernels.PARTS) - {"shared"}
    assert set(kernels.PARTS) == set(kernels._PROBES)  # noqa: SLF001
    kernels.warm_up(["motors"], processes=1)
    assert kernels._cached("motors")  # noqa: SLF001 - the probe is what decides on the helper


@pytest.mark.slow
def test_on_a_cold_cache_a_helper_process_compiles_the_later_parts(tmp_path):
    """With an empty cache and two processes, the helper (``python -m server_stub.kernels``)
    compiles the second part into the cache while the first compiles here: both parts' kernels
    are in the cache afterwards, and a later warm-up finds them there and starts no helper."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    script = (
        "import subprocess, sys\n"
        "from server_stub import kernels\n"
        "helpers = []\n"
        "real = subprocess.Popen\n"
        "def counted(*a, **k):\n"
        "    helpers.append(a[0])\n"
        "    return real(*a, **k)\n"
        "subprocess.Popen = counted\n"
        "kernels.warm_up(['motors', 'sensors'])\n"
        "print(len(helpers), kernels._cached('motors'), kernels._cached('sensors'))\n"
    )
    first = _python(script, env)
    assert first.stdout.split() == ["1", "True", "True"]
    cached = {path.name.split(".")[0] for path in tmp_path.rglob("*.nbi")}
    assert {"motors", "number_text", "vision", "rotations"} <= cached
    again = _python(script, env)
    assert again.stdout.split() == ["0", "True", "True"]


@pytest.mark.slow
def test_a_cold_walk_compile_finds_each_shared_kernel_with_the_listed_types_only(tmp_path):
    """A walk's warm-up on an empty cache (two processes: the helper compiles ``SHARED`` by the
    listed types, this process a robot's step, and each loads the other's). Had a robot's step or
    an island's called a shared kernel with other types, its cache index would hold a second
    signature; had the helper not compiled it, none."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    script = (
        "from server_stub import kernels\n"
        "kernels.warm_up(kernels.WALK)\n"
        "for kernel, spec in kernels.SHARED:\n"
        "    held = [key[0] for key in kernel()._cache._cache_file._load_index()]\n"
        "    print(kernel().__name__, held == [kernels.shared_signature(spec)], len(held))\n"
    )
    done = _python(script, env)
    lines = done.stdout.split("\n")[: len(kernels.SHARED)]
    assert [line.split()[1:] for line in lines] == [["True", "1"]] * len(kernels.SHARED), done.stdout


def _python(script: str, env: dict[str, str]) -> subprocess.CompletedProcess:
    """``script`` run by a new Python in the repository, which must exit 0."""
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    return done
