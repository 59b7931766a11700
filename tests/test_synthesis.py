"""Grasp synthesis: the model, the starts, and sweeps that survive crashes, interruptions and restarts.

Solver runs use a short iteration cap (tests/data/solver_fast.yaml) so that the suite stays quick; a
start that needs more iterations is recorded as max-iter, which the sweep must handle anyway.
"""

import json
import multiprocessing as mp
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyomo.environ as pyo
import pytest

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import load_hand
from grasptask.objects import load_object
from grasptask.paths import DEFAULT_HAND
from grasptask.records.solutions import STATUSES
from grasptask.synthesis.nlp import build_model
from grasptask.synthesis.solver_config import IPOPT_DEFAULTS
from grasptask.synthesis.starts import make_starts, palm_directions, subset
from grasptask.synthesis.sweep import _next_start
from grasptask.task.task_model import load_task_models

FAST = Path("tests/data/solver_fast.yaml")


def synthesize(cli, tasks, out, *extra):
    return cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", out, "--solver-config", FAST, *extra)


def test_model_components_cite_the_paper_and_size_is_recorded(tasks):
    nlp = build_model(
        load_hand(), load_object("configs/objects/tool.yaml"), load_task_models(tasks)["drawing"], GraspSettings()
    )
    names = {c.local_name for c in nlp.model.component_objects((pyo.Constraint, pyo.Objective), active=True)}
    for expected in (
        "eq2_frame",
        "eq3_contact",
        "eq4_force_closure",
        "eq5_wrench",
        "eq7_jacobian",
        "eq24_cone_edge",
        "eq8_task_force",
        "eq10_torque",
        "eq12_objective",
        "eq14_collision",
        "eq16_23_palm_orthonormal",
        "eq22_coupling",
    ):
        assert expected in names
    size = nlp.size()
    # an octagonal cone (configs/grasp.yaml); each edge more adds eq. 10's force per contact and task wrench
    assert 1000 < size["variables"] < 1200 and 700 < size["constraints"] < 900


def test_model_initialisation_reproduces_the_hand_kinematics(tasks):
    """The NLP's own kinematics (Pyomo) and the verifier's (numpy) agree at a start, written independently."""
    from grasptask.hand import forward

    hand = load_hand()
    nlp = build_model(
        hand, load_object("configs/objects/tool.yaml"), load_task_models(tasks)["drawing"], GraspSettings()
    )
    start = make_starts(np.array([[-0.01, -0.01, -0.1], [0.01, 0.01, 0.1]]))[17]
    q = nlp.hand.mid_range()
    nlp.initialise(start.palm_rotation, start.palm_position, q)
    pose = forward(hand.grasping_hand(), q, start.palm_rotation, start.palm_position)
    # a rolling contact starts at the pad's home point, sunk by the compliance along the pad's normal
    offsets = hand.grasping_hand().contact_offsets()[:, None]
    starting = pose.pad_centres()[0] + offsets * pose.pad_normals()[0]
    np.testing.assert_allclose(nlp.read()["contacts"], starting, atol=1e-12)
    m = nlp.model
    jacobians = pose.jacobians_at(starting[None])
    for j, finger in enumerate(pose.fingers.values()):
        model_jacobian = [[pyo.value(m.J[j, k, i]) for k in range(finger.jacobian.shape[2])] for i in range(3)]
        np.testing.assert_allclose(model_jacobian, jacobians[j][0], atol=1e-12)


def test_initialisation_satisfies_every_defining_equality(tasks):
    """Each auxiliary variable (frames, contacts, normals, tangents, cone edges, wrenches, Jacobians, edge
    torques) is set from the expression its equality constraint states, so they all hold at a start."""
    nlp = build_model(
        load_hand(), load_object("configs/objects/tool.yaml"), load_task_models(tasks)["drawing"], GraspSettings()
    )
    start = make_starts(np.array([[-0.01, -0.01, -0.1], [0.01, 0.01, 0.1]]))[40]
    nlp.initialise(start.palm_rotation, start.palm_position, nlp.hand.mid_range())
    m = nlp.model
    defining = ("eq2_frame", "eq2_contact_point", "normal_definition", "tangent_definition", "eq24_cone_edge")
    defining += ("eq5_wrench", "eq7_jacobian", "eq7_edge_torque")
    for name in defining:
        residuals = [abs(pyo.value(c.body) - pyo.value(c.upper)) for c in getattr(m, name).values()]
        assert max(residuals, default=0.0) < 1e-12, name
    # rolling contacts: their equality holds at a solution, not at a start (p starts at the pad's home point)
    assert len(m.eq2_contact_point) == 0 and len(m.eq2_rolling_contact) == 9


