"""Where numba keeps the stand-in's compiled kernels: a folder named after the kernels' sources.

numba's disk cache checks a kernel against its own source file only. A kernel that calls
kernels of other files (a robot's step calls the solver's, which call the linear algebra's) has
their code compiled into it, so after a change to a callee's file, and nothing else, the caller
is loaded from the cache with the old callee inside: the stand-in would run the old physics,
silently. Keying the cache folder by a hash of every kernel source of the package makes any such
change start from an empty folder.

The folder is ``kernels-<hash>`` under ``NUMBA_CACHE_DIR`` when that is set, else under the
package's ``__pycache__`` (per checkout, as numba's own default), else, when that cannot be
written (an installed package), under the user's cache folder (or the temporary folder),
starting from a copy of the package's own when it has one (kernels compiled at install,
``docker/Dockerfile``); a copy left half made by a killed process is removed by the next one to
set the cache up. Folders of older sources left in the package's ``__pycache__`` are
removed once nothing has been written to them for a day.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
import time
from pathlib import Path

import numba

PACKAGE = Path(__file__).resolve().parent
_PREFIX = "kernels-"
#: a folder of older sources is removed after this long unwritten (a process still running the
#: old sources may be using it)
_STALE_AFTER = 24 * 3600.0


def sources_hash(root: Path = PACKAGE) -> str:
    """A hash of every Python file under ``root`` that uses numba (path and contents), so that a
    change to any kernel, or a kernel file added or removed, gives another hash."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0" + text + b"\0")
    return digest.hexdigest()[:16]


def _writable(folder: Path) -> bool:
    """Whether ``folder`` can be made and written to (numba's own test of a cache folder)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def _elsewhere() -> tuple[Path, ...]:
    """Where the kernels go when the package cannot be written: the user's cache folder, else
    (a container run as a user without a home) the temporary folder."""
    user = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return user / "gala-kernels", Path(tempfile.gettempdir()) / "gala-kernels"


def cache_folder(root: Path = PACKAGE, base: str | None = None) -> Path:
    """The cache folder for the kernels under ``root`` as their sources are now (``base``: a
    folder named by the user, ``NUMBA_CACHE_DIR``)."""
    name = _PREFIX + sources_hash(root)
    if base:
        return Path(base) / name
    in_tree = root / "__pycache__" / name
    if _writable(in_tree):
        return in_tree
    # an installed package (a container's): numba writes beside every kernel it loads, so kernels
    # compiled into the package when it was installed are used from a copy
    for place in _elsewhere():
        _remove_orphans(place)
        folder = place / name
        if not folder.is_dir() and in_tree.is_dir() and _writable(place):
            _copy_whole(in_tree, folder)
        if _writable(folder):
            return folder
    return in_tree  # nowhere to write: numba's own fallbacks decide


def _copy_whole(source: Path, folder: Path) -> None:
    """Copy ``source`` to ``folder`` so that no process sees it half copied: into a folder of
    this process's own, then renamed. Where another process's copy came first, or the copy
    failed, nothing is put in place (what is missing is compiled)."""
    part = folder.with_name(f"{folder.name}.{os.getpid()}")
    try:
        shutil.copytree(source, part)
        os.rename(part, folder)
    except OSError:
        shutil.rmtree(part, ignore_errors=True)


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (one of another user's counts)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # not ours to signal: it exists
        return True
    return True


def _remove_orphans(place: Path) -> None:
    """Remove the half-made copies in ``place`` (``_copy_whole``'s ``kernels-<hash>.<pid>``) of
    processes that no longer exist: killed while copying, they never renamed nor removed them.
    A copy whose process still runs is left to it (a reused pid only delays the removal)."""
    for part in place.glob(_PREFIX + "*.*"):
        pid = part.suffix[1:]
        if pid.isdigit() and part.is_dir() and not _alive(int(pid)):
            shutil.rmtree(part, ignore_errors=True)


def _remove_stale(folder: Path) -> None:
    """Remove the folders of older sources beside ``folder`` not written to for a day."""
    now = time.time()
    for other in folder.parent.glob(_PREFIX + "*"):
        if other != folder and other.is_dir():
            try:
                idle = now - max((p.stat().st_mtime for p in other.iterdir()), default=other.stat().st_mtime)
            except OSError:
                continue
            if idle > _STALE_AFTER:
                shutil.rmtree(other, ignore_errors=True)


def use_source_keyed_cache(root: Path = PACKAGE) -> Path:
    """Point numba's disk cache at ``cache_folder``. Called before the package's first kernel
    is defined (numba picks a kernel's cache folder then); it applies to the whole process."""
    user = os.environ.get("NUMBA_CACHE_DIR")
    folder = cache_folder(root, user)
    numba.config.CACHE_DIR = str(folder)  # type: ignore[attr-defined]  # set from NUMBA_* at import
    if not user and folder.parent == root / "__pycache__":
        _remove_stale(folder)
    return folder
