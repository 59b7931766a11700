"""Where a hand file's palm is, and what moves with it.

Published hand files root their tree where their authors mount it: at an empty frame fixed to the palm, at a
forearm with wrist joints before the palm, or at the palm itself. The palm is the link where the chains to the
fingertips branch. Joints on the way to it (a wrist, an arm) are held at a stated angle: zero, or the nearest
limit where zero is outside the joint's range, unless the hand YAML sets one. Every link fixed to the palm, before
it and beside it, is part of the palm's collision geometry, in the palm's frame; the links beyond a held
joint (a forearm) are not."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from grasptask.errors import BadInputError

if TYPE_CHECKING:  # the tree imports this module to find its palm
    from grasptask.hand.tree import HandOptions, Tree, TreeJoint

REVOLUTE = ("revolute", "continuous")
#: the joints that move a finger: a jaw slides
MOVING = (*REVOLUTE, "prismatic")


def path_from_root(into: dict[str, TreeJoint], link: str) -> list[str]:
    """The links from the root down to ``link``, both included."""
    links = [link]
    while links[-1] in into:
        links.append(into[links[-1]].parent)
    return links[::-1]


def branching_link(into: dict[str, TreeJoint], tips: list[str]) -> str:
    """The deepest link every tip hangs from (or is): where the chains to the fingertips branch."""
    paths = [path_from_root(into, tip) for tip in tips]
    common = paths[0][0]
    for links in zip(*paths, strict=False):
        if len(set(links)) > 1:
            break
        common = links[0]
    return common


def held_joints(
    into: dict[str, TreeJoint], root: str, palm: str, options: HandOptions, source: Path
) -> dict[str, float]:
    """The movable joints between the root and the palm, each with the angle it is held at (rad)."""
    held: dict[str, float] = {}
    for link in path_from_root(into, palm)[1:]:
        joint = into[link]
        if joint.kind == "fixed":
            continue
        if joint.kind not in REVOLUTE:
            raise BadInputError(source, f"joint '{joint.name}' before the palm is {joint.kind}: only revolute joints")
        lower = -np.pi if joint.lower is None else joint.lower
        upper = np.pi if joint.upper is None else joint.upper
        value = options.held.get(joint.name, float(np.clip(0.0, lower, upper)))
        if not lower - 1e-9 <= value <= upper + 1e-9:
            raise options.fault(
                source, f"held_joints.{joint.name}", f"{value} rad is outside the joint's range [{lower}, {upper}]"
            )
        held[joint.name] = float(value)
    unknown = sorted(set(options.held) - set(held))
    if unknown:
        raise options.fault(
            source,
            f"held_joints.{unknown[0]}",
            f"'{unknown[0]}' is no joint between the root and the palm '{palm}' ({', '.join(held) or 'none are'})",
        )
    return held


def fixed_links(
    tree: Tree, link: str, into: dict[str, TreeJoint] | None = None, skip: frozenset[str] | set[str] = frozenset()
) -> list[tuple[str, np.ndarray]]:
    """``link`` and every link fixed to it, with its frame in ``link``'s frame: down the tree through fixed joints
    (but not into ``skip``), and, given ``into``, up it too (an empty root frame fixed to the palm)."""
    frames = {link: np.eye(4)}
    stack = [link]
    while stack:
        current = stack.pop()
        joint = into.get(current) if into is not None else None
        if joint is not None and joint.kind == "fixed" and joint.parent not in frames:
            frames[joint.parent] = frames[current] @ np.linalg.inv(joint.origin)
            stack.append(joint.parent)
        for child in tree.joints:
            if (
                child.parent == current
                and child.kind == "fixed"
                and child.child not in frames
                and child.child not in skip
            ):
                frames[child.child] = frames[current] @ child.origin
                stack.append(child.child)
    return list(frames.items())


def fixed_to_palm(tree: Tree, into: dict[str, TreeJoint], palm: str) -> list[tuple[str, np.ndarray]]:
    """Every link fixed to the palm (the palm included), before it and beside it, with its frame in the palm's
    frame: the palm's collision geometry. Links beyond a held joint (a forearm) are not the palm's."""
    return fixed_links(tree, palm, into)
