"""The collision spheres a polish carries (SPEC section 12): a hand covered by thousands of spheres (a published
LEAP hand's 5,000) makes the paper's NLP one constraint per sphere, most of them far from the object at any
grasp. A polish keeps only the spheres within a stated distance of the object where the search ended; the
verifier still checks every sphere, and a polished grasp that a left-out sphere penetrates is polished again with
that sphere in (:meth:`NearSpheres.widened`).

numpy in and out: the hand's forward kinematics and the object's signed distance.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from grasptask.hand.hand_model import Hand
from grasptask.hand.kinematics import forward
from grasptask.objects.surface import ImplicitObject


@dataclass(frozen=True)
class NearSpheres:
    """Which of a grasping hand's collision spheres a polish's model carries: per finger the indices into its
    ``spheres``, and the palm's into its points."""

    fingers: tuple[tuple[int, ...], ...]
    palm: tuple[int, ...]

    @property
    def count(self) -> int:
        return sum(len(kept) for kept in self.fingers) + len(self.palm)

    def widened(self, other: NearSpheres) -> NearSpheres:
        """These spheres and ``other``'s."""
        fingers = tuple(tuple(sorted({*a, *b})) for a, b in zip(self.fingers, other.fingers, strict=True))
        return NearSpheres(fingers, tuple(sorted({*self.palm, *other.palm})))

    def covers(self, other: NearSpheres) -> bool:
        """Whether every sphere of ``other`` is one of these."""
        fingers = all(set(b) <= set(a) for a, b in zip(self.fingers, other.fingers, strict=True))
        return fingers and set(other.palm) <= set(self.palm)


def sphere_count(hand: Hand) -> int:
    """The collision spheres of a hand's grasping fingers and palm: the NLP's clearance constraints."""
    grasping = hand.grasping_hand()
    return sum(len(f.spheres) for f in grasping.fingers.values()) + len(grasping.palm.radii)


def clearances(
    hand: Hand, obj: ImplicitObject, palm_rotation: np.ndarray, palm_position: np.ndarray, joints: np.ndarray
) -> np.ndarray:
    """Each collision sphere's clearance from the object (m, negative inside) at a grasp: the fingers' spheres in
    the hand's order (as :meth:`HandPose.collision_spheres`), then the palm's."""
    grasping = hand.grasping_hand()
    centres, radii = forward(grasping, joints, palm_rotation, palm_position).collision_spheres()
    return obj.signed_distance(centres[0]) - radii


def chosen(hand: Hand, mask: np.ndarray) -> NearSpheres:
    """The spheres where ``mask`` (one entry a sphere, ordered as :func:`clearances`) is true."""
    grasping = hand.grasping_hand()
    fingers, at = [], 0
    for finger in grasping.fingers.values():
        fingers.append(tuple(int(i) for i in np.flatnonzero(mask[at : at + len(finger.spheres)])))
        at += len(finger.spheres)
    return NearSpheres(tuple(fingers), tuple(int(i) for i in np.flatnonzero(mask[at:])))


def within(hand: Hand, clearance: np.ndarray, distance_m: float) -> NearSpheres:
    """The spheres whose ``clearance`` (:func:`clearances`) is at most ``distance_m``. A fingertip's contact rolls
    over its pad sphere, which is not one of them: a LEAP hand's mesh tips are covered by 728."""
    return chosen(hand, clearance <= distance_m)


def penetrating(hand: Hand, clearance: np.ndarray, allowance_m: float) -> NearSpheres:
    """The spheres deeper in the object than ``allowance_m`` (:func:`clearances`): those a polish must take in."""
    return chosen(hand, clearance < -allowance_m)


def carrying(hand: Hand, kept: NearSpheres) -> Hand:
    """The hand whose grasping fingers and palm carry only the ``kept`` spheres (the others' spheres as they are):
    the hand a polish's model is built on."""
    grasping = list(hand.grasping)
    fingers = dict(hand.fingers)
    for name, indices in zip(grasping, kept.fingers, strict=True):
        finger = fingers[name]
        fingers[name] = replace(finger, spheres=tuple(finger.spheres[i] for i in indices))
    index = np.asarray(kept.palm, dtype=int)
    palm = replace(hand.palm, points=hand.palm.points[index].reshape(-1, 3), radii=hand.palm.radii[index])
    return replace(hand, fingers=fingers, palm=palm)
