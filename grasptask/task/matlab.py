"""MATLAB ``.mat`` files as MATLAB writes them: v4 to v7 through scipy, v7.3 (HDF5) through h5py.

Every variable keeps MATLAB's own shape (nothing squeezed: a 7 x 1 matrix stays 7 x 1) and its kind: numeric
arrays as numpy arrays, cell arrays as :class:`Cell`, structs and struct arrays as :class:`Struct`, anything else
(text, function handles, objects) as :class:`Other`. Elements are kept in MATLAB's linear order (column-major), so
element ``k`` of MATLAB is ``items[k - 1]`` here. :func:`describe` says what a file holds as one line, descending
into cells and structs, the way MATLAB's ``whos`` would name it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError

MAT_SUFFIX = ".mat"
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: MATLAB's name of each numpy kind a recording may hold
_CLASSES = {"float64": "double", "float32": "single", "bool": "logical"}
#: how many fields or elements a one-line description names before it says "..."
_SHOWN = 8


@dataclass(frozen=True)
class Cell:
    """A cell array: its MATLAB shape and its elements in MATLAB's linear order."""

    shape: tuple[int, ...]
    items: tuple[Any, ...]


@dataclass(frozen=True)
class Struct:
    """A struct (shape 1 x 1) or a struct array: its field names and one dict of fields per element."""

    shape: tuple[int, ...]
    fields: tuple[str, ...]
    items: tuple[dict[str, Any], ...]


@dataclass(frozen=True)
class Other:
    """What a recording cannot be made of: text, a function handle, an object; ``what`` names it."""

    what: str


#: the last file read, by its path, size and modification time: a wildcard's recordings read one file in turn
_LAST: dict[tuple[str, int, int], dict[str, Any]] = {}


def read_variables(path: Path) -> dict[str, Any]:
    """Every variable of the file by name, in MATLAB's shapes (see the module's docstring)."""
    path = Path(path)
    stat = path.stat()
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns)
    if key not in _LAST:
        variables = _read(path)
        _LAST.clear()
        _LAST[key] = variables
    return _LAST[key]


def _read(path: Path) -> dict[str, Any]:
    with open(path, "rb") as handle:
        head = handle.read(520)
    if _HDF5_SIGNATURE in (head[:8], head[512:520]):  # v7.3: HDF5, behind a 512-byte MATLAB header
        return _hdf5_variables(path)
    from scipy.io import loadmat  # deferred: only for .mat files

    try:
        raw = loadmat(path, squeeze_me=False, struct_as_record=True, chars_as_strings=True)
    except NotImplementedError as exc:  # v7.3 without the HDF5 signature where we looked
        raise BadInputError(path, f"not a readable MAT-file ({exc})") from None
    except Exception as exc:  # scipy raises ValueError, TypeError, zlib and struct errors on damaged files
        raise BadInputError(path, f"not a readable MAT-file ({type(exc).__name__}: {exc})") from None
    return {name: _from_scipy(value) for name, value in raw.items() if not name.startswith("__")}


def _from_scipy(value: Any) -> Any:
    """scipy's reading of one value (structured arrays for structs, object arrays for cells) as ours."""
    if isinstance(value, np.ndarray):
        shape = tuple(int(s) for s in value.shape)
        if value.dtype.names:
            fields = tuple(value.dtype.names)
            items = tuple({f: _from_scipy(element[f]) for f in fields} for element in value.ravel(order="F"))
            return Struct(shape, fields, items)
        if value.dtype.kind == "O":
            return Cell(shape, tuple(_from_scipy(v) for v in value.ravel(order="F")))
        if value.dtype.kind in "US":
            return Other("char")
        if value.dtype.kind in "fiubc":
            return value if value.ndim >= 2 else value.reshape(1, -1)
        return Other(str(value.dtype))
    if hasattr(value, "toarray"):  # a sparse matrix holds numbers all the same
        return np.asarray(value.toarray())
    return Other({"MatlabFunction": "function_handle", "MatlabOpaque": "object"}.get(type(value).__name__, "other"))


