"""Child processes that do not outlive a killed parent.

A ``kill -9`` gives a process no chance to end its children: the physics check's pool workers were left running,
reparented to init, and a browser check left chromedriver, eleven Chromium processes and their profile. Two
remedies, both Linux's: a worker asks the kernel to kill it when its parent dies (``PR_SET_PDEATHSIG``), and a
program we cannot change (a browser and its driver) runs in a process group of its own that a small reaper
kills, and whose scratch folder it removes, once our end of a pipe closes, which a kill cannot prevent.
"""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
from pathlib import Path

#: prctl's option number (linux/prctl.h)
_PR_SET_PDEATHSIG = 1

#: the reaper: read the group's id, wait until the parent's end of the pipe closes, then kill the group (if it
#: was ever given) and remove the folders
_REAPER = """
import os, shutil, signal, sys
given = sys.stdin.buffer.readline().strip()
sys.stdin.buffer.read()
if given.isdigit() and int(given) > 0:
    try:
        os.killpg(int(given), signal.SIGKILL)
    except OSError:
        pass
for folder in sys.argv[1:]:
    shutil.rmtree(folder, ignore_errors=True)
"""


def die_with_parent() -> None:
    """Ask the kernel to kill this process when its parent dies; exit now if it already has. For a worker's
    initializer: a pool whose parent was killed outright otherwise waits on its queue for ever."""
    parent = os.getppid()
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if parent == 1 or not _alive(parent):
        os._exit(1)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class Reaper:
    """A context manager: a reaper process started on entry, told the process group to kill by :meth:`arm`
    (the id of a process started with ``start_new_session=True``, which leads its own group). On exit, or when
    this process dies in any way (only this process holds the pipe's write end, so the reaper then reads
    end-of-file), the group is killed and ``folders`` are removed."""

    def __init__(self, folders: tuple[Path, ...] = ()) -> None:
        self.folders = folders
        self._process: subprocess.Popen | None = None

    def __enter__(self) -> Reaper:
        self._process = subprocess.Popen(
            [sys.executable, "-c", _REAPER, *map(str, self.folders)],
            stdin=subprocess.PIPE,
            start_new_session=True,  # a Ctrl-C to our terminal's group must not end it before us
        )
        return self

    def arm(self, group: int) -> None:
        assert self._process is not None and self._process.stdin is not None, "enter first"
        self._process.stdin.write(f"{group}\n".encode())
        self._process.stdin.flush()

    def __exit__(self, *exc: object) -> None:
        if self._process is not None and self._process.stdin is not None:
            self._process.stdin.close()
            self._process.wait(timeout=30)
            self._process = None


#: the exit code of a spawned worker process that, while importing the user's script, reached a sweep in it: the
#: script starts the sweep at import, without an ``if __name__ == "__main__":`` guard
UNGUARDED_SCRIPT_EXIT = 86


def refuse_in_worker_import() -> None:
    """Called where a sweep begins. A solver worker is a spawned process, which first imports the script that
    started the sweep; a script that starts it at import (no ``if __name__ == "__main__":`` guard) would start
    a sweep in every worker, each on the folder the first one holds. The worker ends at once with
    :data:`UNGUARDED_SCRIPT_EXIT`, which the sweep turns into one line naming the fix."""
    import multiprocessing

    if getattr(multiprocessing.current_process(), "_inheriting", False):  # multiprocessing's flag for that import
        os._exit(UNGUARDED_SCRIPT_EXIT)
