"""The geometric phase: a start's first IPOPT iterations on the model without eq. 10, carried into the first
model (solver config ``geometric_iterations``)."""

from dataclasses import replace

import numpy as np
import pytest

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.paths import DEFAULT_HAND
from grasptask.synthesis.solver_config import load_solver_config
from grasptask.synthesis.starts import make_starts, subset
from tests.grasp_fixtures import unhurried_solver


@pytest.fixture(scope="module")
def context(tasks):
    from grasptask.synthesis.context import Job, SolverContext

    # the shipped seconds per solve: the start below must converge, also on a machine half as fast
    solver = replace(unhurried_solver(), geometric_iterations=5, torque_axes=4)
    return SolverContext(
        Job.from_files(
            str(DEFAULT_HAND),
            "configs/objects/tool.yaml",
            str(tasks),
            "drawing",
            solver=solver,
            settings=GraspSettings(),
        )
    )


def record_solves(monkeypatch, solvers: dict) -> list:
    """Each named solver's solves, in order, as (name, starting point, result)."""
    solves: list = []

    def recorded(name, solve):
        def wrapper(x0, limits=None):
            solves.append((name, x0.copy(), result := solve(x0, limits)))
            return result

        return wrapper

    for name, solver in solvers.items():
        monkeypatch.setattr(solver, "solve", recorded(name, solver.solve))
    return solves


def test_the_geometric_model_is_the_first_without_eq_10(context):
    geometric, first = context.models.geometric.nlp.model, context.models.first.nlp.model
    assert len(geometric.eq10_wrench) == len(geometric.eq10_torque) == 0
    assert len(first.eq10_wrench) > 0
    # every variable of the geometric model is one of the first model's, so its point carries over whole
    assert (context.models.geometric_positions >= 0).all()
    names = [v.name for v in context.models.first.order]
    assert [names[k] for k in context.models.geometric_positions] == [v.name for v in context.models.geometric.order]
    assert context.models.geometric.nlp.size()["variables"] < context.size["variables"]


def test_a_start_goes_on_from_the_capped_warm_up_and_counts_its_iterations(context, monkeypatch):
    """The warm-up stops at its cap, the first model starts where it stopped, and the row's iterations and
    seconds are both solves'."""
    # the whole model's solves (an all-axes re-solve or a feedback round) are counted in the row too
    solvers = {"warm": context.models.geometric, "first": context.models.first, "whole": context.models.whole}
    solves = record_solves(monkeypatch, solvers)
    start = subset(make_starts(context.bounds), 12)[0]
    row = context.solve(start)
    assert solves[0][0] == "warm" and solves[1][0] == "first"
    later = [result for name, _, result in solves if name != "warm"]
    seen = {"warm": solves[0][2], "x0": solves[1][1], "later": later}
    assert row["attempts"] == 1  # the fast solver config has no retry postures: one phase, then the first model
    assert seen["warm"].status == "max-iter" and seen["warm"].iterations == 5
    np.testing.assert_array_equal(seen["x0"][context.models.geometric_positions], seen["warm"].x)
    assert row["iterations"] == 5 + sum(r.iterations for r in seen["later"])
    solve_seconds = seen["warm"].seconds + sum(r.seconds for r in seen["later"])
    assert solve_seconds <= row["seconds"] <= solve_seconds + row["placement_seconds"] + 1e-9
    assert row["verified"], (row["status"], row.get("verify_failures"))


def test_a_failed_warm_up_leaves_the_placed_point(context, monkeypatch):
    from grasptask.synthesis.backends import SolveResult
    from grasptask.synthesis.solvers import values as _values

    placed: dict = {}
    first = context.models.first.solve

    def broken(x0, limits=None):
        placed["x"] = _values(context.models.first.order)  # placement has run; nothing has been carried yet
        return SolveResult("error", 3, 0.01, None, "test")

    def first_solve(x0, limits=None):
        placed.setdefault("x0", x0.copy())
        return first(x0, limits)

    monkeypatch.setattr(context.models.geometric, "solve", broken)
    monkeypatch.setattr(context.models.first, "solve", first_solve)
    context.solve(subset(make_starts(context.bounds), 12)[1])
    np.testing.assert_array_equal(placed["x0"], placed["x"])


def test_the_phase_runs_longer_where_the_turn_is_held(tasks):
    """Drawing on the tool holds the grasp's turn about its axis and gets the held cap; cutting, too asymmetric
    about it, keeps the free one."""
    from grasptask.synthesis.context import Job, SolverContext

    fast = load_solver_config("tests/data/solver_fast.yaml")
    solver = replace(fast, geometric_iterations=5, held_geometric_iterations=7, hold_axis_rotation=0.1)
    caps = {}
    for task in ("drawing", "cutting"):
        job = Job.from_files(
            str(DEFAULT_HAND), "configs/objects/tool.yaml", str(tasks), task, solver=solver, settings=GraspSettings()
        )
        context = SolverContext(job)
        caps[task] = (context.models.first.held_positions is not None, context.size["geometric_iterations"])
    assert caps == {"drawing": (True, 7), "cutting": (False, 5)}
