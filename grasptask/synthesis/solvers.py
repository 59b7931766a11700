"""A worker's models, built once: the NLP a start is solved with first, the whole NLP a torque rejection is
solved again with, and the geometric phase's NLP without eq. 10, each behind its own IPOPT backend, with the maps
that carry a point from one to another."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from grasptask.synthesis.feedback import Limits
from grasptask.synthesis.solver_config import SolverConfig
from grasptask.task.symmetry import axis_asymmetry

if TYPE_CHECKING:  # the solver stack loads in the workers, not where a Job is made
    from grasptask.grasp.grasp_settings import GraspSettings
    from grasptask.hand.hand_model import Hand
    from grasptask.objects.surface import ImplicitObject
    from grasptask.synthesis.backends import Backend, Bounds, SolveResult
    from grasptask.synthesis.nlp import GraspNLP
    from grasptask.task.task_model import TaskModel


@dataclass
class Solver:
    """One NLP and the IPOPT backend built for it, with the NL file's variable order, the positions of the
    limits that the verifier's feedback tightens and those of the held turn's reference (None: not held)."""

    nlp: GraspNLP
    order: list
    backend: Backend
    limit_positions: tuple[np.ndarray, np.ndarray]
    held_positions: tuple[np.ndarray, np.ndarray] | None = None

    def bounds(self, limits: Limits) -> Bounds:
        """The NLP's bounds with ``limits`` in place of the activation cap and the pads' angle bounds."""
        base = self.backend.nlp.bounds
        columns, rows = self.limit_positions
        ubx, lbg = base.ubx.copy(), base.lbg.copy()
        ubx[columns] = limits.activation_cap
        lbg[rows] = np.cos(np.radians(limits.pad_angle_deg))
        return replace(base, ubx=ubx, lbg=lbg)

    def solve(self, x0: np.ndarray, limits: Limits | None = None) -> SolveResult:
        """IPOPT from ``x0`` within ``limits`` (None: the model's own). A held turn is held at ``x0``'s palm
        pose: its reference variables are set to it and pinned there by their bounds."""
        bounds = self.backend.nlp.bounds if limits is None else self.bounds(limits)
        if self.held_positions is not None:
            reference, palm = self.held_positions
            x0 = x0.copy()
            x0[reference] = x0[palm]
            lbx, ubx = bounds.lbx.copy(), bounds.ubx.copy()
            lbx[reference] = ubx[reference] = x0[palm]
            bounds = replace(bounds, lbx=lbx, ubx=ubx)
        return self.backend.solve(x0, bounds)


def build_solver(
    hand: Hand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings,
    config: SolverConfig,
    backend: str = "casadi",
    torque_axes: int | None = None,
    max_iter: int | None = None,
) -> Solver:
    """The NLP written, imported into the ``backend`` and compiled for initialisation; ``max_iter`` caps IPOPT's
    iterations below the solver config's."""
    from grasptask.synthesis.backends import BACKENDS, write_nl_rows  # the solver stack: CasADi, Pyomo
    from grasptask.synthesis.nlp import build_model  # deferred: Pyomo, in the workers

    held = held_axis(obj, task, config.hold_axis_rotation)
    bounds, regularisation = config.search_bounds, config.regularisation
    nlp = build_model(hand, obj, task, settings, bounds, regularisation, torque_axes, held)
    text, order, rows = write_nl_rows(nlp.model)
    nlp.compile()  # now, so that its one-off cost is not counted in the first start's seconds
    options = config.ipopt if max_iter is None else {**config.ipopt, "max_iter": max_iter}
    solver = BACKENDS[backend](text, options, nlp.surrogate_spec(order, rows))
    return Solver(nlp, order, solver, nlp.limit_positions(order, rows), nlp.held_positions(order))


def held_axis(obj: ImplicitObject, task: TaskModel, tolerance: float | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The object's axis of revolution when the grasp's turn about it is to be held: the object has one and the
    task is at most ``tolerance`` asymmetric about it (None: never held)."""
    axis = obj.revolution_axis()
    if tolerance is None or axis is None or axis_asymmetry(task.weights, task.axes, *axis) > tolerance:
        return None
    return axis


@dataclass
class Models:
    """A worker's solvers. ``first`` is the whole NLP, or with the solver config's ``torque_axes`` the NLP with
    eq. 10 for the task's longest axes only, whose iterations cost less; ``geometric`` (None: no phase) is the
    NLP without eq. 10 whose iterations a start begins with. ``size`` is the first model's variable and
    constraint count."""

    first: Solver
    whole: Solver
    geometric: Solver | None
    #: where each of the whole model's variables is in the first model's order (-1: not there)
    carried: np.ndarray
    #: where each of the geometric model's variables is in the first model's order
    geometric_positions: np.ndarray | None
    #: the whole model's starting point where the first model has no variable
    whole_initial: np.ndarray
    size: dict

    def in_whole(self, x: np.ndarray) -> np.ndarray:
        """The first model's point as a starting point of the whole model: the shared variables carried over,
        the other axes' eq. 10 forces and activations at their initial values."""
        x0 = self.whole_initial.copy()
        known = self.carried >= 0
        x0[known] = x[self.carried[known]]
        return x0


def build_models(
    hand: Hand, obj: ImplicitObject, task: TaskModel, settings: GraspSettings, config: SolverConfig, backend: str
) -> Models:
    parts = (hand, obj, task, settings, config, backend)
    whole = build_solver(*parts)
    axes = config.torque_axes
    first = build_solver(*parts, axes) if axes is not None and axes < len(task.weights) else whole
    # formula objects only: on meshes the phase lost verified starts and added a third surrogate-laden build
    held = first.held_positions is not None
    warmup = config.phase_iterations(held) if first.nlp.surrogate is None else 0
    geometric = build_solver(*parts, 0, warmup) if warmup else None
    # eq. 10's initial forces and activations for the other axes, which depend on no pose
    whole.nlp.initialise_forces()
    return Models(
        first=first,
        whole=whole,
        geometric=geometric,
        carried=positions(first, whole),
        geometric_positions=None if geometric is None else positions(first, geometric),
        whole_initial=values(whole.order),
        size={**first.nlp.size(), "geometric_iterations": warmup},
    )


def positions(source: Solver, target: Solver) -> np.ndarray:
    """Where each of ``target``'s variables is in ``source``'s order (-1: ``source`` has no such variable)."""
    position = {v.name: k for k, v in enumerate(source.order)}
    return np.array([position.get(v.name, -1) for v in target.order], dtype=int)


def values(order: list) -> np.ndarray:
    """The current values of the variables in ``order`` (0 where unset)."""
    return np.array([v.value if v.value is not None else 0.0 for v in order], dtype=float)


def assign(order: list, x: np.ndarray) -> None:
    for var, value in zip(order, x, strict=True):
        var.set_value(float(value), skip_validation=True)
