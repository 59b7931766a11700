"""Before IPOPT: placing a start at the object, the solver settings it is read from, and derivatives of the
NLP's surface that stay finite where a cylinder's exponents meet zero."""

import math
import re

import numpy as np
import pyomo.environ as pyo
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyomo.core.expr.calculus.derivatives import Modes, differentiate

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import load_hand
from grasptask.objects import load_object
from grasptask.synthesis.nlp import build_model
from grasptask.synthesis.placement import ANCHOR_DEPTH_CELLS, Anchors, anchor_point, place
from grasptask.synthesis.solver_config import (
    IPOPT_DEFAULTS,
    Regularisation,
    SearchBounds,
    SolverConfig,
    load_solver_config,
)
from grasptask.synthesis.starts import SURFACE_FIRST_ID, SURFACE_TURNS, make_starts, surface_starts
from grasptask.synthesis.surfaces import surface_for
from grasptask.task.task_model import load_task_models

TOOL = "configs/objects/tool.yaml"


@pytest.fixture(scope="module")
def nlp(simulated):
    root, _, _ = simulated
    task = load_task_models(root / "tasks" / "task_models.json")["drawing"]
    return build_model(load_hand(), load_object(TOOL), task, GraspSettings())


def test_anchor_is_the_nearest_point_of_the_shrunken_box():
    bounds = np.array([[-0.01, -0.01, -0.1], [0.01, 0.01, 0.1]])
    np.testing.assert_allclose(anchor_point([0.2, 0.0, 0.0], bounds), [0.008, 0.0, 0.0])
    np.testing.assert_allclose(anchor_point([0.0, 0.0, 0.19], bounds), [0.0, 0.0, 0.08])
    np.testing.assert_allclose(anchor_point([0.001, -0.002, 0.03], bounds), [0.001, -0.002, 0.03])  # inside: kept


@settings(max_examples=12, deadline=None)
@given(st.integers(min_value=0, max_value=125))
def test_placed_start_keeps_its_orientation_and_starts_collision_free(nlp, start_id):
    obj = load_object(TOOL)
    start = make_starts(obj.bounds(), seed=0)[start_id]
    joints = nlp.hand.mid_range()
    backoff = place(nlp, start, Anchors(obj.bounds()), joints)
    state = nlp.read()
    np.testing.assert_allclose(state["palm_rotation"], start.palm_rotation, atol=1e-12)
    np.testing.assert_allclose(state["joint_angles"], np.clip(joints, nlp.hand.lower, nlp.hand.upper))
    assert 0.0 <= backoff <= 0.08 + 1e-12
    if backoff < 0.08:  # it stopped backing off because the hand was clear, not at the limit
        assert nlp.min_clearance() >= 0
    # the pads straddle the anchor: their centroid is the anchor, moved back along the palm-to-pads line
    anchor = anchor_point(start.palm_position, obj.bounds())
    offset = state["contacts"].mean(axis=0) - anchor
    assert np.linalg.norm(offset) == pytest.approx(backoff, abs=1e-9)


def test_placement_is_deterministic(nlp):
    obj = load_object(TOOL)
    start = make_starts(obj.bounds(), seed=0)[40]
    first = place(nlp, start, Anchors(obj.bounds()), nlp.hand.mid_range()), nlp.read()["palm_position"]
    second = place(nlp, start, Anchors(obj.bounds()), nlp.hand.mid_range()), nlp.read()["palm_position"]
    assert first[0] == second[0]
    np.testing.assert_array_equal(first[1], second[1])


def test_search_bounds_reach_the_force_variables(simulated):
    root, _, _ = simulated
    task = load_task_models(root / "tasks" / "task_models.json")["cutting"]
    model = build_model(load_hand(), load_object(TOOL), task, GraspSettings(), bounds=SearchBounds(80.0, None)).model
    assert all(v.lb == -80.0 and v.ub == 80.0 for v in model.force.values())
    assert all(v.lb == 0 and v.ub is None for v in model.lam.values())


