"""Solver settings (``configs/solver.yaml``), read and validated once: IPOPT's options, whether a start is
placed at the object before IPOPT, how a rejected start is solved again (other postures, the verifier's
feedback), the NLP's search bounds on forces and the small regularising weights on the variables its objective
does not see."""

from __future__ import annotations

from dataclasses import field
from math import inf
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, Field, Strict, field_validator
from pydantic.dataclasses import dataclass

from grasptask.io.config_schema import SCHEMA, Flag, Fraction, NonNegative, Positive, load_yaml, validated

#: IPOPT's options (passed as ipopt.<name> through CasADi, or straight to cyipopt); a config's own are set over
#: these. Why each is set so: docs/design/synthesis.md
IPOPT_DEFAULTS: dict[str, int | float | str] = {
    "obj_scaling_factor": 100.0,  # Q is only 0.002-0.015
    "tol": 1.0e-4,  # on the scaled NLP: the same 1e-6 of unscaled dual infeasibility
    "acceptable_tol": 1.0e-2,
    "constr_viol_tol": 1.0e-6,  # feasibility and complementarity asked of the unscaled NLP directly
    "compl_inf_tol": 1.0e-6,
    "acceptable_iter": 10,
    "acceptable_constr_viol_tol": 1.0e-6,  # an 'acceptable' exit must still be feasible
    "max_iter": 1500,  # a solve stops on its iterations, never on the clock: the same rows on a busy machine
    "max_resto_iter": 250,  # a solve the restoration phase cannot bring back stops there, and its start retries
    "mu_strategy": "adaptive",
    "alpha_for_y": "min-dual-infeas",  # the equality multipliers' step minimises the dual infeasibility
    "nlp_scaling_method": "gradient-based",
    "mumps_permuting_scaling": 0,  # MUMPS's weighted-matching permutation made some factorizations 10-50x slower
    "mumps_pivot_order": 5,  # METIS
    "print_level": 0,
    "sb": "yes",  # no IPOPT banner
}


def _ipopt_value(value: Any) -> Any:
    if isinstance(value, bool) or not isinstance(value, int | float | str) or value != value or value in (inf, -inf):
        raise ValueError("must be a finite number or a word")
    return value


#: an IPOPT option's value: a finite number or a word, never true/false (IPOPT itself checks the option)
IpoptValue = Annotated[Any, AfterValidator(_ipopt_value)]

#: the most IPOPT iterations one solve may be given: a start's solves stop on their iterations, so this bounds
#: its time (an iteration takes 5-60 ms); the default is 1500
MAX_ITERATIONS = 10_000
#: IPOPT's clock limits, refused: where a solve stops would depend on how busy the machine is
_CLOCK_OPTIONS = {"max_wall_time": "the wall clock", "max_cpu_time": "the CPU time"}
#: a count of solves per start (retry postures, feedback rounds) above this is no real run's
MAX_ROUNDS = 10
#: a cap on IPOPT iterations
Iterations = Annotated[int, Strict(), Field(ge=0, le=MAX_ITERATIONS)]


@dataclass(frozen=True, config=SCHEMA)
class SearchBounds:
    """Bounds on the NLP's force variables that no grasp worth finding reaches; not part of the paper's model.
    Without them IPOPT stepped through configurations where the contacts line up (G nearly singular) with
    forces of 1e4 N. ``None`` leaves a force unbounded, as in the paper."""

    task_force_n: Positive | None = 100.0  # |f_i| per component, for a unit task axis (eq. 8)
    edge_force_n: Positive | None = 50.0  # cone-edge magnitudes for the real task wrenches (eq. 10)


@dataclass(frozen=True, config=SCHEMA)
class Regularisation:
    """Weights of small quadratic terms added to eq. 12 for the variables Q does not depend on: eq. 4's
    force-closure weights phi (about their mean), eq. 10's cone-edge magnitudes and its tendon activations, and a
    two-contact grasp's turn about its contacts' line.

    Those variables only have to be feasible, so without these terms every optimum lies on a manifold of them
    along which the Lagrangian is flat, and IPOPT crept along it. The terms make each optimum isolated. Q as
    reported is eq. 12 alone, and zeros give the paper's objective exactly."""

    closure_weight: NonNegative = 1e-5  # on sum (phi - 1/n)^2
    edge_force: NonNegative = 1e-7  # on sum lambda^2 (N^2)
    activation: NonNegative = 1e-6  # on sum a^2
    #: on the squared turn (rad^2) of a two-contact grasp (a gripper's) about the line joining its contacts, from
    #: its start's: a turn that moves neither contact, so that neither Q nor any force sees it
    pair_turn: NonNegative = 1e-3
    #: on sum |f_i|^2 (N^2) of eq. 8's task forces at fingers of fewer than three turning joints (a jaw's), which
    #: Q sees in part only, and on the soft contacts' task twists
    task_force: NonNegative = 1e-6


