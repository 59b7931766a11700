"""Example non-primitive objects built by the project (closed triangle meshes): a mug, a spray bottle, and two
of the paper's tools in a real shape, a kitchen knife and a screwdriver.

python -m grasptask.objects.shapes data/objects      # writes mug.stl, spray_bottle.stl, kitchen_knife.stl, ...
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh


def _revolve(profile: np.ndarray, sections: int = 180) -> trimesh.Trimesh:
    """Body of revolution about z from an (r, z) profile that starts and ends on the axis."""
    return trimesh.creation.revolve(np.asarray(profile, dtype=float), sections=sections)


def _rounded_profile(corners: list[tuple[float, float, float]], steps: int = 16) -> np.ndarray:
    """An (r, z) polyline through ``(r, z, fillet radius)`` corners, each corner rounded by its radius.

    Rounded edges keep the implicit surfaces fitted to these shapes within a millimetre everywhere. The
    tessellation is fine enough that the triangles' normals are within about a degree of the shape's own.
    """
    points = np.asarray([(r, z) for r, z, _ in corners], dtype=float)
    out = [points[0]]
    for k in range(1, len(points) - 1):
        radius = corners[k][2]
        if radius <= 0:
            out.append(points[k])
            continue
        before = points[k - 1] - points[k]
        after = points[k + 1] - points[k]
        before, after = before / np.linalg.norm(before), after / np.linalg.norm(after)
        half = np.arccos(np.clip(before @ after, -1, 1)) / 2
        start = points[k] + before * radius / np.tan(half)
        end = points[k] + after * radius / np.tan(half)
        centre = points[k] + (before + after) / np.linalg.norm(before + after) * radius / np.sin(half)
        a0, a1 = (np.arctan2(*(x - centre)[::-1]) for x in (start, end))
        sweep = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
        angles = a0 + sweep * np.linspace(0, 1, steps)
        out.extend(centre + radius * np.column_stack([np.cos(angles), np.sin(angles)]))
    out.append(points[-1])
    return np.array(out)


def mug() -> trimesh.Trimesh:
    """A closed mug-like body (radius 4 cm, height 10 cm, slightly tapered) with a ring handle on the +x side."""
    profile = _rounded_profile([(0.0, -0.05, 0), (0.040, -0.05, 0.008), (0.042, 0.05, 0.006), (0.0, 0.05, 0)])
    body = _revolve(profile)
    handle = trimesh.creation.torus(major_radius=0.028, minor_radius=0.007, major_sections=160, minor_sections=40)
    handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    handle.apply_translation([0.052, 0.0, 0.0])
    return trimesh.boolean.union([body, handle], engine="manifold")


def spray_bottle() -> trimesh.Trimesh:
    """A spray bottle: a round body with a shoulder and neck, a rounded trigger head on top and a trigger."""
    profile = _rounded_profile(
        [(0.0, -0.10, 0), (0.040, -0.10, 0.008), (0.040, 0.03, 0.012), (0.015, 0.06, 0.006),
         (0.015, 0.080, 0.004), (0.0, 0.080, 0)]
    )  # fmt: skip
    body = _revolve(profile)
    head = trimesh.creation.capsule(height=0.05, radius=0.016, count=[64, 32])
    head.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    head.apply_translation([0.015, 0.0, 0.088])
    trigger = trimesh.creation.capsule(height=0.025, radius=0.007, count=[48, 24])
    trigger.apply_translation([0.040, 0.0, 0.066])
    return trimesh.boolean.union([body, head, trigger], engine="manifold")


def _extruded_section(section: np.ndarray, z: np.ndarray, scale: np.ndarray) -> trimesh.Trimesh:
    """A closed tube through ``(k, 2)`` cross-sections at heights ``z``, each scaled by ``scale`` (x, y per
    height), capped at both ends."""
    rings = [np.column_stack([section * s, np.full(len(section), h)]) for h, s in zip(z, scale, strict=True)]
    vertices = np.vstack(rings + [[0.0, 0.0, z[0]], [0.0, 0.0, z[-1]]])
    k, n = len(section), len(z)
    faces = []
    for i in range(n - 1):
        for j in range(k):
            a, b = i * k + j, i * k + (j + 1) % k
            faces += [[a, b, b + k], [a, b + k, a + k]]
    bottom, top = n * k, n * k + 1
    for j in range(k):
        faces += [[bottom, (j + 1) % k, j], [top, (n - 1) * k + j, (n - 1) * k + (j + 1) % k]]
    mesh = trimesh.Trimesh(vertices, np.array(faces), process=True)
    trimesh.repair.fix_normals(mesh)
    return mesh


def _superellipse(a: float, b: float, exponent: float = 4.0, points: int = 128) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, points, endpoint=False)
    c, s = np.cos(t), np.sin(t)
    return np.column_stack([a * np.sign(c) * np.abs(c) ** (2 / exponent), b * np.sign(s) * np.abs(s) ** (2 / exponent)])


def _rounded_ends(z: np.ndarray, half_length: float) -> np.ndarray:
    """Section scales that round a handle's ends off over its last few millimetres."""
    return np.sqrt(np.clip(1 - (np.abs(z) / half_length) ** 8, 0.05, 1))


