"""Fingertips that are not spheres, through the search route (SPEC section 12, issue 88 item 7): a gripper whose
tips are URDF boxes (flat pads) and one whose tips are the LEAP's printed pad as an OBJ mesh (no sphere, no box),
each built as published. The search's contacts are functions of the pose; the polish keeps the pad the loader
fitted; the verifier measures each contact against the tip's own triangles and physics holds the grasps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hand_files import write_mesh_gripper

#: how far a verified contact may lie off the object's surface or outside the fingertip's own mesh (m)
ON_PAD_M = 0.5e-3


@pytest.mark.parametrize("tip", ["box", "pad"])
def test_a_gripper_with_flat_or_mesh_pads_is_searched_polished_verified_and_held(tmp_path, simulated, tip):
    from grasptask.stages import PhysicsOptions, SynthesisOptions, run_physics, run_synthesize

    hand = write_mesh_gripper(tmp_path, tip=tip)
    config = tmp_path / "solver.yaml"
    config.write_text("search_round: 2\nsearch: {batch_size: 2}\n")
    tasks = simulated[0] / "tasks" / "task_models.json"
    out = tmp_path / "out"
    options = SynthesisOptions(tasks=tasks, task="drawing", out=out, hand=hand, solver_config=config, starts=4,
                               route="search", executor="serial")  # fmt: skip
    run_synthesize(options, echo=lambda _: None)
    rows = pd.read_parquet(out / "drawing" / "solutions.parquet")
    verified = rows[rows["verified"].astype(bool)]
    assert len(verified) >= 2, rows[["start_id", "outcome", "status", "verify_failures"]].to_string()
    assert set(verified["outcome"]) == {"polished"}
    fingers = [c.removeprefix("verify_fingertip_gap_m_") for c in rows if c.startswith("verify_fingertip_gap_m_")]
    assert len(fingers) == 3
    for name in fingers:
        # on the object, and on the real tip (its box face or its printed pad), not where only a fitted sphere is
        assert (verified[f"verify_contact_distance_m_{name}"].abs() <= ON_PAD_M).all()
        gaps = verified[f"verify_fingertip_gap_m_{name}"].to_numpy()
        assert np.isfinite(gaps).all() and (gaps <= ON_PAD_M).all()
    checked = run_physics(PhysicsOptions(solutions=out / "drawing" / "solutions.parquet", out=tmp_path / "physics",
                                         tasks=tasks, task="drawing")).table  # fmt: skip
    judged = checked[checked["verified"].astype(bool)]
    assert len(judged) == len(verified)
    assert judged["physics_passed"].astype(bool).all(), judged[["start_id", "physics_why"]].to_string()


def test_the_printed_pad_is_fitted_as_a_sphere_not_a_face(tmp_path: Path):
    """The LEAP's pad is rounded: the loader fits it a sphere (within a tenth of a millimetre) facing the axis,
    where the box tip gets a flat face."""
    from grasptask.hand import load_hand

    for finger in load_hand(write_mesh_gripper(tmp_path, tip="pad")).fingers.values():
        pad = finger.pad
        assert not pad.flat and pad.radius > 0.0 and pad.fit_error_m < 1e-4
        assert pad.normal @ np.array([-1.0, 0.0, 0.0]) > 0.99
        assert finger.tip_mesh is not None


def test_a_pad_mesh_written_inside_out_gets_the_same_pad(tmp_path: Path):
    """Some exporters write a closed mesh's faces inward: the fingertip is turned outward before its pad is
    fitted, so its pad is the front's sphere, not the back face's plane (which faces the axis once inverted)."""
    import trimesh

    from grasptask.hand import load_hand

    path = write_mesh_gripper(tmp_path, tip="pad")
    as_published = {name: f.pad for name, f in load_hand(path).fingers.items()}
    mesh_file = tmp_path / "gripper" / "meshes" / "tip_pad.obj"
    inside_out = trimesh.load(mesh_file, force="mesh", process=False)
    inside_out.invert()
    assert inside_out.volume < 0
    inside_out.export(mesh_file)
    for name, finger in load_hand(path).fingers.items():
        pad, expected = finger.pad, as_published[name]
        assert not pad.flat
        np.testing.assert_allclose(pad.point, expected.point, atol=1e-9)
        np.testing.assert_allclose(pad.normal, expected.normal, atol=1e-9)
        assert pad.radius == pytest.approx(expected.radius, abs=1e-9)
