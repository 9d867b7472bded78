"""A run folder: the manifest, the append-only episode log and the result files of one optimizer run.

Layout (``runs/gala-20250101-120000/``)::

    manifest.json      what was run: command, settings, seed, versions, command line, start time
    episodes.jsonl     one JSON object per finished episode, appended and flushed as it finishes
    results.json       the search results (GALAResult/GAResult.to_dict() plus the best episode)
    table1.csv/.md     Table I (GALA runs)
    *.png              convergence plots
    best_gait*.json    the best gaits, in the gait file format (``python -m agent --gait FILE``)
    fastest_gait.json  (GALA runs) the fastest walk of the run that passed its stability check

The episode log is what makes a run resumable: a search replayed with the same seed asks the same
keys in the same order, and every key found in the log is answered from it instead of being run.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import time
from collections.abc import Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from optimizer.evaluation.record import EpisodeRecord, RecordError

MANIFEST = "manifest.json"
EPISODES = "episodes.jsonl"
MANIFEST_FORMAT = "gala-run/1"
#: Where ``repair_episode_log`` moves the lines it cannot use, beside the log.
REJECTED_SUFFIX = ".rejected"
#: How a resumed run is told to go on past bad lines (named in the error that stops it).
SKIP_FLAG = "--skip-bad-lines"
_REPO = Path(__file__).resolve().parents[2]


class RunFolderError(ValueError):
    """A folder that cannot be used as asked; the message names the folder and the problem."""


def write_json(path: Path, document: Any) -> None:
    """Write through a temporary file and rename, so a reader (or a kill) never sees half a file."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(document, indent=2) + "\n")
    os.replace(tmp, path)


def _distribution_version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def _package_version() -> str | None:
    """This project's version: from the installed metadata, else from the pyproject.toml beside
    the sources (a checkout run without ``pip install``)."""
    installed = _distribution_version("gala-nao")
    if installed is not None:
        return installed
    try:
        import tomllib

        return tomllib.loads((_REPO / "pyproject.toml").read_text())["project"]["version"]
    except (OSError, KeyError, ValueError):
        return None


