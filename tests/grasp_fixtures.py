"""Grasps for tests: a precision grasp of a ball found by a small least-squares fit (for the verifier and
mechanics), robot grippers on a ball, a finished sweep folder made from the ball grasp, and the solver settings
of tests whose solves must converge."""

from __future__ import annotations

import shutil
from dataclasses import replace
from functools import lru_cache
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import forward, load_hand
from grasptask.objects import Superquadric
from grasptask.records.reference import read_paper_synthesis
from grasptask.records.solutions import grasp_columns
from grasptask.stages import SynthesisOptions, summarise
from grasptask.synthesis.solver_config import IPOPT_DEFAULTS, SolverConfig, load_solver_config
from grasptask.task.ellipsoid import Ellipsoid
from grasptask.task.task_model import TaskModel
from grasptask.verifier.verify import Grasp, verify

BALL_RADIUS = 0.03


def unhurried_solver() -> SolverConfig:
    """The suite's fast solver settings with the shipped iteration cap, for tests that need a start to converge."""
    fast = load_solver_config("tests/data/solver_fast.yaml")
    return replace(fast, ipopt={**fast.ipopt, "max_iter": IPOPT_DEFAULTS["max_iter"]})


def drawing_like_task(scale: float = 0.2) -> TaskModel:
    """A drawing-like task, pressing along z with friction and tip torques about x and y; at ``scale=1``
    the paper's magnitudes (2 N, 0.6 N, 0.04 N.m), by default a light version that the ball grasp can hold."""
    s = (scale * np.diag([0.6, 0.5, 2.0, 0.04, 0.035, 0.0004])) ** 2
    return TaskModel("test", 1, Ellipsoid.from_matrix(s))


