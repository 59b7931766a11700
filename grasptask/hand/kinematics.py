"""Forward kinematics of the hand, vectorised over configurations (paper eq. 2, Appendix 10.2).

Each finger is a chain from the palm frame: joint k sits at its offset in the frame of the link before it,
turned by its fixed rotation, and turns about its axis (a sliding joint moves along it); its collision spheres
and, on the last link, the pad
move with the link after it. Everything is computed for a batch of ``N`` configurations at once and returned
in the object frame, given the palm pose ``(R_h, d_h)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasptask.hand.hand_model import Finger, Hand, Skin


def axis_rotations(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rodrigues: ``(N, 3, 3)`` rotations by ``angles`` about the unit ``axis``."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


@dataclass
class FingerPose:
    """One finger in a batch of ``N`` configurations, in the object frame."""

    joint_positions: np.ndarray  # (N, n+1, 3): each joint's link's origin (a sliding one's where it slid to), the tip
    joint_axes: np.ndarray  # (N, n, 3): each joint's axis
    link_rotations: np.ndarray  # (N, n, 3, 3): each link's frame after its joint
    contact: np.ndarray  # (N, 3): the fingertip pad's home point
    pad_centre: np.ndarray  # (N, 3): the centre of the fingertip sphere the contact rolls over
    pad_normal: np.ndarray  # (N, 3): outward normal of the pad
    pad_tangent: np.ndarray  # (N, 3): the direction the first friction-cone edge follows
    jacobian: np.ndarray  # (N, 3, n): d contact / d joint angles
    sliding: np.ndarray  # (n,): which joints slide (their Jacobian column is their axis, and they carry no torque)
    samples: np.ndarray  # (N, s, 3): collision sphere centres on the links
    radii: np.ndarray  # (s,)
    radius: float  # for drawing the links
    #: the links' true collision surfaces, sampled in their own frames (placed by :meth:`skin`, on demand: a
    #: batch of many configurations would not hold them all)
    skin_shapes: tuple[Skin, ...] = ()

    def skin(self) -> np.ndarray:
        """``(N, k, 3)`` points on the links' true collision surfaces."""
        placed = [
            self.joint_positions[:, s.link, None] + np.einsum("nij,kj->nki", self.link_rotations[:, s.link], s.points)
            for s in self.skin_shapes
        ]
        return np.concatenate([np.zeros((len(self.joint_positions), 0, 3)), *placed], axis=1)


@dataclass
class HandPose:
    fingers: dict[str, FingerPose]
    palm_samples: np.ndarray  # (N, k, 3)
    palm_radii: np.ndarray  # (k,)
    palm_rotation: np.ndarray  # (N, 3, 3)
    palm_position: np.ndarray  # (N, 3)
    palm_skin: np.ndarray  # (k, 3) in the palm frame

    def skin(self) -> np.ndarray:
        """``(N, k, 3)`` points on the true collision surface of every link, the palm's last."""
        palm = np.einsum("nij,kj->nki", self.palm_rotation, self.palm_skin) + self.palm_position[:, None, :]
        return np.concatenate([f.skin() for f in self.fingers.values()] + [palm], axis=1)

    def contacts(self) -> np.ndarray:
        """``(N, b, 3)`` pad points of the fingers, in order."""
        return np.stack([f.contact for f in self.fingers.values()], axis=1)

    def pad_centres(self) -> np.ndarray:
        """``(N, b, 3)`` centres of the fingertip spheres."""
        return np.stack([f.pad_centre for f in self.fingers.values()], axis=1)

    def jacobians_at(self, points: np.ndarray) -> list[np.ndarray]:
        """Each finger's ``(N, 3, n)`` Jacobian of the point of its last link at ``points`` ``(N, b, 3)``
        (a contact that rolled away from the pad's home point)."""
        return [
            point_jacobian(f.joint_axes, f.joint_positions[:, :-1], points[:, j], f.sliding)
            for j, f in enumerate(self.fingers.values())
        ]

    def turn_jacobians(self) -> list[np.ndarray]:
        """Each finger's ``(N, 3, n)`` d (its last link's turn) / d joints: a revolute joint's axis, a sliding
        joint's zero; a torque ``m`` on the last link asks ``J^T m`` of the joints (a flat pad's twist)."""
        return [np.where(f.sliding[None, None, :], 0.0, f.joint_axes.transpose(0, 2, 1)) for f in self.fingers.values()]

    def pad_normals(self) -> np.ndarray:
        return np.stack([f.pad_normal for f in self.fingers.values()], axis=1)

    def pad_tangents(self) -> np.ndarray:
        return np.stack([f.pad_tangent for f in self.fingers.values()], axis=1)

    def collision_spheres(self) -> tuple[np.ndarray, np.ndarray]:
        """All sphere centres ``(N, s, 3)`` and their radii ``(s,)``: the fingers' links, then the palm."""
        points = [f.samples for f in self.fingers.values()] + [self.palm_samples]
        radii = [f.radii for f in self.fingers.values()] + [self.palm_radii]
        return np.concatenate(points, axis=1), np.concatenate(radii)