def test_126_starts_from_42_orientations_and_3_positions():
    directions = palm_directions()
    assert directions.shape == (42, 3) and np.allclose(np.linalg.norm(directions, axis=1), 1)
    starts = make_starts(np.array([[-0.01, -0.01, -0.1], [0.01, 0.01, 0.1]]), seed=3)
    assert len(starts) == 126 and len({s.position_name for s in starts}) == 3
    for s in starts:
        np.testing.assert_allclose(s.palm_rotation.T @ s.palm_rotation, np.eye(3), atol=1e-12)
        assert np.linalg.norm(s.palm_position) > 0.09  # away from the object
    again = make_starts(np.array([[-0.01, -0.01, -0.1], [0.01, 0.01, 0.1]]), seed=3)
    assert all(np.array_equal(a.palm_rotation, b.palm_rotation) for a, b in zip(starts, again, strict=True))
    assert [s.start_id for s in subset(starts, 4)] == [0, 42, 83, 125]


def test_sweep_writes_rows_verifies_and_clusters(cli, tasks, tmp_path):
    result = synthesize(cli, tasks, tmp_path, "--starts", "4", "--workers", "2")
    assert result.exit_code == 0, result.output
    solutions = pd.read_parquet(tmp_path / "drawing" / "solutions.parquet")
    assert list(solutions["start_id"]) == [0, 42, 83, 125]
    assert set(solutions["status"]) <= set(STATUSES)
    for column in ("iterations", "seconds", "Q", "verified", "contact_index_x", "normal_thumb_z", "palm_r22"):
        assert column in solutions.columns
    # placed starts (the bundled default): the placement's time is part of each start's seconds
    assert (solutions["placement_backoff_m"].between(0, 0.08)).all()
    assert (solutions["seconds"] > solutions["placement_seconds"]).all() and (solutions["placement_seconds"] > 0).all()
    run = json.loads((tmp_path / "drawing" / "run.json").read_text())
    assert run["model_size"]["variables"] > 0 and run["paper"]["variables"] == 579
    assert run["paper"]["distinct_optima"] == 7
    assert sum(run["status_counts"].values()) == 4
    # at an optimum the NLP's Q is the verifier's own least-Q recomputation, or above it where that needs task
    # forces beyond the solver's bound (task_force_n); a start cut off by the time limit may still be a verified
    # grasp, but its task forces are not yet the least-Q ones
    verified = solutions[solutions["verified"]]
    converged = verified[verified["status"] == "optimal"]
    assert (converged["Q"] >= converged["verify_Q"] * (1 - 1e-3)).all()
    assert np.isclose(converged["Q"], converged["verify_Q"], rtol=1e-3).any()
    # rolling contacts: each fingertip sphere's centre is its radius minus the compliance from the surface
    distances = converged[[f"verify_contact_distance_m_{f}" for f in ("thumb", "index", "middle")]]
    assert len(converged) and np.abs(distances.to_numpy()).max() < 1e-6
    optima = pd.read_parquet(tmp_path / "drawing" / "optima.parquet")
    assert len(optima) <= len(verified) and optima["members"].sum() == len(verified)
    # what the user waited for: starts and optima a second, and when the best grasp came in
    rates, wall = run["throughput"], run["sweep_wall_seconds_this_run"]
    assert rates["starts_per_s"] == pytest.approx(4 / wall) and rates["optima_per_s"] == pytest.approx(
        len(optima) / wall
    )
    best = optima.loc[optima["Q"].idxmin()]
    assert rates["best_Q_after_s"] == best["found_after_s"] and 0 < best["found_after_s"] <= wall
    assert (solutions["found_after_s"] > 0).all()
    said = f"{rates['starts_per_s']:.2f} starts/s, {rates['optima_per_s']:.2f} optima/s, the best Q after "
    assert said in result.output


