"""The search's batch evaluation (issue 88): contacts, normals and Jacobians as functions of the palm pose and the
joints alone, equal to the hand's own kinematics at the same pose; its gradient against finite differences; a
batch of one and of many giving the same end points; a start whose value is not finite a status of its own; eq. 10's
forces reaching the bounded least squares' residual that scipy finds, and eq. 4's weights the least wrench sum that
quadprog finds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from grasptask.grasp.grasp_settings import load_grasp_settings
from grasptask.hand import load_hand
from grasptask.hand.kinematics import forward
from grasptask.objects import load_object
from grasptask.synthesis.batch_geometry import (
    Field,
    HandArrays,
    StrengthArrays,
    closure_residual,
    closure_steps,
    contacts,
    fingers,
    jax_module,
    strength_matrix,
    strength_residuals,
    strength_steps,
)
from grasptask.synthesis.batch_search import BatchSearch
from grasptask.synthesis.solver_config import BatchSearchConfig
from grasptask.task.task_model import load_task_models

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "configs" / "objects" / "tool.yaml"
HUMAN = ROOT / "configs" / "hands" / "human.yaml"


@pytest.fixture(scope="module")
def jnp():
    return jax_module().numpy


def posed(hand, seed: int):
    rng = np.random.default_rng(seed)
    q = hand.apply_coupling(hand.lower + rng.random(hand.n_joints) * (hand.upper - hand.lower))
    return Rotation.random(random_state=seed).as_matrix(), rng.normal(size=3) * 0.03, q


@pytest.mark.parametrize("hand_file", [HUMAN, ROOT / "configs" / "hands" / "allegro.yaml"])
@pytest.mark.parametrize("seed", [0, 1])
def test_the_batch_contacts_normals_and_jacobians_are_the_kinematics(jnp, hand_file, seed):
    hand = load_hand(hand_file).grasping_hand()
    obj = load_object(TOOL)
    rotation, position, q = posed(hand, seed)
    arrays, field = HandArrays.of(hand, 45.0), Field.of(obj)
    placed = fingers(jnp, arrays, jnp.asarray(rotation), jnp.asarray(position), jnp.asarray(q))
    touch = contacts(jnp, arrays, field, placed)
    pose = forward(hand, q, rotation, position)
    offsets = hand.contact_offsets()
    at = np.where(offsets[:, None] > 0, pose.pad_centres()[0], pose.contacts()[0])
    outward = obj.gradient(at)
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    expected = at - offsets[:, None] * outward
    np.testing.assert_allclose(np.asarray(touch.points), expected, atol=1e-9)
    np.testing.assert_allclose(np.asarray(touch.normals), -outward, atol=1e-9)
    for J, reference in zip(touch.jacobians, pose.jacobians_at(expected[None]), strict=True):
        np.testing.assert_allclose(np.asarray(J), reference[0].T, atol=1e-9)
    spheres = np.concatenate([np.asarray(f.spheres) for f in placed])
    np.testing.assert_allclose(spheres, np.concatenate([f.samples[0] for f in pose.fingers.values()]), atol=1e-12)


@pytest.fixture(scope="module")
def search(tasks):
    hand = load_hand(HUMAN).grasping_hand()
    settings = load_grasp_settings()
    task = load_task_models(tasks)["drawing"]
    strength = StrengthArrays.of(hand.capability, [0, 1], settings, 0.05)
    config = BatchSearchConfig(iterations=40, newton_iterations=5, batch_size=6)
    return BatchSearch(hand, load_object(TOOL), task, strength, settings.pad_angle_max_deg, settings.rolling_contacts,
                       config)  # fmt: skip


def starts(hand, count: int):
    poses = [posed(hand, seed) for seed in range(count)]
    rotation = np.array([p[0] for p in poses])
    position = np.array([[0.0, 0.0, 0.0] + p[1] * 0.1 + np.array([0.06, 0.0, 0.0]) for p in poses]).reshape(-1, 3)
    return rotation, position, np.array([p[2] for p in poses])


def test_the_gradient_is_the_values_own(search):
    """The compiled search's gradient (JAX's reverse mode) against central differences of the value."""
    jax = jax_module()
    jnp = jax.numpy
    rotation, position, q = starts(search.hand, 1)
    params = {"w": jnp.asarray([0.01, -0.02, 0.03]), "d": jnp.asarray(position[0]),
              "q": jnp.asarray(q[0][search.arrays.free])}  # fmt: skip
    b = len(search.arrays.fingers)
    z = {"forces": jnp.full((4, search.strength.columns(b)), 0.3), "closure": jnp.full(b * search.strength.edges, 0.1)}
    task = search.task_arrays.arguments(jnp)
    value = jax.jit(lambda p: search.value(p, jnp.asarray(rotation[0]), 0.002, 1.0, z, task)[0])
    grad = jax.jit(jax.grad(lambda p: search.value(p, jnp.asarray(rotation[0]), 0.002, 1.0, z, task)[0]))(params)
    for key in params:
        for k in range(0, len(params[key]), 2 if key == "q" else 1):
            step = 1e-6
            up = {**params, key: params[key].at[k].add(step)}
            down = {**params, key: params[key].at[k].add(-step)}
            numeric = (float(value(up)) - float(value(down))) / (2 * step)
            assert float(grad[key][k]) == pytest.approx(numeric, rel=1e-4, abs=1e-3 * (1 + abs(numeric)))


def test_a_batch_of_one_and_of_many_end_alike_and_a_nan_start_is_its_own(search):
    rotation, position, q = starts(search.hand, 6)
    whole = search.run(rotation, position, q)
    for k in (0, 4):
        alone = search.run(rotation[k : k + 1], position[k : k + 1], q[k : k + 1])
        np.testing.assert_allclose(alone.joint_angles[0], whole.joint_angles[k], atol=1e-12)
        np.testing.assert_allclose(alone.palm_position[0], whole.palm_position[k], atol=1e-12)
    broken = position.copy()
    broken[2] = np.nan
    ended = search.run(rotation, broken, q)
    assert not ended.finite[2] and not ended.converged()[2]
    keep = [0, 1, 3, 4, 5]
    assert ended.finite[keep].all()
    np.testing.assert_allclose(ended.joint_angles[keep], whole.joint_angles[keep], atol=1e-12)


@pytest.mark.parametrize("seed", [0, 3])
def test_eq10s_forces_reach_the_least_residual_that_scipy_finds(search, jnp, seed):
    """The search's projected-gradient steps on eq. 10's forces and activations, at a fixed geometry, end at the
    least squared residual of the same bounded least squares, as scipy's lsq_linear solves it."""
    from scipy.optimize import lsq_linear

    strength, b = search.strength, len(search.arrays.fingers)
    rotation, position, q = posed(search.hand, seed)
    placed = fingers(jnp, search.arrays, jnp.asarray(rotation), jnp.asarray(position), jnp.asarray(q))
    touch = contacts(jnp, search.arrays, search.field, placed)
    M = strength_matrix(jnp, strength, touch, [f.pad_tangent for f in placed])
    task = search.task_arrays
    given = task.arguments(jnp)
    z = strength_steps(jnp, strength, M, jnp.zeros((len(task.targets), M.shape[1])), given, 20000)
    ours = np.sum(np.asarray(strength_residuals(jnp, M, z, given)) ** 2, axis=1)
    n_edges = b * strength.edges
    upper = np.r_[np.full(n_edges, np.inf), np.full(M.shape[1] - n_edges, strength.cap)]
    for k, target in enumerate(task.targets):
        size = np.linalg.norm(target)
        rows = np.r_[np.full(6, 1.0 / size), np.ones(M.shape[0] - 6)]
        wanted = np.r_[target, np.zeros(M.shape[0] - 6)] * rows
        least = lsq_linear(np.asarray(M) * rows[:, None], wanted, bounds=(0.0, upper), tol=1e-12).cost * 2
        assert ours[k] == pytest.approx(least, rel=1e-3, abs=1e-6)


