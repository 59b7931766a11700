"""Solver settings (``configs/solver.yaml``), read and validated once: IPOPT's options, whether a start is
placed at the object before IPOPT, how a rejected start is solved again (other postures, the verifier's
feedback), the NLP's search bounds on forces and the small regularising weights on the variables its objective
does not see."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, reject_unknown


@dataclass(frozen=True)
class SearchBounds:
    """Bounds on the NLP's force variables that no grasp worth finding reaches; not part of the paper's model.
    Without them IPOPT stepped through configurations where the contacts line up (G nearly singular) with
    forces of 1e4 N. ``None`` leaves a force unbounded, as in the paper."""

    task_force_n: float | None = 100.0  # |f_i| per component, for a unit task axis (eq. 8)
    edge_force_n: float | None = 50.0  # cone-edge magnitudes for the real task wrenches (eq. 10)


@dataclass(frozen=True)
class Regularisation:
    """Weights of small quadratic terms added to eq. 12 for the variables Q does not depend on: eq. 4's
    force-closure weights phi (about their mean), eq. 10's cone-edge magnitudes and its tendon activations.

    Those variables only have to be feasible, so without these terms every optimum lies on a manifold of them
    along which the Lagrangian is flat, and IPOPT crept along it. The terms make each optimum isolated. Q as
    reported is eq. 12 alone, and zeros give the paper's objective exactly (docs/synthesis-notes.md)."""

    closure_weight: float = 1e-5  # on sum (phi - 1/n)^2
    edge_force: float = 1e-7  # on sum lambda^2 (N^2)
    activation: float = 1e-6  # on sum a^2


@dataclass(frozen=True)
class SolverConfig:
    ipopt: dict = field(default_factory=dict)
    #: a worker that has not reported this long after its start's time limit is taken as hung and replaced
    hang_grace_s: float = 30.0
    #: move the palm from its far-away start to the object, keeping its orientation, before IPOPT
    placement: bool = True
    bounds: SearchBounds = SearchBounds()
    regularisation: Regularisation = Regularisation()
    #: the posture a start's first attempt is placed and solved from: each joint this fraction of its range from
    #: its lower limit (0.5: the start's own mid-range joints)
    first_posture: float = 0.5
    #: a start the verifier rejects is solved again from each of these postures in turn, until one is verified;
    #: () solves each start once
    retry_postures: tuple[float, ...] = ()
    #: a solved grasp the verifier rejects only on the torque check or the pad angle is solved again from itself
    #: with those limits tightened by what the verifier measured, up to this many times (synthesis.feedback)
    feedback_rounds: int = 0
    #: eq. 10 in the NLP for the task's this many longest axes (None: all six); a grasp the verifier then rejects
    #: on its torque check is solved again from itself with all six (grasptask.synthesis.context)
    torque_axes: int | None = None
    #: on an object of revolution, the grasp's turn about its axis is held at each start's when the task is at
    #: most this asymmetric about it: the most Q can change along the turn, relative
    #: (grasptask.task.symmetry.axis_asymmetry); None leaves the turn free, as the paper does
    hold_axis_rotation: float | None = None
    #: a start's first IPOPT iterations, up to this many, are made on the model without eq. 10, whose iterations
    #: cost half as much; the first model goes on from where they stop (0: none, the paper's single model).
    #: Formula objects only: meshes and point clouds skip it (grasptask.synthesis.context)
    geometric_iterations: int = 0
    #: the phase's cap instead when the grasp's turn about the object's axis is held (None: the same cap). The
    #: cap keeps the phase from creeping along that turn; held, it can run on, and more starts reach the lower
    #: optima (docs/synthesis-notes.md, "A longer phase where the turn is held")
    held_geometric_iterations: int | None = None
    #: on every attempt but the last, IPOPT's iteration cap for the first model: an attempt not converged by then
    #: goes on to the next posture instead of running on to max_iter. Cutting's first attempts that end locally
    #: infeasible take 150-360 iterations, most verified ones under 100 (None: every attempt runs to max_iter)
    retry_after_iterations: int | None = None

    @property
    def time_limit(self) -> float:
        """The longest one solve may take, by IPOPT's own wall-time limit."""
        return float(self.ipopt.get("max_wall_time", 60.0))

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

    @property
    def start_time_limit(self) -> float:
        """The longest a start may take: every attempt, its solve with all axes and every feedback round at its
        time limit."""
        phase = max(self.phase_iterations(held=False), self.phase_iterations(held=True)) > 0
        per_attempt = 1 + self.feedback_rounds + (self.torque_axes is not None) + phase
        return self.time_limit * len(self.postures) * per_attempt


