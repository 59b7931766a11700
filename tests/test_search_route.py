"""Search, then polish (SPEC section 12): the force problem on its own, the basins, the polish's start (the route's
sweeps: test_search_sweeps.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import Capability
from grasptask.synthesis.basins import EndPoint, group, joins
from grasptask.synthesis.clustering import THRESHOLD
from grasptask.synthesis.force_problem import ForceProblem, GraspGeometry
from grasptask.task.ellipsoid import Ellipsoid
from grasptask.task.task_model import TaskModel

ROOT = Path(__file__).resolve().parents[1]
RHO = 1e7


def _task() -> TaskModel:
    """A task whose ellipsoid is long along fz and short in torque, as drawing's is."""
    rng = np.random.default_rng(3)
    turn, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    lengths = np.array([1.5, 0.6, 0.4, 0.01, 0.008, 0.004])
    return TaskModel("t", 1, Ellipsoid.from_matrix(turn @ np.diag(lengths**2) @ turn.T))


def _cone(normal: np.ndarray, settings: GraspSettings) -> np.ndarray:
    """The linearised friction cone's unit edges about an inward ``normal`` (eq. 24)."""
    mu = settings.friction_scale * settings.friction_coefficient
    t1 = np.cross(normal, [0.3, 0.5, 0.8])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(normal, t1)
    angles = 2 * np.pi * np.arange(1, settings.cone_edges + 1) / settings.cone_edges
    edges = [normal + mu * (np.cos(a) * t1 + np.sin(a) * t2) for a in angles]
    return np.array(edges) / np.sqrt(1 + mu**2)


def _sphere_grasp(polar_deg: float, settings: GraspSettings, seed: int = 0) -> GraspGeometry:
    """Three contacts on a 3 cm sphere, 120 degrees apart about z, ``polar_deg`` from its top; each finger's
    Jacobian a fixed full-rank 3 x 3."""
    rng = np.random.default_rng(seed)
    polar = np.radians(polar_deg)
    contacts, edges = [], []
    for azimuth in np.radians([0.0, 120.0, 240.0]):
        outward = np.array([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])
        contacts.append(0.03 * outward)
        edges.append(_cone(-outward, settings))
    jacobians = tuple(0.05 * (np.eye(3) + 0.3 * rng.normal(size=(3, 3))) for _ in range(3))
    return GraspGeometry(np.array(contacts), np.array(edges), jacobians)


def _problem(settings: GraspSettings, effort: float = 5.0) -> ForceProblem:
    names = tuple(f"j{k}" for k in range(9))
    capability = Capability.motors(names, np.full(9, effort), np.eye(9))
    return ForceProblem(capability, (3, 3, 3), _task(), settings, RHO)


def _task_value(problem: ForceProblem, geometry: GraspGeometry) -> float:
    solution = problem.solve(geometry)
    return solution.Q + RHO * float(solution.weights @ (solution.slacks**2).sum(axis=1))


def test_the_force_problems_gradient_is_its_finite_differences():
    settings = GraspSettings()
    problem, geometry = _problem(settings), _sphere_grasp(75.0, settings)
    d_contacts, d_jacobians = problem.solve(geometry).gradient(geometry)
    step = 1e-6
    for j in range(3):
        for i in range(3):
            moved = [geometry.contacts.copy(), geometry.contacts.copy()]
            moved[0][j, i] += step
            moved[1][j, i] -= step
            values = [_task_value(problem, GraspGeometry(c, geometry.edges, geometry.jacobians)) for c in moved]
            assert (values[0] - values[1]) / (2 * step) == pytest.approx(d_contacts[j, i], rel=1e-4, abs=1e-9)
            for k in range(3):
                plus, minus = list(geometry.jacobians), list(geometry.jacobians)
                plus[j], minus[j] = plus[j].copy(), minus[j].copy()
                plus[j][k, i] += step
                minus[j][k, i] -= step
                values = [
                    _task_value(problem, GraspGeometry(geometry.contacts, geometry.edges, tuple(J)))
                    for J in (plus, minus)
                ]
                assert (values[0] - values[1]) / (2 * step) == pytest.approx(d_jacobians[j][k, i], rel=1e-4, abs=1e-9)


def test_the_search_objective_is_the_force_problems_task_part():
    """The closed form the batched search minimises equals the QP's eq. 8 part (Q and its penalised slack)."""
    from grasptask.synthesis.batch_geometry import TaskArrays, closed_form_q, jax_module

    jnp = jax_module().numpy
    settings = GraspSettings()
    problem, geometry = _problem(settings), _sphere_grasp(80.0, settings, seed=1)
    jacobians = [jnp.asarray(J) for J in geometry.jacobians]
    axes = jnp.asarray(TaskArrays.of(problem.task, None).axes_matrix)
    closed = closed_form_q(jnp, jnp.asarray(geometry.contacts), jacobians, axes, RHO, floor=0.0)
    assert float(closed) == pytest.approx(_task_value(problem, geometry), rel=1e-8)


