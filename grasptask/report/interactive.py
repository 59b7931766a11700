"""Interactive 3D views for the report (plotly): a grasp that can be turned, zoomed and have its parts toggled,
and a task's force and torque ellipsoids. Each view is figure data; the page draws it with the one inlined
plotly.js when it scrolls into sight (:mod:`grasptask.report.page`)."""

from __future__ import annotations

import base64
import hashlib
import html
from typing import Any

import numpy as np
import plotly.graph_objects as go
import trimesh
from plotly.io.json import to_json_plotly
from plotly.subplots import make_subplots

from grasptask.exports.scene_meshes import CONTACT_COLOUR, OBJECT_COLOUR, PALM_COLOUR, GraspScene, icosphere_copies
from grasptask.task.ellipsoid import FORCE, TORQUE, semi_axes
from grasptask.task.units import PAPER_TORQUE_UNIT, TORQUE_UNITS
from grasptask.verifier.mechanics import friction_cone_edges
from grasptask.verifier.verification import Verification

#: the friction cones' drawn length (m) and edges: long enough to read the cone's opening beside a fingertip
CONE_LENGTH, CONE_EDGES = 0.015, 16
HEIGHT = 560


def _mesh_trace(mesh: trimesh.Trimesh, colour: str, name: str, opacity: float, **extra: Any) -> go.Mesh3d:
    """A mesh as a plotly trace, in single precision (a tenth of a micrometre at hand scale) and 16-bit
    indices where they fit: a page of forty views stays within its budget."""
    vertices = np.asarray(mesh.vertices, dtype=np.float32)
    faces = np.asarray(mesh.faces, dtype=np.uint16 if len(vertices) < 2**16 else np.int32)
    return go.Mesh3d(
        x=vertices[:, 0], y=vertices[:, 1], z=vertices[:, 2], i=faces[:, 0], j=faces[:, 1], k=faces[:, 2],
        color=colour, opacity=opacity, name=name, flatshading=False,
        lighting={"ambient": 0.55, "diffuse": 0.7, "specular": 0.15}, **{"showlegend": True, **extra},
    )  # fmt: skip


#: the sphere every instanced sphere is drawn as: an icosphere of 42 vertices and 80 faces, unit radius
_TEMPLATE = trimesh.creation.icosphere(subdivisions=1, radius=1.0)


def instanced_spheres(
    centres: np.ndarray, radii: np.ndarray, colour: str, name: str, opacity: float, **extra: Any
) -> go.Mesh3d:
    """Spheres as one mesh that the page builds from one template sphere and a centre and radius each (16 bytes a
    sphere, not 1 KB): a LEAP hand's 6,600 collision spheres drawn one by one made a 13.9 MB page."""
    packed = np.column_stack([np.asarray(centres, dtype=np.float32).reshape(-1, 3), np.asarray(radii, np.float32)])
    spheres = {
        "data": base64.b64encode(np.ascontiguousarray(packed, dtype="<f4").tobytes()).decode("ascii"),
        "vertices": np.round(_TEMPLATE.vertices, 6).ravel().tolist(),
        "faces": np.asarray(_TEMPLATE.faces).ravel().tolist(),
    }
    return go.Mesh3d(
        x=[], y=[], z=[], i=[], j=[], k=[], color=colour, opacity=opacity, name=name, flatshading=False,
        meta={"spheres": spheres}, lighting={"ambient": 0.55, "diffuse": 0.7, "specular": 0.15},
        **{"showlegend": True, **extra},
    )  # fmt: skip


def _line(points: np.ndarray, colour: str, name: str, width: float = 5, **extra: Any) -> go.Scatter3d:
    points = np.asarray(points, dtype=np.float32)
    return go.Scatter3d(
        x=points[:, 0], y=points[:, 1], z=points[:, 2], mode="lines", line={"color": colour, "width": width},
        name=name, **extra,
    )  # fmt: skip


