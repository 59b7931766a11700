"""The results schema of a synthesis sweep, in one light module (numpy only): the start statuses, the columns of
a solutions table and the row of a start that produced no solution.

A solutions row holds ``start_id``, ``orientation``, ``position``, ``status``, ``iterations``, ``seconds``,
``message``, ``Q`` and ``verified``; for a start with a solution also the palm pose ``palm_x/y/z`` and
``palm_r<i><j>``, joint angles ``q_<joint>``, ``contact_<finger>_<axis>`` and ``normal_<finger>_<axis>``
(outward), and the verifier's ``verify_*`` figures. On a mesh or point cloud, ``surrogate_error_m_<finger>`` is
the synthesis surrogate's signed distance at each contact minus the mesh's own.
"""

from __future__ import annotations

import numbers
from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np

from grasptask.grasp.grasp_pose import Grasp
from grasptask.io.wording import plural

#: how a start ends: IPOPT's outcomes, then the sweep's own (a solver error, a worker that died or hung), then the
#: search route's start whose end point joined a basin another start's polish stands for
STATUSES = ("optimal", "acceptable", "infeasible", "max-iter", "time-limit", "error", "crashed", "hung", "same-basin")
AXES = "xyz"

Row = Mapping[str, Any]


#: the prefixes of a grasp's columns: palm pose, joint angles, contacts and outward normals
GRASP_PREFIXES = ("palm_", "q_", "contact_", "normal_")


def joint_columns(joint_names: list[str]) -> list[str]:
    return [f"q_{n}" for n in joint_names]


def _finger_columns(kind: str, fingers: list[str]) -> list[list[str]]:
    return [[f"{kind}_{finger}_{axis}" for axis in AXES] for finger in fingers]


def grasp_columns(
    grasp: Grasp, joint_names: list[str], fingers: list[str], contacts: np.ndarray, normals: np.ndarray
) -> dict[str, float]:
    """The palm pose, joint angles, contacts and outward normals of a grasp as row values."""
    row = {}
    for i, axis in enumerate(AXES):
        row[f"palm_{axis}"] = float(grasp.palm_position[i])
        for j in range(3):
            row[f"palm_r{i}{j}"] = float(grasp.palm_rotation[i, j])
    row.update({c: float(v) for c, v in zip(joint_columns(joint_names), grasp.joint_angles, strict=True)})
    for kind, values in (("contact", contacts), ("normal", normals)):
        for names, value in zip(_finger_columns(kind, fingers), values, strict=True):
            row.update({name: float(v) for name, v in zip(names, value, strict=True)})
    return row


def _counted_above(solutions: Any, column: str, floor: int) -> np.ndarray:
    """Which rows count more than ``floor`` in ``column``; a table without the column, or a row without a value,
    counts ``floor``."""
    if column not in solutions:
        return np.zeros(len(solutions), dtype=bool)
    return np.asarray(solutions[column].fillna(floor) > floor, dtype=bool)


def retried(solutions: Any) -> np.ndarray:
    """Which starts of a solutions table were solved again from a retry posture (``attempts`` above 1)."""
    return _counted_above(solutions, "attempts", 1)


def solved_with_all_axes(solutions: Any) -> np.ndarray:
    """Which starts had an attempt solved again with eq. 10 for all six task axes (``all_axes_solves`` above 0)."""
    return _counted_above(solutions, "all_axes_solves", 0)


def fingers_in(columns: list[str], known: list[str]) -> list[str]:
    """The fingers a solutions table holds contacts of (its ``contact_<finger>_x`` columns), in its order."""
    found = [c[len("contact_") : -len("_x")] for c in columns if c.startswith("contact_") and c.endswith("_x")]
    return [f for f in found if f in known]


def failed_row(start_id: int, orientation: int, position: str, status: str, seconds: float, message: str) -> dict:
    """The row of a start that produced no solution (an error, a crashed or hung worker)."""
    return {
        "start_id": start_id,
        "orientation": orientation,
        "position": position,
        "status": status,
        "iterations": 0,
        "seconds": seconds,
        "message": message,
        "Q": float("nan"),
        "verified": False,
    }


