"""What the loader understood of a hand file, before any sweep (``grasptask hand``): its chains, joints, couplings,
fingertips and pads as text and tables, and one self-contained HTML view of the hand at mid-range joints with its
pads and collision spheres over its true collision surfaces."""

from __future__ import annotations

import html

import numpy as np
import pandas as pd
import plotly.graph_objects as go
import trimesh

from grasptask.exports.scene_meshes import PALM_COLOUR, finger_colour, spheres_mesh
from grasptask.hand.hand_model import Finger, Hand, Joint
from grasptask.hand.kinematics import forward
from grasptask.hand.mesh_cover import BOUND_M, MAX_SPHERES
from grasptask.report.interactive import _line, _mesh_trace, figure_json, instanced_spheres
from grasptask.report.page import Section, Table, View, render_html

#: the pad normals' drawn length (m)
NORMAL_M = 0.015


def _mm(vector: np.ndarray) -> str:
    return "(" + ", ".join(f"{1e3 * v + 0.0:.1f}" for v in np.round(vector, 4)) + ")"


def _unit(vector: np.ndarray) -> str:
    return "(" + ", ".join(f"{v + 0.0:.2f}" for v in np.round(vector, 2)) + ")"


def _range(joint: Joint) -> str:
    """A joint's range in its own unit: degrees for a turning joint, millimetres for a sliding one."""
    if joint.sliding:
        return f"[{1e3 * joint.lower:.0f}, {1e3 * joint.upper:.0f}] mm, sliding"
    return f"[{np.degrees(joint.lower):.0f}, {np.degrees(joint.upper):.0f}] deg"


def _coupling(joint: Joint) -> str:
    if joint.coupled_to is None:
        return ""
    if joint.shared:
        return f" (is {joint.coupled_to})"
    size, unit = (1e3, "mm") if joint.sliding else (np.degrees(1.0), "deg")
    offset = f" {'+' if joint.coupling_offset >= 0 else '-'} {size * abs(joint.coupling_offset):.1f} {unit}"
    return f" = {joint.ratio:g} x {joint.coupled_to}" + (offset if joint.coupling_offset else "")


def _one_motor_fingers(hand: Hand) -> list[str]:
    """A hint where more than three fingers grasp and some close on one motor each: every start must bring each
    of those pads onto the object along a single path, which over-constrains the NLP (the Inspire Hand's five
    such fingers ended every drawing start in IPOPT's restoration failure, at 37 s a start; three fingers:
    6/6 optimal at 0.7 s)."""
    grasping = [hand.fingers[name] for name in hand.grasping]
    single = [f.name for f in grasping if sum(j.coupled_to is None for j in f.joints) <= 1]
    if len(grasping) <= 3 or not single:
        return []
    return [
        f"{len(grasping)} fingers grasp, and {', '.join(single)} close on one motor each: every start must bring "
        "all their pads onto the object, which few poses allow; --fingers (or grasping_fingers in a hand YAML) "
        f"can name three, e.g. {','.join(hand.grasping[:3])}"
    ]


def _pad_shape(finger: Finger) -> str:
    """What the contact lies on: the pad's sphere, its flat face, or a fixed point; a fitted sphere's error and how
    far it follows the mesh."""
    pad = finger.pad
    if pad.flat:
        length, width = (2e3 * e for e in pad.half_extents)
        return f"a flat face {length:.1f} x {width:.1f} mm, lying on the surface"
    shape = f"sphere radius {1e3 * pad.radius:.1f} mm" if pad.radius > 0 else "a fixed point"
    if pad.fit_error_m > 0:
        shape += f", fit error {1e3 * pad.fit_error_m:.3f} mm"
    if finger.tip_mesh is not None and pad.radius > 0:
        shape += f", on the mesh for {pad.roll_max_deg:g} deg of roll"
    return shape


def _effort_lines(hand: Hand) -> list[str]:
    """Where the motors' efforts came from: the file, or the hand YAML's keys (which joints each set)."""
    by_source: dict[str, list[str]] = {}
    for joint, source in hand.effort_sources.items():
        by_source.setdefault(source or "file", []).append(joint)
    if not by_source:
        return []
    parts = [
        f"{len(joints)} from the file" if source == "file" else f"{', '.join(joints)} from {source}"
        for source, joints in by_source.items()
    ]
    return ["motor efforts: " + "; ".join(parts)]


