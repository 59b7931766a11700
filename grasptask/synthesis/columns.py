"""The columns of a solutions table, written and read in one place: palm pose ``palm_x/y/z`` and
``palm_r<i><j>``, joint angles ``q_<joint>``, and ``contact_<finger>_<axis>`` / ``normal_<finger>_<axis>``."""

from __future__ import annotations

import numpy as np

from grasptask.grasp.verify import Grasp

AXES = "xyz"


def grasp_columns(grasp: Grasp, joint_names: list[str], fingers: list[str], contacts, normals) -> dict[str, float]:
    row = {}
    for i, axis in enumerate(AXES):
        row[f"palm_{axis}"] = float(grasp.palm_position[i])
        for j in range(3):
            row[f"palm_r{i}{j}"] = float(grasp.palm_rotation[i, j])
    row.update({f"q_{name}": float(v) for name, v in zip(joint_names, grasp.joint_angles, strict=True)})
    for f, finger in enumerate(fingers):
        for i, axis in enumerate(AXES):
            row[f"contact_{finger}_{axis}"] = float(contacts[f, i])
            row[f"normal_{finger}_{axis}"] = float(normals[f, i])
    return row


def grasp_from_row(row, joint_names: list[str]) -> Grasp:
    rotation = np.array([[row[f"palm_r{i}{j}"] for j in range(3)] for i in range(3)], dtype=float)
    return Grasp(rotation, palm_position_from_row(row), np.array([row[f"q_{n}"] for n in joint_names], dtype=float))


def palm_position_from_row(row) -> np.ndarray:
    return np.array([row[f"palm_{a}"] for a in AXES], dtype=float)


def contacts_from_row(row, fingers: list[str]) -> np.ndarray:
    return np.array([[row[f"contact_{f}_{a}"] for a in AXES] for f in fingers], dtype=float)


def palm_normal_from_row(row) -> np.ndarray:
    """The palm's normal (the third column of R_h) in the object frame."""
    return np.array([row[f"palm_r{i}2"] for i in range(3)], dtype=float)


def joint_columns(joint_names: list[str]) -> list[str]:
    return [f"q_{n}" for n in joint_names]