def test_a_grasp_that_cannot_close_gets_a_finite_value_that_falls_toward_closure():
    """Three contacts bunched on top of a sphere cannot push it up: eq. 10's slack takes the rest, and the value
    falls as the contacts spread toward the equator, where the grasp closes."""
    settings = GraspSettings()
    problem = _problem(settings)
    solutions = [problem.solve(_sphere_grasp(polar, settings)) for polar in (10.0, 25.0, 40.0, 55.0, 70.0, 90.0)]
    values = [s.value for s in solutions]
    assert np.isfinite(values).all()
    assert [s.closes for s in solutions] == [False] * 5 + [True]
    assert all(later < earlier for earlier, later in zip(values, values[1:], strict=False))
    # closed, the slacks are spent: the value is Q's
    assert values[-1] == pytest.approx(solutions[-1].Q, rel=0.01) and values[0] > 1e6 * values[-1]


def test_the_force_problem_refuses_a_geometry_that_is_not_finite():
    settings = GraspSettings()
    geometry = _sphere_grasp(60.0, settings)
    contacts = geometry.contacts.copy()
    contacts[1, 2] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        _problem(settings).solve(GraspGeometry(contacts, geometry.edges, geometry.jacobians))


def test_at_an_optimum_of_the_paper_nlp_the_force_problems_q_is_the_nlps(tasks):
    from grasptask.paths import DEFAULT_HAND
    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.starts import make_starts

    job = Job.from_files(
        str(DEFAULT_HAND), ROOT / "configs/objects/tool.yaml", tasks, "drawing", settings=GraspSettings()
    )
    context = SolverContext(job)
    row = context.solve(make_starts(context.obj.bounds(), 0)[3])
    assert row["status"] == "optimal" and row["verified"]
    # the model that solved it holds its point: contacts, cone edges and Jacobians as IPOPT left them
    solved = next(m.nlp for m in (context.models.first, context.models.whole) if m.nlp.read()["Q"] == row["Q"])
    solution = context.force_problem.solve(solved.geometry())
    assert solution.closes
    assert solution.Q == pytest.approx(row["Q"], abs=1e-6, rel=1e-4)


def _point(start_id: int, x: float, Q: float = 1.0, value: float | None = None) -> EndPoint:
    return EndPoint(start_id, np.array([x, 0.0, 0.0]), Q, Q if value is None else value)


def test_two_distinct_optima_whose_basins_lie_close_are_both_kept():
    """A chain of end points 0.8 thresholds apart spans two optima 1.6 thresholds apart: complete linkage
    never puts the chain's ends in one basin, as single or average linkage would."""
    step = 0.8 * THRESHOLD
    ends = [_point(0, 0.0), _point(1, step), _point(2, 2 * step), _point(3, 0.0, Q=1.2), _point(4, 0.1 * step)]
    basins = group(ends)
    together = {frozenset(e.start_id for e in b) for b in basins}
    assert not any({0, 2} <= members for members in together)
    # the same place but a Q 20% apart: another optimum
    assert not any({0, 3} <= members for members in together)
    assert any({0, 4} <= members for members in together)
    assert joins(_point(9, 0.2 * step), next(b for b in basins if any(e.start_id == 0 for e in b)))


def test_a_basin_polishes_its_best_end_point_first():
    ends = [_point(5, 0.0, value=3.0), _point(2, 0.1 * THRESHOLD, value=1.0), _point(7, 0.0, value=1.0)]
    (basin,) = group(ends)
    assert [e.start_id for e in basin] == [2, 7, 5]


def test_a_polish_starts_on_eq4_with_weights_within_their_bounds():
    """The polish's eq. 4 weights at a grasp that closes (the verifier's ball grasp): within their bounds,
    summing to 1, with a wrench sum far below the mean weights' (which IPOPT was started from before)."""
    import pyomo.environ as pyo

    from grasptask.hand import load_hand
    from grasptask.synthesis.nlp import build_model
    from tests.grasp_fixtures import ball_grasp, drawing_like_task

    grasp, ball = ball_grasp()
    settings = GraspSettings()
    nlp = build_model(load_hand(), ball, drawing_like_task(), settings)
    nlp.initialise(grasp.palm_rotation, grasp.palm_position, grasp.joint_angles)
    m = nlp.model
    phi = nlp.closure_weights()
    assert phi.sum() == pytest.approx(1.0, abs=1e-9)
    assert phi.min() >= settings.force_closure_min_weight - 1e-12 and phi.max() <= 1.0
    wrenches = np.array([[pyo.value(v) for v in (*m.l[j, e, :], *m.l_torque[j, e, :])] for j, e in m.phi]).T
    mean = np.full(len(phi), 1.0 / len(phi))
    assert np.linalg.norm(wrenches @ phi) < 1e-3 * np.linalg.norm(wrenches @ mean)
