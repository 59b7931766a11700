"""Atomic, provenance-stamped artifacts.

Every command stages its outputs in a temporary folder beside ``--out`` and moves them in only once all of
them are complete, so that bad input or a crash never leaves a half-written artifact behind. Each artifact is
recorded in ``<out>/provenance.json`` with the package version, the hash of the configuration that made it,
the hashes of its inputs and the seed; Parquet and JSON artifacts also carry the same record inside.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from grasptask import __version__

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
            inputs={str(p): path_hash(p) for p in inputs},
            seed=seed,
        )

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class StagedOutput:
    """Collects a command's artifacts in a temporary folder and moves them into place together.

    Use as a context manager: on an exception nothing reaches ``out``; on success every staged file is
    renamed into ``out`` (same filesystem, so each rename is atomic) and ``provenance.json`` is updated.
    """

    def __init__(self, out: str | Path, provenance: Provenance):
        self.out = Path(out)
        self.provenance = provenance
        self._staged: list[str] = []
        self._tmp = Path()  # the staging folder, made on entry

    def __enter__(self) -> StagedOutput:
        parent = self.out.resolve().parent
        parent.mkdir(parents=True, exist_ok=True)
        self._tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.staging-", dir=parent))
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is None:
                self._commit()
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)

    def path(self, name: str) -> Path:
        """Where to write artifact ``name`` (a path relative to ``out``) while staging."""
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

    def _commit(self) -> None:
        self.out.mkdir(parents=True, exist_ok=True)
        for name in self._staged:
            target = self.out / name
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(self._tmp / name, target)
        _record_provenance(self.out, self._staged, self.provenance)


def _record_provenance(out: Path, names: list[str], provenance: Provenance) -> None:
    ledger_path = out / PROVENANCE_FILE
    ledger = json.loads(ledger_path.read_text()) if ledger_path.exists() else {}
    record = provenance.to_dict()
    for name in names:
        if "/" not in name:  # per-recording files are covered by their manifest's entry
            ledger[name] = record
    tmp = ledger_path.with_name(f".{PROVENANCE_FILE}.tmp")
    tmp.write_text(json.dumps(ledger, indent=2, sort_keys=True) + "\n")
    os.replace(tmp, ledger_path)


def read_parquet_provenance(path: str | Path) -> dict[str, Any] | None:
    meta = pq.read_schema(path).metadata or {}
    raw = meta.get(b"grasptask.provenance")
    return json.loads(raw) if raw else None


def _jsonable(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
