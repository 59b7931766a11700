"""Slow per-object work made once and kept: an object's convex parts for MuJoCo and a scan's distance grid, by
the content they are made from. The first build says what it makes and how long it took; a truncated entry,
another version's or a foreign one under its name is said, rebuilt and never trusted; a cache that cannot be
written is said once and the run goes on."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from grasptask import progress
from grasptask.io import cache
from grasptask.objects.mesh_object import MeshObject
from grasptask.physics.scene import convex_parts


def l_block() -> trimesh.Trimesh:
    """A non-convex solid (an L of two boxes), which CoACD cuts into parts."""
    a = trimesh.creation.box([0.06, 0.02, 0.02]).apply_translation([0.0, 0.0, 0.0])
    b = trimesh.creation.box([0.02, 0.02, 0.06]).apply_translation([0.02, 0.0, 0.03])
    return trimesh.boolean.union([a, b], engine="manifold")


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.setattr(progress, "SAY_PREPARING_AFTER_S", 0.0)  # say every build, however quick
    return tmp_path / "cache"


def entries(folder, kind: str) -> list:
    return sorted((folder / kind).glob("*.npz"))


def same_parts(a, b) -> None:
    assert len(a) == len(b) > 1
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.vertices, y.vertices)
        np.testing.assert_array_equal(x.faces, y.faces)


def test_convex_parts_are_made_once_said_and_kept(fresh_cache, capsys):
    mesh = l_block()
    first = convex_parts(mesh, "L")
    said = capsys.readouterr().err
    assert "L: its convex parts for MuJoCo (CoACD): done in" in said and "kept in" in said
    assert len(entries(fresh_cache, "convex")) == 1
    again = convex_parts(l_block(), "L")  # the same content, read again: from the cache, and quiet about a build
    same_parts(first, again)
    assert "kept in" in capsys.readouterr().err  # said as quick, found where it is kept
    moved = l_block().apply_translation([0.001, 0.0, 0.0])  # other content: another entry
    convex_parts(moved, "L")
    assert len(entries(fresh_cache, "convex")) == 2


@pytest.mark.parametrize("damage", ["truncated", "another version", "foreign", "garbage"])
def test_a_damaged_entry_is_said_and_rebuilt(fresh_cache, capsys, damage):
    mesh = l_block()
    made = convex_parts(mesh, "L")
    (path,) = entries(fresh_cache, "convex")
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[:200])
    elif damage == "garbage":
        path.write_bytes(b"not a numpy archive at all")
    else:
        with np.load(path) as data:
            arrays = {name: data[name] for name in data.files}
        if damage == "another version":
            arrays["__format__"] = np.array(cache.FORMAT + 1)
        else:  # a well-formed entry of something else, under this name
            arrays["vertices"] = arrays["vertices"][:3]
        np.savez(path, **arrays)
    capsys.readouterr()
    again = convex_parts(mesh, "L")
    said = capsys.readouterr().err
    assert f"{path}: cache entry not used (" in said and "made again" in said, said
    expected = {"another version": "written by another version", "foreign": "counts that do not add up"}
    assert expected.get(damage, "") in said
    same_parts(made, again)
    with np.load(path) as data:  # the entry is whole again
        assert int(data["__format__"]) == cache.FORMAT


def test_a_cache_that_cannot_be_written_is_said_once_and_the_run_goes_on(tmp_path, monkeypatch, capsys):
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the cache folder would be")
    monkeypatch.setenv(cache.CACHE_ENV, str(blocked))
    first = convex_parts(l_block(), "L")
    convex_parts(l_block().apply_translation([0.0, 0.001, 0.0]), "L")
    said = capsys.readouterr().err
    assert said.count("cannot keep the cache") == 1, said
    assert len(first) > 1
    monkeypatch.setenv(cache.CACHE_ENV, "off")
    assert cache.folder() is None and len(convex_parts(l_block(), "L")) == len(first)


def test_a_scans_distance_grid_is_kept_and_equal_to_a_fresh_one(fresh_cache, capsys):
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    made = MeshObject(mesh, name="ball").distance_grid
    assert "ball: its signed-distance grid for the synthesis: done in" in capsys.readouterr().err
    kept = MeshObject(mesh.copy(), name="ball").distance_grid
    np.testing.assert_array_equal(made.values, kept.values)
    np.testing.assert_array_equal(made.origin, kept.origin)
    assert made.spacing == kept.spacing and len(entries(fresh_cache, "distance_grid")) == 1
    (path,) = entries(fresh_cache, "distance_grid")
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["values"] = np.full_like(arrays["values"], np.nan)
    np.savez(path, **arrays)
    rebuilt = MeshObject(mesh.copy(), name="ball").distance_grid
    assert "a grid that is not finite" in capsys.readouterr().err
    np.testing.assert_array_equal(made.values, rebuilt.values)
