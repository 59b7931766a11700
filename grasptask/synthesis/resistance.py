"""What a hand's grasping contacts can never resist, wherever they are placed: said before a sweep, so that no
one waits for starts that cannot verify.

Two point contacts with friction cannot resist a torque about the line joining them, whatever their
placement: every force they apply passes through that line. A task whose wrench ellipsoid has torque about every
axis cannot be held by them, and the axis the sweep could best turn that line to is the task's least torque
axis. A soft contact (a flat pad, :attr:`GraspSettings.torsional_friction_m`) resists that twist, and three
contacts or more have no such line."""

from __future__ import annotations

import numpy as np

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import GraspingHand
from grasptask.task.ellipsoid import TORQUE, principal_axes
from grasptask.task.task_model import TaskModel

#: a torque extent (relative to the task's largest wrench extent) below which the task asks for none
NEGLIGIBLE = 1e-6


def least_torque(task: TaskModel) -> tuple[float, np.ndarray]:
    """The task ellipsoid's least extent along a pure torque (N.m) and its axis in the task frame: the smallest
    ``sqrt(d^T S d)`` over unit torques ``d``, the shortest principal axis of ``S``'s torque block."""
    lengths, axes = principal_axes(task.ellipsoid.S[TORQUE, TORQUE])
    return float(lengths[-1]), axes[:, -1]


def soft_contacts(hand: GraspingHand, settings: GraspSettings) -> list[int]:
    """The grasping fingers whose contact is a soft finger's: a flat pad, while the grasp config gives it
    torsional friction; every other contact is a point contact."""
    if settings.torsional_friction_m <= 0:
        return []
    return [j for j, finger in enumerate(hand.fingers.values()) if finger.pad.flat]


def unresistable(hand: GraspingHand, task: TaskModel, settings: GraspSettings) -> str | None:
    """A line saying what ``hand``'s grasping contacts cannot resist of ``task`` wherever they are placed, with
    the axis; None when some placement may hold it."""
    if len(hand.fingers) != 2 or soft_contacts(hand, settings):
        return None
    extent, axis = least_torque(task)
    largest = float(np.max(task.lengths))
    if extent <= NEGLIGIBLE * largest:
        return None
    shown = "(" + ", ".join(f"{v + 0.0:.2f}" for v in np.round(axis, 2)) + ")"
    fingers = " and ".join(hand.fingers)
    return (
        f"two point contacts ({fingers}) cannot resist a torque about the line joining them, and the task asks "
        f"for torque about every axis: at least {extent:.3g} N.m about {shown} in the task frame, its least"
    )
