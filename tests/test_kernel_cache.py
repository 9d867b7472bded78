"""``server_stub.kernel_cache``: numba's cache folder is keyed by every kernel source, so that a
change to a kernel's callee is never run as the old code from the cache."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numba

from server_stub import kernel_cache
from server_stub.physics import tree_step

_CALLEE = "from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return x + {}\n"
_CALLER = "from numba import njit\nfrom pkg.callee import f\n\n@njit(cache=True)\ndef g(x):\n    return f(x) * 2.0\n"


def _package(root: Path, add: float) -> Path:
    """A package ``pkg`` of two kernel files: ``caller.g`` calls ``callee.f`` (x + ``add``)."""
    pkg = root / "pkg"
    pkg.mkdir(exist_ok=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "callee.py").write_text(_CALLEE.format(add))
    (pkg / "caller.py").write_text(_CALLER)
    return pkg


def _g_of_one(root: Path) -> float:
    """``pkg.caller.g(1.0)`` in a new process, its cache under ``root/cache`` keyed by the
    package's sources."""
    script = (
        "from pathlib import Path\n"
        "from server_stub.kernel_cache import use_source_keyed_cache\n"
        "use_source_keyed_cache(Path('pkg'))\n"
        "from pkg.caller import g\n"
        "print(g(1.0))\n"
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(root / "cache"), PYTHONPATH=os.pathsep.join([str(root), *sys.path]))
    done = subprocess.run([sys.executable, "-c", script], cwd=root, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    return float(done.stdout)


def test_a_changed_callee_is_compiled_anew_not_loaded_stale(tmp_path):
    """``g`` calls ``f``, each in its own file; ``f``'s file changes, ``g``'s does not. numba
    alone (numba 0.68) would load ``g`` from its cache with the old ``f`` compiled in, and print
    4.0 again; keyed by the sources, ``g`` is compiled anew."""
    pkg = _package(tmp_path, 1.0)
    assert _g_of_one(tmp_path) == 4.0
    _package(tmp_path, 100.0)
    assert (pkg / "callee.py").read_text().endswith("x + 100.0\n")
    assert _g_of_one(tmp_path) == 202.0


def test_the_hash_follows_kernel_files_only(tmp_path):
    pkg = _package(tmp_path, 1.0)
    first = kernel_cache.sources_hash(pkg)
    (pkg / "plain.py").write_text("X = 1\n")  # no kernel: the same folder
    assert kernel_cache.sources_hash(pkg) == first
    (pkg / "callee.py").write_text(_CALLEE.format(2.0))
    second = kernel_cache.sources_hash(pkg)
    assert second != first
    (pkg / "more.py").write_text("import numba\n")  # a new kernel file
    assert kernel_cache.sources_hash(pkg) != second


def test_the_stand_ins_kernels_are_cached_in_the_folder_of_their_sources():
    folder = Path(numba.config.CACHE_DIR)
    base = os.environ.get("NUMBA_CACHE_DIR")
    assert folder == kernel_cache.cache_folder(kernel_cache.PACKAGE, base)
    assert folder.name == "kernels-" + kernel_cache.sources_hash()
    assert Path(tree_step.step_tree._cache._cache_path).parent == folder  # noqa: SLF001


def test_an_unwritable_package_folder_falls_back_to_the_users_cache(tmp_path, monkeypatch):
    pkg = _package(tmp_path, 1.0)
    (pkg / "__pycache__").write_text("a file, not a folder")  # nothing can be made under it
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user"))
    folder = kernel_cache.cache_folder(pkg)
    assert folder == tmp_path / "user" / "gala-kernels" / ("kernels-" + kernel_cache.sources_hash(pkg))


def _installed(tmp_path: Path, monkeypatch) -> tuple[Path, Path]:
    """A package that cannot be written (only ``_writable`` says so: the tests run as root), its
    kernels compiled into its ``__pycache__`` (one file, "compiled"); and where the user's copy of
    them goes."""
    pkg = _package(tmp_path, 1.0)
    name = "kernels-" + kernel_cache.sources_hash(pkg)
    (pkg / "__pycache__" / name).mkdir(parents=True)
    (pkg / "__pycache__" / name / "k.nbi").write_text("compiled")
    monkeypatch.setattr(kernel_cache, "_writable", lambda folder: not folder.is_relative_to(pkg))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user"))
    return pkg, tmp_path / "user" / "gala-kernels" / name


def test_kernels_compiled_into_an_unwritable_package_are_copied_to_the_users_cache(tmp_path, monkeypatch):
    """A container's user cannot write the installed package, where its image compiled the
    kernels: they are used from a copy in the user's folder (numba writes beside what it loads)."""
    pkg, mine = _installed(tmp_path, monkeypatch)
    folder = kernel_cache.cache_folder(pkg)
    assert folder == mine
    assert (folder / "k.nbi").read_text() == "compiled"


def test_a_copy_put_in_place_first_by_another_process_is_kept(tmp_path, monkeypatch):
    """Two processes of a new container copy the package's kernels at once: the first renamed
    into place stays, the other's copy is dropped (no process reads a half-made copy)."""
    pkg, theirs = _installed(tmp_path, monkeypatch)
    real_copy = shutil.copytree

    def raced(source, target):
        theirs.mkdir(parents=True)
        (theirs / "k.nbi").write_text("theirs")
        return real_copy(source, target)

    monkeypatch.setattr(kernel_cache.shutil, "copytree", raced)
    assert kernel_cache.cache_folder(pkg) == theirs
    assert (theirs / "k.nbi").read_text() == "theirs"
    assert sorted(p.name for p in theirs.parent.iterdir()) == [theirs.name]


def test_a_copy_left_half_made_by_a_killed_process_is_removed_at_the_next_set_up(tmp_path, monkeypatch):
    """A process killed while copying the package's kernels leaves its ``kernels-<hash>.<pid>``
    behind: the next process to set the cache up removes it; a copy still being made is kept."""
    pkg, mine = _installed(tmp_path, monkeypatch)
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    orphan = mine.with_name(f"{mine.name}.{int(gone.stdout)}")
    running = mine.with_name(f"{mine.name}.{os.getppid()}")  # alive: this test's parent
    for part in (orphan, running):
        part.mkdir(parents=True)
        (part / "k.nbi").write_text("half")
    assert kernel_cache.cache_folder(pkg) == mine
    assert sorted(p.name for p in mine.parent.iterdir()) == sorted([mine.name, running.name])


def test_without_a_writable_user_folder_the_temporary_folder_holds_them(tmp_path, monkeypatch):
    """A container run as a user without a home (``docker/compose.yaml`` takes the host's uid)."""
    pkg = _package(tmp_path, 1.0)
    (pkg / "__pycache__").write_text("")
    (tmp_path / "nohome").write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "nohome"))
    monkeypatch.setattr(kernel_cache.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    folder = kernel_cache.cache_folder(pkg)
    assert folder == tmp_path / "tmp" / "gala-kernels" / ("kernels-" + kernel_cache.sources_hash(pkg))
    assert folder.is_dir()


def test_folders_of_older_sources_go_after_a_day_unwritten(tmp_path, monkeypatch):
    pkg = _package(tmp_path, 1.0)
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)  # restored after the test
    old, recent = pkg / "__pycache__" / "kernels-old", pkg / "__pycache__" / "kernels-recent"
    for folder, age in ((old, 2 * 24 * 3600), (recent, 3600)):
        folder.mkdir(parents=True)
        (folder / "k.nbi").write_text("")
        stamp = time.time() - age
        os.utime(folder / "k.nbi", (stamp, stamp))
    kept = kernel_cache.use_source_keyed_cache(pkg)
    assert numba.config.CACHE_DIR == str(kept)
    assert sorted(p.name for p in (pkg / "__pycache__").iterdir()) == sorted([kept.name, "kernels-recent"])


def test_a_user_cache_folder_is_kept_and_holds_the_keyed_folder(tmp_path, monkeypatch):
    pkg = _package(tmp_path, 1.0)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)
    (tmp_path / "mine" / "kernels-old").mkdir(parents=True)  # not ours to remove, however old
    os.utime(tmp_path / "mine" / "kernels-old", (0, 0))
    kept = kernel_cache.use_source_keyed_cache(pkg)
    assert kept.parent == tmp_path / "mine"
    assert (tmp_path / "mine" / "kernels-old").is_dir()


def test_the_package_sets_it_before_its_first_kernel():
    """``server_stub``'s own import points the cache, so any kernel module imported alone gets it."""
    script = textwrap.dedent(
        """
        import numba
        from server_stub.physics import linalg
        print(linalg.cross3._cache._cache_path.startswith(numba.config.CACHE_DIR))
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=Path(__file__).resolve().parents[1], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["True"]