def test_regularisation_leaves_q_as_eq_12_alone(simulated):
    """The objective IPOPT minimises is Q plus the small terms; the Q a solution reports is eq. 12's alone, and
    zero weights give eq. 12 exactly."""
    root, _, _ = simulated
    task = load_task_models(root / "tasks" / "task_models.json")["cutting"]
    start = make_starts(load_object(TOOL).bounds(), seed=0)[7]
    values = {}
    for name, weights in (("paper", Regularisation(0.0, 0.0, 0.0)), ("default", Regularisation())):
        nlp = build_model(load_hand(), load_object(TOOL), task, GraspSettings(), regularisation=weights)
        nlp.initialise(start.palm_rotation, start.palm_position, nlp.hand.mid_range())
        for a, j, i in nlp.model.force:
            nlp.model.force[a, j, i].set_value(0.1 * (i + 1))  # Q > 0
        values[name] = (pyo.value(nlp.model.eq12_Q), pyo.value(nlp.model.eq12_objective), nlp.read()["Q"])
    q, objective, reported = values["paper"]
    assert q > 0 and objective == q == reported
    q_default, objective_default, reported_default = values["default"]
    assert q_default == q == reported_default
    # phi, lambda and the activations start at 1/n, 0.1 and 0.2: the terms add their weighted squares
    n_lam, n_act = len(nlp.model.lam), len(nlp.model.act)
    extra = Regularisation().edge_force * 0.01 * n_lam + Regularisation().activation * 0.04 * n_act
    assert objective_default == pytest.approx(q + extra, rel=1e-12)


def test_cylinder_contact_has_finite_second_derivatives_on_its_axis_planes():
    """e2 = 1 makes an exponent of the superquadric 0; written as x ** 0 its derivative is NaN at x = 0."""
    surface = surface_for(load_object(TOOL))
    m = pyo.ConcreteModel()
    m.p = pyo.Var(range(3), initialize={0: 0.0, 1: 0.01, 2: 0.03})
    p = [m.p[i] for i in range(3)]
    for expression in (surface.contact(p), *surface.gradient(p)):
        for wrt in p:
            first = differentiate(expression, wrt=wrt, mode=Modes.reverse_symbolic)
            for second in differentiate(first, wrt_list=p, mode=Modes.reverse_numeric):
                assert math.isfinite(second)


@pytest.mark.parametrize(
    "text, message",
    [
        ("ipopt: {}\nplacment: true\n", "unknown field 'placment' (allowed: feedback_rounds, first_posture,"),
        ("placement: 1\n", "field 'placement': must be a valid boolean, got 1"),
        ("search_bounds: {task_force_n: -5}\n", "field 'search_bounds.task_force_n': must be greater than 0, got -5"),
        ("search_bounds: {edge: 5}\n", "unknown field 'search_bounds.edge' (allowed: edge_force_n, task_force_n)"),
        ("ipopt: [tol]\n", "field 'ipopt': must be a valid dictionary"),
        ("ipopt: {tol: .nan}\n", "field 'ipopt.tol': must be a finite number or a word, got nan"),
        ("ipopt: {print_level: true}\n", "field 'ipopt.print_level': must be a finite number or a word, got True"),
        ("regularisation: {activation: -1.0e-6}\n", "field 'regularisation.activation': must be greater than or equal"),
        ("retry_postures: [0.25, 1.5]\n", "field 'retry_postures[2]': must be less than or equal to 1, got 1.5"),
        ("retry_postures: 0.25\n", "field 'retry_postures': must be a valid tuple, got 0.25"),
        ("first_posture: 1.5\n", "field 'first_posture': must be less than or equal to 1, got 1.5"),
        ("first_posture: null\n", "field 'first_posture': must be a valid number, got None"),
        ("first_posture: .inf\n", "field 'first_posture': must be a finite number, got inf"),
        ("feedback_rounds: 1.5\n", "field 'feedback_rounds': must be a valid integer, got 1.5"),
        ("feedback_rounds: -1\n", "field 'feedback_rounds': must be greater than or equal to 0, got -1"),
        ("regularisation: {lam: 0.1}\n", "unknown field 'regularisation.lam'"),
        ("regularisation: 0\n", "field 'regularisation': must be a dictionary"),
        ("torque_axes: 0\n", "field 'torque_axes': must be greater than or equal to 1, got 0"),
        ("torque_axes: 2.5\n", "field 'torque_axes': must be a valid integer, got 2.5"),
        ("hold_axis_rotation: -0.1\n", "field 'hold_axis_rotation': must be greater than or equal to 0"),
        ("hold_axis_rotation: yes\n", "field 'hold_axis_rotation': must be a valid number, got True"),
        ("geometric_iterations: -5\n", "field 'geometric_iterations': must be greater than or equal to 0"),
        ("geometric_iterations: 2.5\n", "field 'geometric_iterations': must be a valid integer, got 2.5"),
        ("held_geometric_iterations: -1\n", "field 'held_geometric_iterations': must be greater than or equal to 0"),
        ("retry_after_iterations: 200\n", "unknown field 'retry_after_iterations'"),
    ],
)
def test_bad_solver_config_is_one_clear_line(tmp_path, text, message):
    path = tmp_path / "solver.yaml"
    path.write_text(text)
    with pytest.raises(BadInputError, match=re.escape(message)):
        load_solver_config(path)


