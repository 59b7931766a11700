"""Object files laid out as scans are published, built here rather than shipped: textured OBJs whose vertices are
split along every texture seam (as YCB's and photogrammetry exports are), a GLB scene of several nodes, meshes with
a small hole or a non-manifold fin. ``benchmarks/objects.py`` synthesizes grasps on the bottle and the box."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

#: a bottle's profile (radius, height) in metres: a 7 cm body, a shoulder, a 3 cm neck, 20 cm tall in all
BOTTLE_PROFILE = [(0.0, 0.0), (0.034, 0.0), (0.035, 0.004), (0.035, 0.12), (0.026, 0.15), (0.015, 0.165),
                  (0.015, 0.195), (0.013, 0.2), (0.0, 0.2)]  # fmt: skip


def bottle(sections: int = 48, step: float = 0.004) -> trimesh.Trimesh:
    """A closed bottle of revolution about z, its base at z = 0 (the file's origin, as YCB's are), its profile
    cut into pieces of at most ``step`` (m) so that its triangles are scan-sized."""
    corners = np.array(BOTTLE_PROFILE)
    profile = [corners[0]]
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        count = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        profile.extend(a + (b - a) * t for t in np.linspace(0, 1, count + 1)[1:])
    return trimesh.creation.revolve(np.array(profile), sections=sections)


def bowl(radius: float = 0.0805, height: float = 0.055, wall: float = 0.005, sections: int = 64) -> trimesh.Trimesh:
    """A bowl of revolution about z, YCB's bowl's size (161 mm across), open at the top, its base at z = 0: two
    of its principal axes are equal, and its third, the axis of symmetry, its shortest."""
    profile = [(0.0, 0.0), (0.6 * radius, 0.0), (radius, height), (radius - wall, height),
               (0.6 * radius - wall, wall), (0.0, wall)]  # fmt: skip
    return trimesh.creation.revolve(np.array(profile), sections=sections)


def can(radius: float = 0.0335, height: float = 0.102, sections: int = 64) -> trimesh.Trimesh:
    """A closed can, YCB's soup can's size, its base at z = 0: even-sided along its axis, so no third moment
    points it."""
    mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
    for _ in range(3):
        mesh = mesh.subdivide()
    mesh.apply_translation([0, 0, height / 2])
    return mesh


def box(size=(0.09, 0.04, 0.175), subdivisions: int = 4) -> trimesh.Trimesh:
    """A box with sharp edges, YCB's sugar box's size, its base at z = 0; its faces split ``subdivisions`` times,
    to scan-sized triangles (6 mm at 4)."""
    mesh = trimesh.creation.box(extents=size)
    for _ in range(subdivisions):
        mesh = mesh.subdivide()
    mesh.apply_translation([0, 0, size[2] / 2])
    return mesh


def rod(radius: float = 0.003, length: float = 0.12, sections: int = 24) -> trimesh.Trimesh:
    """A thin rod along z (a knitting needle, a skewer), its base at z = 0: its centre lies ``radius`` inside."""
    mesh = trimesh.creation.cylinder(radius=radius, height=length, sections=sections)
    mesh.apply_translation([0, 0, length / 2])
    return mesh


def cup(radius: float = 0.04, height: float = 0.095, wall: float = 0.004, sections: int = 48) -> trimesh.Trimesh:
    """A mug: a wall ``wall`` thick on a 6 mm base, open at the top, with a handle (a torus segment 9 mm thick)
    on its side; its centre of volume lies in its cavity, as a YCB mug's does."""
    profile = [(0.0, 0.0), (radius, 0.0), (radius, height), (radius - wall, height), (radius - wall, 0.006),
               (0.0, 0.006)]  # fmt: skip
    body = trimesh.creation.revolve(np.array(profile), sections=sections)
    handle = trimesh.creation.torus(major_radius=0.025, minor_radius=0.0045, major_sections=32, minor_sections=12)
    handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    handle.apply_translation([radius + 0.008, 0, height / 2])
    return trimesh.boolean.union([body, handle], engine="manifold")