def _hdf5_variables(path: Path) -> dict[str, Any]:
    import h5py  # deferred: only for v7.3 files

    try:
        with h5py.File(path, "r") as handle:
            return {
                name: _from_hdf5(item, handle) for name, item in handle.items() if not name.startswith("#")
            }  # "#refs#" and "#subsystem#" are MATLAB's own bookkeeping
    except OSError as exc:
        raise BadInputError(path, f"not a readable MAT-file (v7.3, HDF5: {exc})") from None


def _matlab_class(item: Any) -> str:
    kind = item.attrs.get("MATLAB_class", b"")
    return kind.decode() if isinstance(kind, bytes) else str(kind)


def _from_hdf5(item: Any, handle: Any) -> Any:
    """One HDF5 object as MATLAB wrote it: arrays with their dimensions reversed (column-major), cells and struct
    arrays as arrays of references into ``#refs#``, a scalar struct as a group of its fields."""
    import h5py

    kind = _matlab_class(item)
    if isinstance(item, h5py.Group):
        if "MATLAB_sparse" in item.attrs:
            return _hdf5_sparse(item)
        if kind not in ("struct", ""):
            return Other(kind)
        return _hdf5_struct(item, handle)
    if "MATLAB_empty" in item.attrs and item.attrs["MATLAB_empty"]:
        shape = tuple(int(d) for d in np.ravel(item[()])) or (0, 0)
        if kind == "cell":
            return Cell(shape, ())
        if kind == "struct":
            return Struct(shape, (), ())
        return np.zeros(shape) if kind not in ("char",) else Other("char")
    if kind == "cell" or item.dtype == h5py.ref_dtype:
        refs = np.asarray(item[()]).T
        return Cell(tuple(int(s) for s in refs.shape), tuple(_from_hdf5(handle[r], handle) for r in refs.ravel("F")))
    if kind in ("char", "string", "function_handle") or item.dtype.kind not in "fiubV":
        return Other(kind or "other")
    data = np.asarray(item[()])
    if data.dtype.names and {"real", "imag"} <= set(data.dtype.names):
        data = data["real"] + 1j * data["imag"]
    elif data.dtype.kind == "V":
        return Other(kind or "other")
    if kind == "logical":
        data = data.astype(bool)
    return np.atleast_2d(data.T)


def _hdf5_struct(group: Any, handle: Any) -> Struct:
    """A scalar struct (a group of its fields) or a struct array (a group of one array of references per field,
    with no MATLAB_class of their own)."""
    import h5py

    names = group.attrs.get("MATLAB_fields")
    fields = [bytes(np.asarray(f)).decode() for f in names] if names is not None else list(group.keys())
    fields = [f for f in fields if f in group] or list(group.keys())
    arrays = [group[f] for f in fields]
    is_array = bool(arrays) and all(
        isinstance(a, h5py.Dataset) and a.dtype == h5py.ref_dtype and "MATLAB_class" not in a.attrs for a in arrays
    )
    if not is_array:
        return Struct((1, 1), tuple(fields), ({f: _from_hdf5(group[f], handle) for f in fields},))
    refs = {f: np.asarray(group[f][()]).T for f in fields}
    shape = tuple(int(s) for s in refs[fields[0]].shape)
    flat = {f: r.ravel("F") for f, r in refs.items()}
    items = tuple({f: _from_hdf5(handle[flat[f][k]], handle) for f in fields} for k in range(int(np.prod(shape))))
    return Struct(shape, tuple(fields), items)


def _hdf5_sparse(group: Any) -> np.ndarray:
    from scipy.sparse import csc_matrix

    rows = int(group.attrs["MATLAB_sparse"])
    jc = np.asarray(group["jc"][()])
    data = np.asarray(group["data"][()]) if "data" in group else np.zeros(0)
    ir = np.asarray(group["ir"][()]) if "ir" in group else np.zeros(0, dtype=int)
    return np.asarray(csc_matrix((data, ir, jc), shape=(rows, len(jc) - 1)).toarray())


