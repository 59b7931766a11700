"""The verifier's verdict fed back into the NLP: a grasp that IPOPT solved but the verifier rejects only on the
torque check, the pad angle or a contact off its mesh fingertip is solved again from itself with those limits
tightened by what the verifier measured. Nothing here judges a grasp: the verifier's figures come in as numbers,
and the re-solved grasp goes back to the verifier like any other.

On a mesh the NLP sees a smooth surrogate whose normals differ from the mesh's by a degree or more. At an
optimum that uses all of the hand's strength, or puts a pad at its largest angle, that is enough for the
verifier to ask for 1.0-1.25 of the activation the NLP left at 0.98, or to see a pad a degree or two past its
limit (docs/design/synthesis.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the verifier's checks a re-solve with tighter limits can answer; any other failure is not a narrow miss
NARROW = frozenset({"torque_feasibility", "pad_angle", "fingertip_contact"})
#: how far past the verifier's pad angle a tightened bound goes, so the re-solved pad is not left on the edge
PAD_MARGIN_DEG = 0.5
#: how much less a contact off its mesh fingertip may roll on the re-solve than it did
OFF_TIP_STEP_DEG = 2.5


@dataclass(frozen=True)
class Limits:
    """The two per-start limits of the NLP that the verifier's feedback tightens: the tendon or motor activation
    cap (eq. 10) and each pad's largest angle to the surface normal."""

    activation_cap: float
    pad_angle_deg: np.ndarray


def tightened(
    limits: Limits,
    nominal_cap: float,
    failures: list[str],
    effort: float,
    pad_angles_deg: np.ndarray,
    off_tip: np.ndarray | None = None,
) -> Limits | None:
    """Limits for solving a rejected grasp again, or None when it failed a check they cannot answer.

    The cap shrinks by the verifier's effort over the NLP's nominal cap, so that the same ratio between the two
    judges' LPs would leave the verifier at the nominal cap. A pad the verifier sees past the NLP's bound gets a
    bound that much tighter, plus :data:`PAD_MARGIN_DEG`; a contact the verifier found off its mesh fingertip
    (``off_tip``, per finger) may roll :data:`OFF_TIP_STEP_DEG` less than it did."""
    if not failures or not set(failures) <= NARROW:
        return None
    cap = limits.activation_cap
    if "torque_feasibility" in failures:
        if not np.isfinite(effort):
            return None
        cap *= nominal_cap / effort
    bound = limits.pad_angle_deg
    if "pad_angle" in failures:
        excess = np.asarray(pad_angles_deg, dtype=float) - bound
        bound = np.where(excess > 0, bound - excess - PAD_MARGIN_DEG, bound)
    if "fingertip_contact" in failures and off_tip is not None:
        rolled = np.asarray(pad_angles_deg, dtype=float) - OFF_TIP_STEP_DEG
        bound = np.where(off_tip, np.maximum(0.0, np.minimum(bound, rolled)), bound)
    return Limits(float(cap), np.asarray(bound, dtype=float))