def hand_lines(hand: Hand) -> list[str]:
    """The summary a user reads first: the file, the fingers, each finger's chain and pad, and the covers."""
    source = hand.model_file or "the project's own hand model"
    capability = hand.capability  # a motor drives its joint both ways: two actuators, J+ and J-
    actuators = {name.rstrip("+-") for name in capability.actuators} if capability.kind == "motors" else None
    count = (
        f"{len(actuators)} motor{'s' if len(actuators) != 1 else ''}"
        if actuators is not None
        else f"{len(capability.actuators)} actuators"
    )
    lines = [
        f"hand '{hand.name}' from {source}" + (f", palm link '{hand.palm_link}'" if hand.palm_link else ""),
        f"{len(hand.fingers)} fingers ({', '.join(hand.grasping)} grasp), {hand.n_joints} joints, "
        f"{count} ({capability.kind}), compliance {1e3 * hand.compliance_m:.2f} mm",
    ]
    lines += _one_motor_fingers(hand)
    lines += _effort_lines(hand)
    if hand.held_joints:
        held = ", ".join(f"{name} at {np.degrees(value):.0f} deg" for name, value in hand.held_joints.items())
        lines.append(f"joints before the palm held (held_joints in a hand YAML): {held}")
    for joint, fingers in hand.shared_joints().items():
        lines.append(f"joint {joint} moves fingers {' and '.join(fingers)} together: one angle, one motor")
    for name, finger in hand.fingers.items():
        joints = ", ".join(f"{j.name} {_range(j)}" + _coupling(j) for j in finger.joints)
        pad = finger.pad
        link = hand.fingertip_links.get(name, name)
        lines.append(f"finger {name}: joints {joints}")
        lines.append(
            f"  fingertip link '{link}': pad at {_mm(pad.point)} mm, normal {_unit(pad.normal)}, {_pad_shape(finger)}; "
            f"{len(finger.spheres)} collision spheres"
        )
    if hand.unbalanced_inertia:
        links = ", ".join(hand.unbalanced_inertia)
        lines.append(
            f"inertias that break A + B >= C, balanced by the physics check (MuJoCo's balanceinertia): {links}"
        )
    spheres = sum(len(f.spheres) for f in hand.fingers.values())
    lines.append(
        f"{spheres} collision spheres on the fingers, {len(hand.palm.radii)} on the palm"
        + (
            "; the palm has no collision geometry, so nothing keeps the object out of it"
            if not len(hand.palm.radii)
            else ""
        )
    )
    if hand.cover_reach_m:
        worst = max(hand.cover_reach_m, key=lambda link: hand.cover_reach_m[link])
        wide = [f"{link} {1e3 * r:.1f} mm" for link, r in hand.cover_reach_m.items() if r > BOUND_M + 1e-6]
        lines.append(
            f"mesh links' spheres reach at most {1e3 * hand.cover_reach_m[worst]:.1f} mm outside their meshes ({worst})"
            + (
                f"; beyond the {1e3 * BOUND_M:.1f} mm bound, where {MAX_SPHERES} spheres cannot follow a link's "
                f"sharp edges: {', '.join(wide)}"
                if wide
                else f", within the {1e3 * BOUND_M:.1f} mm bound"
            )
        )
    return lines


def joint_table(hand: Hand) -> pd.DataFrame:
    """One row per joint: its finger, limits, what drives it."""
    rows = []
    capability = hand.capability  # a motor "M+" pushes the rows of T with its column of the torque map
    pushing = [k for k, name in enumerate(capability.actuators) if name.endswith("+")]
    columns = {name: k for k, name in enumerate(hand.joint_names)}

    def effort(joint: Joint) -> str:
        """Each motor that pushes the joint's row, with its torque (force) there: its own, or a tendon's."""
        if capability.kind != "motors":
            return ""
        row = int(np.argmax(np.abs(capability.transmission[:, columns[joint.name]])))
        unit = "N" if joint.sliding else "N.m"
        said = []
        for k in pushing:
            value, motor = float(capability.torque_map[row, k]), capability.actuators[k][:-1]
            if value:
                said.append(
                    f"{abs(value):g} {unit}" + ("" if motor in (joint.name, joint.coupled_to) else f" ({motor})")
                )
        return ", ".join(said)

    for name, finger in hand.fingers.items():
        for joint in finger.joints:
            rows.append(
                {
                    "finger": name,
                    "joint": joint.name,
                    "range": _range(joint),
                    "effort": effort(joint),
                    "effort from": hand.effort_sources.get(joint.name, "")
                    or (f"its motor's ({joint.coupled_to})" if joint.coupled_to else ""),
                    "velocity": ""
                    if joint.velocity is None
                    else f"{joint.velocity:g} {'m/s' if joint.sliding else 'rad/s'}",
                    "coupled to": _coupling(joint).removeprefix(" = ").strip(" ()"),
                }
            )
    return pd.DataFrame(rows)


