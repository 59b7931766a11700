"""Atomic, provenance-stamped artifacts.

Every command stages its outputs in a folder beside ``--out`` and swaps it in only once all of them are
complete, so that bad input or a crash never leaves a half-written artifact or a mix of old and new ones.
Each artifact is recorded in ``<out>/provenance.json`` with the package version, the hash of the
configuration that made it, the hashes of its inputs and the seed; Parquet and JSON artifacts also carry the
same record inside.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import re
import shutil
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from grasptask import __version__
from grasptask.errors import BadInputError
from grasptask.io.locking import check_writable, folder_lock, make_owned_folder, remove_stale_folders

PROVENANCE_FILE = "provenance.json"
_CHUNK = 1 << 20


def file_hash(path: str | Path) -> str:
    """sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while block := handle.read(_CHUNK):
            digest.update(block)
    return digest.hexdigest()


def path_hash(path: str | Path) -> str:
    """sha256 of a file, or of every file under a folder (names and contents, in sorted order)."""
    path = Path(path)
    if path.is_file():
        return file_hash(path)
    digest = hashlib.sha256()
    for child in sorted(p for p in path.rglob("*") if p.is_file()):
        digest.update(child.relative_to(path).as_posix().encode())
        digest.update(file_hash(child).encode())
    return digest.hexdigest()


