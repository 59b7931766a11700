"""MATLAB ``.mat`` recordings: v4 to v7 through scipy, v7.3 (HDF5) through h5py, as named channels.

A file's numeric variables are found at any depth of its structs (``data.ft`` is field ``ft`` of struct
``data``). A channel is named by a reference: ``name`` for a vector, or ``name[k]`` for the k-th channel (from 1)
of a matrix whose samples run along its rows (``n x k``) or its columns (``k x n``). Where the layout is not
said, the longer axis holds the samples; a square matrix must be said. A reference the file cannot answer is
one line listing the variables the file holds, with their shapes, as MATLAB prints them.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError

MAT_SUFFIX = ".mat"
_REFERENCE = re.compile(r"^\s*(?P<name>[A-Za-z][\w.]*)\s*(?:\[\s*(?P<index>\d+)\s*\])?\s*$")
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def read_variables(path: Path) -> dict[str, Any]:
    """Every variable of the file, structs flattened to dotted names: numeric ones as arrays in MATLAB's own
    shape (rows x columns), the others as a short description of what they are."""
    with open(path, "rb") as handle:
        head = handle.read(520)
    if _HDF5_SIGNATURE in (head[:8], head[512:520]):  # v7.3: HDF5, behind a 512-byte MATLAB header
        return _hdf5_variables(path)
    from scipy.io import loadmat  # deferred: only for .mat files

    try:
        raw = loadmat(path, simplify_cells=True)
    except NotImplementedError as exc:  # v7.3 without the HDF5 signature where we looked
        raise BadInputError(path, f"not a readable MAT-file ({exc})") from None
    except Exception as exc:  # scipy raises ValueError, TypeError, zlib and struct errors on damaged files
        raise BadInputError(path, f"not a readable MAT-file ({type(exc).__name__}: {exc})") from None
    variables: dict[str, Any] = {}
    for name, value in raw.items():
        if not name.startswith("__"):
            _flatten(name, value, variables)
    return variables


def _flatten(name: str, value: Any, into: dict[str, Any]) -> None:
    if isinstance(value, dict):
        for field, inner in value.items():
            _flatten(f"{name}.{field}", inner, into)
    elif isinstance(value, np.ndarray) and (value.dtype.kind in "fiub"):
        into[name] = np.atleast_2d(value)  # loadmat squeezed a vector to 1D and a scalar to 0D: MATLAB's 1 x n
    elif isinstance(value, (int, float, bool, np.number)) and not isinstance(value, complex):
        into[name] = np.atleast_2d(np.asarray(value, dtype=float))
    else:
        into[name] = "char" if isinstance(value, str) else "cell" if isinstance(value, (list, np.ndarray)) else "other"


def _hdf5_variables(path: Path) -> dict[str, Any]:
    import h5py  # deferred: only for v7.3 files

    variables: dict[str, Any] = {}
    try:
        with h5py.File(path, "r") as handle:
            for name, item in _hdf5_items(handle, ""):
                kind = item.attrs.get("MATLAB_class", b"")
                kind = kind.decode() if isinstance(kind, bytes) else str(kind)
                if kind in ("char", "cell", "string") or item.dtype.kind not in "fiub":
                    variables[name] = kind or "other"
                else:  # HDF5 keeps MATLAB's column-major arrays with their dimensions reversed
                    variables[name] = np.atleast_2d(np.asarray(item[()]).T)
    except OSError as exc:
        raise BadInputError(path, f"not a readable MAT-file (v7.3, HDF5: {exc})") from None
    return variables


def _hdf5_items(group: Any, prefix: str) -> Iterator[tuple[str, Any]]:
    import h5py  # deferred: only for v7.3 files

    for key, item in group.items():
        if key.startswith("#"):  # MATLAB's own bookkeeping (#refs#, #subsystem#)
            continue
        name = f"{prefix}{key}"
        if isinstance(item, h5py.Group):
            yield from _hdf5_items(item, f"{name}.")
        else:
            yield name, item


def describe(variables: Mapping[str, Any]) -> str:
    """``ft 1200x7 double, info char``: what the file holds, as MATLAB's ``whos`` would name it."""
    parts = []
    for name, value in variables.items():
        if isinstance(value, np.ndarray):
            kind = {"f": "double" if value.dtype == np.float64 else "single", "b": "logical"}.get(
                value.dtype.kind, str(value.dtype)
            )
            parts.append(f"{name} {'x'.join(str(s) for s in value.shape)} {kind}")
        else:
            parts.append(f"{name} {value}")
    return ", ".join(parts) if parts else "no variables"


def channels(
    path: Path, variables: Mapping[str, Any], references: Mapping[str, str], samples: str | None, hint: str
) -> dict[str, np.ndarray]:
    """Each reference's samples as a float vector, all of one length; ``hint`` ends the line of a reference the
    file cannot answer (it names the setting that maps them)."""
    found: dict[str, np.ndarray] = {}
    for key, reference in references.items():
        match = _REFERENCE.match(reference)
        if match is None:
            raise BadInputError(path, f"'{reference}' is not a variable (name, or name[k] for channel k)", column=key)
        name, index = match["name"], match["index"]
        value = variables.get(name)
        if not isinstance(value, np.ndarray):
            what = f"no numeric variable '{name}'" if value is None else f"variable '{name}' is {value}, not numbers"
            raise BadInputError(path, f"{what} for {key} (the file holds: {describe(variables)}); {hint}")
        matrix = _samples_first(path, name, value, samples)
        if index is None:
            if matrix.shape[1] != 1:
                raise BadInputError(
                    path, f"'{name}' has {matrix.shape[1]} channels: name one as {name}[k] for {key}; {hint}"
                )
            column = matrix[:, 0]
        else:
            k = int(index)
            if not 1 <= k <= matrix.shape[1]:
                raise BadInputError(path, f"'{name}' has no channel {k} (it has {matrix.shape[1]}) for {key}")
            column = matrix[:, k - 1]
        found[key] = np.asarray(column, dtype=float)
    lengths = {key: len(v) for key, v in found.items()}
    if len(set(lengths.values())) > 1:
        said = ", ".join(f"{key} {n}" for key, n in lengths.items())
        raise BadInputError(path, f"channels of different lengths ({said}); {hint}")
    return found


def _samples_first(path: Path, name: str, value: np.ndarray, samples: str | None) -> np.ndarray:
    """``value`` as ``(n, k)``, samples along the first axis."""
    if value.ndim != 2:
        raise BadInputError(path, f"'{name}' has {value.ndim} dimensions; a recording is a vector or a matrix")
    rows, cols = value.shape
    if samples is None:
        if min(rows, cols) == 1:
            return value.reshape(-1, 1)
        if rows == cols:
            raise BadInputError(
                path, f"'{name}' is {rows}x{cols}: say whether its samples are rows or columns (matlab: samples)"
            )
        samples = "rows" if rows > cols else "columns"
    return value if samples == "rows" else value.T
