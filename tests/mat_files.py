"""MAT-files as MATLAB writes them, for the tests: v5 through scipy's own writer, v7.3 (HDF5) as MATLAB lays it out.

A value is given as scipy's ``savemat`` takes it: a numpy array (numbers), a str (char), a dict (a scalar struct),
an object array (a cell, elements in its shape) and a structured array (a struct array).
"""

from __future__ import annotations

from itertools import count
from typing import Any

import h5py
import numpy as np
import scipy.io


def write_mat(path, variables: dict, version: str) -> None:
    if version == "v5":
        scipy.io.savemat(path, variables)
    else:
        write_mat73(path, variables)


def write_mat73(path, variables: dict) -> None:
    """A MATLAB v7.3 MAT-file as MATLAB writes it: HDF5 behind a 512-byte text header; every array stored with
    its dimensions reversed (column-major) and its class in a MATLAB_class attribute; a scalar struct as a group of
    its fields; a cell, and each field of a struct array, as an array of references to objects in ``#refs#``; an
    empty array as its dimensions, flagged MATLAB_empty."""
    with h5py.File(path, "w", userblock_size=512) as handle:
        refs = handle.create_group("#refs#")
        names = (f"r{k}" for k in count())
        for name, value in variables.items():
            _write(handle, name, value, refs, names)
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sun Dec  6 12:00:00 2026 HDF5 schema 1.00 ."
    with open(path, "r+b") as raw:
        raw.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM" + b"\x00" * (512 - 128))


def _fields_attr(fields) -> np.ndarray:
    """MATLAB_fields: the field names in order, each a variable-length array of characters."""
    names = np.empty(len(fields), dtype=h5py.vlen_dtype(np.dtype("S1")))
    for k, field in enumerate(fields):
        names[k] = np.frombuffer(field.encode(), "S1")
    return names


def _write(group, name: str, value: Any, refs, names) -> Any:
    if isinstance(value, dict):
        inner = group.create_group(name)
        inner.attrs["MATLAB_class"] = np.bytes_("struct")
        inner.attrs["MATLAB_fields"] = _fields_attr(value)
        for field, item in value.items():
            _write(inner, field, item, refs, names)
        return inner
    if isinstance(value, np.ndarray) and value.dtype.names:  # a struct array: a reference array per field
        inner = group.create_group(name)
        inner.attrs["MATLAB_class"] = np.bytes_("struct")
        inner.attrs["MATLAB_fields"] = _fields_attr(value.dtype.names)
        for field in value.dtype.names:
            pointers = np.empty(value.shape, dtype=h5py.ref_dtype)
            for index in np.ndindex(value.shape):
                pointers[index] = _write(refs, next(names), value[index][field], refs, names).ref
            inner.create_dataset(field, data=pointers.T)
        return inner
    if isinstance(value, np.ndarray) and value.dtype == object:  # a cell
        if value.size == 0:
            return _empty(group, name, value.shape, "cell")
        pointers = np.empty(value.shape, dtype=h5py.ref_dtype)
        for index in np.ndindex(value.shape):
            pointers[index] = _write(refs, next(names), value[index], refs, names).ref
        data = group.create_dataset(name, data=pointers.T)
        data.attrs["MATLAB_class"] = np.bytes_("cell")
        return data
    if isinstance(value, str):
        data = group.create_dataset(name, data=np.frombuffer(value.encode("utf-16-le"), np.uint16)[None, :].T)
        data.attrs["MATLAB_class"] = np.bytes_("char")
        return data
    array = np.asarray(value)
    array = array.reshape(1, -1) if array.ndim < 2 else array
    if array.size == 0:
        return _empty(group, name, array.shape, "double")
    if array.dtype.kind == "c":
        compound = np.empty(array.T.shape, dtype=[("real", "<f8"), ("imag", "<f8")])
        compound["real"], compound["imag"] = array.T.real, array.T.imag
        data = group.create_dataset(name, data=compound)
    else:
        data = group.create_dataset(name, data=np.asarray(array, dtype=float).T)
    data.attrs["MATLAB_class"] = np.bytes_("double")
    return data


def _empty(group, name: str, shape, kind: str):
    data = group.create_dataset(name, data=np.asarray(shape, dtype=np.uint64))
    data.attrs["MATLAB_class"] = np.bytes_(kind)
    data.attrs["MATLAB_empty"] = np.uint8(1)
    return data


def cell(*items) -> np.ndarray:
    """A 1 x n cell of ``items``, as scipy's writer and ours take it."""
    array = np.empty((1, len(items)), dtype=object)
    for k, item in enumerate(items):
        array[0, k] = item
    return array


def struct_array(rows: list[dict]) -> np.ndarray:
    """A 1 x n struct array of the dicts' fields."""
    array = np.zeros((1, len(rows)), dtype=[(f, object) for f in rows[0]])
    for k, row in enumerate(rows):
        for field, value in row.items():
            array[0, k][field] = value
    return array