#: the largest plausible magnitudes of a solution's palm position (m, object frame), rotation entries and joint
#: angles (rad): a row beyond them was not written by a sweep
PLAUSIBLE = {"palm": 10.0, "rotation": 1.5, "joint": 100.0}


def implausible_column(row: Row, joint_names: list[str]) -> str | None:
    """The first grasp column of ``row`` that is not a finite number within :data:`PLAUSIBLE`, or None."""
    limits = [(f"palm_{a}", PLAUSIBLE["palm"]) for a in AXES]
    limits += [(f"palm_r{i}{j}", PLAUSIBLE["rotation"]) for i in range(3) for j in range(3)]
    limits += [(c, PLAUSIBLE["joint"]) for c in joint_columns(joint_names)]
    for column, limit in limits:
        value = row[column]
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not abs(float(value)) <= limit:
            return column
    return None


def grasp_from_row(row: Row, joint_names: list[str]) -> Grasp:
    rotation = np.array([[row[f"palm_r{i}{j}"] for j in range(3)] for i in range(3)], dtype=float)
    joints = np.array([row[c] for c in joint_columns(joint_names)], dtype=float)
    return Grasp(rotation, palm_position_from_row(row), joints)


def palm_position_from_row(row: Row) -> np.ndarray:
    return np.array([row[f"palm_{a}"] for a in AXES], dtype=float)


def palm_normal_from_row(row: Row) -> np.ndarray:
    """The palm's normal (the third column of R_h) in the object frame."""
    return np.array([row[f"palm_r{i}2"] for i in range(3)], dtype=float)


def contacts_from_row(row: Row, fingers: list[str]) -> np.ndarray:
    return np.array([[row[c] for c in names] for names in _finger_columns("contact", fingers)], dtype=float)


def normals_from_row(row: Row, fingers: list[str]) -> np.ndarray:
    """The outward surface normals at the contacts."""
    return np.array([[row[c] for c in names] for names in _finger_columns("normal", fingers)], dtype=float)


#: a sweep verifying less than this share of its starts says why, where one reason dominates
FEW_VERIFIED = 0.5


def why_few_verified(solutions: Any, task: str) -> str | None:
    """Why a sweep verified few of its starts. Where the hand is too weak for the task, that: most of the
    rejected starts whose contacts could hold the task's wrenches at all (``verify_torque_effort`` finite: the
    activation they need, 1 the rating) failed the torque check, asking more than the motors' or tendons'
    strength, by how much at the least and the most. Otherwise the checks most starts failed. Every start IPOPT
    left a point at counts, converged or not: where none converges (a hand too weak for the task leaves the NLP
    infeasible), the verifier's figures at those points still say why. None where most starts verified."""
    if not len(solutions) or float(np.mean(solutions["verified"])) >= FEW_VERIFIED:
        return None
    if "verify_failures" not in solutions or "verify_torque_effort" not in solutions:
        return None
    effort = solutions["verify_torque_effort"].to_numpy(dtype=float)
    converged = solutions["status"].isin(["optimal", "acceptable"]).to_numpy()
    rejected = (~np.isnan(effort) | converged) & ~solutions["verified"].to_numpy(dtype=bool)
    if not rejected.any():
        return None
    failures = solutions["verify_failures"].fillna("").astype(str)
    torque = failures.str.contains("torque_feasibility").to_numpy()
    holdable = rejected & np.isfinite(effort)
    weak = holdable & torque
    if weak.sum() > FEW_VERIFIED * holdable.sum():
        never = int((rejected & torque & np.isinf(effort)).sum())
        return (
            f"the hand is too weak for {task}: {int(weak.sum())} of the {plural(int(rejected.sum()), 'start')} "
            f"the verifier rejected failed its torque check, asking {effort[weak].min():.1f}-"
            f"{effort[weak].max():.1f}x its motors' or tendons' rated strength"
            + (f" (and {never} whose contacts could not hold them at any strength)" if never else "")
        )
    counts = Counter(check for listed in failures[rejected] for check in listed.split(";") if check)
    commonest = ", ".join(f"{n} {check}" for check, n in counts.most_common(3)).replace(" ", " failed ", 1)
    return (
        f"of the {plural(int(rejected.sum()), 'start')} the verifier rejected (IPOPT converged on "
        f"{int((rejected & converged).sum())}), {commonest}"
    )