@lru_cache(maxsize=1)
def ball_grasp() -> tuple[Grasp, Superquadric]:
    """Thumb, index and middle pads on a ball, pads facing its centre; the ball is placed to fit the hand. The
    fingertip spheres touch it as rolling contacts do, sunk by the hand's compliance."""
    hand = load_hand().grasping_hand()
    offsets = hand.contact_offsets()
    free = [i for i in range(hand.n_joints) if i not in {d for d, *_ in hand.couplings()}]
    lower, upper = hand.lower[free], hand.upper[free]

    def unpack(x):
        q = np.zeros(hand.n_joints)
        q[free] = x[: len(free)]
        return hand.apply_coupling(q), x[len(free) :]

    def residuals(x):
        q, centre = unpack(x)
        pose = forward(hand, q)
        tips, normals = pose.pad_centres()[0], pose.pad_normals()[0]
        towards = centre - tips
        dist = np.linalg.norm(towards, axis=1)
        inward = towards / dist[:, None]
        align = normals - inward
        spheres, radii = pose.collision_spheres()
        gap = np.linalg.norm(spheres[0] - centre, axis=1) - BALL_RADIUS - radii - 0.002
        mid = (x[: len(free)] - 0.5 * (lower + upper)) / (upper - lower)
        # inward normals summing to zero: the pads squeeze from around the ball, not from one side
        touch = (dist - BALL_RADIUS - offsets) * 300
        return np.concatenate([touch, 2.0 * align.ravel(), inward.sum(axis=0), 100 * np.minimum(gap, 0), 0.05 * mid])

    start_q = 0.5 * (lower + upper)
    centre0 = forward(hand, unpack(np.concatenate([start_q, np.zeros(3)]))[0]).contacts()[0].mean(axis=0)
    x0 = np.concatenate([start_q, centre0])
    bounds = (np.concatenate([lower + 1e-3, centre0 - 0.1]), np.concatenate([upper - 1e-3, centre0 + 0.1]))
    fit = least_squares(residuals, x0, bounds=bounds, xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    q, centre = unpack(fit.x)
    # express everything in the ball's frame: the object sits at the origin, the palm is moved instead
    grasp = Grasp(np.eye(3), -centre, q)
    return grasp, Superquadric(np.full(3, BALL_RADIUS), 1.0, 1.0, name="ball")


GRIPPER_BALL_RADIUS = 0.02


def _turn_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _facing(direction: np.ndarray) -> np.ndarray:
    """A rotation whose x axis points along ``-direction`` (towards the ball's centre)."""
    x = -direction / np.linalg.norm(direction)
    helper = np.array([0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    z = np.cross(x, helper)
    z /= np.linalg.norm(z)
    return np.column_stack([x, np.cross(z, x), z])


def gripper_grasp(directions: np.ndarray, effort_nm: float, bend_deg: float = 30.0):
    """A test hand of two-joint fingers whose pads touch a ball of radius 2 cm at ``radius * directions``
    (each finger's base 8 cm out along its direction, its two links bent by ``bend_deg`` so that the pad
    can press along the ball's normal), motors of ``effort_nm`` on every joint; the ball at the origin, the
    palm frame there too. Returns ``(hand, grasp, ball)``."""
    from grasptask.hand.hand_model import Capability, Finger, GraspingHand, Joint, Pad, Palm, Sphere

    theta = np.radians(bend_deg)
    base = 0.08
    link = (base - GRIPPER_BALL_RADIUS) / (2 * np.cos(theta))
    fingers = {}
    for k, direction in enumerate(np.asarray(directions, dtype=float)):
        direction = direction / np.linalg.norm(direction)
        first = Joint(
            f"f{k}_base", np.array([0.0, 0.0, 1.0]), -1.0, 1.0, base * direction, _facing(direction) @ _turn_z(theta)
        )
        second = Joint(
            f"f{k}_bend", np.array([0.0, 0.0, 1.0]), -1.0, 1.0, np.array([link, 0.0, 0.0]), _turn_z(-2 * theta)
        )
        normal = np.array([np.cos(theta), np.sin(theta), 0.0])
        pad = Pad(np.array([link, 0.0, 0.0]), normal, np.array([0.0, 0.0, 1.0]))
        spheres = (
            Sphere(0, np.array([0.5 * link, 0.0, 0.0]), 0.005),
            Sphere(1, np.array([0.5 * link, 0.0, 0.0]), 0.005),
        )
        fingers[f"f{k}"] = Finger(f"f{k}", (first, second), spheres, pad, np.array([link, 0.0, 0.0]), 0.008)
    names = tuple(j.name for f in fingers.values() for j in f.joints)
    capability = Capability.motors(names, np.full(len(names), effort_nm), np.eye(len(names)))
    hand = GraspingHand("gripper", fingers, Palm(np.zeros((0, 3)), np.zeros(0)), tuple(fingers), capability)
    grasp = Grasp(np.eye(3), np.zeros(3), np.zeros(len(names)))
    return hand, grasp, Superquadric(np.full(3, GRIPPER_BALL_RADIUS), 1.0, 1.0, name="ball")


#: pads all round the ball, and all on one side of it
TETRAHEDRON = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])
ONE_SIDE = np.array([[1.0, 0.3, 0.3], [1.0, -0.3, 0.3], [1.0, 0.3, -0.3], [1.0, -0.3, -0.3]])


def results_with_tasks(simulated, root):
    """A results folder with the simulated recordings and fit-task's output (copied, so tests may add to it)."""
    source = simulated[0]
    root.mkdir()
    (root / "recordings").symlink_to(source / "recordings", target_is_directory=True)
    shutil.copytree(source / "tasks", root / "tasks")
    return root


def ball_sweep(results, task="drawing"):
    """A finished sweep folder for ``task``: the verified ball grasp (twice, one optimum) and a failed start,
    written by the same summary code as ``synthesize``."""
    ball_config = results / "ball.yaml"
    ball_config.write_text(
        f"type: superquadric\nname: ball\nsize_m: [{BALL_RADIUS}, {BALL_RADIUS}, {BALL_RADIUS}]\n"
        "exponents: [1.0, 1.0]\nsymmetry: {rotation_axis: any}\n"
    )
    grasp, ball = ball_grasp()
    hand = load_hand().grasping_hand()
    check = verify(grasp, hand, ball, drawing_like_task(), GraspSettings())
    assert check.ok, check.failures
    fingers = list(hand.fingers)
    good = {"status": "optimal", "iterations": 40, "Q": check.Q}
    good.update(grasp_columns(grasp, hand.joint_names, fingers, check.contacts, check.normals))
    good.update(check.record(fingers))
    rows = [
        {"start_id": 0, "seconds": 1.5, **good},
        {"start_id": 1, "seconds": 2.5, **good},
        {"start_id": 2, "status": "max-iter", "iterations": 400, "seconds": 4.0, "Q": float("nan"), "verified": False},
    ]
    options = SynthesisOptions(
        tasks=results / "tasks" / "task_models.json", task=task, out=results / "grasps", object=ball_config
    )
    size = {"variables": 643, "constraints": 462}
    return summarise(
        options,
        rows,
        model_size=size,
        wall_seconds=5.0,
        symmetry=None,
        fingers=fingers,
        paper=read_paper_synthesis(),
    )


def first_verified(hand: str, obj: str, tasks: str, task: str, starts: int = 8) -> tuple[dict, Any]:
    """The first verified row of ``starts`` spread-out starts of ``hand`` on ``obj`` (the shipped solver config,
    the default grasp settings), and the solver context that solved it; the test fails with every start's status
    and failures when none verifies."""
    import pytest

    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.starts import make_starts, subset

    solver = load_solver_config("configs/solver.yaml")
    context = SolverContext(Job.from_files(hand, obj, tasks, task, solver=solver, settings=GraspSettings()))
    tried = []
    for start in subset(make_starts(context.bounds), starts):
        row = context.solve(start)
        tried.append((start.start_id, row["status"], row.get("verify_failures")))
        if row["verified"]:
            return row, context
    pytest.fail(f"no verified {task} grasp of {obj} by {hand} in {len(tried)} starts: {tried}")
