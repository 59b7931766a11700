"""The grip controller (the default): at each control step, contact forces from a small QP over MuJoCo's own
current contacts, commanded as joint torques ``tau = J^T f``.

The QP, with three variables per contact (normal and two tangential components in the contact's frame), and
for tendons their activations:

    min   w |W (G f - w_d)|^2 + effort + e |f|^2
    s.t.  f inside each friction cone (an inscribed octagonal pyramid of ``grip_friction_fraction`` mu)
          at least ``min_normal_force_n`` of normal force on each hand link in contact
          the torques ``T J^T f`` within the actuators' reach (``= A a``, 0 <= a <= 1; for motors ``|.| <= E``)

``G`` is the grasp matrix about the object frame's origin, and ``w_d`` the wrench the hand must apply: minus
the wrench now applied to the object (a person anticipates the task's forces, and so does this controller), plus
an impedance on the object's pose error from where the grasp settled (a spring and a damper). The balance is a
heavily weighted least squares rather than an equality, so that a hand too weak for the load still does its
best. Effort is the squared activations: for motors ``(T J^T f / E)^2``.

Joints with no contact below them hold the synthesized posture; the others hold it in the contacts' null
space. A grasping finger with no contact yet is closed along the object's inward normal at its synthesized
contact, with the minimum normal force. The torques are mapped onto the actuators exactly
(:mod:`grasptask.physics.actuation`), and a torque out of reach is reported as saturation."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import quadprog

from grasptask.physics.loads import Test
from grasptask.physics.scene import Scene
from grasptask.physics.sensing import Contacts, pad_positions, point_jacobian
from grasptask.physics.settings import PhysicsSettings

#: the friction pyramid's faces: an octagon inscribed in the cone
_ANGLES = np.arange(8) * np.pi / 4
_FACES = np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])
#: torque errors weigh as force errors at this lever (m) in the balance
_LEVER_M = 0.05
#: the balance's weight against the effort (1 N of unbalanced force costs as much as 1e4 full activations)
_BALANCE_WEIGHT = 1e4
#: the damping of the null-space projection (m^2): keeps it defined where contacts' Jacobians are dependent
_NULL_SPACE_DAMPING = 1e-8
#: a small weight on the forces, so that quadprog's Hessian is positive definite
_FORCE_WEIGHT = 1e-6


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotation_error(reference: np.ndarray, current: np.ndarray) -> np.ndarray:
    """The rotation vector (world frame) that turns ``current`` into ``reference`` (unit quaternions)."""
    difference = np.zeros(4)
    inverse = np.zeros(4)
    mujoco.mju_negQuat(inverse, current)
    mujoco.mju_mulQuat(difference, reference, inverse)
    vector = np.zeros(3)
    mujoco.mju_quat2Vel(vector, difference, 1.0)
    return vector


@dataclass
class GripController:
    scene: Scene
    settings: PhysicsSettings
    reference_position: np.ndarray
    reference_quat: np.ndarray

    @classmethod
    def of(cls, scene: Scene, settings: PhysicsSettings) -> GripController:
        return cls(scene, settings, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0]))

    def hold(self, data: mujoco.MjData) -> None:
        """The object's settled pose becomes the impedance's rest pose."""
        body = self.scene.object_body
        self.reference_position, self.reference_quat = data.xpos[body].copy(), data.xquat[body].copy()

    def wanted_wrench(self, data: mujoco.MjData, test: Test | None, ramp: float) -> np.ndarray:
        """The wrench the hand must apply to the object, about its frame's origin (world coordinates)."""
        s, body = self.settings, self.scene.object_body
        origin, quat = data.xpos[body], data.xquat[body]
        rotation = data.xmat[body].reshape(3, 3)
        dof = self.scene.model.jnt_dofadr[self.scene.model.body_jntadr[body]]
        linear, angular = data.qvel[dof : dof + 3], rotation @ data.qvel[dof + 3 : dof + 6]
        force = s.object_stiffness_n_per_m * (self.reference_position - origin) - s.object_damping_ns_per_m * linear
        torque = (
            s.object_rotational_stiffness_nm_per_rad * _rotation_error(self.reference_quat, quat)
            - s.object_rotational_damping_nms_per_rad * angular
        )
        wanted = np.concatenate([force, torque])
        if test is not None:
            wanted -= ramp * test.about_origin(origin, data.xipos[body])
        return wanted

    def torques(self, data: mujoco.MjData, contacts: Contacts, test: Test | None, ramp: float) -> np.ndarray:
        scene, s = self.scene, self.settings
        q = data.qpos[scene.hand_qpos]
        driven = scene.finger_of_body[contacts.bodies] >= 0  # a palm contact is passive: nothing commands it
        jacobians = [
            point_jacobian(scene, data, p, int(b))
            for p, b in zip(contacts.points[driven], contacts.bodies[driven], strict=True)
        ]
        torque = np.zeros(len(q))
        rows = []
        if jacobians:
            chosen = _select(contacts, driven)
            forces = self.contact_forces(data, chosen, np.array(jacobians), test, ramp)
            for jacobian, frame, f in zip(jacobians, chosen.frames, forces, strict=True):
                torque += jacobian.T @ (frame.T @ f)
            rows.extend(jacobians)
        touching = set(scene.finger_of_body[contacts.bodies[driven]].tolist())
        pads = pad_positions(scene, data)
        rotation = data.xmat[scene.object_body].reshape(3, 3)
        for k in range(scene.finger_count):
            if k in touching:
                continue  # closing: the pad pushed along the object's inward normal at its synthesized contact
            jacobian = point_jacobian(scene, data, pads[k], int(scene.pad_bodies[k]))
            torque += jacobian.T @ (-s.min_normal_force_n * (rotation @ scene.normals[k]))
            rows.append(jacobian)
        posture = s.posture_stiffness_nm_per_rad * (scene.posture - q)
        if rows:  # held in the null space of the contacts and closing pads (damped least squares)
            stacked = np.vstack(rows)
            gram = stacked @ stacked.T + _NULL_SPACE_DAMPING * np.eye(len(stacked))
            posture -= stacked.T @ np.linalg.solve(gram, stacked @ posture)
        return torque + posture

    def contact_forces(
        self, data: mujoco.MjData, contacts: Contacts, jacobians: np.ndarray, test: Test | None, ramp: float
    ) -> np.ndarray:
        """``(m, 3)``: each contact's force in its frame (normal into the object, two tangents)."""
        scene, s = self.scene, self.settings
        m = len(contacts)
        origin = data.xpos[scene.object_body]
        bases = contacts.frames.transpose(0, 2, 1)  # (m, 3, 3): columns normal, tangents
        levers = np.cross((contacts.points - origin)[:, None, :], contacts.frames)  # (m, 3 columns, 3)
        grasp = np.vstack(
            [bases.transpose(1, 0, 2).reshape(3, 3 * m), levers.transpose(2, 0, 1).reshape(3, 3 * m) / _LEVER_M]
        )
        joint_map = scene.transmission @ np.einsum("mjn,mjk->nmk", jacobians, bases).reshape(-1, 3 * m)
        wanted = self.wanted_wrench(data, test, ramp)
        wanted[3:] /= _LEVER_M
        hessian = _BALANCE_WEIGHT * grasp.T @ grasp + _FORCE_WEIGHT * np.eye(3 * m)
        linear = _BALANCE_WEIGHT * grasp.T @ wanted
        cone = self._cone(m)
        links = np.unique(contacts.bodies)
        minimum = (contacts.bodies[None, :] == links[:, None]).astype(float)
        minimum = np.column_stack([minimum, np.zeros((len(links), m)), np.zeros((len(links), m))])
        minimum = minimum.reshape(len(links), 3, m).transpose(0, 2, 1).reshape(len(links), 3 * m)
        if scene.motors:
            used = np.flatnonzero(np.abs(joint_map).sum(axis=1) > 0)
            scaled = joint_map[used] / self._efforts[used, None]
            hessian += scaled.T @ scaled
            constraints = np.vstack([cone, -scaled, scaled])
            bounds = np.concatenate([np.zeros(len(cone)), -np.ones(2 * len(used))])
            return _solve(hessian, linear, 0, constraints, bounds, minimum, s.min_normal_force_n).reshape(m, 3)
        actuators = scene.torque_map.shape[1]
        full = np.zeros((3 * m + actuators, 3 * m + actuators))
        full[: 3 * m, : 3 * m] = hessian
        full[3 * m :, 3 * m :] = np.eye(actuators)
        constraints = np.zeros((len(joint_map) + len(cone) + 2 * actuators, 3 * m + actuators))
        constraints[: len(joint_map), : 3 * m] = joint_map
        constraints[: len(joint_map), 3 * m :] = -scene.torque_map
        constraints[len(joint_map) : len(joint_map) + len(cone), : 3 * m] = cone
        constraints[len(joint_map) + len(cone) :, 3 * m :] = np.vstack([np.eye(actuators), -np.eye(actuators)])
        bounds = np.concatenate([np.zeros(len(joint_map) + len(cone) + actuators), -np.ones(actuators)])
        minimum = np.hstack([minimum, np.zeros((len(links), actuators))])
        padded = np.concatenate([linear, np.zeros(actuators)])
        solution = _solve(full, padded, len(joint_map), constraints, bounds, minimum, s.min_normal_force_n)
        return solution[: 3 * m].reshape(m, 3)

    @property
    def _efforts(self) -> np.ndarray:
        """A motor's effort per transmission row (the scene's torque map is ``[E, -E]``)."""
        return np.abs(self.scene.torque_map).max(axis=1)

    def _cone(self, m: int) -> np.ndarray:
        """The friction octagons and non-negative normal forces of ``m`` contacts, as rows ``>= 0``."""
        mu = self.settings.grip_friction_fraction * self.scene.friction * np.cos(np.pi / 8)
        one = np.vstack([np.column_stack([np.full(8, mu), -_FACES]), [1.0, 0.0, 0.0]])
        cone = np.zeros((9 * m, 3 * m))
        for i in range(m):
            cone[9 * i : 9 * i + 9, 3 * i : 3 * i + 3] = one
        return cone


def _select(contacts: Contacts, keep: np.ndarray) -> Contacts:
    return Contacts(contacts.index[keep], contacts.points[keep], contacts.frames[keep], contacts.bodies[keep],
                    contacts.depths[keep])  # fmt: skip


def _solve(
    hessian: np.ndarray,
    linear: np.ndarray,
    equalities: int,
    constraints: np.ndarray,
    bounds: np.ndarray,
    minimum: np.ndarray,
    minimum_n: float,
) -> np.ndarray:
    """quadprog's ``min 1/2 x^T H x - a^T x`` with ``C x >= b`` (the first ``equalities`` rows equal); without
    the minimum normal force when the hand cannot give it (a weak hand: it still squeezes as it can)."""
    for extra in (True, False):
        rows = np.vstack([constraints, minimum]) if extra else constraints
        limits = np.concatenate([bounds, np.full(len(minimum), minimum_n)]) if extra else bounds
        try:
            return quadprog.solve_qp(hessian, linear, rows.T, limits, equalities)[0]
        except ValueError:  # inconsistent constraints
            continue
    return np.zeros(len(linear))