def point_jacobian(
    axes: np.ndarray, joints: np.ndarray, points: np.ndarray, sliding: np.ndarray | None = None
) -> np.ndarray:
    """``(N, 3, n)``: d point / d joint values, ``a_k x (p - P_k)`` for revolute joints of axes ``(N, n, 3)`` at
    ``(N, n, 3)``, ``a_k`` for ``sliding`` ones, at moving points ``(N, 3)`` of the link after the last of them."""
    columns = np.cross(axes, points[:, None, :] - joints)
    if sliding is not None and sliding.any():
        columns = np.where(sliding[None, :, None], axes, columns)
    return columns.transpose(0, 2, 1)


def finger_forward(finger: Finger, q: np.ndarray) -> FingerPose:
    """Finger ``finger`` at joint angles ``q`` ``(N, n)``, in the palm frame."""
    n_conf = len(q)
    rotation = np.broadcast_to(np.eye(3), (n_conf, 3, 3))
    position = np.zeros((n_conf, 3))
    positions, axes, rotations = [], [], []
    for k, joint in enumerate(finger.joints):
        position = position + rotation @ joint.offset
        if joint.rotation is not None:
            rotation = rotation @ joint.rotation
        axes.append(rotation @ joint.axis)
        if joint.sliding:  # the link slides along the axis, unturned; its origin is where it slid to
            position = position + q[:, k, None] * axes[-1]
        else:
            rotation = rotation @ axis_rotations(joint.axis, q[:, k])
        positions.append(position)
        rotations.append(rotation)
    link_rotations, joint_positions = np.stack(rotations, axis=1), np.stack(positions, axis=1)
    pad = finger.pad
    contact = position + rotation @ pad.point
    centre = position + rotation @ pad.centre
    centres = np.array([s.center for s in finger.spheres]).reshape(-1, 3)
    links = [s.link for s in finger.spheres]
    samples = joint_positions[:, links] + np.einsum("nsij,sj->nsi", link_rotations[:, links], centres)
    axes_arr = np.stack(axes, axis=1)
    sliding = np.array([joint.sliding for joint in finger.joints], dtype=bool)
    jacobian = point_jacobian(axes_arr, joint_positions, contact, sliding)
    return FingerPose(
        joint_positions=np.concatenate([joint_positions, (position + rotation @ finger.tip)[:, None]], axis=1),
        joint_axes=axes_arr,
        link_rotations=link_rotations,
        contact=contact,
        pad_centre=centre,
        pad_normal=rotation @ pad.normal,
        pad_tangent=rotation @ pad.tangent,
        jacobian=jacobian,
        sliding=sliding,
        samples=samples,
        radii=np.array([s.radius for s in finger.spheres]),
        radius=finger.radius,
        skin_shapes=finger.skin,
    )


def _to_object(pose: FingerPose, rotation: np.ndarray, position: np.ndarray) -> FingerPose:
    def point(x):
        return np.einsum("nij,n...j->n...i", rotation, x) + position.reshape(len(position), *([1] * (x.ndim - 2)), 3)

    def vector(x):
        return np.einsum("nij,n...j->n...i", rotation, x)

    return FingerPose(
        joint_positions=point(pose.joint_positions),
        joint_axes=vector(pose.joint_axes),
        link_rotations=np.einsum("nij,nkjl->nkil", rotation, pose.link_rotations),
        contact=point(pose.contact[:, None, :])[:, 0],
        pad_centre=point(pose.pad_centre[:, None, :])[:, 0],
        pad_normal=vector(pose.pad_normal[:, None, :])[:, 0],
        pad_tangent=vector(pose.pad_tangent[:, None, :])[:, 0],
        jacobian=rotation @ pose.jacobian,
        sliding=pose.sliding,
        samples=point(pose.samples),
        radii=pose.radii,
        radius=pose.radius,
        skin_shapes=pose.skin_shapes,
    )


def forward(
    hand: Hand,
    q: np.ndarray,
    palm_rotation: np.ndarray | None = None,
    palm_position: np.ndarray | None = None,
) -> HandPose:
    """The hand at joint angles ``q`` (``(n,)`` or ``(N, n)``, ordered as ``hand.joint_names``) with the palm at
    ``(R_h, d_h)`` (``(3, 3)``/``(3,)`` or batched) in the object frame. Coupled joints are taken as given."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    n_conf = len(q)
    rotation = np.eye(3) if palm_rotation is None else np.asarray(palm_rotation, dtype=float)
    position = np.zeros(3) if palm_position is None else np.asarray(palm_position, dtype=float)
    rotation = np.broadcast_to(rotation, (n_conf, 3, 3))
    position = np.broadcast_to(position, (n_conf, 3))
    fingers = {
        name: _to_object(finger_forward(finger, q[:, cols]), rotation, position)
        for (name, finger), cols in zip(hand.fingers.items(), hand.slices().values(), strict=True)
    }
    palm = np.einsum("nij,kj->nki", rotation, hand.palm.points) + position[:, None, :]
    return HandPose(fingers, palm, hand.palm.radii, rotation, position, hand.palm.skin)
