"""3D renderings of a grasp: the hand's links and its own collision spheres, fingertip pads, the object's
surface, contact points, friction cones and the task's main wrench axis (for the report, and for looking at a
grasp in a notebook)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import trimesh
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from grasptask.exports.scene_meshes import PALM_COLOUR, finger_colour
from grasptask.hand.hand_model import Hand
from grasptask.hand.kinematics import forward
from grasptask.objects.surface import ImplicitObject
from grasptask.report.style import apply_style, save_figure
from grasptask.verifier.mechanics import friction_cone_edges


def display_mesh(obj: ImplicitObject, faces: int = 5000) -> trimesh.Trimesh:
    """A mesh of about ``faces`` triangles for pictures: a full surface is cheap to draw and has no holes."""
    return obj.picture(faces)


_U, _V = np.meshgrid(np.linspace(0, 2 * np.pi, 9), np.linspace(0, np.pi, 6))
#: a coarse unit sphere, (3, 6, 9), for drawing collision spheres
UNIT_SPHERE = np.stack([np.cos(_U) * np.sin(_V), np.sin(_U) * np.sin(_V), np.cos(_V)])


def _collision_spheres(ax, centres: np.ndarray, radii: np.ndarray, colour: str) -> None:
    """The hand's own collision geometry, the spheres eq. 14 and the verifier keep outside the object."""
    for centre, radius in zip(centres, radii, strict=True):
        x, y, z = centre[:, None, None] + radius * UNIT_SPHERE
        ax.plot_surface(x, y, z, color=colour, alpha=0.35, linewidth=0, shade=True, zorder=3)


def draw_grasp(
    ax: Any,
    hand: Hand,
    obj: ImplicitObject,
    palm_rotation: np.ndarray,
    palm_position: np.ndarray,
    joint_angles: np.ndarray,
    contacts: np.ndarray | None = None,
    normals: np.ndarray | None = None,
    mu: float = 0.5,
    task_axis: np.ndarray | None = None,
    mesh: trimesh.Trimesh | None = None,
) -> None:
    """Draw one grasp on a 3D axis; ``contacts``/``normals`` (outward) add contact points and friction cones.
    ``mesh`` is the object's picture (made by :func:`display_mesh` when not given)."""
    mesh = display_mesh(obj) if mesh is None else mesh
    ax.add_collection3d(
        Poly3DCollection(
            mesh.vertices[mesh.faces], facecolor="#a0a0a0", edgecolor="#8a8a8a", linewidth=0.1, alpha=0.45, zorder=0
        )
    )
    pose = forward(hand, joint_angles, palm_rotation, palm_position)
    for k, (name, finger) in enumerate(pose.fingers.items()):
        colour = finger_colour(name, k)
        ax.plot(*finger.joint_positions[0].T, color=colour, lw=1.5, marker="o", ms=2)
        _collision_spheres(ax, finger.samples[0], finger.radii, colour)
        ax.scatter(*finger.contact[0], color=colour, s=25, edgecolors="black", zorder=5)
    _collision_spheres(ax, pose.palm_samples[0], pose.palm_radii, PALM_COLOUR)
    if contacts is not None and normals is not None:
        edges = friction_cone_edges(-np.asarray(normals), mu, 12)
        scale = 0.02
        for point, cone in zip(contacts, edges, strict=True):
            ax.scatter(*point, color="red", s=30, marker="x", zorder=6)
            for edge in cone:
                ax.plot(*np.column_stack([point - scale * edge, point]), color="red", lw=0.6, alpha=0.7)
    if task_axis is not None:
        centre = np.zeros(3)  # the task frame's origin: objects live in their task frame
        for vector, colour, label in ((task_axis[:3], "magenta", "force"), (task_axis[3:], "black", "torque")):
            norm = np.linalg.norm(vector)
            if norm > 1e-6:
                tip = centre + 0.06 * vector / norm
                ax.plot(*np.column_stack([centre, tip]), color=colour, lw=2, label=f"main task axis ({label})")
    points = np.vstack([mesh.vertices, pose.collision_spheres()[0][0]])
    middle, half = points.mean(axis=0), (points.max(axis=0) - points.min(axis=0)).max() / 2
    for setter, m in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), middle, strict=True):
        setter(m - half, m + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")


def render_grasp(
    path: Path, title: str, views: tuple[tuple[float, float], ...] = ((20, -60), (20, 30)), **grasp: Any
) -> None:
    """Two viewpoints of one grasp side by side, saved as a PNG: at 90 dpi, not the other figures' 110, because
    a report inlines one per optimum (74 on the paper's tool) within its 15 MB."""
    apply_style()
    fig = plt.figure(figsize=(10, 4.8), dpi=90)
    for k, (elevation, azimuth) in enumerate(views, start=1):
        ax = fig.add_subplot(1, len(views), k, projection="3d")
        draw_grasp(ax, **grasp)
        ax.view_init(elevation, azimuth)
    fig.suptitle(title)
    save_figure(fig, path)
    plt.close(fig)