def cone_mesh(points: np.ndarray, inward: np.ndarray, mu: float) -> trimesh.Trimesh:
    """The friction cones as one surface: apex at each contact, opening out of the object, as the forces they
    admit push in."""
    edges = friction_cone_edges(inward, mu, CONE_EDGES)
    vertices: list[np.ndarray] = []
    faces: list[np.ndarray] = []
    for point, cone in zip(points, edges, strict=True):
        base = len(vertices) * (CONE_EDGES + 1)
        vertices.append(np.vstack([point, point - CONE_LENGTH * cone]))
        ring = np.arange(CONE_EDGES)
        faces.append(np.column_stack([np.full(CONE_EDGES, base), base + 1 + ring, base + 1 + (ring + 1) % CONE_EDGES]))
    return trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=False)


def _contact_text(scene: GraspScene, verification: Verification) -> list[str]:
    """Hover text per contact: its forces over the task wrenches and the verifier's figures at it."""
    texts = []
    for k, finger in enumerate(scene.fingers):
        lines = [f"<b>{html.escape(finger.name)}</b>"]
        if verification.loads:
            forces = np.array([load.contact_forces[k] for load in verification.loads])
            first = forces[0]
            lines.append(f"force under +gamma_1 u_1: [{first[0]:.2f}, {first[1]:.2f}, {first[2]:.2f}] N")
            lines.append(f"largest |force| over the 12 task wrenches: {np.linalg.norm(forces, axis=1).max():.2f} N")
        else:
            lines.append("no contact forces: some task wrench cannot be applied")
        lines.append(f"pad to surface: {verification.contact_distance_m[k] * 1e3:.2f} mm")
        lines.append(f"pad angle: {verification.pad_angle_deg[k]:.1f} deg")
        texts.append("<br>".join(lines))
    return texts


def _scene_points(scene: GraspScene) -> np.ndarray:
    """Every vertex a grasp's view draws: the object, the palm and the fingers."""
    meshes = [scene.object_mesh, scene.palm, *(finger.mesh for finger in scene.fingers)]
    return np.vstack([np.asarray(m.vertices) for m in meshes] + [np.asarray(scene.contacts, dtype=float)])


def grasp_view(
    scene: GraspScene,
    verification: Verification,
    title: str,
    centre: np.ndarray,
    task_axis: np.ndarray | None = None,
) -> go.Figure:
    """One grasp: the object, the palm's and each finger's collision spheres and links, the pads with hover
    text (contact forces, Q and the verifier's figures), the friction cones and the task's main axis."""
    shared = {"shared": f"mesh-{mesh_digest(scene.object_mesh)}"}  # one copy in the page for every view
    traces: list[Any] = [_mesh_trace(scene.object_mesh, OBJECT_COLOUR, "object", 0.45, hoverinfo="skip", meta=shared)]
    traces.append(_mesh_trace(scene.palm, PALM_COLOUR, "palm", 0.5, hoverinfo="skip"))
    for finger in scene.fingers:
        group = finger.name
        name = html.escape(finger.name)
        traces.append(_mesh_trace(finger.mesh, finger.colour, name, 0.55, hoverinfo="skip", legendgroup=group))
        traces.append(_line(finger.chain, finger.colour, f"{name} links", showlegend=False, legendgroup=group))
    summary = (
        f"Q {verification.Q:.3g}, epsilon {verification.epsilon:.3g}, peak activation "
        f"{verification.torque_effort:.3g}, strength margin {verification.strength_margin:.3g}, friction needed "
        f"{verification.friction_margin:.3g}, clearance {verification.min_clearance_m * 1e3:.2f} mm, penetration "
        f"{verification.penetration_m * 1e3:.2f} mm, "
        f"{'verified' if verification.ok else 'rejected: ' + ', '.join(verification.failures)}"
    )
    title = html.escape(title)  # plotly reads titles as HTML; a task or finger name is the user's text
    pads = np.asarray(scene.contacts, dtype=np.float32)
    traces.append(
        go.Scatter3d(
            x=pads[:, 0],
            y=pads[:, 1],
            z=pads[:, 2],
            mode="markers",
            name="contacts",
            marker={"size": 5, "color": [f.colour for f in scene.fingers], "line": {"color": "black", "width": 1}},
            text=[f"{t}<br>{summary}" for t in _contact_text(scene, verification)],
            hoverinfo="text",
        )
    )
    cones = cone_mesh(np.asarray(verification.contacts), -scene.normals, scene.mu)
    traces.append(_mesh_trace(cones, CONTACT_COLOUR, f"friction cones (mu {scene.mu:g})", 0.35, hoverinfo="skip"))
    if task_axis is not None:
        for vector, colour, label in ((task_axis[:3], "magenta", "force"), (task_axis[3:], "black", "torque")):
            norm = np.linalg.norm(vector)
            if norm > 1e-6:
                tip = centre + 0.06 * vector / norm
                traces.append(_line(np.vstack([centre, tip]), colour, f"main task axis ({label})", width=7))
    figure = go.Figure(traces)
    axis = {"title": "", "showbackground": False, "gridcolor": "#dddddd", "zerolinecolor": "#bbbbbb"}
    figure.update_layout(
        template="none", height=HEIGHT, margin={"l": 0, "r": 0, "t": 50, "b": 0},
        title={"text": f"{title}<br><sup>{summary}</sup>", "x": 0.02, "font": {"size": 14}},
        scene={"aspectmode": "data", "xaxis": axis | {"title": "x (m)"}, "yaxis": axis | {"title": "y (m)"},
               "zaxis": axis | {"title": "z (m)"}, "camera": fitted_camera(_scene_points(scene))},
        legend={"itemclick": "toggle", "x": 0.0, "y": 0.95, "bgcolor": "rgba(255,255,255,0.6)"},
    )  # fmt: skip
    return figure