# --- what a file holds, in one line ------------------------------------------------------------------------------


def class_name(value: np.ndarray) -> str:
    """MATLAB's class of a numeric array: double, single, int16, logical, complex double..."""
    if value.dtype.kind == "c":
        return "complex " + ("single" if value.dtype == np.complex64 else "double")
    return _CLASSES.get(str(value.dtype), str(value.dtype))


def size(shape: Sequence[int]) -> str:
    return "x".join(str(s) for s in shape)


def describe_value(value: Any, merged: bool = False) -> str:
    """``6x1141 double``, ``1x14 cell of struct {Hand_FT 6x1141 double, ...}``, ``1x4 struct array {...}``
    (``merged``: ``value``'s items are the scalar structs of a cell's elements, whose fields it describes)."""
    if isinstance(value, np.ndarray):
        return f"{size(value.shape)} {class_name(value)}"
    if isinstance(value, Cell):
        if not value.items:
            return f"{size(value.shape)} cell (empty)"
        return f"{size(value.shape)} cell of {_common(value.items)}"
    if isinstance(value, Struct):
        fields = ", ".join(f"{f} {_common([item[f] for item in value.items])}" for f in value.fields[:_SHOWN])
        fields += ", ..." if len(value.fields) > _SHOWN else ""
        if len(value.items) == 1 or merged:  # merged: the scalar structs of a cell's elements, described as one
            return f"struct {{{fields}}}"
        return f"{size(value.shape)} struct array {{{fields}}}"
    return str(value.what)


def _common(values: Sequence[Any]) -> str:
    """What the elements of a cell (or one field over a struct array) share: their description where they all
    share it; numeric arrays that differ only in their dimensions with the dimensions as ranges (trials of
    different lengths); scalar structs of the same fields merged field by field; and the elements of another kind
    than most named ("except element 3: 0x0 double")."""
    said = [describe_value(v) for v in values]
    if len(set(said)) == 1:
        return said[0]
    kinds = [_kind(v) for v in values]
    most = max(kinds, key=kinds.count)
    alike = [v for v, kind in zip(values, kinds, strict=True) if kind == most]
    if len(alike) < len(values):
        odd = [k for k, kind in enumerate(kinds) if kind != most]
        more = f" and {len(odd) - 1} more" if len(odd) > 1 else ""
        return f"{_common(alike)}, except element {odd[0] + 1}: {said[odd[0]]}{more}"
    if isinstance(values[0], np.ndarray):
        dims = zip(*(v.shape for v in values), strict=True)
        shape = "x".join(str(d[0]) if len(set(d)) == 1 else f"({min(d)}-{max(d)})" for d in dims)
        return f"{shape} {class_name(values[0])}"
    if isinstance(values[0], Struct) and most[2]:
        return describe_value(Struct((1, 1), values[0].fields, tuple(v.items[0] for v in values)), True)
    return f"mixed {{element 1: {said[0]}, element 2: {said[1]}}}"


def _kind(value: Any) -> tuple:
    """What two elements must share to be described as one."""
    if isinstance(value, np.ndarray):
        return ("array", class_name(value), value.ndim, value.size == 0)
    if isinstance(value, Struct):
        return ("struct", value.fields, len(value.items) == 1)
    return ("cell",) if isinstance(value, Cell) else ("other", value.what)


def describe(variables: Mapping[str, Any]) -> str:
    """``rawdata_FT 1x14 cell of struct {Hand_FT 6x1141 double, Tool_FT 6x1141 double}, dt 1x1 double``."""
    parts = [f"{name} {describe_value(value)}" for name, value in variables.items()]
    return ", ".join(parts) if parts else "no variables"
