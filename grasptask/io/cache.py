"""Slow per-object work kept on disk, by the content it was made from: an object's convex parts for MuJoCo (CoACD
takes a minute on a scan), a scan's signed-distance grid. The same mesh with the same settings is then made
once, whichever command (``physics``, ``export``, ``synthesize``) needs it first.

An entry is a ``.npz`` of plain arrays (never pickled objects), named by the SHA-256 of everything that shapes it:
the input arrays, the settings, the library and format versions. It is written whole or not at all (a
temporary file renamed into place), and read back only if its own record of its key and format matches and the
caller's check of its arrays passes; anything else (a truncated file, another version's, a foreign file under the
name) is said in one line, deleted and rebuilt, never trusted. A cache that cannot be written (a read-only or
full disk) is said once and the run goes on without it.

The folder is ``GRASPTASK_CACHE`` if set (``off`` turns the cache off), else ``$XDG_CACHE_HOME/grasptask`` or
``~/.cache/grasptask``.
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

CACHE_ENV = "GRASPTASK_CACHE"
#: bumped when what an entry holds changes shape: an older entry then reads as another version's, and is rebuilt
FORMAT = 1
_KEY, _FORMAT = "__key__", "__format__"

Arrays = dict[str, np.ndarray]
_warned: set[str] = set()


def folder() -> Path | None:
    """Where entries are kept, or None when the cache is off."""
    setting = os.environ.get(CACHE_ENV, "").strip()
    if setting.lower() == "off":
        return None
    if setting:
        return Path(setting)
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    return (Path(base) if base else Path.home() / ".cache") / "grasptask"


def key(kind: str, *parts: object) -> str:
    """The SHA-256 of ``kind`` and ``parts``: arrays by their dtype, shape and bytes, anything else by its repr."""
    digest = hashlib.sha256(f"{kind}/{FORMAT}".encode())
    for part in parts:
        if isinstance(part, np.ndarray):
            array = np.ascontiguousarray(part)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        else:
            digest.update(repr(part).encode())
        digest.update(b"\0")
    return digest.hexdigest()


@dataclass(frozen=True)
class Entry:
    """What :func:`cached` found or made: the arrays, and where they are kept (None: not kept)."""

    arrays: Arrays
    path: Path | None
    built: bool


def cached(kind: str, digest: str, build: Callable[[], Arrays], check: Callable[[Arrays], None]) -> Entry:
    """The entry ``digest`` of ``kind`` from the cache, else ``build()``'s arrays, kept for next time. ``check``
    raises ``ValueError`` on arrays that cannot be what was kept (their shapes, their values)."""
    root = folder()
    path = None if root is None else root / kind / f"{digest}.npz"
    if path is not None and path.is_file():
        found = _read(path, digest, check)
        if found is not None:
            return Entry(found, path, built=False)
    arrays = build()
    check(arrays)
    return Entry(arrays, _write(path, digest, arrays) if path is not None else None, built=True)


def _read(path: Path, digest: str, check: Callable[[Arrays], None]) -> Arrays | None:
    """The entry's arrays, or None (said, and the file removed) where it is not the entry it should be."""
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
        if _FORMAT not in arrays or int(arrays.pop(_FORMAT)) != FORMAT:
            raise ValueError("written by another version")
        if _KEY not in arrays or str(arrays.pop(_KEY)) != digest:
            raise ValueError("not the entry its name says")
        check(arrays)
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        print(f"{path}: cache entry not used ({exc}): made again", file=sys.stderr, flush=True)
        path.unlink(missing_ok=True)
        return None
    return arrays


def _write(path: Path, digest: str, arrays: Arrays) -> Path | None:
    """Keep ``arrays`` at ``path``, whole or not at all; None where the disk refuses (said once per folder)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".npz.tmp")
        try:
            with os.fdopen(handle, "wb") as stream:
                payload: dict[str, Any] = {**arrays, _KEY: np.array(digest), _FORMAT: np.array(FORMAT)}
                np.savez(stream, **payload)
                stream.flush()
                os.fsync(stream.fileno())
            os.replace(temporary, path)
        finally:
            Path(temporary).unlink(missing_ok=True)
    except OSError as exc:
        if str(path.parent) not in _warned:
            _warned.add(str(path.parent))
            print(f"{path.parent}: cannot keep the cache ({exc.strerror or exc}); going on without it", file=sys.stderr)
        return None
    return path