def write_textured_obj(mesh: trimesh.Trimesh, path: Path, unit_scale: float = 1.0) -> Path:
    """``mesh`` as a textured OBJ (with its .mtl and a small PNG) whose texture atlas cuts it into charts: a
    cylindrical chart for the sides, split where the angle wraps, and one chart per face direction for the caps
    and flat faces. Every vertex on a chart's border is written once per chart, as scanners' exporters do, so
    that read as is, each seam is an open edge. ``unit_scale`` multiplies the coordinates (1000: millimetres)."""
    from PIL import Image

    normals = mesh.face_normals
    side = np.abs(normals[:, 2]) < 0.7
    angle = np.arctan2(mesh.triangles_center[:, 1], mesh.triangles_center[:, 0])
    axis = np.argmax(np.abs(normals), axis=1)
    direction = axis * 2 + (normals[np.arange(len(normals)), axis] > 0)
    chart = np.where(side, 6 + (angle > 0), direction)  # the sides split into two half-charts at the wrap
    positions, uvs, faces = [], [], []
    low, span = mesh.bounds[0], np.maximum(mesh.extents, 1e-9)
    for label in np.unique(chart):
        picked = np.flatnonzero(chart == label)
        used, local = np.unique(mesh.faces[picked], return_inverse=True)
        base = len(positions)
        points = mesh.vertices[used]
        positions.extend(points * unit_scale)
        uvs.extend(((points - low) / span)[:, :2] * 0.12 + 0.12 * (label % 8))
        faces.extend((local.reshape(-1, 3) + base + 1).tolist())
    image = path.with_suffix(".png")
    Image.fromarray(np.full((8, 8, 3), 180, dtype=np.uint8)).save(image)
    path.with_suffix(".mtl").write_text(f"newmtl scan\nKd 1 1 1\nmap_Kd {image.name}\n")
    lines = [f"mtllib {path.with_suffix('.mtl').name}", "usemtl scan"]
    lines += [f"v {x:.7g} {y:.7g} {z:.7g}" for x, y, z in positions]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in uvs]
    lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_scene_glb(path: Path) -> Path:
    """A GLB of two nodes, each mesh stored about its own origin and placed by its node's transform: a bottle's
    body and, on top of it, a cap turned 90 degrees (a scene as photogrammetry tools export it)."""
    body = trimesh.creation.cylinder(radius=0.03, height=0.12, sections=32)
    cap = trimesh.creation.box(extents=(0.02, 0.04, 0.02))
    scene = trimesh.Scene()
    scene.add_geometry(body, node_name="body", transform=trimesh.transformations.translation_matrix([0, 0, 0.06]))
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1])
    turn[:3, 3] = [0.0, 0.0, 0.13]
    scene.add_geometry(cap, node_name="cap", transform=turn)
    path.write_bytes(scene.export(file_type="glb"))
    return path


def with_hole(mesh: trimesh.Trimesh, at: np.ndarray, radius: float) -> trimesh.Trimesh:
    """``mesh`` with the faces whose centres lie within ``radius`` of ``at`` cut away."""
    out = mesh.copy()
    out.update_faces(np.linalg.norm(out.triangles_center - at, axis=1) > radius)
    out.remove_unreferenced_vertices()
    return out


def with_fin(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """``mesh`` with a loose triangle on one of its edges: that edge then has three faces (non-manifold)."""
    a, b = mesh.edges_unique[0]
    middle = (mesh.vertices[a] + mesh.vertices[b]) / 2
    tip = middle + 0.01 * (middle - mesh.centroid) / np.linalg.norm(middle - mesh.centroid)
    vertices = np.vstack([mesh.vertices, tip])
    faces = np.vstack([mesh.faces, [a, b, len(mesh.vertices)]])
    return trimesh.Trimesh(vertices, faces, process=False)