def _positive_or_none(value, path: Path, name: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or value <= 0:
        raise BadInputError(path, f"field '{name}' must be a positive number or null, got {value!r}")
    return float(value)


def _is_non_negative(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and value >= 0


def _non_negative(value, path: Path, name: str) -> float:
    if not _is_non_negative(value):
        raise BadInputError(path, f"field '{name}' must be a number >= 0, got {value!r}")
    return float(value)


def _non_negative_or_none(value, path: Path, name: str) -> float | None:
    if value is None:
        return None
    if not _is_non_negative(value):
        raise BadInputError(path, f"field '{name}' must be a number >= 0 or null, got {value!r}")
    return float(value)


def _is_count(value, least: int = 0) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= least


def _count(value, path: Path, name: str) -> int:
    if not _is_count(value):
        raise BadInputError(path, f"field '{name}' must be a whole number >= 0, got {value!r}")
    return value


def _count_or_none(value, path: Path, name: str, least: int = 0) -> int | None:
    if value is not None and not _is_count(value, least):
        raise BadInputError(path, f"field '{name}' must be a whole number >= {least} or null, got {value!r}")
    return value


def _axes(value, path: Path) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 6:
        raise BadInputError(path, f"field 'torque_axes' must be a whole number from 1 to 6 or null, got {value!r}")
    return value


def _is_fraction(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and 0 <= value <= 1


def _fraction(value, path: Path, name: str) -> float:
    if not _is_fraction(value):
        raise BadInputError(path, f"field '{name}' must be a number in [0, 1], got {value!r}")
    return float(value)


def _fractions(value, path: Path, name: str) -> tuple[float, ...]:
    if not isinstance(value, list) or not all(_is_fraction(v) for v in value):
        raise BadInputError(path, f"field '{name}' must be a list of numbers in [0, 1], got {value!r}")
    return tuple(float(v) for v in value)


def _section(data: dict, name: str, fields: tuple[str, ...], path: Path) -> dict:
    section = data.get(name, {})
    if not isinstance(section, dict):
        raise BadInputError(path, f"field '{name}' must be a mapping, got {section!r}")
    reject_unknown(section, set(fields), path, f"{name}.")
    return section


def load_solver_config(path: str | Path) -> SolverConfig:
    path = Path(path)
    data = load_yaml(path)
    known = {
        "ipopt",
        "hang_grace_s",
        "placement",
        "first_posture",
        "retry_postures",
        "feedback_rounds",
        "torque_axes",
        "hold_axis_rotation",
        "geometric_iterations",
        "held_geometric_iterations",
        "retry_after_iterations",
        "search_bounds",
        "regularisation",
    }
    reject_unknown(data, known, path)
    ipopt = data.get("ipopt", {})
    if not isinstance(ipopt, dict):
        raise BadInputError(path, f"field 'ipopt' must be a mapping of IPOPT options, got {ipopt!r}")
    if not isinstance(data.get("placement", True), bool):
        raise BadInputError(path, f"field 'placement' must be true or false, got {data['placement']!r}")
    bound_names, weight_names = ("task_force_n", "edge_force_n"), ("closure_weight", "edge_force", "activation")
    bounds = _section(data, "search_bounds", bound_names, path)
    weights = _section(data, "regularisation", weight_names, path)
    defaults, default_weights = SearchBounds(), Regularisation()
    return SolverConfig(
        ipopt=dict(ipopt),
        hang_grace_s=_positive_or_none(data.get("hang_grace_s", 30.0), path, "hang_grace_s") or 30.0,
        placement=data.get("placement", True),
        first_posture=_fraction(data.get("first_posture", 0.5), path, "first_posture"),
        retry_postures=_fractions(data.get("retry_postures", []), path, "retry_postures"),
        feedback_rounds=_count(data.get("feedback_rounds", 0), path, "feedback_rounds"),
        torque_axes=_axes(data.get("torque_axes"), path),
        hold_axis_rotation=_non_negative_or_none(data.get("hold_axis_rotation"), path, "hold_axis_rotation"),
        geometric_iterations=_count(data.get("geometric_iterations", 0), path, "geometric_iterations"),
        held_geometric_iterations=_count_or_none(
            data.get("held_geometric_iterations"), path, "held_geometric_iterations"
        ),
        retry_after_iterations=_count_or_none(
            data.get("retry_after_iterations"), path, "retry_after_iterations", least=1
        ),
        bounds=SearchBounds(
            *(
                _positive_or_none(bounds.get(name, getattr(defaults, name)), path, f"search_bounds.{name}")
                for name in bound_names
            )
        ),
        regularisation=Regularisation(
            *(
                _non_negative(weights.get(name, getattr(default_weights, name)), path, f"regularisation.{name}")
                for name in weight_names
            )
        ),
    )