@pytest.mark.slow
def test_sweep_on_a_gp_object(cli, tasks, tmp_path):
    """The NLP on a Gaussian-process surface (a capsule-shaped handle fitted from surface points) reaches grasps
    that the verifier, with its own numpy GP, accepts: contacts on the surface, Q as it recomputes it."""
    import trimesh

    mesh = trimesh.creation.capsule(height=0.12, radius=0.012, count=[24, 24])
    points, faces = trimesh.sample.sample_surface_even(mesh, 1500, seed=0)
    table = pd.DataFrame(np.hstack([points, mesh.face_normals[faces]]), columns=["x", "y", "z", "nx", "ny", "nz"])
    table.to_csv(tmp_path / "capsule.csv", index=False)
    (tmp_path / "capsule.yaml").write_text(
        "type: gp\nname: capsule\npoints_csv: capsule.csv\nn_support: 30\nmax_support: 40\ntolerance_m: 0.001\n"
        "symmetry: {rotation_axis: z, flip_axis: z}\n"
    )
    solver = tmp_path / "solver.yaml"  # the fast settings' own iteration cap
    solver.write_text(FAST.read_text())
    out = tmp_path / "out"
    result = cli(
        "synthesize", "--tasks", tasks, "--task", "drawing", "--out", out, "--object", tmp_path / "capsule.yaml",
        "--solver-config", solver, "--starts", "2", "--workers", "2",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    solutions = pd.read_parquet(out / "drawing" / "solutions.parquet")
    verified = solutions[solutions["verified"]]
    assert len(verified) >= 1, solutions[["status", "message", "verify_failures"]]
    distances = verified[[f"verify_contact_distance_m_{f}" for f in ("thumb", "index", "middle")]].abs()
    assert (distances.to_numpy() < 1e-4).all()
    converged = verified[verified["status"] == "optimal"]
    np.testing.assert_allclose(converged["Q"], converged["verify_Q"], rtol=1e-3)


CRASHING_WORKER = """
import os
from grasptask.synthesis import context
from grasptask.grasp.grasp_settings import GraspSettings

_solve = context.SolverContext.solve


def _crash_on_62(self, start):
    if start.start_id == 62:
        os._exit(13)
    return _solve(self, start)


context.SolverContext.solve = _crash_on_62
"""


@pytest.mark.slow
def test_a_crashed_worker_is_recorded_and_the_sweep_goes_on(cli, tasks, tmp_path, monkeypatch):
    """A worker process that dies outright on start 62 (the middle one of the subset 0, 62, 125): the spawned
    workers import a sitecustomize that makes them exit there, so no hook lives in the package."""
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(CRASHING_WORKER)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, (str(hook), os.environ.get("PYTHONPATH")))))
    result = synthesize(cli, tasks, tmp_path, "--starts", "3", "--workers", "1")
    assert result.exit_code == 0, result.output
    solutions = pd.read_parquet(tmp_path / "drawing" / "solutions.parquet").set_index("start_id")
    assert solutions.loc[62, "status"] == "crashed" and not solutions.loc[62, "verified"]
    assert solutions.loc[0, "status"] != "crashed" and solutions.loc[125, "status"] != "crashed"


def test_a_worker_stops_when_its_sweep_was_killed():
    """A sweep killed outright cannot send its workers the stop message; they notice that it is gone."""
    context = mp.get_context("spawn")
    tasks = context.Queue()
    gone = context.Process(target=time.sleep, args=(0,))
    gone.start()
    gone.join()
    assert _next_start(tasks, gone, poll_s=0.05) is None
    start = make_starts(np.array([[-0.01, -0.01, -0.1], [0.01, 0.01, 0.1]]))[3]
    tasks.put(start)
    assert _next_start(tasks, None, poll_s=0.05).start_id == 3


