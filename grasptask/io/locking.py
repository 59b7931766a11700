"""One process at a time per output folder, with locks that survive a crash.

A lock is the file ``.<name>.lock`` beside the folder, made with ``O_EXCL`` and holding the owner's process
identity: its pid, its start time (so that a reused pid is not mistaken for the owner) and its host. A lock
whose owner on this host has died is stale and is taken over; one held by a live process refuses the second
run with one line. Locks are reentrant within a process, so a sweep that holds its folder can still commit
artifacts into it.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from grasptask.errors import BadInputError

_HELD: dict[Path, int] = {}  # lock file -> nesting depth, for this process


def _start_time(pid: int) -> str | None:
    """The process's start time in clock ticks since boot (Linux), or None when it has no /proc entry."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rsplit(")", 1)[1].split()[19]  # field 22, counted after the command name


def identity() -> dict[str, object]:
    """This process, as a lock or staging folder records it."""
    return {"pid": os.getpid(), "start": _start_time(os.getpid()) or "0", "host": socket.gethostname()}


def is_alive(owner: dict) -> bool:
    """Whether the process that ``identity()`` described still runs. An owner on another host is taken to be
    alive, since this host cannot tell."""
    if owner.get("host") != socket.gethostname():
        return True
    pid = owner.get("pid")
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # alive, but someone else's
    started = _start_time(pid)
    return started is None or owner.get("start") in (None, "0", started)


def lock_path(folder: Path) -> Path:
    folder = Path(folder).absolute()
    return folder.parent / f".{folder.name}.lock"


def _read_owner(path: Path) -> dict | None:
    try:
        owner = json.loads(path.read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        return {}  # unreadable: a crash mid-write, so no live owner
    return owner if isinstance(owner, dict) else {}


@contextmanager
def folder_lock(folder: str | Path, purpose: str = "grasptask") -> Iterator[Path]:
    """Hold ``folder`` for this process; a second process asking for it gets a one-line error."""
    path = lock_path(Path(folder))
    if path in _HELD:
        _HELD[path] += 1
        try:
            yield path
        finally:
            _HELD[path] -= 1
        return
    created = not path.parent.exists()
    path.parent.mkdir(parents=True, exist_ok=True)
    record = json.dumps({**identity(), "purpose": purpose, "since": time.strftime("%Y-%m-%d %H:%M:%S")})
    for _ in range(3):
        try:
            descriptor = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            owner = _read_owner(path)
            if owner is None:
                continue  # released in the meantime
            if is_alive(owner):
                raise BadInputError(
                    folder,
                    f"in use by another run ({owner.get('purpose', 'grasptask')}, pid {owner.get('pid')} on "
                    f"{owner.get('host')} since {owner.get('since')}); wait for it to finish",
                ) from None
            path.unlink(missing_ok=True)  # its owner died: the lock is stale
            continue
        try:
            with os.fdopen(descriptor, "w") as handle:
                handle.write(record)
        except OSError as exc:  # a full disk: the lock is not taken, and the error names it
            path.unlink(missing_ok=True)
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        break
    else:
        raise BadInputError(folder, f"could not take the lock {path}")
    _HELD[path] = 1
    try:
        yield path
    finally:
        del _HELD[path]
        path.unlink(missing_ok=True)
        if created:
            try:
                path.parent.rmdir()  # a run that failed before writing anything leaves no empty --out behind
            except OSError:
                pass


def make_owned_folder(parent: Path, prefix: str) -> Path:
    """A new temporary folder ``parent/<prefix><pid>-<start>-<random>``: its name says which process owns it."""
    me = identity()
    return Path(tempfile.mkdtemp(prefix=f"{prefix}{me['pid']}-{me['start']}-", dir=parent))


def remove_stale_folders(parent: Path, prefix: str) -> list[Path]:
    """Remove the folders made by :func:`make_owned_folder` under ``parent`` whose owner has died (a killed
    run's leftovers)."""
    removed = []
    for folder in parent.glob(f"{prefix}*"):
        pid, _, rest = folder.name[len(prefix) :].partition("-")
        start = rest.split("-", 1)[0]
        owner = {"pid": int(pid) if pid.isdigit() else -1, "start": start, "host": socket.gethostname()}
        if folder.is_dir() and not is_alive(owner):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def check_writable(folder: str | Path) -> None:
    """One line now, before any work, when ``folder`` cannot take a new file, nor its parent (where a stage
    stages its artifacts and takes its lock): a read-only file system, an immutable folder. Found only at the
    commit, it cost the user the whole run."""
    folder = Path(folder).absolute()
    for target in (folder.parent, folder) if folder.is_dir() else (folder.parent,):
        probe_writable(target)


def probe_writable(folder: Path, named: Path | None = None) -> None:
    """One line naming ``named`` (default ``folder``) when ``folder`` cannot take a new file: one is made in it
    and removed, the only test that a read-only mount, an immutable folder and permissions all answer."""
    try:
        descriptor, probe = tempfile.mkstemp(prefix=".grasptask-probe-", dir=folder)
        os.close(descriptor)
        os.unlink(probe)
    except OSError as exc:
        raise BadInputError(named or folder, f"cannot be written ({exc.strerror or exc})") from None
