"""Speed of the grasp-mechanics library: forward kinematics plus contact Jacobians for 10,000 random
hand configurations (vectorised), and one call of the independent verifier per grasp.

Baselines in the same run: the same kinematics one configuration at a time. The paper reports no timings
for these parts.

    python benchmarks/mechanics.py        # prints a summary, writes benchmarks/results/mechanics.json
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import median_seconds, save  # noqa: E402

from grasptask.grasp.grasp_settings import GraspSettings  # noqa: E402
from grasptask.hand import forward, load_hand  # noqa: E402
from grasptask.objects import load_object  # noqa: E402
from grasptask.verifier.verify import verify  # noqa: E402
from tests.grasp_fixtures import ball_grasp, drawing_like_task  # noqa: E402

TARGET_FK_10K_S = 1.0
TARGET_VERIFY_S = 0.020


def main() -> dict:
    hand = load_hand()
    rng = np.random.default_rng(0)
    n = 10_000
    q = hand.apply_coupling(rng.uniform(hand.lower, hand.upper, (n, hand.n_joints)))
    rotations = Rotation.random(n, random_state=1).as_matrix()
    positions = rng.normal(size=(n, 3)) * 0.1
    median, runs = median_seconds(lambda: forward(hand, q, rotations, positions), 5)
    results = {"fk_jacobians_10000_s": {"median": median, "runs": runs, "joints": hand.n_joints}}
    k = 300
    loop, _ = median_seconds(lambda: [forward(hand, q[i], rotations[i], positions[i]) for i in range(k)], 3)
    results["baseline_one_at_a_time_10000_estimated_s"] = loop / k * n
    results["ratio_fk_loop_vs_vectorised"] = results["baseline_one_at_a_time_10000_estimated_s"] / median

    grasp, ball = ball_grasp()
    task = drawing_like_task()
    start = time.perf_counter()
    verify(grasp, hand.grasping_hand(), ball, task, GraspSettings())  # the first call builds the object's surface index
    results["surface_index_ball_s"] = time.perf_counter() - start
    perturbed = [
        dataclasses.replace(grasp, palm_position=grasp.palm_position + rng.normal(size=3) * 0.0005) for _ in range(100)
    ]
    times, accepted = [], 0
    for g in perturbed:
        start = time.perf_counter()
        accepted += verify(g, hand.grasping_hand(), ball, task, GraspSettings()).ok
        times.append(time.perf_counter() - start)
    results["verify_per_grasp_s"] = {
        "median": float(np.median(times)),
        "p90": float(np.percentile(times, 90)),
        "grasps": len(times),
        "accepted": accepted,
    }
    for name in ("tool", "mug"):
        obj = load_object(ROOT / "configs" / "objects" / f"{name}.yaml")
        start = time.perf_counter()
        _ = obj.surface
        results[f"surface_index_{name}_s"] = time.perf_counter() - start
    results["targets"] = {
        "fk_jacobians_10000_s": TARGET_FK_10K_S,
        "fk_meets_target": results["fk_jacobians_10000_s"]["median"] < TARGET_FK_10K_S,
        "verify_s": TARGET_VERIFY_S,
        "verify_meets_target": results["verify_per_grasp_s"]["median"] < TARGET_VERIFY_S,
        "paper": "the paper reports no timings for kinematics or verification",
    }
    return results


def report(r: dict) -> str:
    v = r["verify_per_grasp_s"]
    return "\n".join(
        [
            f"FK + Jacobians, 10,000 configurations of the 21-joint hand: {r['fk_jacobians_10000_s']['median']:.3f} s "
            f"(target < 1 s); one at a time would take ~{r['baseline_one_at_a_time_10000_estimated_s']:.1f} s "
            f"(x{r['ratio_fk_loop_vs_vectorised']:.0f})",
            "verify: median {:.1f} ms, p90 {:.1f} ms per grasp (target < 20 ms; {}/{} perturbed accepted)".format(
                v["median"] * 1e3, v["p90"] * 1e3, v["accepted"], v["grasps"]
            ),
            "one-off surface index per object: ball {:.2f} s, tool {:.2f} s, mug (mesh) {:.1f} s".format(
                r["surface_index_ball_s"], r["surface_index_tool_s"], r["surface_index_mug_s"]
            ),
        ]
    )


if __name__ == "__main__":
    results = main()
    print(report(results))
    print(f"saved {save('mechanics', results)}")