@pytest.mark.parametrize("seed", [0, 3])
def test_eq4s_weights_reach_the_least_wrench_sum_that_quadprog_finds(search, jnp, seed):
    """The search's projected-gradient steps on eq. 4's weights (each at least the floor, summing to 1) end at
    the least |sum phi w|^2 of the same problem, as quadprog solves it, and within its bounds."""
    import quadprog

    strength, b = search.strength, len(search.arrays.fingers)
    rotation, position, q = posed(search.hand, seed)
    placed = fingers(jnp, search.arrays, jnp.asarray(rotation), jnp.asarray(position), jnp.asarray(q))
    touch = contacts(jnp, search.arrays, search.field, placed)
    M = strength_matrix(jnp, strength, touch, [f.pad_tangent for f in placed])
    n = b * strength.edges
    phi = np.asarray(closure_steps(jnp, strength, M, jnp.full(n, 1.0 / n), 20000))
    assert phi.sum() == pytest.approx(1.0, abs=1e-12) and phi.min() >= strength.closure_floor - 1e-12
    W = np.asarray(M)[:6, :n]
    rows = np.vstack([np.ones(n), np.eye(n)])
    least = quadprog.solve_qp(W.T @ W + 1e-12 * np.eye(n), np.zeros(n), rows.T,
                              np.r_[1.0, np.full(n, strength.closure_floor)], 1)[0]  # fmt: skip
    ours = float(np.sum(np.asarray(closure_residual(M, jnp.asarray(phi))) ** 2))
    assert ours == pytest.approx(float(np.sum((W @ least) ** 2)), rel=1e-3, abs=1e-9)