@pytest.mark.slow
def test_resume_keeps_finished_starts(cli, tasks, tmp_path):
    assert synthesize(cli, tasks, tmp_path, "--starts", "2", "--executor", "serial").exit_code == 0
    log = tmp_path / "drawing" / "solutions.jsonl"
    first = [json.loads(line) for line in log.read_text().splitlines()]
    assert [r["start_id"] for r in first] == [0, 125]
    result = synthesize(cli, tasks, tmp_path, "--starts", "3", "--executor", "serial", "--resume")
    assert result.exit_code == 0 and "2 already done" in result.output
    rows = [json.loads(line) for line in log.read_text().splitlines()]
    assert rows[:2] == first and [r["start_id"] for r in rows] == [0, 125, 62]


@pytest.mark.slow
def test_ctrl_c_then_resume(tasks, tmp_path):
    """SIGINT mid-sweep keeps what finished; --resume completes the rest without redoing it."""
    command = [
        sys.executable,
        "-m",
        "grasptask.cli",
        "synthesize",
        "--tasks",
        str(tasks),
        "--task",
        "drawing",
        "--out",
        str(tmp_path),
        "--solver-config",
        str(FAST),
        "--starts",
        "3",
        "--executor",
        "serial",
    ]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = tmp_path / "drawing" / "solutions.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and not (log.exists() and log.read_text().count("\n") >= 1):
        time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and "--resume" in err
    kept = [json.loads(line)["start_id"] for line in log.read_text().splitlines()]
    assert 1 <= len(kept) < 3
    assert not (tmp_path / "drawing" / "solutions.parquet").exists()
    finished = subprocess.run(command + ["--resume"], capture_output=True, text=True, timeout=300)
    assert finished.returncode == 0, finished.stderr
    rows = [json.loads(line)["start_id"] for line in log.read_text().splitlines()]
    assert rows[: len(kept)] == kept and sorted(rows) == [0, 62, 125]


def test_dask_local_cluster(tasks, tmp_path):
    from dask.distributed import LocalCluster

    from grasptask.stages import SynthesisOptions, run_synthesize

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        options = SynthesisOptions(
            tasks=tasks,
            task="drawing",
            out=tmp_path,
            solver_config=FAST,
            starts=2,
            executor="dask",
            scheduler=cluster.scheduler_address,
        )
        run = run_synthesize(options, echo=lambda _: None).run
    assert run["starts"] == 2
    assert len(pd.read_parquet(tmp_path / "drawing" / "solutions.parquet")) == 2


def test_verify_command_recomputes_the_columns(cli, tasks, tmp_path):
    """With the sweep's own task models, task, hand, object and grasp config, from its run.json."""
    assert synthesize(cli, tasks, tmp_path, "--starts", "2", "--executor", "serial").exit_code == 0
    result = cli("verify", tmp_path / "drawing" / "solutions.parquet", "--out", tmp_path / "check")
    assert result.exit_code == 0, result.output
    again = pd.read_parquet(tmp_path / "check" / "verification.parquet")
    before = pd.read_parquet(tmp_path / "drawing" / "solutions.parquet")
    assert list(again["verified"]) == list(before["verified"])


def test_synthesize_bad_input(cli, tasks, tmp_path):
    result = synthesize(cli, tasks, tmp_path / "o", "--task", "juggling")
    assert result.exit_code == 2 and "juggling" in result.output
    assert (
        cli("synthesize", "--tasks", tmp_path / "none.json", "--task", "drawing", "--out", tmp_path / "o").exit_code
        == 2
    )


def _toy_nl():
    """A small NLP with one optimum, through the same NL writer: min (x0-2)^2 + x1^4 + exp(y) + x2^2 on the unit
    sphere, with x2 - y >= 0.1."""
    from grasptask.synthesis.backends import write_nl

    m = pyo.ConcreteModel()
    m.x = pyo.Var(range(3), initialize=1.0, bounds=(-5, 5))
    m.y = pyo.Var(initialize=0.5)
    m.sphere = pyo.Constraint(expr=m.x[0] ** 2 + m.x[1] ** 2 + m.y**2 == 1)
    m.gap = pyo.Constraint(expr=m.x[2] - m.y >= 0.1)
    m.objective = pyo.Objective(expr=(m.x[0] - 2) ** 2 + m.x[1] ** 4 + pyo.exp(m.y) + m.x[2] ** 2)
    text, order = write_nl(m)
    return text, np.array([v.value for v in order])


