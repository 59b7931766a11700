"""The search (SPEC section 12): a start's geometry moved by IPOPT on the model without the task forces.

The search's model is :func:`~grasptask.synthesis.nlp.search_equations`: palm pose, joints, contacts, normals,
cone edges, Jacobians and eq. 4's weights, with eqs. 3, 14 and 16-23 as constraints, none of eq. 8's task forces,
and eq. 10's rows for the solver config's ``search_torque_axes`` longest axes only, each kept by a slack that the
objective weighs as the force problem does (so that a start whose grasp cannot meet eq. 10 yet is not
infeasible). Its objective is the force problem's eq. 8 part in closed form
(:func:`~grasptask.synthesis.force_problem.symbolic_quality`), added where CasADi imports the model, so IPOPT has
its exact derivatives: the gradient the envelope theorem gives from the force problem's solution and multipliers.
An iteration's cost then does not grow with the task's wrench rows. Eq. 10 for the other axes is the force
problem's to judge at each end point, and the polish's (the paper's NLP) to meet.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.synthesis.solvers import Solver, assign
from grasptask.synthesis.starts import StartJob

if TYPE_CHECKING:
    from grasptask.synthesis.backends import Objective
    from grasptask.synthesis.force_problem import ForceSolution
    from grasptask.synthesis.nlp import GraspNLP
    from grasptask.task.task_model import TaskModel

#: IPOPT's options for the search, over the solver config's: the search ends where a basin is told apart, not at
#: the polish's tolerance
SEARCH_IPOPT: dict[str, Any] = {"tol": 1e-3, "acceptable_tol": 1e-1, "acceptable_iter": 5}


def search_objective(nlp: GraspNLP, order: list, task: TaskModel, rho: float) -> Objective:
    """The search's objective as CasADi sees the model: the force problem's eq. 8 part in closed form, of the
    contacts' and Jacobians' columns in the NL file's ``order``."""
    import casadi  # the solver stack, in the workers

    from grasptask.synthesis.force_problem import symbolic_quality

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
        return symbolic_quality(contacts, jacobians, task, rho)

    return quality


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
class SearchTask(StartJob):
    """A worker's job: search from ``start``."""
