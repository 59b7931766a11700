"""How much room a grasp leaves, from the verifier's load LP (:mod:`grasptask.verifier.loads_lp`):

- the strength margin: the largest ``s`` such that ``s`` times every task wrench is held at the hand's real
  strength and friction (one LP that maximises ``s``; 1 is a grasp at the edge of its strength, 2 one that
  could carry twice the task);
- the friction margin: the smallest friction coefficient with which every task wrench is held at the real
  strength (bisection on the LP's feasibility, which only grows with mu); below the model's mu, the grasp
  does not need all the friction it is credited with."""

from __future__ import annotations

import numpy as np

from grasptask.hand.hand_model import Hand
from grasptask.verifier.loads_lp import MARGIN_CAP, LoadBlock, load_block, solve_loads
from grasptask.verifier.mechanics import friction_cone_edges
from grasptask.verifier.soft_contacts import Twists

#: bisection steps of the friction margin: its resolution is 1/32 of its bracket (0.0125 at a bracket of 0.4),
#: finer than a friction coefficient is known; each step is an LP, and 7 of them were 60% of the verifier's time
FRICTION_STEPS = 5
#: the friction margin is sought up to this multiple of the model's mu (beyond it: infinite)
FRICTION_CEILING = 8.0


def strength_margin(block: LoadBlock, targets: list[np.ndarray]) -> float:
    """The largest scale of ``targets`` held with every activation at most 1 (0 when none is)."""
    result = solve_loads(block, targets, scale_wrenches=True, activation_max=1.0)
    return float(min(result.x[-1], MARGIN_CAP)) if result.status == 0 else 0.0


def _holds(mu: float, inward, tangents, points, jacobians, hand: Hand, edges: int, targets, twists=None) -> bool:
    cones = friction_cone_edges(inward, mu, edges, tangents)
    result = solve_loads(load_block(cones, points, jacobians, hand, twists), targets, scale_wrenches=False,
                         activation_max=None)  # fmt: skip
    return result.status == 0 and result.x[-1] <= 1.0 + 1e-9


def friction_margin(
    inward: np.ndarray,
    tangents: np.ndarray,
    points: np.ndarray,
    jacobians: list[np.ndarray],
    hand: Hand,
    mu: float,
    edges: int,
    targets: list[np.ndarray],
    known: float | None = None,
    twists: Twists | None = None,
) -> float:
    """The smallest friction coefficient (to 1/32 of its bracket) with which the cones of ``edges`` edges about
    ``inward`` hold every target at full strength; inf above ``FRICTION_CEILING mu``. ``known``: a coefficient
    already known to hold them, which brackets the search without an LP. A soft contact's ``twists`` keep their
    own coefficient."""
    low, high = 0.0, mu if known is None else known
    while (known is None or high > known) and not _holds(high, inward, tangents, points, jacobians, hand, edges,
                                                          targets, twists):  # fmt: skip
        low, high = high, 2.0 * high
        if high > FRICTION_CEILING * mu:
            return float("inf")
    for _ in range(FRICTION_STEPS):
        middle = 0.5 * (low + high)
        if _holds(middle, inward, tangents, points, jacobians, hand, edges, targets, twists):
            high = middle
        else:
            low = middle
    return high
