"""Hand files laid out as people publish them, built in the tests: a URDF whose links are STL meshes found
through ``package://`` paths, with joints named by number."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import trimesh

#: the ball the gripper's three tips touch at its zero posture, centred above the palm
GRIPPER_BALL_RADIUS_M = 0.02
TIP_RADIUS_M = 0.01
LINKS_M = (0.07, 0.04)


def ball_centre() -> np.ndarray:
    return np.array([0.0, 0.0, sum(LINKS_M)])


#: a box tip's size (m): across the way it closes, wide, long; its inner face where the sphere tip's nearest point is
BOX_TIP_M = (0.008, 0.016, 0.024)


#: a printed box tip's edges are rounded over this radius (m)
PRINTED_FILLET_M = 0.0015


def _tip_geometry(tip: str, package: Path) -> str:
    depth = TIP_RADIUS_M - BOX_TIP_M[0] / 2  # a box's middle, its inner face at the sphere's innermost point
    if tip == "box":
        return f'<origin xyz="{-depth} 0 0"/><geometry><box size="{" ".join(map(str, BOX_TIP_M))}"/></geometry>'
    if tip == "printed":
        rounded_box(np.array(BOX_TIP_M) / 2, PRINTED_FILLET_M).export(package / "meshes" / "tip.stl")
        return f'<origin xyz="{-depth} 0 0"/><geometry><mesh filename="package://gripper/meshes/tip.stl"/></geometry>'
    if tip == "pad":  # the LEAP's printed pad, facing the axis (-x), centred where the sphere's centre is
        pad = leap_tip_mesh()
        pad.apply_transform(np.diag([-1.0, 1.0, 1.0, 1.0]))
        pad.apply_translation([0.0, 0.0, -0.021])
        pad.export(package / "meshes" / "tip_pad.obj")
        return '<geometry><mesh filename="package://gripper/meshes/tip_pad.obj"/></geometry>'
    return f'<geometry><sphere radius="{TIP_RADIUS_M}"/></geometry>'


def write_mesh_gripper(root: Path, effort_nm: float = 2.0, inertia: str | None = None, tip: str = "sphere") -> Path:
    """A three-finger gripper as a ROS package under ``root``: ``gripper/urdf/gripper.urdf`` and its meshes in
    ``gripper/meshes``. Each finger rises from the palm 3 cm off its axis, two links (STL boxes) and a sphere
    tip; at zero posture the tips touch a 2 cm ball centred :func:`ball_centre` above the palm, and the joints
    (named "0" to "5") close them towards it. ``inertia`` replaces the first link's inertial element; ``tip`` "box"
    makes each tip a box whose inner face is where the sphere's nearest point to the ball is (a flat pad),
    "printed" the same box as an STL mesh with its edges rounded over :data:`PRINTED_FILLET_M`, and "pad" the
    LEAP's printed pad (:func:`leap_tip_mesh`, an OBJ mesh, neither sphere nor box) facing the axis."""
    package = root / "gripper"
    (package / "meshes").mkdir(parents=True, exist_ok=True)
    (package / "urdf").mkdir(parents=True, exist_ok=True)
    trimesh.creation.cylinder(radius=0.025, height=0.01).export(package / "meshes" / "palm.stl")
    for k, length in enumerate(LINKS_M):
        box = trimesh.creation.box([0.012, 0.012, length])
        box.apply_translation([0.0, 0.0, length / 2])
        box.export(package / "meshes" / f"link{k}.stl")
    links = ['<link name="palm"><collision><geometry><mesh filename="package://gripper/meshes/palm.stl"/>'
             "</geometry></collision></link>"]  # fmt: skip
    joints = []
    for f in range(3):
        angle = 2 * np.pi * f / 3
        radial = np.array([np.cos(angle), np.sin(angle), 0.0])
        parent = "palm"
        for k in range(len(LINKS_M)):
            name = f"finger{f}_link{k}"
            inertial = inertia if (inertia is not None and f == 0 and k == 0) else ""
            links.append(
                f'<link name="{name}">{inertial}<collision><geometry>'
                f'<mesh filename="package://gripper/meshes/link{k}.stl"/></geometry></collision></link>'
            )
            origin = (
                f'xyz="{0.03 * radial[0]:.6f} {0.03 * radial[1]:.6f} 0" rpy="0 0 {angle:.6f}"'
                if k == 0
                else f'xyz="0 0 {LINKS_M[0]}"'
            )
            # about the finger's own y axis: a positive angle tips the finger's top towards -x (the axis)
            joints.append(
                f'<joint name="{2 * f + k}" type="revolute"><parent link="{parent}"/><child link="{name}"/>'
                f'<origin {origin}/><axis xyz="0 -1 0"/>'
                f'<limit lower="-0.4" upper="0.4" effort="{effort_nm}" velocity="2"/></joint>'
            )
            parent = name
        links.append(f'<link name="finger{f}_tip"><collision>{_tip_geometry(tip, package)}</collision></link>')
        joints.append(
            f'<joint name="finger{f}_tip_joint" type="fixed"><parent link="{parent}"/>'
            f'<child link="finger{f}_tip"/><origin xyz="0 0 {LINKS_M[1]}"/></joint>'
        )
    path = package / "urdf" / "gripper.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="gripper">\n' + "\n".join(links + joints) + "\n</robot>\n")
    return path