def moment_traces(fingers: GraspScene, moved_object: trimesh.Trimesh, label: str) -> list[Any]:
    """The physics check's worst moment over a grasp's view, hidden until its legend entry is clicked: the
    object where the test wrench had pushed it, and the fingers as the controller held them then."""
    extra = {"legendgroup": "moment", "visible": "legendonly", "hoverinfo": "skip"}
    traces = [_mesh_trace(moved_object, "#7f7f7f", html.escape(label), 0.5, **extra)]
    for finger in fingers.fingers:
        traces.append(_mesh_trace(finger.mesh, "#555555", f"{html.escape(finger.name)} then", 0.6, **extra))
    return traces


#: plotly's default camera, and how much farther it must stand per unit of a scene's longest side (the scene's
#: sides in plotly's 'data' aspect, scaled so that their product is 1): a sugar box's 1.8 cropped the box's top
#: at the default, and 1.5 times farther showed it whole
DEFAULT_EYE, EYE_PER_ASPECT = np.array([1.25, 1.25, 1.25]), 0.85
#: farther still for the ellipsoids' two side-by-side scenes, each half the width (at the default, the drawing
#: task's spread of recordings ran 3,385 pixels into its view's border)
SUBPLOT_EYE_SCALE = 1.4


def fitted_camera(points: np.ndarray, scale: float = 1.0) -> dict:
    """A camera on plotly's default diagonal, as far as the scene's longest side needs (times ``scale``): the
    whole of the hand and the object in the view, not cut at the canvas's edge."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    extents = np.maximum(np.ptp(points, axis=0), 1e-9)
    aspect = extents / np.cbrt(np.prod(extents))
    eye = DEFAULT_EYE * scale * max(1.0, EYE_PER_ASPECT * float(aspect.max()))
    return {"eye": dict(zip("xyz", map(float, eye), strict=True))}


def ellipsoid_mesh(blocks: list[np.ndarray], subdivisions: int) -> trimesh.Trimesh:
    """The ellipsoids ``{B^(1/2) u : |u| = 1}`` of the 3 x 3 ``blocks`` as one mesh (one trace draws fast;
    forty do not, in a software-GL browser)."""
    roots = []
    for block in blocks:
        values, vectors = np.linalg.eigh(block)
        roots.append(vectors @ np.diag(np.sqrt(np.clip(values, 0, None))) @ vectors.T)
    return icosphere_copies(np.array(roots), np.zeros((len(roots), 3)), subdivisions)


def ellipsoid_view(task: str, model: np.ndarray, recordings: list[np.ndarray], colour: str) -> go.Figure:
    """A task's force (N) and torque (N.cm) ellipsoids in 3D: the task model's (the Log-Euclidean mean) and,
    faint, each recording's, with the model's three axes as arrows."""
    torque_factor = 1.0 / TORQUE_UNITS[PAPER_TORQUE_UNIT]
    titles = (f"force (N), {html.escape(task)}", f"torque ({PAPER_TORQUE_UNIT}), {html.escape(task)}")
    figure = make_subplots(rows=1, cols=2, specs=[[{"type": "scene"}, {"type": "scene"}]], subplot_titles=titles)
    cameras = {}
    for col, (block, factor) in enumerate(((FORCE, 1.0), (TORQUE, torque_factor)), start=1):
        scale, first = factor**2, col == 1
        trials = ellipsoid_mesh([m[block, block] * scale for m in recordings], subdivisions=1)
        cameras["scene" if col == 1 else "scene2"] = fitted_camera(trials.vertices, SUBPLOT_EYE_SCALE)
        model_block = model[block, block] * scale
        semi = semi_axes(model_block)  # the model's, longest first
        tips = go.Cone(x=semi[:, 0], y=semi[:, 1], z=semi[:, 2], u=semi[:, 0], v=semi[:, 1], w=semi[:, 2],
                       sizemode="absolute", sizeref=0.15 * float(np.linalg.norm(semi[0])), anchor="tip",
                       colorscale=[[0, "black"], [1, "black"]], showscale=False, hoverinfo="skip",
                       legendgroup="axes", showlegend=False)  # fmt: skip
        arrows = np.vstack([[np.zeros(3), a, np.full(3, np.nan)] for a in semi])
        for trace in (
            _mesh_trace(trials, colour, f"{len(recordings)} recordings", 0.12, hoverinfo="skip",
                        legendgroup="recordings", showlegend=first),
            _mesh_trace(ellipsoid_mesh([model_block], subdivisions=3), colour, "task model", 0.75, hoverinfo="skip",
                        legendgroup="model", showlegend=first),
            _line(arrows, "black", "task model's axes", width=5, legendgroup="axes", showlegend=first),
            tips,
        ):  # fmt: skip
            figure.add_trace(trace, row=1, col=col)
    axis_style = {"showbackground": False, "gridcolor": "#dddddd", "zerolinecolor": "#999999"}
    for name, unit in (("scene", "N"), ("scene2", PAPER_TORQUE_UNIT)):
        figure.update_layout(
            {
                name: {
                    "aspectmode": "data",
                    "camera": cameras[name],
                    **{f"{a}axis": axis_style | {"title": f"{a} ({unit})"} for a in "xyz"},
                }
            }
        )
    figure.update_layout(
        template="none", height=480, margin={"l": 0, "r": 0, "t": 40, "b": 0},
        legend={"x": 0.0, "y": 1.0, "bgcolor": "rgba(255,255,255,0.6)"},
    )  # fmt: skip
    return figure


def mesh_digest(mesh: trimesh.Trimesh) -> str:
    digest = hashlib.sha1(np.asarray(mesh.vertices, dtype=np.float32).tobytes())
    digest.update(np.asarray(mesh.faces, dtype=np.int64).tobytes())
    return digest.hexdigest()[:16]


#: the data of a trace marked ``meta.shared``, kept once in the page and put back by the page's script
SHARED_KEYS = ("x", "y", "z", "i", "j", "k")


def figure_json(figure: go.Figure) -> tuple[str, dict[str, str]]:
    """The figure as JSON that is safe inside an HTML ``<script>`` element (no ``</`` can close it), and the
    data of its shared traces by key (``meta.shared``), left out of the figure."""
    data = figure.to_plotly_json()
    shared: dict[str, str] = {}
    for trace in data["data"]:
        key = (trace.get("meta") or {}).get("shared")
        if key:
            shared[key] = _safe_json({name: trace.pop(name) for name in SHARED_KEYS if name in trace})
    return _safe_json(data), shared


def _safe_json(value: Any) -> str:
    return to_json_plotly(value).replace("</", "<\\/")