def test_both_backends_reach_the_same_optimum_on_a_test_problem():
    from grasptask.synthesis.backends import CasadiBackend, CyipoptBackend

    pytest.importorskip("cyipopt", reason="make setup-cyipopt builds it; `make test` does so first")
    text, x0 = _toy_nl()
    options = {"tol": 1e-10, "print_level": 0, "sb": "yes"}
    a, b = CasadiBackend(text, options).solve(x0), CyipoptBackend(text, options).solve(x0)
    assert a.status == b.status == "optimal"
    np.testing.assert_allclose(a.x, b.x, atol=1e-7)
    assert b.iterations > 0


@pytest.mark.parametrize("backend", ["casadi", "cyipopt"])
def test_a_solve_stuck_in_restoration_stops_there_as_max_iter(backend):
    """A solve the restoration phase cannot bring back (the unit circle and x0 = 3 share no point) stops after
    max_resto_iter iterations in a row there, as a recorded max-iter with its last point, for a retry to follow."""
    from grasptask.synthesis.backends import BACKENDS, write_nl

    if backend == "cyipopt":
        pytest.importorskip("cyipopt", reason="make setup-cyipopt builds it; `make test` does so first")
    m = pyo.ConcreteModel()
    m.x = pyo.Var(range(2), initialize=0.1)
    m.sphere = pyo.Constraint(expr=m.x[0] ** 2 + m.x[1] ** 2 == 1)
    m.off = pyo.Constraint(expr=m.x[0] == 3)
    m.objective = pyo.Objective(expr=m.x[0] ** 2 + m.x[1] ** 2)
    text, order = write_nl(m)
    x0 = np.array([v.value for v in order])
    options = {"print_level": 0, "sb": "yes", "max_iter": 500}
    unbounded = BACKENDS[backend](text, options).solve(x0)
    capped = BACKENDS[backend](text, {**options, "max_resto_iter": 1}).solve(x0)
    assert unbounded.status == "infeasible"
    assert capped.status == "max-iter" and capped.x is not None and capped.iterations < unbounded.iterations
    # the shipped defaults cap the restoration phase inside a solve's iterations
    assert IPOPT_DEFAULTS["max_resto_iter"] < IPOPT_DEFAULTS["max_iter"]


def test_cyipopt_backend_on_the_grasp_nlp(cli, tasks, tmp_path):
    pytest.importorskip("cyipopt", reason="make setup-cyipopt builds it; `make test` does so first")
    result = synthesize(cli, tasks, tmp_path, "--starts", "2", "--executor", "serial", "--solver", "cyipopt")
    assert result.exit_code == 0, result.output
    run = json.loads((tmp_path / "drawing" / "run.json").read_text())
    assert run["backend"] == "cyipopt" and run["starts"] == 2 and run["status_counts"]["error"] == 0


def test_eq10_for_the_task_longest_axes_only(tasks):
    """``torque_axes`` keeps eq. 10's blocks for the task's longest axes, both signs, and every other family."""
    hand, obj, task = load_hand(), load_object("configs/objects/tool.yaml"), load_task_models(tasks)["cutting"]
    whole = build_model(hand, obj, task, GraspSettings()).model
    two = build_model(hand, obj, task, GraspSettings(), torque_axes=2).model
    assert len(whole.eq10_wrench) == 6 * 2 * 6 and len(two.eq10_wrench) == 2 * 2 * 6
    assert {index[:2] for index in two.act.index_set()} == {(0, 0), (0, 1), (1, 0), (1, 1)}
    for name in ("eq2_frame", "eq4_force_closure", "eq8_task_force", "eq14_collision"):
        assert len(getattr(two, name)) == len(getattr(whole, name))
    assert build_model(hand, obj, task, GraspSettings(), torque_axes=9).model.act.index_set() == whole.act.index_set()