def write_spread_gripper(root: Path, effort_nm: float = 2.0) -> Path:
    """:func:`write_mesh_gripper` with fingers 1 and 2 on one spread joint, as a Schunk SVH's ring and little
    fingers are: joint "spread" turns a knuckle link (its own collision box) about the palm's axis, and both
    fingers rise from it. At zero posture the hand is the plain gripper's."""
    path = write_mesh_gripper(root, effort_nm)
    text = path.read_text()
    for f in (1, 2):
        text = text.replace(
            f'<parent link="palm"/><child link="finger{f}_link0"/>',
            f'<parent link="knuckle"/><child link="finger{f}_link0"/>',
        )
    knuckle = (
        '<link name="knuckle"><collision><origin xyz="-0.01 0 -0.008"/><geometry><box size="0.01 0.01 0.004"/>'
        '</geometry></collision></link>\n<joint name="spread" type="revolute"><parent link="palm"/>'
        '<child link="knuckle"/><axis xyz="0 0 1"/>'
        f'<limit lower="-0.3" upper="0.3" effort="{effort_nm}" velocity="2"/></joint>\n</robot>'
    )
    path.write_text(text.replace("</robot>", knuckle))
    return path


ALLEGRO_MJCF = Path(__file__).resolve().parents[1] / "configs" / "hands" / "allegro.xml"
#: the mesh hand's links are the Allegro's boxes with their edges rounded over this radius (m)
FILLET_M = 0.003


def rounded_box(half_sizes: np.ndarray, fillet: float) -> trimesh.Trimesh:
    """A box of ``half_sizes`` about the origin, its edges and corners rounded over ``fillet``, as printed."""
    corner = trimesh.creation.icosphere(subdivisions=2, radius=fillet)
    inset = np.maximum(np.asarray(half_sizes, dtype=float) - fillet, 1e-4)
    corners = [corner.vertices + np.array(s) * inset for s in itertools.product((-1, 1), repeat=3)]
    return trimesh.convex.convex_hull(np.vstack(corners))


def _geom_mesh(model, g: int) -> trimesh.Trimesh:
    """One MuJoCo primitive geom as a triangle mesh in its body's frame."""
    import mujoco

    kind, size = int(model.geom_type[g]), model.geom_size[g]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[24, 24])
    elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=size[0])
    else:  # a printed link's box, its edges rounded over FILLET_M as published hand meshes are
        mesh = rounded_box(np.asarray(size[:3]), FILLET_M)
    mesh.apply_transform(trimesh.transformations.quaternion_matrix(model.geom_quat[g]))
    mesh.apply_translation(model.geom_pos[g])
    return mesh


