"""3D renderings of a grasp: hand links as capsules, fingertip pads, the object's surface, contact points,
friction cones and the task's main wrench axis (for the report, and for looking at a grasp in a notebook)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import trimesh
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from grasptask.grasp.mechanics import friction_cone_edges
from grasptask.hand.kinematics import forward
from grasptask.hand.model import Hand
from grasptask.objects.surface import ImplicitObject, surface_mesh
from grasptask.report.style import apply_style

FINGER_COLOURS = {"thumb": "#d95f02", "index": "#1b9e77", "middle": "#7570b3", "ring": "#e7298a", "little": "#66a61e"}
#: for fingers by other names (a robot hand's), in order
OTHER_COLOURS = ("#d95f02", "#1b9e77", "#7570b3", "#e7298a", "#66a61e", "#e6ab02")


def display_mesh(obj: ImplicitObject, faces: int = 5000) -> trimesh.Trimesh:
    """A mesh of about ``faces`` triangles for pictures: a full surface is cheap to draw and has no holes."""
    spacing = float(np.sqrt(2 * obj.surface.mesh.area / faces))
    return surface_mesh(obj, spacing)


def _capsule_line(ax, a, b, radius, colour):
    # a thick line with round caps reads as a capsule at report sizes
    width = max(2.0, radius * 900)
    ax.plot(*np.column_stack([a, b]), color=colour, lw=width, solid_capstyle="round", alpha=0.85)


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
        colour = FINGER_COLOURS.get(name, OTHER_COLOURS[k % len(OTHER_COLOURS)])
        chain = finger.joint_positions[0]
        for a, b in zip(chain[:-1], chain[1:], strict=True):
            if np.linalg.norm(b - a) > 1e-9:
                _capsule_line(ax, a, b, finger.radius, colour)
        ax.scatter(*finger.contact[0], color=colour, s=25, edgecolors="black", zorder=5)
    palm = pose.palm_samples[0]
    ax.scatter(*palm.T, color="#8c6d31", s=12, alpha=0.6)
    if contacts is not None and normals is not None:
        edges = friction_cone_edges(-np.asarray(normals), mu, 12)
        scale = 0.02
        for point, cone in zip(contacts, edges, strict=True):
            ax.scatter(*point, color="red", s=30, marker="x", zorder=6)
            for edge in cone:
                ax.plot(*np.column_stack([point - scale * edge, point]), color="red", lw=0.6, alpha=0.7)
    if task_axis is not None:
        centre = obj.centre
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
    """Two viewpoints of one grasp side by side, saved as a PNG."""
    apply_style()
    fig = plt.figure(figsize=(10, 4.8))
    for k, (elevation, azimuth) in enumerate(views, start=1):
        ax = fig.add_subplot(1, len(views), k, projection="3d")
        draw_grasp(ax, **grasp)
        ax.view_init(elevation, azimuth)
    fig.suptitle(title)
    fig.savefig(path)
    plt.close(fig)