def kitchen_knife() -> trimesh.Trimesh:
    """A kitchen knife: a 12 cm handle of rounded-rectangle section, 2.6 x 1.8 cm, bulging gently, along z
    from -6 to 6 cm, and a 16 cm blade beyond it, 3 mm thick at the spine (+y) tapering to 1.2 mm at the
    edge, 3.6 cm tall, narrowing to a point."""
    z = np.linspace(-0.06, 0.06, 97)
    bulge = (1.0 + 0.08 * np.cos(np.pi * z / 0.12)) * _rounded_ends(z, 0.06)
    handle = _extruded_section(_superellipse(0.009, 0.013), z, np.column_stack([bulge, bulge]))
    # the blade's section in (x, y): thickness along x, height along y, its spine level with the handle's top
    section = np.array([[-0.0015, 0.012], [0.0015, 0.012], [0.0006, -0.024], [-0.0006, -0.024]])
    heights = np.linspace(0.058, 0.22, 17)
    taper = np.clip((0.22 - heights) / 0.12, 0.08, 1.0)  # full height for 4 cm, then narrowing to the tip
    scale = np.column_stack([np.ones_like(taper), taper])
    blade = _extruded_section(section - [0.0, 0.012], heights, scale)
    blade.apply_translation([0.0, 0.012, 0.0])
    return trimesh.boolean.union([handle, blade], engine="manifold")


def screwdriver() -> trimesh.Trimesh:
    """A screwdriver: a 10 cm fluted handle (radius 1.6 cm with six flutes 1.5 mm deep, rounded ends) along z
    from -5 to 5 cm, and a 3 mm shaft of 10 cm beyond it with a flat tip."""
    theta = np.linspace(0, 2 * np.pi, 192, endpoint=False)
    radius = 0.016 - 0.0015 * (0.5 + 0.5 * np.cos(6 * theta))
    section = np.column_stack([radius * np.cos(theta), radius * np.sin(theta)])
    z = np.linspace(-0.05, 0.05, 81)
    ends = _rounded_ends(z, 0.05)
    handle = _extruded_section(section, z, np.column_stack([ends, ends]))
    shaft = trimesh.creation.cylinder(radius=0.003, height=0.105, sections=64)
    shaft.apply_translation([0.0, 0.0, 0.0975])
    return trimesh.boolean.union([handle, shaft], engine="manifold")


SHAPES = {"mug": mug, "spray_bottle": spray_bottle, "kitchen_knife": kitchen_knife, "screwdriver": screwdriver}


def main(out: str = "data/objects") -> None:
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    for name, build in SHAPES.items():
        mesh = build()
        assert mesh.is_watertight, name
        mesh.export(folder / f"{name}.stl")
        print(f"{folder / name}.stl: {len(mesh.faces)} faces, volume {mesh.volume * 1e6:.0f} cm^3")


if __name__ == "__main__":
    main(*sys.argv[1:])