def write_mesh_allegro(root: Path, tips: str = "mesh") -> Path:
    """The Allegro Hand's kinematics as a hand is often published: a ROS package under ``root``
    (``hand/urdf/hand.urdf``) whose every link is an STL mesh found through ``package://``, its 16 joints named
    "0" to "15", no YAML. ``tips="sphere"`` writes its twin, whose fingertips are the sphere at the end of each
    capsule tip, as a primitive."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(ALLEGRO_MJCF))
    package = root / "hand"
    (package / "meshes").mkdir(parents=True, exist_ok=True)
    (package / "urdf").mkdir(parents=True, exist_ok=True)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)]
    links, joints, number = [], [], 0
    for b in range(1, model.nbody):
        geoms = np.flatnonzero(model.geom_bodyid == b)
        collision = ""
        capsule = [g for g in geoms if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CAPSULE]
        if tips == "sphere" and capsule:
            g = capsule[0]
            axis = trimesh.transformations.quaternion_matrix(model.geom_quat[g])[:3, 2]
            end = model.geom_pos[g] + axis * model.geom_size[g][1]
            collision = (
                f'<collision><origin xyz="{end[0]:.6f} {end[1]:.6f} {end[2]:.6f}"/>'
                f'<geometry><sphere radius="{model.geom_size[g][0]}"/></geometry></collision>'
            )
        elif len(geoms):
            mesh = trimesh.util.concatenate([_geom_mesh(model, int(g)) for g in geoms])
            mesh.export(package / "meshes" / f"{names[b]}.stl")
            collision = (
                f'<collision><geometry><mesh filename="package://hand/meshes/{names[b]}.stl"/></geometry></collision>'
            )
        links.append(f'<link name="{names[b]}">{collision}</link>')
        parent = int(model.body_parentid[b])
        if parent == 0:
            continue
        xyz = " ".join(f"{v:.6f}" for v in model.body_pos[b])
        rpy = " ".join(f"{v:.6f}" for v in trimesh.transformations.euler_from_quaternion(model.body_quat[b], "sxyz"))
        ends = f'<parent link="{names[parent]}"/><child link="{names[b]}"/><origin xyz="{xyz}" rpy="{rpy}"/>'
        if model.body_jntnum[b]:
            j = int(model.body_jntadr[b])
            axis = " ".join(f"{v:.6f}" for v in model.jnt_axis[j])
            low, high = model.jnt_range[j]
            joints.append(
                f'<joint name="{number}" type="revolute">{ends}<axis xyz="{axis}"/>'
                f'<limit lower="{low:.6f}" upper="{high:.6f}" effort="0.7" velocity="6"/></joint>'
            )
            number += 1
        else:
            joints.append(f'<joint name="{names[b]}_fixed" type="fixed">{ends}</joint>')
    path = package / "urdf" / "hand.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="hand">\n' + "\n".join(links + joints) + "\n</robot>\n")
    return path


#: the published-gripper layout's jaw: its pad box (m), depth x thickness x length, and its stroke and force
JAW_BOX_M = (0.02, 0.01, 0.05)
JAW_STROKE_M = 0.04
JAW_EFFORT_N = 100.0


def write_jaw_gripper(root: Path, effort_n: float = JAW_EFFORT_N, pads: str = "box") -> Path:
    """A parallel-jaw gripper laid out as dex-urdf publishes the Franka's (``panda_gripper_glb.urdf``), as a ROS
    package under ``root``: the hand an STL mesh, two prismatic finger joints 58.4 mm above it sliding apart along
    y over :data:`JAW_STROKE_M`, the second's axis reversed and a ``<mimic>`` of the first, each finger a box pad
    whose inner face is on the midplane when shut, an empty ``tcp`` frame hung off the hand, and no YAML.
    ``pads="mesh"``: each finger the same box as an STL mesh, its edges rounded over :data:`PRINTED_FILLET_M`."""
    package = root / "jaws"
    (package / "meshes").mkdir(parents=True, exist_ok=True)
    (package / "urdf").mkdir(parents=True, exist_ok=True)
    body = trimesh.creation.box([0.06, 0.2, 0.058])
    body.apply_translation([0.0, 0.0, 0.029])
    body.export(package / "meshes" / "hand.stl")
    depth, thickness, length = JAW_BOX_M
    fingers = []
    for side, (name, sign) in enumerate((("panda_leftfinger", 1.0), ("panda_rightfinger", -1.0))):
        mimic = '<mimic joint="panda_finger_joint1" multiplier="1" offset="0"/>' if side else ""
        shape = f'<box size="{depth} {thickness} {length}"/>'
        if pads == "mesh":
            finger = rounded_box(np.array(JAW_BOX_M) / 2, PRINTED_FILLET_M)
            finger.apply_translation([0.0, sign * thickness / 2, length / 2])
            finger.export(package / "meshes" / f"finger{side}.stl")
            shape = f'<mesh filename="package://jaws/meshes/finger{side}.stl"/>'
        origin = "" if pads == "mesh" else f'<origin xyz="0 {sign * thickness / 2} {length / 2}"/>'
        fingers.append(
            f'<link name="{name}"><inertial><mass value="0.015"/><inertia ixx="3e-6" iyy="3e-6" izz="1e-6" '
            f'ixy="0" ixz="0" iyz="0"/></inertial><collision>{origin}<geometry>{shape}</geometry></collision>'
            "</link>\n"
            f'<joint name="panda_finger_joint{side + 1}" type="prismatic"><parent link="panda_hand"/>'
            f'<child link="{name}"/><origin xyz="0 0 0.0584" rpy="0 0 0"/><axis xyz="0 {sign:g} 0"/>'
            f'<limit effort="{effort_n}" lower="0.0" upper="{JAW_STROKE_M}" velocity="0.2"/>{mimic}</joint>'
        )
    text = (
        '<?xml version="1.0"?>\n<robot name="panda_gripper">\n'
        '<link name="panda_hand"><inertial><origin xyz="0 0 0.029"/><mass value="0.7"/><inertia ixx="0.0025" '
        'iyy="0.0004" izz="0.0025" ixy="0" ixz="0" iyz="0"/></inertial><visual><geometry>'
        '<mesh filename="package://jaws/meshes/hand_visual.glb"/></geometry></visual><collision><geometry>'
        '<mesh filename="package://jaws/meshes/hand.stl"/></geometry></collision></link>\n'
        '<link name="panda_hand_tcp"/>\n<joint name="panda_hand_tcp_joint" type="fixed"><parent link="panda_hand"/>'
        '<child link="panda_hand_tcp"/><origin xyz="0 0 0.1034"/></joint>\n' + "\n".join(fingers) + "\n</robot>\n"
    )
    path = package / "urdf" / "panda_gripper.urdf"
    path.write_text(text)
    return path


#: a LEAP-like hand's finger links, as (link, length along the finger (m), its collision boxes: centre and size in
#: the link's frame, m): thin printed shells, as the published LEAP URDF covers its links with boxes 4 mm thick
LEAP_LINKS = (
    ("mcp", 0.0, [((0.0, 0.0, 0.0), (0.024, 0.028, 0.012))]),
    ("pip", 0.046, [((0.0, 0.012, 0.023), (0.020, 0.004, 0.040)), ((0.0, -0.012, 0.023), (0.020, 0.004, 0.040)),
                    ((0.009, 0.0, 0.023), (0.004, 0.022, 0.040))]),
    ("dip", 0.036, [((-0.008, 0.0, 0.018), (0.004, 0.020, 0.034)), ((0.008, 0.0, 0.018), (0.004, 0.020, 0.034))]),
    ("fingertip", 0.0, [((-0.004, 0.0, 0.010), (0.004, 0.022, 0.030))]),
)  # fmt: skip


def leap_tip_mesh() -> trimesh.Trimesh:
    """The fingertip's rubber pad, as a printed hand publishes it: a mesh (no sphere, no box), the front of a
    flattened capsule over the last 3 cm of the finger, facing +x (the way the finger closes)."""
    pad = trimesh.creation.capsule(height=0.022, radius=0.0095, count=[24, 16])
    pad.apply_scale([0.8, 1.0, 1.0])
    pad.apply_translation([0.0, 0.0, 0.021])
    keep = pad.vertices[:, 0] >= -0.002
    front = trimesh.convex.convex_hull(pad.vertices[keep])
    return front


def write_leap_like(root: Path, effort_nm: float = 0.95) -> Path:
    """A four-finger hand laid out as the published LEAP URDF is: an empty ``base`` fixed to ``palm_lower``, the
    palm and every finger link covered by thin collision boxes (thousands of spheres in all), each fingertip a
    mesh pad (``meshes/collision/white_tip.obj``, no sphere), joints named by number, 0.95 N.m motors, visual
    meshes named that are not there. Three fingers rise along +z from the palm and close towards +x; the thumb
    rises in front of them and closes towards -x."""
    folder = root / "leap_hand"
    (folder / "meshes" / "collision").mkdir(parents=True, exist_ok=True)
    leap_tip_mesh().export(folder / "meshes" / "collision" / "white_tip.obj")

    def boxes(items) -> str:
        return "".join(
            f'<collision><origin xyz="{c[0]} {c[1]} {c[2]}"/><geometry><box size="{s[0]} {s[1]} {s[2]}"/></geometry>'
            "</collision>"
            for c, s in items
        )

    palm = [((-0.012, 0.0, -0.025), (0.004, 0.11, 0.05)), ((-0.004, 0.0, -0.052), (0.02, 0.11, 0.004))]
    links = ['<link name="base"/>', '<link name="palm_lower"><visual><geometry><mesh filename="meshes/visual/'
             f'palm_lower.obj"/></geometry></visual>{boxes(palm)}</link>']  # fmt: skip
    joints = ['<joint name="base_joint" type="fixed"><parent link="base"/><child link="palm_lower"/>'
              '<origin xyz="0 0.038 0.098" rpy="0 -1.57079 0"/></joint>']  # fmt: skip
    limits = {"mcp": (-1.047, 1.047), "pip": (-0.314, 2.23), "dip": (-0.506, 1.885), "fingertip": (-0.366, 2.042)}
    number = 0
    fingers = [("", (0.0, -0.045, 0.0), 0.0), ("_2", (0.0, 0.0, 0.0), 0.0), ("_3", (0.0, 0.045, 0.0), 0.0),
               ("_thumb", (0.06, 0.0, -0.03), np.pi)]  # fmt: skip
    for suffix, base, turn in fingers:
        parent, origin = "palm_lower", f'xyz="{base[0]} {base[1]} {base[2]}" rpy="0 0 {turn:.6f}"'
        for name, length, items in LEAP_LINKS:
            link = f"{name}{suffix}"
            tip = '<collision><geometry><mesh filename="meshes/collision/white_tip.obj"/></geometry></collision>'
            tip = tip if name == "fingertip" else ""
            links.append(f'<link name="{link}"><visual><geometry><mesh filename="meshes/visual/{name}.obj"/>'
                         f"</geometry></visual>{boxes(items)}{tip}</link>")  # fmt: skip
            axis = "0 0 1" if name == "mcp" else "0 1 0"  # the mcp swings the finger sideways, the rest curl it
            low, high = limits[name]
            joints.append(
                f'<joint name="{number}" type="revolute"><origin {origin}/><parent link="{parent}"/>'
                f'<child link="{link}"/><axis xyz="{axis}"/>'
                f'<limit effort="{effort_nm}" velocity="8.48" lower="{low}" upper="{high}"/></joint>'
            )
            parent, origin, number = link, f'xyz="0 0 {length if length else 0.012}"', number + 1
    path = folder / "leap_hand_right.urdf"
    path.write_text('<?xml version="1.0" encoding="utf-8"?>\n<robot name="leap_right">\n' + "\n".join(links + joints)
                    + "\n</robot>\n")  # fmt: skip
    return path