def _git_commit() -> str | None:
    try:
        out = subprocess.run(
            ["git", "-C", str(_REPO), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5, check=True
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None


def versions() -> dict[str, str | None]:
    """What produced the numbers: read from package metadata, so pybullet is never imported here."""
    return {
        "python": platform.python_version(),
        "numpy": _distribution_version("numpy"),
        "pybullet": _distribution_version("pybullet"),
        "gala-nao": _package_version(),
        "git_commit": _git_commit(),
    }


def new_run_path(kind: str, root: Path = Path("runs")) -> Path:
    """``runs/<kind>-YYYYmmdd-HHMMSS``; a suffix keeps two runs started in one second apart."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    path = root / f"{kind}-{stamp}"
    n = 1
    while path.exists():
        n += 1
        path = root / f"{kind}-{stamp}-{n}"
    return path


class RunFolder:
    """One run's folder. ``create`` starts a run, ``open`` finds an existing one (``--resume``)."""

    def __init__(self, path: Path, manifest: dict[str, Any]) -> None:
        self.path = Path(path)
        self.manifest = manifest

    @classmethod
    def create(
        cls,
        path: Path,
        command: str,
        settings: Mapping[str, Any],
        seed: int,
        argv: Sequence[str],
        runtime: Mapping[str, Any] | None = None,
        settings_version: int | None = None,
    ) -> RunFolder:
        """A new run in ``path`` (created; it may exist only if empty); ``settings_version``: the
        version of the settings' table they were stored by (``optimizer.settings.upgrade``)."""
        path = Path(path)
        if (path / MANIFEST).exists():
            raise RunFolderError(f"{path} already holds a run ({MANIFEST}); resume it instead")
        if path.exists() and any(path.iterdir()):
            raise RunFolderError(f"{path} exists and is not empty")
        path.mkdir(parents=True, exist_ok=True)
        manifest = {
            "format": MANIFEST_FORMAT,
            "command": command,
            "settings": dict(settings),
            **({} if settings_version is None else {"settings_version": settings_version}),
            "seed": seed,
            "versions": versions(),
            "argv": list(argv),
            "command_line": " ".join([f"python -m optimizer.{command}", *argv]),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "runtime": dict(runtime or {}),
            "resumed": [],
        }
        folder = cls(path, manifest)
        write_json(path / MANIFEST, manifest)
        return folder

    @classmethod
    def open(cls, path: Path) -> RunFolder:
        """An existing run; ``RunFolderError`` if ``path`` has no readable manifest."""
        path = Path(path)
        try:
            manifest = json.loads((path / MANIFEST).read_text())
        except FileNotFoundError:
            raise RunFolderError(f"{path} has no {MANIFEST}: not a run folder") from None
        except (OSError, json.JSONDecodeError) as exc:
            raise RunFolderError(f"{path / MANIFEST} cannot be read: {exc}") from None
        if not isinstance(manifest, dict) or manifest.get("format") != MANIFEST_FORMAT:
            raise RunFolderError(f'{path / MANIFEST}: expected "format": "{MANIFEST_FORMAT}"')
        return cls(path, manifest)

    def note_resume(self, argv: Sequence[str], runtime: Mapping[str, Any]) -> None:
        """Record a resume in the manifest: when, with which command line, on what workers."""
        self.manifest["resumed"].append(
            {"time": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "argv": list(argv), "runtime": dict(runtime)}
        )
        write_json(self.path / MANIFEST, self.manifest)

    @property
    def episodes_path(self) -> Path:
        return self.path / EPISODES

    def open_log(self) -> EpisodeLog:
        return EpisodeLog(self.episodes_path)

    def check_log(self, skip_bad_lines: bool = False) -> list[str]:
        """Before resuming: ``RunFolderError`` (one line: file, line number, problem) if the
        episode log has bad lines, or with ``skip_bad_lines`` move them to
        ``episodes.jsonl.rejected`` and return a note saying how many."""
        if skip_bad_lines:
            moved = repair_episode_log(self.episodes_path)
            if moved:
                return [
                    f"{self.episodes_path}: moved {moved} bad line(s) to "
                    f"{self.episodes_path.name}{REJECTED_SUFFIX}; the run goes on without them"
                ]
        read_episode_log(self.episodes_path)
        return []


def _parse_line(line: bytes) -> tuple[EpisodeRecord | None, str | None]:
    """(record, None) or (None, what is wrong with the line)."""
    try:
        document = json.loads(line)
    except UnicodeDecodeError as exc:
        return None, f"not UTF-8 text (byte {exc.start + 1} of the line)"
    except json.JSONDecodeError as exc:
        return None, f"not JSON ({exc.msg} at column {exc.colno})"
    try:
        return EpisodeRecord.from_json(document), None
    except RecordError as exc:
        return None, str(exc)


def scan_episode_log(path: Path) -> tuple[dict[str, EpisodeRecord], list[str], int, list[tuple[int, str]]]:
    """Records by key, warnings, the byte length of the complete lines, and the bad lines as
    (line number, problem), in order.

    Grammar: ``<json object>\\n`` per line. Only the last line may be incomplete or garbled (a
    writer killed mid-write): it is left out with a warning, as a torn write. A key logged twice
    keeps its first record (the one a search was told) and gives a warning.
    """
    records: dict[str, EpisodeRecord] = {}
    warnings: list[str] = []
    bad: list[tuple[int, str]] = []
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return records, warnings, 0, bad
    lines = data.split(b"\n")
    complete = len(data) - len(lines[-1])  # bytes up to and including the last newline
    if lines[-1]:
        warnings.append(f"{path}: ignored an incomplete last line ({len(lines[-1])} bytes)")
    for number, line in enumerate(lines[:-1], start=1):
        record, problem = _parse_line(line)
        if record is None:
            if number == len(lines) - 1 and not lines[-1]:
                # the last line ended by a newline but garbled: a torn write, same as truncated
                warnings.append(f"{path}: ignored an unreadable last line ({problem})")
                complete -= len(line) + 1
            else:
                bad.append((number, problem or "unreadable"))
            continue
        key = record.key
        if key in records:
            warnings.append(f"{path}, line {number}: key {key!r} logged again; the first record is kept")
            continue
        records[key] = record
    return records, warnings, complete, bad


def read_episode_log(path: Path) -> tuple[dict[str, EpisodeRecord], list[str], int]:
    """Records by key, warnings, and the byte length of the complete lines (``scan_episode_log``).

    A bad line before the last is corruption and an error naming the file, the line and what is
    wrong, because silently skipping it would re-run or lose a finished episode; the error says
    how to go on (``repair_episode_log``, ``--skip-bad-lines``).
    """
    records, warnings, complete, bad = scan_episode_log(path)
    if bad:
        number, problem = bad[0]
        more = f" (and {len(bad) - 1} more bad line(s))" if len(bad) > 1 else ""
        raise RunFolderError(
            f"{path}, line {number}: {problem}{more}; to resume without the bad lines, add "
            f"{SKIP_FLAG} (they move to {Path(path).name}{REJECTED_SUFFIX})"
        )
    return records, warnings, complete


def repair_episode_log(path: Path) -> int:
    """Move the log's bad lines (``scan_episode_log``) to ``<log>.rejected`` and return how many.

    Appended to the rejected file first, then the log is rewritten without them through a
    temporary file and a rename, so a kill at any point loses no line: every intact line stays
    in the log, byte for byte, and a bad one is in the log or in the rejected file (or both).
    """
    path = Path(path)
    bad = scan_episode_log(path)[3]
    if not bad:
        return 0
    lines = path.read_bytes().split(b"\n")
    numbers = {number for number, _ in bad}
    rejected = path.with_name(path.name + REJECTED_SUFFIX)
    with rejected.open("ab") as out:
        out.writelines(lines[n - 1] + b"\n" for n in sorted(numbers))
        out.flush()
        os.fsync(out.fileno())
    kept = [line for n, line in enumerate(lines[:-1], start=1) if n not in numbers]
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(b"".join(line + b"\n" for line in kept) + lines[-1])
    os.replace(tmp, path)
    return len(bad)


class EpisodeLog:
    """The append-only episode log of a run: what it already holds, and where new records go.

    Each record is written and flushed as one line when its episode finishes, so a killed run
    loses no finished episode (flush hands the line to the OS; a kill -9 of the process cannot
    lose it, only a crash of the machine could). An incomplete tail left by a kill is cut off
    before appending, so the next record starts on a line of its own.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.records, self.warnings, complete = read_episode_log(self.path)
        self._file = self.path.open("ab")
        if self._file.tell() > complete:
            self._file.truncate(complete)
            self._file.seek(complete)

    def append(self, record: EpisodeRecord) -> None:
        """Log one finished episode; a key already logged is an error (it would count twice)."""
        key = record.key
        if key in self.records:
            raise ValueError(f"episode {key!r} is already in the log")
        line = json.dumps(record.to_json(), separators=(",", ":"), allow_nan=False) + "\n"
        self._file.write(line.encode())
        self._file.flush()
        self.records[key] = record

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> EpisodeLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
