"""The grip controller (the default): at each control step, contact forces from a small QP over MuJoCo's own
current contacts, commanded as joint torques ``tau = J^T f``.

The QP, with three variables per contact (normal and two tangential components in the contact's frame), and
for tendons their activations:

    min   w |W (G f - w_d)|^2 + effort + w_s |s|^2 + e |f|^2
    s.t.  f inside each friction cone (an inscribed octagonal pyramid of ``grip_friction_fraction`` mu)
          a flat pad's contact's twist about its normal within that fraction of MuJoCo's torsional friction
          each hand link in contact pressing with at least ``min_normal_force_n`` less its shortfall s >= 0
          the torques ``T J^T f`` within the actuators' reach (``= A a``, 0 <= a <= 1; for motors ``|.| <= E``)

``G`` is the grasp matrix about the object frame's origin, and ``w_d`` the wrench the hand must apply: minus
the wrench now applied to the object (a person anticipates the task's forces, and so does this controller), plus
an impedance on the object's pose error from where the grasp settled (a spring and a damper). ``W`` weighs
torques at the object's smallest radius of gyration. The balance is a heavily weighted least squares rather than
an equality, so that a hand too weak for the load still does its best, and the squeeze is soft, far below the
balance, so that contacts that cannot oppose each other never push the object away to meet it. Effort is the
squared activations: for motors ``(T J^T f / E)^2``.

A grasping finger out of contact closes on the object's nearest point (MuJoCo's geom distance): planned as a
frictionless contact while other fingers touch, pushed with the squeeze when none does or under a test. The squeeze
rises from 0 over ``closing_s``. The posture is held in the null space of the contacts and closing points. The
torques are mapped onto the actuators exactly (:mod:`grasptask.physics.actuation`), and a torque out of reach
is reported as saturation."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import mujoco
import numpy as np
import quadprog

from grasptask.physics.loads import Test
from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.physics.scene import Scene
from grasptask.physics.sensing import Contacts, pad_positions, point_jacobian

#: the friction pyramid's faces: an octagon inscribed in the cone
_ANGLES = np.arange(8) * np.pi / 4
_FACES = np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])
#: the balance's weight against the effort (1 N of unbalanced force costs as much as 1e4 full activations)
_BALANCE_WEIGHT = 1e4
#: the damping of the null-space projection (m^2): keeps it defined where contacts' Jacobians are dependent
_NULL_SPACE_DAMPING = 1e-8
#: how far (m) a finger out of contact looks for the object's nearest point to close on
CLOSING_RANGE_M = 0.01
#: the weight of a link's squeeze shortfall (per N^2): far below the balance's, so an unbalanced squeeze yields
_SQUEEZE_WEIGHT = 1e2
#: a small weight on the forces, so that quadprog's Hessian is positive definite
_FORCE_WEIGHT = 1e-6


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
    elapsed_s: float = 0.0

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
        self.elapsed_s += s.control_period_s
        q = data.qpos[scene.hand_qpos]
        fingers = scene.finger_of_body[contacts.bodies]
        chosen = _select(contacts, fingers >= 0)  # a palm contact is passive: nothing commands it
        touching = set(fingers[fingers >= 0].tolist())
        # a grasping finger out of contact closes on the object's nearest point. While the hand closes, that is
        # planned as a frictionless contact, so that the fingers still closing push no harder than the others
        # can balance; under a test it is pushed there with the squeeze, since a plan on a finger that has
        # lost its contact would carry load it cannot. With no finger touching there is nothing to balance
        # against, and frictionless pushes that cannot balance each other were planned at almost nothing: the
        # fingers stayed put while a seated object drifted off (9 of the YCB wood block's 27 lost grasps)
        closing = [self.nearest(data, k) for k in range(scene.finger_count) if k not in touching]
        if closing and test is None and touching:
            frames = np.array([_frame(inward) for _, _, inward in closing])
            chosen = Contacts(
                np.concatenate([chosen.index, np.full(len(closing), -1)]),
                np.vstack([chosen.points.reshape(-1, 3), [p for p, _, _ in closing]]),
                np.concatenate([chosen.frames.reshape(-1, 3, 3), frames]),
                np.concatenate([chosen.bodies, [b for _, b, _ in closing]]).astype(int),
                np.concatenate([chosen.depths, np.zeros(len(closing))]),
            )
            closing = []
        jacobians = [point_jacobian(scene, data, p, int(b)) for p, b in zip(chosen.points, chosen.bodies, strict=True)]
        torque = np.zeros(len(q))
        rows = list(jacobians)
        if jacobians:
            forces = self.contact_forces(data, chosen, np.array(jacobians), test, ramp)
            for jacobian, frame, f in zip(jacobians, chosen.frames, forces, strict=True):
                torque += jacobian.T @ (frame.T @ f)
        for point, body, inward in closing:
            jacobian = point_jacobian(scene, data, point, body)
            torque += jacobian.T @ (self.squeeze_n * inward)
            rows.append(jacobian)
        posture = s.posture_stiffness_nm_per_rad * (scene.posture - q)
        if rows:  # held in the null space of the contacts and closing pads (damped least squares)
            stacked = np.vstack(rows)
            gram = stacked @ stacked.T + _NULL_SPACE_DAMPING * np.eye(len(stacked))
            posture -= stacked.T @ np.linalg.solve(gram, stacked @ posture)
        return torque + posture

    def nearest(self, data: mujoco.MjData, finger: int) -> tuple[np.ndarray, int, np.ndarray]:
        """The point of ``finger`` nearest the object (MuJoCo's own geom distance), its body and the unit direction
        to the object; the pad and the object's inward normal at the synthesized contact when nothing of the
        finger is within ``CLOSING_RANGE_M``."""
        scene = self.scene
        best, found = CLOSING_RANGE_M, None
        span = np.zeros(6)
        for g in self._finger_geoms[finger]:
            for o in scene.object_geoms:
                gap = mujoco.mj_geomDistance(scene.model, data, int(g), int(o), CLOSING_RANGE_M, span)
                if gap < best and np.linalg.norm(span[3:] - span[:3]) > 0:
                    best, found = gap, (span[:3].copy(), int(scene.model.geom_bodyid[g]), span[3:] - span[:3])
        if found is not None:
            return found[0], found[1], found[2] / np.linalg.norm(found[2])
        rotation = data.xmat[scene.object_body].reshape(3, 3)
        pad = pad_positions(scene, data)[finger]
        return pad, int(scene.pad_bodies[finger]), -(rotation @ scene.normals[finger])

    @cached_property
    def _finger_geoms(self) -> list[np.ndarray]:
        scene = self.scene
        owner = scene.finger_of_body[scene.model.geom_bodyid]
        return [np.flatnonzero(scene.hand_geoms & (owner == k)) for k in range(scene.finger_count)]

    def contact_forces(
        self, data: mujoco.MjData, contacts: Contacts, jacobians: np.ndarray, test: Test | None, ramp: float
    ) -> np.ndarray:
        """``(m, 3)``: each contact's force in its frame (normal into the object, two tangents).

        The variables are the forces, one squeeze shortfall per link in contact, and for tendons their
        activations. The squeeze is soft: contacts that cannot oppose each other (all on one side, while the
        others have not touched yet) must not push the object away to meet it."""
        scene = self.scene
        m = len(contacts)
        origin = data.xpos[scene.object_body]
        bases = contacts.frames.transpose(0, 2, 1)  # (m, 3, 3): columns normal, tangents
        levers = np.cross((contacts.points - origin)[:, None, :], contacts.frames)  # (m, 3 columns, 3)
        soft = np.flatnonzero(np.isin(contacts.bodies, scene.soft_bodies) & (contacts.index >= 0))
        twists = np.vstack([np.zeros((3, len(soft))), contacts.frames[soft, 0].T / self.lever])  # a twist: (0, n)
        forces = [bases.transpose(1, 0, 2).reshape(3, 3 * m), levers.transpose(2, 0, 1).reshape(3, 3 * m) / self.lever]
        grasp = np.hstack([np.vstack(forces), twists])
        joint_map = scene.transmission @ np.einsum("mjn,mjk->nmk", jacobians, bases).reshape(-1, 3 * m)
        joint_map = np.hstack([joint_map, np.zeros((len(joint_map), len(soft)))])  # a sliding jaw feels no twist
        wanted = self.wanted_wrench(data, test, ramp)
        wanted[3:] /= self.lever
        links = np.unique(contacts.bodies)
        n_f, n_s = 3 * m + len(soft), len(links)
        actuators = 0 if scene.motors else scene.torque_map.shape[1]
        size = n_f + n_s + actuators
        hessian = np.zeros((size, size))
        hessian[:n_f, :n_f] = _BALANCE_WEIGHT * grasp.T @ grasp + _FORCE_WEIGHT * np.eye(n_f)
        hessian[n_f : n_f + n_s, n_f : n_f + n_s] = _SQUEEZE_WEIGHT * np.eye(n_s)
        linear = np.zeros(size)
        linear[:n_f] = _BALANCE_WEIGHT * grasp.T @ wanted
        # each link's normal force plus its shortfall at least the squeeze; shortfalls non-negative
        squeeze = np.zeros((2 * n_s, size))
        normal_of = np.zeros((n_s, n_f))
        normal_of[:, 0 : 3 * m : 3] = contacts.bodies[None, :] == links[:, None]
        squeeze[:n_s, :n_f], squeeze[:n_s, n_f : n_f + n_s] = normal_of, np.eye(n_s)
        squeeze[n_s:, n_f : n_f + n_s] = np.eye(n_s)
        floors = np.concatenate([np.full(n_s, self.squeeze_n), np.zeros(n_s)])
        cone = np.zeros((9 * m + 2 * len(soft), size))
        cone[: 9 * m, : 3 * m] = self._cone(contacts.index >= 0)
        spin = self.settings.grip_friction_fraction * data.contact.friction[contacts.index[soft], 2]
        for k, (contact, limit) in enumerate(zip(soft, spin, strict=True)):  # |twist| <= mu_t f_n, both ways
            rows = cone[9 * m + 2 * k : 9 * m + 2 * k + 2]
            rows[:, 3 * contact], rows[:, 3 * m + k] = limit, [1.0, -1.0]
        if scene.motors:
            used = np.flatnonzero(np.abs(joint_map).sum(axis=1) > 0)
            scaled = joint_map[used] / self._efforts[used, None]
            hessian[:n_f, :n_f] += scaled.T @ scaled
            reach = np.zeros((2 * len(used), size))
            reach[: len(used), :n_f], reach[len(used) :, :n_f] = -scaled, scaled
            rows = np.vstack([cone, squeeze, reach])
            limits = np.concatenate([np.zeros(len(cone)), floors, -np.ones(2 * len(used))])
            return _solve(hessian, linear, rows, limits, 0)[: 3 * m].reshape(m, 3)
        hessian[n_f + n_s :, n_f + n_s :] = np.eye(actuators)
        carried = np.zeros((len(joint_map), size))  # T J^T f = A a
        carried[:, :n_f], carried[:, n_f + n_s :] = joint_map, -scene.torque_map
        box = np.zeros((2 * actuators, size))
        box[:actuators, n_f + n_s :], box[actuators:, n_f + n_s :] = np.eye(actuators), -np.eye(actuators)
        rows = np.vstack([carried, cone, squeeze, box])
        limits = np.concatenate([np.zeros(len(carried) + len(cone)), floors, np.zeros(actuators), -np.ones(actuators)])
        return _solve(hessian, linear, rows, limits, len(carried))[: 3 * m].reshape(m, 3)

    @property
    def squeeze_n(self) -> float:
        """The minimum normal force, raised from 0 over the first ``closing_s`` of the grasp, so that the fingers
        close on the object together rather than knock it."""
        return self.settings.min_normal_force_n * min(1.0, self.elapsed_s / self.settings.closing_s)

    @cached_property
    def lever(self) -> float:
        """Torque errors weigh as force errors at the object's smallest radius of gyration (m) in the balance: a
        tool's twist about its own axis is as much a failure as a push along it."""
        model, body = self.scene.model, self.scene.object_body
        return float(np.sqrt(model.body_inertia[body].min() / model.body_mass[body]))

    @cached_property
    def _efforts(self) -> np.ndarray:
        """A motor's effort per transmission row (the scene's torque map is ``[E, -E]``)."""
        return np.abs(self.scene.torque_map).max(axis=1)

    def _cone(self, real: np.ndarray) -> np.ndarray:
        """The friction octagons and non-negative normal forces of the contacts, as rows ``>= 0``; a closing
        finger's planned contact (``real`` False) has no friction."""
        mu = self.settings.grip_friction_fraction * self.scene.friction * np.cos(np.pi / 8)
        m = len(real)
        cone = np.zeros((9 * m, 3 * m))
        for i in range(m):
            one = np.vstack([np.column_stack([np.full(8, mu if real[i] else 0.0), -_FACES]), [1.0, 0.0, 0.0]])
            cone[9 * i : 9 * i + 9, 3 * i : 3 * i + 3] = one
        return cone


def _frame(normal: np.ndarray) -> np.ndarray:
    """A contact frame whose first row is ``normal``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    first = np.cross(normal, helper)
    first /= np.linalg.norm(first)
    return np.array([normal, first, np.cross(normal, first)])


def _select(contacts: Contacts, keep: np.ndarray) -> Contacts:
    return Contacts(contacts.index[keep], contacts.points[keep], contacts.frames[keep], contacts.bodies[keep],
                    contacts.depths[keep])  # fmt: skip


def _solve(hessian: np.ndarray, linear: np.ndarray, rows: np.ndarray, limits: np.ndarray, equalities: int):
    """quadprog's ``min 1/2 x^T H x - a^T x`` with ``rows x >= limits`` (the first ``equalities`` equal); zero
    forces where quadprog finds the constraints inconsistent, which with a soft squeeze only round-off can make."""
    try:
        return quadprog.solve_qp(hessian, linear, rows.T, limits, equalities)[0]
    except ValueError:
        return np.zeros(len(linear))
