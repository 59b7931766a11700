"""Example non-primitive objects built by the project: a mug and a spray bottle (closed triangle meshes).

python -m grasptask.objects.shapes data/objects      # writes mug.stl and spray_bottle.stl
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import trimesh


def _revolve(profile: np.ndarray, sections: int = 72) -> trimesh.Trimesh:
    """Body of revolution about z from an (r, z) profile that starts and ends on the axis."""
    return trimesh.creation.revolve(np.asarray(profile, dtype=float), sections=sections)


def _rounded_profile(corners: list[tuple[float, float, float]], steps: int = 8) -> np.ndarray:
    """An (r, z) polyline through ``(r, z, fillet radius)`` corners, each corner rounded by its radius.

    Rounded edges keep the implicit surfaces fitted to these shapes within a millimetre everywhere.
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
    handle = trimesh.creation.torus(major_radius=0.028, minor_radius=0.007, major_sections=64, minor_sections=20)
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
    head = trimesh.creation.capsule(height=0.05, radius=0.016, count=[32, 16])
    head.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    head.apply_translation([0.015, 0.0, 0.088])
    trigger = trimesh.creation.capsule(height=0.025, radius=0.007, count=[24, 12])
    trigger.apply_translation([0.040, 0.0, 0.066])
    return trimesh.boolean.union([body, head, trigger], engine="manifold")


SHAPES = {"mug": mug, "spray_bottle": spray_bottle}


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