def test_solver_config_defaults_and_bundled_files():
    bundled = load_solver_config("configs/solver.yaml")
    assert bundled.placement
    assert bundled.search_bounds == SearchBounds(100.0, 50.0)
    assert bundled.regularisation == Regularisation()
    # a solve stops on its iterations, never on the clock
    assert "max_wall_time" not in bundled.ipopt and "max_cpu_time" not in bundled.ipopt
    # the shipped file sets nothing: every value is the schema's one default
    assert bundled == SolverConfig() and bundled.ipopt == IPOPT_DEFAULTS
    fast = load_solver_config("tests/data/solver_fast.yaml")
    assert fast.placement and fast.hold_axis_rotation is None and fast.geometric_iterations == 0
    # a config's IPOPT options are set over the defaults, not in their place
    assert fast.ipopt == {**IPOPT_DEFAULTS, **fast.ipopt} and fast.ipopt["max_iter"] == 150
    assert bundled.hold_axis_rotation == 0.1 and bundled.geometric_iterations == 20
    assert bundled.phase_iterations(held=False) == 20 and bundled.phase_iterations(held=True) == 30
    free = SolverConfig(geometric_iterations=20, held_geometric_iterations=None)
    assert free.phase_iterations(held=True) == 20  # no held cap: the same one


def test_compiled_expressions_match_pyomo_for_every_operation():
    """The CasADi conversion of a Pyomo expression gives Pyomo's own value: sums (short and long), products,
    quotients, powers, negation, the unary functions, parameters, named expressions and defined variables."""
    from grasptask.synthesis.compiled import CompiledExpressions

    m = pyo.ConcreteModel()
    m.x = pyo.Var(range(3), initialize={0: 0.7, 1: -1.3, 2: 2.1})
    m.y = pyo.Var(initialize=0.0)
    m.k = pyo.Param(initialize=1.5, mutable=True)
    m.e = pyo.Expression(expr=pyo.cos(m.x[0]) * m.x[1] - m.x[2] / (1 + m.x[0] ** 2))
    long_sum = sum((m.x[i % 3] - 0.1 * i) ** 2 for i in range(12))
    definitions = [(m.y, m.e + pyo.sqrt(long_sum) + abs(m.x[1]) ** m.k)]
    extra = [-m.y * pyo.sin(m.x[2]) + pyo.exp(m.x[0]) - pyo.log(m.x[2]), -(m.x[0] * m.x[1]) + pyo.tan(m.x[0]), m.e]
    compiled = CompiledExpressions(list(m.x.values()), definitions, extra)
    expected_y = pyo.value(definitions[0][1])
    compiled.assign_defined(compiled.input_values())
    assert m.y.value == pytest.approx(expected_y, rel=1e-14)
    np.testing.assert_allclose(compiled.extra(compiled.input_values()), [pyo.value(e) for e in extra], rtol=1e-14)
    with pytest.raises(ValueError, match="neither an input"):
        CompiledExpressions([m.x[0]], [(m.y, m.x[1] + 1)])