@dataclass(frozen=True, config=SCHEMA)
class BatchSearchConfig:
    """The search of route search (SPEC section 12, :mod:`grasptask.synthesis.batch_search`): the starts of a
    batch moved together by Adam, then damped Newton steps, on the palm pose and the joints, for a fixed budget
    of iterations."""

    #: Adam's steps for every start of a batch; the rows depend on it, not on the machine
    iterations: Annotated[int, Strict(), Field(ge=1, le=MAX_ITERATIONS)] = 600
    #: starts searched as one batch (one compiled evaluation); a round's starts make batches of this many, in
    #: start order, whatever the workers: the rows depend on it, not on them. Half a round: a round's two
    #: batches go to two workers
    batch_size: Annotated[int, Strict(), Field(ge=1, le=1008)] = 21
    #: the contacts are held this far off the surface at first (m) ...
    standoff_m: Annotated[float, Strict(), Field(ge=0, le=0.05)] = 0.01
    #: ... falling to 0 at this share of the iterations (BODex's schedule: the fingers close from outside)
    standoff_until: Annotated[float, Strict(), Field(gt=0, le=1)] = 0.6
    #: eq. 12's Q enters the objective after this share of the iterations, once the pads are near the surface
    quality_after: Fraction = 0.3
    #: Adam's step sizes at first (they decay to a tenth): the palm's position (m), its turn and the joints (rad)
    step_position_m: Annotated[float, Strict(), Field(gt=0, le=0.05)] = 0.005
    step_turn_rad: Annotated[float, Strict(), Field(gt=0, le=0.5)] = 0.06
    step_joint_rad: Annotated[float, Strict(), Field(gt=0, le=0.5)] = 0.06
    #: the weight of the pads' facing penalty against the contacts' distance
    facing_weight: NonNegative = 1.0
    #: rho of eq. 8's closed form (the slack on G f = u_i): the search's, milder than the force problem's
    rho: Positive = 1.0e3
    #: damped Newton steps after Adam's, on the whole objective at no stand-off: they bring each end point to a
    #: local minimum, where two starts of one basin meet and the polish has little left to do
    newton_iterations: Annotated[int, Strict(), Field(ge=0, le=MAX_ITERATIONS)] = 100
    #: eqs. 10 and 4 in the search: the weight of their squared residuals (eq. 10's wrench rows relative to the
    #: wrench, its torque rows in shares of the hand's full strength, each in units of ``strength_unit``); 0
    #: leaves them to the polish
    strength_weight: NonNegative = 1.0
    strength_unit: Annotated[float, Strict(), Field(gt=0, le=1)] = 0.25
    #: projected-gradient steps on eq. 10's forces after each step of the search
    strength_steps: Annotated[int, Strict(), Field(ge=1, le=1000)] = 20
    #: a hand with more collision spheres than this (its grasping fingers' and palm's) is polished with only the
    #: spheres within ``polish_sphere_distance_m`` of the object where its search ended: each sphere is a
    #: constraint of the NLP. The verifier still checks them all
    polish_all_spheres_max: Annotated[int, Strict(), Field(ge=0)] = 500
    #: ... and how near the object (m) a sphere must be where the search ended to be one of a polish's constraints
    polish_sphere_distance_m: Annotated[float, Strict(), Field(gt=0, le=0.2)] = 0.015


