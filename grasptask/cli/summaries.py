"""What each command says when it is done: one line a person reads, made from what the stage returned."""

from __future__ import annotations

import math

from grasptask.stages import plural


def fit_summary(ellipsoids, stats) -> str:
    """Per group (paper order): recordings and the mean main-axis lengths of the force and torque ellipsoids."""
    main_axis = stats[(stats["stat"] == "mu") & (stats["axis"] == "3")]
    counts = ellipsoids.groupby("group").size()
    lines = [f"{'group':<24}{'n':>4}{'force main axis (N)':>22}{'torque main axis (N.cm)':>26}"]
    for group, rows in main_axis.groupby("group", sort=False):
        force, torque = (rows.loc[rows["domain"] == d, "value"].iloc[0] for d in ("force", "torque"))
        lines.append(f"{group:<24}{counts[group]:>4}{force:>22.2f}{torque:>26.2f}")
    return "\n".join(lines)


def finding_lines(findings: list[dict]) -> list[str]:
    """What fit-task's checks found, a line each: the file, the recording's id, and what was found."""
    return [f"check: {f['file']} ({f['id']}): {f['message']}" for f in findings]


def nearest_lines(tasks: dict) -> list[str]:
    """Each task's nearest task and the Log-Euclidean distance between their models, raw and normalised."""
    return [
        f"nearest task: {task} -> {near['task']}, Log-Euclidean distance {number(near['distance'])} between their "
        f"models (normalised {number(near['distance_normalised'])})"
        for task, near in tasks["nearest"].items()
    ]


def number(value) -> str:
    """Three significant digits: a Q of 0.00074 is not 0.001."""
    return "n/a" if value is None else f"{value:.3g}"


def synthesis_line(task: str, run: dict) -> str:
    """The sweep's summary line: verified starts, distinct optima, the best Q, time per start, statuses, what the
    user waited for and where the object's task frame is."""
    seconds = run["seconds_per_start"]
    route = run.get("route")
    if route:
        verified = (
            f"{route['polished']} of {plural(run['starts'], 'start')} polished ({plural(route['basins'], 'basin')}, "
            f"{route['polished_verified']} verified, {route['same_basin']} joined a basin, "
            f"{route['search_failed']} searches failed), "
        )
        model = route.get("polish_model")
        if model:
            verified += (
                f"a polish {model['variables']} variables x {model['constraints']} constraints with "
                f"{model['spheres']} collision spheres (median), "
            )
    else:
        verified = (
            f"{run['verified']}/{plural(run['starts'], 'start')} verified ({run['verified_on_retry']} on a retry), "
        )
    return (
        f"{task}: {verified}"
        f"{plural(run['distinct_optima'], 'distinct optimum')}, "
        f"best Q {number(run['best_Q'])}{verifier_said(run)}; {seconds['median']:.2f} s per start (median), "
        f"statuses {', '.join(f'{k} {v}' for k, v in run['status_counts'].items() if v)}"
        f"{throughput_said(run)}{object_said(run)}"
    )


def throughput_said(run: dict) -> str:
    """The summary's word on what the user waited for: starts and distinct optima a second, and when the best
    grasp came in."""
    rates = run.get("throughput") or {}
    if not rates or not math.isfinite(rates["starts_per_s"]):
        return ""
    best = rates.get("best_Q_after_s")
    found = f", the best Q after {best:.0f} s" if best is not None else ""
    return f"; {rates['starts_per_s']:.2f} starts/s, {rates['optima_per_s']:.2f} optima/s{found}"


def object_said(run: dict) -> str:
    """The summary's word on a mesh or cloud object: where its task frame is, and a mass not given."""
    frame = run.get("task_frame") or {}
    if frame.get("rule") in (None, "object"):
        return ""
    origin = ", ".join(str(int(round(row[3] * 1e3))) for row in frame["in_file_frame"][:3])  # no "-0"
    axes = f" ({frame['axes']})" if frame.get("axes") else ""
    said = f"; task frame: {frame['rule']}{axes}, at ({origin}) mm in the file's frame"
    if run.get("object_mass_kg") is None:
        said += "; the object's mass is not given (physics takes its config's object_mass_kg; --mass KG)"
    return said


def verifier_said(run: dict) -> str:
    """The verifier's Q of the best optimum beside the NLP's, where they differ by over 1%: which is which."""
    nlp, verifier = run.get("best_Q"), run.get("best_Q_verifier")
    if nlp is None or verifier is None or abs(verifier - nlp) <= 0.01 * abs(nlp):
        return ""
    return f" (the NLP's; the verifier's {number(verifier)})"


def physics_line(result: dict) -> str:
    """The physics check's line: how many verified grasps held, and how the two judges agreed."""
    pair = result["agreement"]
    ours, theirs = result["physics_pass_rate_of_verified"], result["dexgraspbench_pass_rate_of_verified"]
    rates = "no verified grasps" if ours is None else f"{ours:.0%} held (DexGraspBench's test: {theirs:.0%})"
    return (
        f"{result['task']}: of {result['verified']} verified grasps {rates}; verifier x physics: "
        f"{pair['verified_and_held']} both accept, {pair['verified_and_dropped']} only the verifier, "
        f"{pair['rejected_and_held']} only physics, {pair['rejected_and_dropped']} neither"
        + (
            f"; the object's mass is not given: {result['object_mass_kg']:g} kg assumed (physics config "
            "object_mass_kg; --mass KG on synthesize)"
            if result.get("object_mass_given") is False
            else ""
        )
    )
