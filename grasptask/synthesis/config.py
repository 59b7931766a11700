"""Solver settings (``configs/solver.yaml``), read and validated once: IPOPT's options, how a start is brought
to the object before IPOPT (placement, two-phase) and the NLP's search bounds on forces."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, reject_unknown


@dataclass(frozen=True)
class SearchBounds:
    """Bounds on the NLP's force variables that no grasp worth finding reaches. They are not part of the
    paper's model: without them IPOPT takes steps of 1e4 N through configurations where the contacts line up
    (G nearly singular) and spends hundreds of iterations in restoration coming back. ``None`` leaves a force
    unbounded, as in the paper."""

    task_force_n: float | None = 100.0  # |f_i| per component, for a unit task axis (eq. 8)
    edge_force_n: float | None = 50.0  # cone-edge magnitudes for the real task wrenches (eq. 10)


@dataclass(frozen=True)
class SolverConfig:
    ipopt: dict = field(default_factory=dict)
    #: a worker that has not reported this long after its start's time limit is taken as hung and replaced
    hang_grace_s: float = 30.0
    #: move the palm from its far-away start to the object, keeping its orientation, before IPOPT
    placement: bool = True
    #: solve without torque feasibility first, then the full NLP from there
    two_phase: bool = False
    bounds: SearchBounds = SearchBounds()

    @property
    def time_limit(self) -> float:
        """The longest a start's solves may take, by IPOPT's own wall-time limit."""
        return float(self.ipopt.get("max_wall_time", 60.0)) * (2 if self.two_phase else 1)


def _positive_or_none(value, path: Path, name: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or value <= 0:
        raise BadInputError(path, f"field '{name}' must be a positive number or null, got {value!r}")
    return float(value)


def load_solver_config(path: str | Path) -> SolverConfig:
    path = Path(path)
    data = load_yaml(path)
    reject_unknown(data, {"ipopt", "hang_grace_s", "placement", "two_phase", "search_bounds"}, path)
    ipopt = data.get("ipopt", {})
    if not isinstance(ipopt, dict):
        raise BadInputError(path, f"field 'ipopt' must be a mapping of IPOPT options, got {ipopt!r}")
    for flag in ("placement", "two_phase"):
        if not isinstance(data.get(flag, False), bool):
            raise BadInputError(path, f"field '{flag}' must be true or false, got {data[flag]!r}")
    bounds = data.get("search_bounds", {})
    if not isinstance(bounds, dict):
        raise BadInputError(path, f"field 'search_bounds' must be a mapping, got {bounds!r}")
    reject_unknown(bounds, {"task_force_n", "edge_force_n"}, path, "search_bounds.")
    defaults = SearchBounds()
    return SolverConfig(
        ipopt=dict(ipopt),
        hang_grace_s=_positive_or_none(data.get("hang_grace_s", 30.0), path, "hang_grace_s") or 30.0,
        placement=data.get("placement", True),
        two_phase=data.get("two_phase", False),
        bounds=SearchBounds(
            *(
                _positive_or_none(bounds.get(name, getattr(defaults, name)), path, f"search_bounds.{name}")
                for name in ("task_force_n", "edge_force_n")
            )
        ),
    )