def config_hash(config: Any) -> str:
    """sha256 of a JSON-serialisable configuration, independent of key order."""
    text = json.dumps(config, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class Provenance:
    """Where an artifact came from."""

    command: str
    config_hash: str
    inputs: dict[str, str] = field(default_factory=dict)
    seed: int | None = None
    version: str = __version__

    @classmethod
    def of(
        cls,
        command: str,
        config: Any,
        inputs: Iterable[str | Path] = (),
        seed: int | None = None,
    ) -> Provenance:
        return cls(
            command=command,
            config_hash=config_hash(config),
            inputs={str(Path(p).resolve()): path_hash(p) for p in inputs},  # where it was really read
            seed=seed,
        )

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def write_text_atomic(path: Path, text: str) -> None:
    """Replace ``path`` by ``text`` in one rename, synced first: a kill leaves the old file or the new one."""
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        with open(tmp, "w") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except OSError as error:
        if error.filename:
            raise
        raise _naming(error, path) from error
    finally:
        tmp.unlink(missing_ok=True)


def json_text(payload: Any) -> str:
    """``payload`` as the project's JSON files hold it: indented, keys sorted, numpy values as plain ones."""
    return json.dumps(payload, indent=2, sort_keys=True, default=_jsonable) + "\n"


def write_json_atomic(path: Path, payload: Any) -> None:
    write_text_atomic(path, json_text(payload))


_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


def plain_name(name: str, source: str | Path, what: str = "name") -> str:
    """``name`` if it can be one folder or file name inside an output folder, else a one-line error: names
    that become paths can come from inputs (a task label in a manifest), and must not lead outside."""
    if not name or name in (".", "..") or "/" in name or "\\" in name or "\0" in name:
        raise BadInputError(source, f"{what} {name!r} cannot be a file or folder name (no '/', '..' or empty)")
    return name


def file_stem(name: str) -> str:
    """A label made safe to use inside a file name: anything but letters, digits, '.', '_' and '-' becomes
    '_' (for figure names built from task labels, whatever they hold)."""
    stem = _UNSAFE.sub("_", name).strip(".")
    return stem or "_"


class StagedOutput:
    """Collects a command's artifacts in a staging folder beside ``out`` and swaps them in all at once.

    Use as a context manager. On an exception nothing reaches ``out``. On success the staging folder becomes
    the new ``out``: the files of the old one that were not rewritten are hard-linked into it, ``provenance.json``
    is updated there, and the two folders trade places in one atomic rename (``renameat2`` with
    ``RENAME_EXCHANGE``), so a reader or a kill sees either every old artifact or every new one. ``out`` is
    locked for the duration (:func:`grasptask.io.locking.folder_lock`), and staging folders that a killed run
    left behind are removed on entry.
    """

    def __init__(self, out: str | Path, provenance: Provenance):
        self.out = Path(out)
        self.provenance = provenance
        self._staged: list[str] = []
        self._carried: dict[str, Path] = {}
        self._tmp = Path()  # the staging folder, made on entry
        self._lock: Any = None

    @property
    def _prefix(self) -> str:
        return f".{self.out.name}.staging-"

    def __enter__(self) -> StagedOutput:
        if self.out.exists() and not self.out.is_dir():
            raise BadInputError(self.out, "is a file, not an output folder")
        parent = self.out.absolute().parent
        parent.mkdir(parents=True, exist_ok=True)
        self._lock = folder_lock(self.out, f"writing {self.out.name}")
        self._lock.__enter__()
        try:
            check_writable(self.out)
            _recover(self.out)
            remove_stale_folders(parent, self._prefix)
            self._tmp = make_owned_folder(parent, self._prefix)
            # it becomes --out: readable as the umask allows, as mkdir makes it (mkdtemp's 0700 kept colleagues out)
            self._tmp.chmod(0o777 & ~_umask())
        except BaseException:
            self._lock.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None:
                self._commit()
        except OSError as error:
            if error.filename:
                raise
            raise _naming(error, self.out) from error
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._lock.__exit__(None, None, None)
        if isinstance(exc, OSError) and not exc.filename:
            raise _naming(exc, self.out) from exc

    def path(self, name: str) -> Path:
        """Where to write artifact ``name`` (a path relative to ``out``) while staging. A name that would leave
        ``out`` (absolute, or with ``..``) is refused: names can come from inputs, such as task labels."""
        parts = PurePosixPath(name).parts
        if not parts or PurePosixPath(name).is_absolute() or ".." in parts or "\\" in name:
            raise BadInputError(self.out, f"refusing to write '{name}': artifact names must stay inside the folder")
        target = self._tmp / name
        target.parent.mkdir(parents=True, exist_ok=True)
        self._staged.append(name)
        return target

    def write_json(self, name: str, payload: dict[str, Any]) -> None:
        payload = {**payload, "provenance": self.provenance.to_dict()}
        self.path(name).write_text(json.dumps(payload, indent=2, default=_jsonable) + "\n")

    def write_parquet(self, name: str, frame: pd.DataFrame, **options: Any) -> None:
        """``options`` go to ``pyarrow.parquet.write_table`` (compression, statistics, dictionaries)."""
        table = pa.Table.from_pandas(frame, preserve_index=False)
        meta = dict(table.schema.metadata or {})
        meta[b"grasptask.provenance"] = json.dumps(self.provenance.to_dict()).encode()
        pq.write_table(table.replace_schema_metadata(meta), self.path(name), **options)

    def write_csv(self, name: str, frame: pd.DataFrame) -> None:
        frame.to_csv(self.path(name), index=False)

    def write_with(self, name: str, writer: Callable[[Path], object]) -> None:
        writer(self.path(name))

    def carry(self, name: str, source: Path) -> None:
        """File ``name`` of the new ``out`` is ``source``, a file of ``out`` kept outside the ledger (a rerun's
        staged log, ``.solutions.jsonl.new``, becoming ``solutions.jsonl``): both change with the rest in the one
        swap, and ``source`` itself is not carried over."""
        self._carried[name] = Path(source)

    def _commit(self) -> None:
        staged = set(self._staged)
        gone = (
            _superseded(self.out, self.provenance.command, staged | set(self._carried)) if self.out.is_dir() else set()
        )
        moved = {source.name for source in self._carried.values() if source.parent.resolve() == self.out.resolve()}
        for name, source in self._carried.items():
            target = self._tmp / name
            target.parent.mkdir(parents=True, exist_ok=True)
            try:
                os.link(source, target)
            except OSError:
                shutil.copy2(source, target)
        if self.out.is_dir():
            _link_tree(self.out, self._tmp, skip=staged | gone | set(self._carried) | moved)
        _record_provenance(self.out, self._tmp, self._staged, self.provenance, gone)
        _sync_tree(self._tmp)
        if not self.out.exists():
            os.rename(self._tmp, self.out)
        else:
            exchange(self._tmp, self.out)
        _fsync_folder(self.out.absolute().parent)


def _umask() -> int:
    """This process's umask, read without setting it (``os.umask`` can only swap, a race with other threads)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _naming(error: OSError, out: Path) -> OSError:
    """``error`` with ``out`` (the file or folder being written) as its file when it names none: a full disk's
    ``write`` does not, and the user was told ``export: No space left on device``."""
    if error.filename:
        return error
    return OSError(error.errno, error.strerror or str(error), str(out))


def _old_prefix(out: Path) -> str:
    return f".{out.name}.old-"


def exchange(a: Path, b: Path) -> None:
    """Swap two folders in one atomic step (Linux ``renameat2(RENAME_EXCHANGE)``). Where the system cannot,
    ``b`` is first moved aside to ``.<b>.old-<owner>`` and restored by :func:`_recover` if a kill comes between
    the two renames."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.renameat2(-100, os.fsencode(a), -100, os.fsencode(b), 2) == 0:  # AT_FDCWD, RENAME_EXCHANGE
            return
    except (OSError, AttributeError):
        pass
    aside = make_owned_folder(b.absolute().parent, _old_prefix(b))
    os.rmdir(aside)
    os.rename(b, aside)
    os.rename(a, b)
    os.rename(aside, a)  # the old content is removed with the staging folder


def _recover(out: Path) -> None:
    """Undo a swap that a kill interrupted: put a dead run's moved-aside folder back if ``out`` is missing."""
    parent = out.absolute().parent
    for aside in sorted(parent.glob(f"{_old_prefix(out)}*")):
        if not out.exists():
            os.rename(aside, out)
    remove_stale_folders(parent, _old_prefix(out))


def _read_ledger(out: Path) -> dict:
    """``out``'s ``provenance.json``: each artifact's provenance ({} when missing or unreadable)."""
    try:
        ledger = json.loads((out / PROVENANCE_FILE).read_text())
    except (OSError, ValueError):
        return {}
    return ledger if isinstance(ledger, dict) else {}


def _superseded(out: Path, command: str, staged: set[str]) -> set[str]:
    """The files of ``out`` that ``command`` made before and did not make now: the artifacts its ledger gives to
    ``command``, and whatever lies in a subfolder it wrote into. They go, so that an export of one optimum does
    not leave an earlier export's others beside it. Another command's artifacts (``distances`` beside
    ``fit-task``) and files no stage staged (a sweep's log) stay."""
    ledger = _read_ledger(out)
    folders = {name.split("/", 1)[0] for name in staged if "/" in name}
    gone = set()
    for path in out.rglob("*"):
        name = path.relative_to(out).as_posix()
        if path.is_dir() or name in staged:
            continue
        if "/" in name:
            mine = name.split("/", 1)[0] in folders
        else:
            owner = ledger.get(name)
            mine = isinstance(owner, dict) and owner.get("command") == command
        if mine:
            gone.add(name)
    return gone


def _link_tree(source: Path, target: Path, skip: set[str]) -> None:
    """Hard-link (or, across devices, copy) every file under ``source`` into ``target`` unless its relative
    name is in ``skip``: the new folder keeps what the stage did not rewrite or supersede."""
    for path in source.rglob("*"):
        if path.is_dir() or path.relative_to(source).as_posix() in skip:
            continue
        destination = target / path.relative_to(source)
        if destination.exists():
            continue
        destination.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.link(path, destination)
        except OSError:
            shutil.copy2(path, destination)


def _sync_tree(folder: Path) -> None:
    """Flush the staged files to disk before they are swapped in, so a power cut cannot leave them empty."""
    for path in folder.rglob("*"):
        if path.is_file():
            with open(path, "rb") as handle:
                os.fsync(handle.fileno())
    _fsync_folder(folder)


def _fsync_folder(folder: Path) -> None:
    descriptor = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _record_provenance(
    out: Path, staging: Path, names: list[str], provenance: Provenance, gone: frozenset[str] | set[str] = frozenset()
) -> None:
    """The new ``provenance.json`` in the staging folder: the old ledger (rebuilt from this stage on when
    unreadable) with this stage's artifacts updated and those it superseded removed."""
    ledger = {name: record for name, record in _read_ledger(out).items() if name not in gone}
    record = provenance.to_dict()
    for name in names:
        if "/" not in name:  # per-recording files are covered by their manifest's entry
            ledger[name] = record
    staged = staging / PROVENANCE_FILE
    staged.unlink(missing_ok=True)  # a hard link to the old ledger: replace it, do not write through it
    staged.write_text(json.dumps(ledger, indent=2, sort_keys=True) + "\n")


def _jsonable(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