@dataclass(frozen=True, config=SCHEMA)
class SolverConfig:
    """How each start is solved (``--solver-config``): the schema of the solver config file, every key's
    default and check declared here once. The paper's model is ``retry_postures=()``, ``feedback_rounds=0``,
    ``torque_axes=None``, ``hold_axis_rotation=None`` and ``geometric_iterations=0``."""

    #: IPOPT's options (tol, max_iter per solve, ...); a file's own are set over these. Options that would write
    #: files, or stop a solve on the clock (max_wall_time, max_cpu_time), are refused
    ipopt: dict[str, IpoptValue] = field(default_factory=lambda: dict(IPOPT_DEFAULTS))
    #: seconds of wall clock after which a start not yet reported is taken as hung, and its worker replaced: a
    #: guard against a hung process, far above any solve (a start's solves stop on their iterations)
    hang_after_s: Annotated[float, Strict(), Field(ge=60)] = 1800.0
    #: move the palm from its far-away start to the object, keeping its orientation, before IPOPT
    placement: Flag = True
    #: bounds on eq. 8's task forces and eq. 10's cone-edge forces (N) that no grasp worth finding reaches; null:
    #: unbounded, as the paper
    search_bounds: SearchBounds = field(default_factory=SearchBounds)
    #: small quadratic terms on the variables Q does not see, so that each optimum is isolated; Q as reported is
    #: eq. 12 alone
    regularisation: Regularisation = field(default_factory=Regularisation)
    #: the posture a start's first attempt is placed and solved from: each joint this fraction of its range from
    #: its lower limit (0.5: the paper's mid-range joints)
    first_posture: Fraction = 0.5
    #: a start the verifier rejects is placed and solved again from each of these postures in turn (a hand opened
    #: a quarter, then nearly open), until one is verified; []: each start solved once
    retry_postures: Annotated[tuple[Fraction, ...], Field(max_length=MAX_ROUNDS)] = (0.25, 0.1)
    #: a solved grasp the verifier rejects only on the torque check or the pad angle is solved again from itself
    #: with those limits tightened by what the verifier measured, up to this many times (synthesis.feedback)
    feedback_rounds: Annotated[int, Strict(), Field(ge=0, le=MAX_ROUNDS)] = 2
    #: eq. 10 in the NLP for the task's this many longest axes; a grasp the verifier (which checks all six)
    #: rejects on its torque check is solved again with all six; null: the paper's model
    torque_axes: Annotated[int, Strict(), Field(ge=1, le=6)] | None = 4
    #: on an object with an axis of revolution, the grasp's turn about it is held at the start's when the task is
    #: at most this asymmetric about it (the most Q can change along the turn); null: free
    hold_axis_rotation: NonNegative | None = 0.1
    #: a start's first IPOPT iterations, up to this many, are made on the model without eq. 10, whose iterations
    #: cost half as much; the first model goes on from where they stop (0: none). Formula objects only
    geometric_iterations: Iterations = 20
    #: that cap instead where the turn about the object's axis is held; null: the same cap
    held_geometric_iterations: Iterations | None = 30
    #: rho, the weight of the force problem's penalised slacks (rho |s|^2 on G f = u_i, and on eq. 10's wrench
    #: rows): large enough that a grasp that closes has s ~ 0 and Q the NLP's, finite where it cannot close
    force_slack_weight: Positive = 1.0e7
    #: route search: the batched search's budget, schedule and steps
    search: BatchSearchConfig = field(default_factory=lambda: BatchSearchConfig())
    #: route search: starts searched in rounds of this many, each round's basins polished before the next round;
    #: the rows depend on it, not on the workers
    search_round: Annotated[int, Strict(), Field(ge=1, le=1000)] = 42
    #: route search: a basin's end points polished, best first, until one is verified
    polish_per_basin: Annotated[int, Strict(), Field(ge=1, le=MAX_ROUNDS)] = 2

    @field_validator("ipopt", mode="before")
    @classmethod
    def _over_the_defaults(cls, value: object) -> object:
        if not isinstance(value, dict):
            return value
        for name, clock in _CLOCK_OPTIONS.items():
            if name in value:
                raise ValueError(
                    f"{name} would stop a solve on {clock}, which gives other grasps on a busy machine; bound it "
                    f"with max_iter (at most {MAX_ITERATIONS})"
                )
        iterations = value.get("max_iter", IPOPT_DEFAULTS["max_iter"])
        if isinstance(iterations, int) and not isinstance(iterations, bool) and not 1 <= iterations <= MAX_ITERATIONS:
            raise ValueError(f"max_iter must be from 1 to {MAX_ITERATIONS}, got {iterations}")
        return {**IPOPT_DEFAULTS, **value}

    @property
    def postures(self) -> tuple[float, ...]:
        """The postures a start's attempts begin from, in order. A retry posture equal to an earlier one would
        only repeat its attempt (IPOPT is deterministic), so it is left out."""
        return tuple(dict.fromkeys((self.first_posture, *self.retry_postures)))

    def phase_iterations(self, held: bool) -> int:
        """The geometric phase's cap for a start whose turn about the object's axis is ``held`` or free."""
        if held and self.held_geometric_iterations is not None:
            return self.held_geometric_iterations
        return self.geometric_iterations


def load_solver_config(path: str | Path) -> SolverConfig:
    """The solver config file at ``path``: only the keys it sets differ from :class:`SolverConfig`'s defaults."""
    return validated(SolverConfig, load_yaml(path), path)
