"""Flat pads: a box fingertip's contact is its face, lying on the surface, not a sphere fitted to it."""

from __future__ import annotations

import numpy as np
import pytest
from grasp_fixtures import first_verified
from hand_files import BOX_TIP_M, PRINTED_FILLET_M, TIP_RADIUS_M, write_mesh_gripper

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import forward, load_hand
from grasptask.objects import load_object
from grasptask.records.solutions import grasp_from_row
from grasptask.verifier.verify import verify


@pytest.mark.parametrize("tip", ["box", "printed"])
def test_a_box_tip_gets_a_flat_pad_on_the_face_that_closes(tmp_path, tip):
    """A URDF box, and the same box printed (an STL mesh, its edges rounded): the pad is the inner face, flat, its
    size the face's flat part."""
    hand = load_hand(write_mesh_gripper(tmp_path, tip=tip))
    rounded = 2 * PRINTED_FILLET_M if tip == "printed" else 0.0  # the fillets' share of each side
    for finger in hand.fingers.values():
        pad = finger.pad
        assert pad.flat and pad.radius == 0.0
        # the inner face, towards the palm's axis (-x in the finger's frame), its middle where the sphere tip's
        # nearest point to the ball was
        np.testing.assert_allclose(pad.normal, [-1.0, 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(pad.point, [-TIP_RADIUS_M, 0.0, 0.04], atol=1e-9)
        length, width = BOX_TIP_M[2] - rounded, BOX_TIP_M[1] - rounded
        np.testing.assert_allclose(pad.half_extents, (length / 2, width / 2), atol=0.3e-3)
        # no sphere of the tip stands within the compliance of the face: eq. 14 leaves the face to lie on the surface
        last = finger.n_joints - 1
        fronts = [(pad.point - s.center) @ pad.normal - s.radius for s in finger.spheres if s.link == last]
        assert fronts and min(fronts) >= hand.compliance_m - 1e-12
        assert finger.tip_mesh is not None  # the verifier measures each contact against the tip's own triangles


@pytest.mark.parametrize("tip", ["box", pytest.param("printed", marks=pytest.mark.slow)])
def test_a_box_tipped_gripper_grasps_a_cylinder_with_its_faces_flat_on_it(tmp_path, simulated, tip):
    """The tool (a cylinder 2 cm across): the verifier accepts a grasp whose contacts lie on the boxes' inner
    faces, within them, and each face square to the surface's normal there."""
    path = write_mesh_gripper(tmp_path, tip=tip)
    tasks = str(simulated[0] / "tasks" / "task_models.json")
    row, context = first_verified(str(path), "configs/objects/tool.yaml", tasks, "drawing")
    hand, tool = load_hand(path).grasping_hand(), load_object("configs/objects/tool.yaml")
    grasp = grasp_from_row(row, hand.joint_names)
    verdict = verify(grasp, hand, tool, context.job.task, GraspSettings())
    assert verdict.ok, verdict.failures
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    for j, (name, finger) in enumerate(hand.fingers.items()):
        placed = pose.fingers[name]
        rotation, origin = placed.link_rotations[0, -1], placed.joint_positions[0, finger.n_joints - 1]
        local = rotation.T @ (verdict.contacts[j] - origin)  # the verifier's contact, in the tip's frame
        pad = finger.pad
        offset = local - pad.point
        assert abs(offset @ pad.normal) <= 0.5e-3  # on the face's plane
        assert abs(offset @ pad.tangent) <= pad.half_extents[0] and abs(offset @ pad.across) <= pad.half_extents[1]
        # the face square to the surface: the object's outward normal against the pad's
        facing = -(rotation @ pad.normal) @ verdict.normals[j]
        assert np.degrees(np.arccos(min(1.0, facing))) < 1.0


def _mjcf_gripper(tip: str) -> str:
    """Two fingers facing each other across the palm, their links capsules, each tip ``tip`` (an MJCF geom)."""
    fingers = []
    for side, name in ((1, "left"), (-1, "right")):
        fingers.append(
            f'<body name="{name}_base" pos="{0.03 * side} 0 0.01" euler="0 0 {90 - 90 * side}">'
            f'<joint name="{name}_1" axis="0 -1 0" range="-0.4 0.4"/>'
            '<geom type="capsule" fromto="0 0 0 0 0 0.06" size="0.006"/>'
            f'<body name="{name}_tip" pos="0 0 0.06"><joint name="{name}_2" axis="0 -1 0" range="-0.4 0.4"/>'
            f"{tip}</body></body>"
        )
    motors = "".join(f'<motor joint="{n}_{k}" gear="1" ctrlrange="-1 1"/>' for n in ("left", "right") for k in (1, 2))
    return (
        '<mujoco model="jaws"><worldbody><body name="palm"><geom type="box" size="0.04 0.02 0.005"/>'
        + "".join(fingers)
        + f"</body></worldbody><actuator>{motors}</actuator></mujoco>"
    )


def test_an_mjcf_box_tip_gets_the_same_flat_pad(tmp_path):
    """The same box tip in an MJCF file: its face towards the other finger is a flat pad."""
    box = '<geom type="box" pos="-0.006 0 0.012" size="0.004 0.008 0.012"/>'
    (tmp_path / "jaws.xml").write_text(_mjcf_gripper(box))
    hand = load_hand(tmp_path / "jaws.xml")
    for finger in hand.fingers.values():
        assert finger.pad.flat
        np.testing.assert_allclose(finger.pad.normal, [-1.0, 0.0, 0.0], atol=1e-9)
        np.testing.assert_allclose(finger.pad.point, [-0.010, 0.0, 0.012], atol=1e-9)
        np.testing.assert_allclose(finger.pad.half_extents, (0.012, 0.008), atol=1e-9)


def test_the_hand_summary_and_view_show_a_flat_pad(tmp_path):
    from grasptask.report.hand_view import hand_figure, hand_lines

    hand = load_hand(write_mesh_gripper(tmp_path, tip="box"))
    lines = [line for line in hand_lines(hand) if "fingertip link" in line]
    assert len(lines) == 3 and all("a flat face 24.0 x 16.0 mm, lying on the surface" in line for line in lines)
    faces = [t for t in hand_figure(hand).data if t.name and t.name.endswith("flat pad")]
    assert len(faces) == 3
    pose = forward(hand, hand.mid_range())
    for face, finger in zip(faces, pose.fingers.values(), strict=True):
        corners = np.column_stack([face.x, face.y, face.z])
        # the rectangle lies on the pad's plane, about its middle
        np.testing.assert_allclose((corners - finger.contact[0]) @ finger.pad_normal[0], 0.0, atol=1e-6)
        np.testing.assert_allclose(corners.mean(axis=0), finger.contact[0], atol=1e-6)


def test_a_hand_yaml_declares_a_flat_pad_and_refuses_one_with_a_radius(tmp_path):
    """A flat tip the rule does not find (here the sphere-tipped gripper's, for the test): the YAML's pad is flat,
    its face the size it says; a flat pad with a radius is one line naming the field."""
    import yaml

    from grasptask.errors import BadInputError

    urdf = write_mesh_gripper(tmp_path)

    def pad() -> dict:  # a new one each time: the YAML has no aliases
        return {"point_m": [-0.01, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0], "tangent": [0.0, 0.0, 1.0],
                "flat_size_m": [0.012, 0.008]}  # fmt: skip

    spec = {"model": str(urdf), "pads": {f"finger{f}_tip": pad() for f in range(3)}}
    (tmp_path / "hand.yaml").write_text(yaml.safe_dump(spec))
    hand = load_hand(tmp_path / "hand.yaml")
    for finger in hand.fingers.values():
        assert finger.pad.flat and finger.pad.half_extents == (0.006, 0.004)
        np.testing.assert_allclose(finger.pad.point, [-0.01, 0.0, 0.04], atol=1e-12)  # in the last link's frame
    spec["pads"]["finger0_tip"] = {**pad(), "radius_m": 0.01}
    (tmp_path / "hand.yaml").write_text(yaml.safe_dump(spec))
    with pytest.raises(BadInputError, match="field 'pads.finger0_tip': a flat pad"):
        load_hand(tmp_path / "hand.yaml")