@settings(max_examples=8, deadline=None)
@given(st.integers(min_value=0, max_value=125), st.floats(min_value=-0.05, max_value=0.05))
def test_min_clearance_is_the_smallest_eq14_margin(nlp, start_id, shift):
    """The compiled collision margins are eq. 14's constraint bodies, at any palm position."""
    obj = load_object(TOOL)
    start = make_starts(obj.bounds(), seed=0)[start_id]
    nlp.initialise(start.palm_rotation, start.palm_position + shift, nlp.hand.mid_range())
    margins = [pyo.value(c.body) - pyo.value(c.lower) for c in nlp.model.eq14_collision.values()]
    assert nlp.min_clearance() == pytest.approx(min(margins), abs=1e-13)


def test_anchors_on_a_mesh_lie_on_parts_its_surrogate_resolves():
    """The knife's bounding box is mostly blade, 1.2-3 mm thick: the box's anchors for the starts above and on
    the diagonal fall on it. On the mesh they move to the nearest point at least 1.5 grid cells inside, on the
    handle (z below 6 cm). Superquadrics keep the box's anchors."""
    knife = load_object("configs/objects/kitchen_knife.yaml")
    grid = knife.distance_grid
    anchors = Anchors(knife.bounds(), grid)
    depth = ANCHOR_DEPTH_CELLS * grid.spacing
    for start in make_starts(knife.bounds(), seed=0)[::7]:
        point = anchors(start.palm_position)
        assert point[2] < 0.06 and knife.signed_distance(point[None])[0] <= -depth + 1e-3
    tool = load_object(TOOL)
    start = make_starts(tool.bounds(), seed=0)[5]
    expected = anchor_point(start.palm_position, tool.bounds())
    np.testing.assert_array_equal(Anchors(tool.bounds())(start.palm_position), expected)


def test_surface_starts_spread_over_the_object_and_face_it():
    """Seeds spread by farthest-point sampling (no two closer than the farthest any surface point lies from its
    nearest seed), each turned SURFACE_TURNS ways about its inward normal, numbered after the paper's and the
    library's starts."""
    obj = load_object(TOOL)
    points, normals = obj.surface.points, obj.surface.normals
    starts = surface_starts(points, normals, 22)
    assert [s.start_id for s in starts] == list(range(SURFACE_FIRST_ID, SURFACE_FIRST_ID + 22))
    assert all(s.position_name == "surface" for s in starts)
    seeds = np.array([s.anchor for s in starts[::SURFACE_TURNS]])
    assert len(seeds) == 6
    apart = np.linalg.norm(seeds[:, None] - seeds[None], axis=2) + np.eye(len(seeds))
    covering = np.linalg.norm(points[:, None] - seeds[None], axis=2).min(axis=1).max()
    assert apart.min() >= covering > 0
    for start in starts:
        outward = obj.normal(start.anchor[None])[0]
        assert start.palm_rotation[:, 2] @ outward == pytest.approx(-1.0, abs=0.05)  # the palm faces the seed
        np.testing.assert_allclose(start.palm_rotation.T @ start.palm_rotation, np.eye(3), atol=1e-12)
    turns = [s.palm_rotation[:, 0] for s in starts[:SURFACE_TURNS]]
    assert all(a @ b < 0.99 for k, a in enumerate(turns) for b in turns[k + 1 :])  # four ways, none twice


def test_a_surface_start_is_placed_at_its_seed(nlp):
    """The pads' centroid goes to the seed, and the palm backs away from it along the approach."""
    obj = load_object(TOOL)
    joints = nlp.hand.mid_range()
    for start in surface_starts(obj.surface.points, obj.surface.normals, 8, turns=1):
        backoff = place(nlp, start, Anchors(obj.bounds()), joints)
        pads = nlp.read()["contacts"].mean(axis=0)
        assert np.linalg.norm(pads - start.anchor) <= backoff + 1e-9