def hand_figure(hand: Hand) -> go.Figure:
    """The hand at mid-range joints, in its palm frame: each link's true collision surface as points, its
    collision spheres, the pads with their normals, and each fingertip's pad sphere."""
    pose = forward(hand, hand.mid_range())
    traces: list = []
    palm_points = pose.palm_skin
    if len(palm_points):
        traces.append(_points(palm_points, PALM_COLOUR, "palm surface"))
    if len(pose.palm_radii):
        traces.append(instanced_spheres(pose.palm_samples[0], pose.palm_radii, PALM_COLOUR, "palm spheres", 0.2))
    for k, (name, finger) in enumerate(pose.fingers.items()):
        colour, label = finger_colour(name, k), html.escape(name)
        surface = finger.skin()[0]
        if len(surface):
            traces.append(_points(surface, colour, f"{label} surface", legendgroup=name))
        if len(finger.radii):
            traces.append(
                instanced_spheres(finger.samples[0], finger.radii, colour, f"{label} spheres", 0.25, legendgroup=name)
            )
        traces.append(_line(finger.joint_positions[0], colour, f"{label} chain", showlegend=False, legendgroup=name))
        pad, normal = finger.contact[0], finger.pad_normal[0]
        traces.append(_line(np.vstack([pad, pad + NORMAL_M * normal]), "black", f"{label} pad normal", width=6))
        own = hand.fingers[name]
        if own.pad.radius > 0:
            sphere = spheres_mesh(finger.pad_centre, np.array([own.pad.radius]), subdivisions=2)
            traces.append(_mesh_trace(sphere, "#d62728", f"{label} pad sphere", 0.3, legendgroup=name))
        if own.pad.flat:
            face = _flat_face(own, finger.link_rotations[0, -1], finger.joint_positions[0, -2])
            traces.append(_mesh_trace(face, "#d62728", f"{label} flat pad", 0.6, legendgroup=name))
    pads = np.array([f.contact[0] for f in pose.fingers.values()])
    marker = {"size": 6, "color": "#d62728", "line": {"color": "black", "width": 1}}
    traces.append(go.Scatter3d(x=pads[:, 0], y=pads[:, 1], z=pads[:, 2], mode="markers", name="pads", marker=marker))
    figure = go.Figure(traces)
    axis = {"title": "", "showbackground": False, "gridcolor": "#dddddd"}
    figure.update_layout(
        template="none", height=640, margin={"l": 0, "r": 0, "t": 40, "b": 0},
        title={"text": f"{html.escape(hand.name)} at mid-range joints (palm frame)", "x": 0.02},
        scene={"aspectmode": "data", "xaxis": axis | {"title": "x (m)"}, "yaxis": axis | {"title": "y (m)"},
               "zaxis": axis | {"title": "z (m)"}},
    )  # fmt: skip
    return figure


def _flat_face(finger: Finger, rotation: np.ndarray, origin: np.ndarray) -> trimesh.Trimesh:
    """A flat pad's face as a rectangle of two triangles, its last link at ``rotation`` and ``origin``."""
    pad = finger.pad
    corners = [pad.point + a * pad.half_extents[0] * pad.tangent + b * pad.half_extents[1] * pad.across
               for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]  # fmt: skip
    return trimesh.Trimesh(np.array(corners) @ rotation.T + origin, [[0, 1, 2], [0, 2, 3]], process=False)


#: the most surface points a trace shows: a printed hand's thin shells sample to 10,000 a finger, and a spread
#: of 3,000 shows the surface as well, at a third of the page
SURFACE_POINTS_SHOWN = 3000


def _points(points: np.ndarray, colour: str, name: str, **extra) -> go.Scatter3d:
    p = np.asarray(points, dtype=np.float32)
    if len(p) > SURFACE_POINTS_SHOWN:  # evenly through the samples, the same ones every time
        p = p[np.linspace(0, len(p) - 1, SURFACE_POINTS_SHOWN).round().astype(int)]
    return go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="markers", name=name,
                        marker={"size": 1.5, "color": colour}, hoverinfo="skip", **extra)  # fmt: skip


def hand_page(hand: Hand) -> str:
    """One self-contained HTML page: the summary, the view, and the joint table."""
    data, shared = figure_json(hand_figure(hand))
    view = View("view-hand", data, "Points: the links' true collision surfaces; translucent: the spheres the NLP "
                "keeps outside the object; red: each pad's sphere, over which the contact rolls, or its flat face; "
                "black: pad normals.",
                height=660, shared=shared)  # fmt: skip
    sections = [
        Section("view", "The hand at mid-range joints", blocks=[view]),
        Section("joints", "Joints", blocks=[Table("joints", "Every joint the fingers move.", joint_table(hand))]),
    ]
    return render_html(f"Hand: {hand.name}", str(hand.model_file or ""), hand_lines(hand), sections)
