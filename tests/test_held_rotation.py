"""The grasp's turn about an object's axis of revolution, held when the task is nearly symmetric about it: the
bound on how much Q can change along that turn, which objects have such an axis, and the held row in the NLP."""

from types import SimpleNamespace

import numpy as np
import pyomo.environ as pyo
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.objects import load_object
from grasptask.objects.superquadric import Superquadric
from grasptask.objects.surface import ImplicitObject
from grasptask.synthesis.backends import Bounds
from grasptask.synthesis.solvers import Solver, held_axis
from grasptask.task.frames import wrench_transform
from grasptask.task.symmetry import axis_asymmetry
from tests.grasp_fixtures import unhurried_solver

Z = np.array([0.0, 0.0, 1.0])


def _turned(s: np.ndarray, axis: np.ndarray, psi: float) -> np.ndarray:
    b = wrench_transform(Rotation.from_rotvec(psi * axis / np.linalg.norm(axis)).as_matrix(), np.zeros(3))
    return b @ s @ b.T


def _task(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    axes = np.linalg.qr(rng.normal(size=(6, 6)))[0].T
    return rng.uniform(0.01, 1.0, 6), axes


def test_a_task_symmetric_about_the_axis_has_no_asymmetry():
    weights = np.array([0.2, 0.2, 0.6, 0.004, 0.004, 0.001])  # x and y alike, forces and torques
    assert axis_asymmetry(weights, np.eye(6), Z, np.zeros(3)) == pytest.approx(0, abs=1e-12)
    assert axis_asymmetry(weights, np.eye(6), np.array([1.0, 0, 0]), np.zeros(3)) > 0.5
    # about a parallel axis elsewhere, the task's forces make torques that are not symmetric
    assert axis_asymmetry(weights, np.eye(6), Z, np.array([0.05, 0, 0])) > 0.5


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), psi=st.floats(-np.pi, np.pi))
def test_q_along_the_turn_stays_within_the_bound(seed, psi):
    """For any grasp (any SPD K in Q = tr(K^-1 S)), Q after a turn differs from its mean over the turn by at most
    the asymmetry times that mean."""
    weights, axes = _task(seed)
    rng = np.random.default_rng(seed + 1)
    axis, point = rng.normal(size=3), rng.normal(scale=0.05, size=3)
    c = axis_asymmetry(weights, axes, axis, point)
    to_point = wrench_transform(np.eye(3), -point)
    s = to_point @ axes.T @ np.diag(weights) @ axes @ to_point.T
    m = rng.normal(size=(6, 6))
    k_inv = np.linalg.inv(m @ m.T + 0.1 * np.eye(6))
    mean = np.trace(k_inv @ np.mean([_turned(s, axis, a) for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)], 0))
    assert abs(np.trace(k_inv @ _turned(s, axis, psi)) - mean) <= c * mean * (1 + 1e-9) + 1e-12


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rotvec=st.lists(st.floats(-3, 3), min_size=3, max_size=3))
def test_asymmetry_is_invariant_when_task_and_axis_turn_together(seed, rotvec):
    weights, axes = _task(seed)
    rotation = Rotation.from_rotvec(rotvec).as_matrix()
    turned_axes = axes @ wrench_transform(rotation, np.zeros(3)).T
    before = axis_asymmetry(weights, axes, Z, np.zeros(3))
    assert axis_asymmetry(weights, turned_axes, rotation @ Z, np.zeros(3)) == pytest.approx(before, rel=1e-6)


def test_which_objects_have_an_axis_of_revolution():
    tool = load_object("configs/objects/tool.yaml")
    direction, point = tool.revolution_axis()
    np.testing.assert_allclose(direction, Z)
    np.testing.assert_allclose(point, 0)
    rotation = Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix()
    moved = Superquadric(rotation=rotation, position=np.array([0.1, 0.0, 0.2]))
    np.testing.assert_allclose(moved.revolution_axis()[0], rotation[:, 2])
    np.testing.assert_allclose(moved.revolution_axis()[1], [0.1, 0.0, 0.2])
    assert Superquadric(a=np.array([0.01, 0.02, 0.1])).revolution_axis() is None
    assert Superquadric(e2=0.5).revolution_axis() is None  # square cross-sections
    assert ImplicitObject().revolution_axis() is None  # meshes, clouds and GPs: sampled, never exact


def test_the_turn_is_held_for_nearly_symmetric_tasks_only(tasks):
    from grasptask.task.task_model import load_task_models

    models, tool = load_task_models(tasks), load_object("configs/objects/tool.yaml")
    assert held_axis(tool, models["drawing"], 0.1) is not None
    assert held_axis(tool, models["cutting"], 0.1) is None
    assert held_axis(tool, models["drawing"], None) is None
    assert held_axis(Superquadric(a=np.array([0.01, 0.02, 0.1])), models["drawing"], 0.1) is None


def test_each_solve_pins_the_reference_to_its_own_starting_palm_pose():
    n = 6
    captured = {}
    base = Bounds(np.full(n, -5.0), np.full(n, 5.0), np.zeros(1), np.zeros(1))

    def solve(x0, bounds):
        captured.update(x0=x0, bounds=bounds)

    backend = SimpleNamespace(nlp=SimpleNamespace(bounds=base), solve=solve)
    reference, palm = np.array([3, 4, 5]), np.array([0, 1, 2])
    solver = Solver(SimpleNamespace(), [], backend, (np.array([], int), np.array([], int)), (reference, palm))
    x0 = np.array([0.1, 0.2, 0.3, 9.0, 9.0, 9.0])
    solver.solve(x0)
    np.testing.assert_allclose(captured["x0"][reference], x0[palm])
    np.testing.assert_allclose(captured["bounds"].lbx[reference], x0[palm])
    np.testing.assert_allclose(captured["bounds"].ubx[reference], x0[palm])
    np.testing.assert_allclose(captured["bounds"].lbx[palm], -5.0)
    assert x0[3] == 9.0  # the caller's point is left alone


def test_a_held_start_solves_verifies_and_keeps_its_turn(tasks):
    """Drawing on the cylinder: the model has the held row, each solve holds the turn at its own starting pose
    (the row is zero at the solution, its reference the pose the solve started from) while the palm still moves,
    and the grasps verify."""
    from dataclasses import replace

    from grasptask.paths import DEFAULT_HAND
    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.starts import make_starts, subset

    solver = replace(unhurried_solver(), hold_axis_rotation=0.1)
    context = SolverContext(
        Job.from_files(
            str(DEFAULT_HAND),
            "configs/objects/tool.yaml",
            str(tasks),
            "drawing",
            solver=solver,
            settings=GraspSettings(),
        )
    )
    assert context.size["held_axis_rotation"]
    rows = [context.solve(start) for start in subset(make_starts(context.bounds), 12)[:3]]
    assert sum(row["verified"] for row in rows) >= 2, [(r["status"], r.get("verify_failures")) for r in rows]
    for solved in {id(s): s for s in (context.models.first, context.models.whole)}.values():
        m = solved.nlp.model
        assert pyo.value(m.held_axis_rotation.body) == pytest.approx(0, abs=1e-6)
    m = context.models.first.nlp.model
    moved = np.linalg.norm([pyo.value(m.d_h[i]) - pyo.value(m.held_reference[i]) for i in range(3)])
    assert moved > 1e-3  # the palm moved from where its solve started; only its turn about the axis is held
