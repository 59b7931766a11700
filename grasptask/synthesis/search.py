"""The search (SPEC section 12): a start's geometry moved by IPOPT on the model without the task forces.

The search's model is :data:`~grasptask.synthesis.nlp.SEARCH_EQUATIONS`: palm pose, joints, contacts, normals,
cone edges, Jacobians and eq. 4's weights, with eqs. 3, 14 and 16-23 as constraints, but none of eq. 8's task
forces or eq. 10's rows. Its objective is the force problem's eq. 8 part in closed form
(:func:`~grasptask.synthesis.force_problem.symbolic_quality`), added where CasADi imports the model, so IPOPT has
its exact derivatives: the gradient the envelope theorem gives from the force problem's solution and multipliers.
An iteration's cost then does not grow with the task's wrench rows. Eq. 10 is the force problem's to judge at
each end point, and the polish's (the paper's NLP) to meet.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.synthesis.solver_config import SolverConfig
from grasptask.synthesis.solvers import Solver, assign, held_axis
from grasptask.synthesis.starts import Start

if TYPE_CHECKING:
    from grasptask.grasp.grasp_settings import GraspSettings
    from grasptask.hand.hand_model import Hand
    from grasptask.objects.surface import ImplicitObject
    from grasptask.synthesis.force_problem import ForceSolution
    from grasptask.task.task_model import TaskModel

#: IPOPT's options for the search, over the solver config's: the search ends where a basin is told apart, not at
#: the polish's tolerance
SEARCH_IPOPT: dict[str, Any] = {"tol": 1e-3, "acceptable_tol": 1e-1, "acceptable_iter": 5}


def build_search(
    hand: Hand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings,
    config: SolverConfig,
    backend: str = "casadi",
) -> Solver:
    """The search's model, written, imported into the ``backend`` with the force problem's closed form added to
    its objective, and compiled for placement."""
    import casadi  # the solver stack, in the workers

    from grasptask.synthesis.backends import BACKENDS, write_nl_rows
    from grasptask.synthesis.force_problem import symbolic_quality
    from grasptask.synthesis.nlp import SEARCH_EQUATIONS, build_model

    held = held_axis(obj, task, config.hold_axis_rotation)
    nlp = build_model(
        hand, obj, task, settings, config.search_bounds, config.regularisation, None, held, SEARCH_EQUATIONS
    )
    text, order, rows = write_nl_rows(nlp.model)
    nlp.compile()
    where = nlp.columns(order)
    joints = [f.n_joints for f in nlp.hand.fingers.values()]

    def quality(x: Any) -> Any:
        contacts = casadi.vertcat(
            *[casadi.horzcat(*[x[where["p"][j, i]] for i in range(3)]) for j in range(len(joints))]
        )
        jacobians = [
            casadi.vertcat(*[casadi.horzcat(*[x[where["J"][j, k, i]] for i in range(3)]) for k in range(n)])
            for j, n in enumerate(joints)
        ]
        return symbolic_quality(contacts, jacobians, task, config.force_slack_weight)

    options = {**config.ipopt, **SEARCH_IPOPT, "max_iter": config.search_iterations}
    solver = BACKENDS[backend](text, options, nlp.surrogate_spec(order, rows), quality)
    return Solver(nlp, order, solver, nlp.limit_positions(order, rows), nlp.held_positions(order))


@dataclass(frozen=True)
class EndGrasp:
    """The grasp where a search converged: palm pose, joints, contacts, outward normals, eq. 4's weights."""

    palm_rotation: np.ndarray
    palm_position: np.ndarray
    joint_angles: np.ndarray
    contacts: np.ndarray
    normals: np.ndarray
    phi: np.ndarray


@dataclass(frozen=True)
class SearchEnd:
    """Where a start's search ended: IPOPT's status, iterations and seconds over its attempts (one per posture
    until one converges); where it converged, the grasp there and the force problem's solution at it."""

    start_id: int
    status: str
    iterations: int
    seconds: float
    attempts: int
    message: str
    grasp: EndGrasp | None = None
    forces: ForceSolution | None = None
    #: the search model's point, which the polish carries into the paper's model by variable name
    x: np.ndarray | None = None

    @property
    def converged(self) -> bool:
        return self.grasp is not None and self.forces is not None


def end_point(search: Solver, x: np.ndarray) -> EndGrasp:
    """The grasp at the search's point ``x``."""
    assign(search.order, x)
    read = search.nlp.read()
    phi = np.array([v.value for v in search.nlp.model.phi.values()], dtype=float)
    names = ("palm_rotation", "palm_position", "joint_angles", "contacts", "normals")
    return EndGrasp(**{name: read[name] for name in names}, phi=phi)


@dataclass(frozen=True)
class SearchTask:
    """A worker's job: search from ``start``."""

    start: Start

    @property
    def start_id(self) -> int:
        return self.start.start_id

    @property
    def orientation(self) -> int:
        return self.start.orientation

    @property
    def position_name(self) -> str:
        return self.start.position_name