@pytest.mark.slow
def test_a_grasp_the_left_out_axes_reject_is_solved_again_with_all_of_them(tasks):
    """With eq. 10 for cutting's longest axis only, some grasps cannot hold the others: the verifier, which
    checks all six, rejects them, and each is solved again from itself with the whole model. The whole model
    starts from the first model's point, and every verified row holds every axis within the tendons' capability."""
    from dataclasses import replace

    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.solver_config import load_solver_config
    from grasptask.synthesis.solvers import values as _values

    solver = replace(load_solver_config(FAST), torque_axes=1, retry_postures=(), feedback_rounds=0)
    context = SolverContext(
        Job.from_files(
            str(DEFAULT_HAND),
            "configs/objects/tool.yaml",
            str(tasks),
            "cutting",
            solver=solver,
            settings=GraspSettings(),
        )
    )
    first, whole = context.models.first, context.models.whole
    assert first.nlp.size()["variables"] < whole.nlp.size()["variables"]
    rows = [context.solve(start) for start in subset(make_starts(context.bounds), 12)[:6]]
    assert any(row["all_axes_solves"] for row in rows), [(r["status"], r.get("verify_failures")) for r in rows]
    assert all(row["verify_torque_effort"] <= 1 + 1e-6 for row in rows if row["verified"])
    carried = context.models.in_whole(_values(first.order))
    values = {v.name: v.value for v in first.order}
    shared = [(k, v.name) for k, v in enumerate(whole.order) if v.name in values]
    assert len(shared) == len(first.order)
    assert all(carried[k] == values[name] for k, name in shared)


def test_attempts_start_from_the_first_posture_then_each_retry_posture(tasks, monkeypatch):
    """Placement and the first attempt use the solver config's first posture; each rejected attempt gives way to
    the next retry posture (one equal to the first is not repeated), and a verified one ends the start."""
    from dataclasses import replace

    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.solver_config import load_solver_config

    solver = replace(load_solver_config(FAST), first_posture=0.25, retry_postures=(0.25, 0.5, 0.1))
    assert solver.postures == (0.25, 0.5, 0.1)
    context = SolverContext(
        Job.from_files(
            str(DEFAULT_HAND),
            "configs/objects/tool.yaml",
            str(tasks),
            "cutting",
            solver=solver,
            settings=GraspSettings(),
        )
    )
    tried = []

    as_they_were = []

    def attempt(start, joints, as_it_is=False, end=None):  # the signature of SolverContext._attempt
        tried.append(joints)
        as_they_were.append(as_it_is)
        keys = ("seconds", "iterations", "placement_seconds", "feedback_rounds", "all_axes_solves")
        return {"verified": len(tried) % 2 == 0, **dict.fromkeys(keys, 1)}

    monkeypatch.setattr(context, "_attempt", attempt)
    row = context.solve(make_starts(context.bounds)[0])
    hand = context.nlp.hand
    assert row["attempts"] == 2 and row["seconds"] == 2 and not row["first_attempt_verified"]
    np.testing.assert_allclose(tried[0], hand.posture(0.25))
    np.testing.assert_allclose(tried[1], hand.mid_range())
    # a warm start (a grasp library's optimum): its own joints first, taken as they are, then the retries
    from dataclasses import replace

    own = hand.posture(0.7)
    context.solve(replace(make_starts(context.bounds)[0], joints=own))
    np.testing.assert_allclose(tried[2], own)
    np.testing.assert_allclose(tried[3], hand.mid_range())
    assert as_they_were == [False, False, True, False]


def test_a_worker_loads_nothing_the_sweep_loaded_already(tasks, monkeypatch):
    """The hand (a published one's sphere cover takes 8.6 s to fit), the object and the task model come to a
    worker by value, as the sweep loaded them: building a worker's context reads no file."""
    import pickle

    from grasptask.synthesis import context as worker
    from grasptask.synthesis.context import Job, SolverContext

    job = Job.from_files(DEFAULT_HAND, "configs/objects/tool.yaml", tasks, "drawing", settings=GraspSettings())
    job = pickle.loads(pickle.dumps(job))  # as a spawned worker or a Dask worker receives it

    def refused(*_, **__):
        raise AssertionError("a worker loaded an input again")

    for name in ("load_hand", "load_object", "load_task_models"):
        monkeypatch.setattr(worker, name, refused)
    built = SolverContext(job)
    assert built.hand is not None and built.task.name == "drawing" and built.size["variables"] > 0
