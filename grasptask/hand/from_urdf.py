"""URDF hands, parsed with ``yourdfpy``: links with their collision geometry, joints with origins, axes,
limits, efforts and ``mimic`` relations. Visual meshes are never read, so a missing ``package://`` visual does
not stop loading; a collision mesh is read with trimesh and covered by spheres."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grasptask.errors import BadInputError
from grasptask.hand import skin
from grasptask.hand import spheres as cover
from grasptask.hand.mesh_cover import mesh_shape
from grasptask.hand.tree import Shape, Tree, TreeJoint, TreeLink


def resolve_mesh(filename: str, source: Path) -> Path | None:
    """Where a mesh a hand file names lies: relative to the file, ``file://``, or ``package://pkg/...`` looked
    up in the folders above the file (as a ROS workspace holds it)."""
    folder = source.resolve().parent
    if filename.startswith("package://"):
        package, _, rest = filename[len("package://") :].partition("/")
        candidates = [d / package / rest for d in (folder, *folder.parents)] + [folder / rest]
    elif filename.startswith("file://"):
        candidates = [Path(filename[len("file://") :])]
    else:
        candidates = [folder / filename]
    return next((c for c in candidates if c.is_file()), None)


def _sizes(values, what: str, link: str, source: Path) -> list[float]:
    """A primitive's sizes as floats, each finite and positive, or the link's one-line refusal."""
    sizes = [float(v) for v in np.atleast_1d(np.asarray(values, dtype=float))]
    if not all(np.isfinite(v) and v > 0 for v in sizes):
        shown = " ".join(f"{v:g}" for v in sizes)
        raise BadInputError(source, f"link '{link}': {what} '{shown}' is not a positive number of metres")
    return sizes


def _shape(geometry, transform: np.ndarray, link: str, source: Path) -> Shape:
    """One collision geometry: the spheres covering it, points on its surface, and a mesh's triangles."""
    import trimesh  # deferred: trimesh, only for mesh links

    if geometry.sphere is not None:
        (radius,) = _sizes([geometry.sphere.radius], "sphere radius", link, source)
        return Shape([(transform[:3, 3].copy(), radius)], skin.sphere(transform[:3, 3], radius), rounded=True)
    if geometry.cylinder is not None:
        radius, length = _sizes([geometry.cylinder.radius, geometry.cylinder.length], "cylinder size", link, source)
        return Shape(cover.cylinder(radius, length, transform), skin.cylinder(radius, length, transform))
    if geometry.box is not None:
        half = np.array(_sizes(geometry.box.size, "box size", link, source)) / 2
        return Shape(cover.box(half, transform), skin.box(half, transform), box=(half, transform))
    if geometry.mesh is not None:
        path = resolve_mesh(geometry.mesh.filename, source)
        if path is None:
            raise BadInputError(source, f"link '{link}': collision mesh '{geometry.mesh.filename}' not found")
        try:  # unprocessed first: trimesh's processing drops vertices that are not finite without a word
            mesh = trimesh.load(path, force="mesh", process=False)
        except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds for a broken file
            raise BadInputError(path, f"link '{link}': not a mesh trimesh can read ({type(exc).__name__})") from exc
        raw = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float)
        bad = int((~np.isfinite(raw).all(axis=1)).sum()) if raw.ndim == 2 else 0
        if bad:
            raise BadInputError(
                path, f"link '{link}': {bad} of the collision mesh's {len(raw)} vertices are not finite numbers"
            )
        if isinstance(mesh, trimesh.Trimesh):
            mesh.process()
        scale = np.ones(3) if geometry.mesh.scale is None else np.broadcast_to(geometry.mesh.scale, 3)
        vertices = np.array(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=np.float64) * scale
        faces = np.array(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
        return mesh_shape(vertices, faces, transform, link, path)
    return Shape([], np.zeros((0, 3)))


def _unique_names(robot, source: Path) -> None:
    """A link or joint defined twice is refused: the parser keeps one of them without a word."""
    for kind, items in (("link", robot.links), ("joint", robot.joints)):
        seen: set[str] = set()
        for item in items:
            if item.name in seen:
                raise BadInputError(source, f"{kind} '{item.name}' is defined twice")
            seen.add(item.name)


def _check_inertial(link, source: Path) -> bool:
    """A link's mass and inertia as physics can use them: finite, the mass not negative, the inertia a
    symmetric matrix with no negative principal moment; whether its principal moments break A + B >= C (as
    many published ones do, by rounding), which the physics check balances."""
    inertial = link.inertial
    if inertial is None:
        return False
    mass = np.nan if inertial.mass is None else float(inertial.mass)
    inertia = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
    origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
    if inertial.mass is not None and not (np.isfinite(mass) and mass >= 0):
        raise BadInputError(source, f"link '{link.name}': inertial mass {mass} is not a mass (finite, >= 0)")
    if not (np.isfinite(inertia).all() and np.isfinite(origin).all()):
        raise BadInputError(source, f"link '{link.name}': its inertia or inertial origin is not finite")
    moments = np.linalg.eigvalsh((inertia + inertia.T) / 2)
    if moments.min() < -1e-12 * max(1.0, float(np.abs(moments).max())):
        raise BadInputError(
            source, f"link '{link.name}': inertia has a negative principal moment ({moments.min():.3g} kg.m^2)"
        )
    return bool(moments[0] + moments[1] < moments[2] * (1 - 1e-9))


def read_urdf(source: Path) -> Tree:
    """The kinematic tree of a URDF file."""
    import yourdfpy  # deferred: only for URDF hands
    from lxml import etree  # deferred: only for URDF hands

    try:  # yourdfpy recovers from broken XML on its own; a hand file must be well-formed
        etree.parse(str(source))
    except etree.XMLSyntaxError as exc:
        raise BadInputError(source, f"malformed XML: {exc.msg}", row=exc.lineno) from exc
    try:
        urdf = yourdfpy.URDF.load(
            str(source),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except (ValueError, KeyError, TypeError, AttributeError, etree.XMLSyntaxError) as exc:
        raise BadInputError(source, f"not a URDF yourdfpy can read ({type(exc).__name__}: {exc})") from exc
    robot = urdf.robot
    _unique_names(robot, source)
    links, unbalanced = {}, []
    for link in robot.links:
        if _check_inertial(link, source):
            unbalanced.append(link.name)
        tree_link = TreeLink(link.name)
        for collision in link.collisions:
            origin = np.eye(4) if collision.origin is None else np.asarray(collision.origin, dtype=float)
            tree_link.add(_shape(collision.geometry, origin, link.name, source))
        links[link.name] = tree_link
    joints = []
    for joint in robot.joints:
        limit = joint.limit
        mimic = (
            None
            if joint.mimic is None
            else (
                joint.mimic.joint,  # a multiplier of 0 is a multiplier of 0, not the default 1
                1.0 if joint.mimic.multiplier is None else float(joint.mimic.multiplier),
                0.0 if joint.mimic.offset is None else float(joint.mimic.offset),
            )
        )
        joints.append(
            TreeJoint(
                name=joint.name,
                kind=joint.type,
                parent=joint.parent,
                child=joint.child,
                origin=np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float),
                axis=np.array([1.0, 0.0, 0.0]) if joint.axis is None else np.asarray(joint.axis, dtype=float),
                lower=None if limit is None or limit.lower is None else float(limit.lower),
                upper=None if limit is None or limit.upper is None else float(limit.upper),
                effort=None if limit is None or limit.effort is None else float(limit.effort),
                mimic=mimic,
                velocity=None if limit is None or limit.velocity is None else float(limit.velocity),
            )
        )
    return Tree(links, joints, unbalanced)
