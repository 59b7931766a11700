"""MJCF hands as MuJoCo Menagerie lays them out (an ``<include>`` of ``<default>`` classes, meshes under a
``meshdir``): a gripper whose two jaws one motor drives through a fixed tendon and a joint equality (Menagerie's
Franka hand), and a finger whose last two joints one motor pulls through a tendon (its Shadow hand, E3M5). The
tendons' motors are rows of the transmission T (eq. 1), by virtual work; a spatial tendon is refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.optimize import linprog

from grasptask.errors import BadInputError
from grasptask.hand import load_hand
from grasptask.report.hand_view import hand_lines, joint_table

DEFAULTS = """<mujoco>
  <default>
    <default class="panda">
      <joint armature="0.1" damping="1"/>
      <general dyntype="none" biastype="affine" ctrlrange="0 255" forcerange="-87 87"/>
      <default class="finger"><joint axis="0 1 0" type="slide" range="0 0.04"/></default>
      <default class="visual"><geom type="mesh" contype="0" conaffinity="0" group="2"/></default>
      <default class="collision">
        <geom type="mesh" group="3"/>
        <default class="pad"><geom type="box" size="0.0085 0.004 0.0085" pos="0 0.0055 0.0445"/></default>
      </default>
    </default>
  </default>
</mujoco>
"""

FRANKA = """<mujoco model="panda hand">
  <compiler angle="radian" meshdir="assets" autolimits="true"/>
  <include file="panda_defaults.xml"/>
  <asset>
    <mesh name="hand_c" file="hand.stl"/>
    <mesh file="finger_0.stl"/>
    <mesh file="finger_visual.obj"/>
  </asset>
  <worldbody>
    <body name="hand" childclass="panda" quat="0 0 0 1">
      <inertial mass="0.73" pos="-0.01 0 0.03" diaginertia="0.001 0.0025 0.0017"/>
      <geom mesh="hand_c" class="collision"/>
      <body name="left_finger" pos="0 0 0.0584">
        <inertial mass="0.015" pos="0 0 0" diaginertia="2.375e-6 2.375e-6 7.5e-7"/>
        <joint name="finger_joint1" class="finger"/>
        <geom mesh="finger_visual" class="visual"/>
        <geom mesh="finger_0" class="collision"/>
        <geom class="pad"/>
      </body>
      <body name="right_finger" pos="0 0 0.0584" quat="0 0 0 1">
        <inertial mass="0.015" pos="0 0 0" diaginertia="2.375e-6 2.375e-6 7.5e-7"/>
        <joint name="finger_joint2" class="finger"/>
        <geom mesh="finger_0" class="collision"/>
        <geom class="pad"/>
      </body>
    </body>
  </worldbody>
  <contact>
    <exclude body1="hand" body2="left_finger"/>
    <exclude body1="hand" body2="right_finger"/>
  </contact>
  <tendon>
    <fixed name="split">
      <joint joint="finger_joint1" coef="0.5"/>
      <joint joint="finger_joint2" coef="0.5"/>
    </fixed>
  </tendon>
  <equality>
    <joint joint1="finger_joint1" joint2="finger_joint2" solimp="0.95 0.99 0.001" solref="0.005 1"/>
  </equality>
  <actuator>
    <general class="panda" name="actuator8" tendon="split" forcerange="-100 100" ctrlrange="0 255"
      gainprm="0.01568627451 0 0" biasprm="0 -100 -10"/>
  </actuator>
</mujoco>
"""


def write_franka(root: Path) -> Path:
    """Menagerie's Franka hand as it lays it out: hand.xml, its defaults in an include, meshes under assets/
    (the visual one, an OBJ, never read)."""
    folder = root / "franka_emika_panda"
    (folder / "assets").mkdir(parents=True)
    trimesh.creation.box([0.04, 0.2, 0.06]).apply_translation([0, 0, 0.03]).export(folder / "assets" / "hand.stl")
    finger = trimesh.creation.box([0.017, 0.01, 0.05]).apply_translation([0, 0.006, 0.025])
    finger.export(folder / "assets" / "finger_0.stl")
    (folder / "panda_defaults.xml").write_text(DEFAULTS)
    (folder / "hand.xml").write_text(FRANKA)
    return folder / "hand.xml"


def shadow_like(tendon: str = "fixed") -> str:
    """Two fingers as Menagerie's Shadow hand drives them: a thumb with a position actuator per joint, and a
    finger whose J3 has its own and whose J2 and J1 one actuator pulls through a fixed tendon (coefficients 1,
    1), with no equality between them: they share the tendon's force, each free to turn."""
    thumb = """
      <body name="thbase" pos="0.03 0 0.02"><joint name="THJ2" class="proximal" axis="0 1 0"/>
        <geom type="capsule" size="0.009 0.015" pos="0 0 0.015"/>
        <body name="thdistal" pos="0 0 0.03"><joint name="THJ1" class="proximal" axis="0 1 0"/>
          <geom type="sphere" size="0.01" pos="0 0 0.02"/></body></body>"""
    finger = """
      <body name="ffproximal" pos="-0.03 0 0.02"><joint name="FFJ3" class="proximal" axis="0 -1 0"/>
        <geom type="capsule" size="0.009 0.02" pos="0 0 0.025"/>
        <body name="ffmiddle" pos="0 0 0.045"><joint name="FFJ2" class="middle_distal" axis="0 -1 0"/>
          <geom type="capsule" size="0.009 0.0125" pos="0 0 0.0125"/>
          <body name="ffdistal" pos="0 0 0.025"><joint name="FFJ1" class="middle_distal" axis="0 -1 0"/>
            <geom type="sphere" size="0.009" pos="0 0 0.012"/><site name="tip" pos="0 0 0.02"/></body></body></body>"""
    path = (
        '<spatial name="FFJ0" width="0.001"><site site="anchor"/><site site="tip"/></spatial>'
        if tendon == "spatial"
        else '<fixed name="FFJ0"><joint joint="FFJ2" coef="1"/><joint joint="FFJ1" coef="1"/></fixed>'
    )
    return f"""<mujoco model="shadow_like">
  <compiler angle="radian" autolimits="true"/>
  <default><default class="right_hand">
    <joint axis="1 0 0" damping="0.05" armature="0.0002"/>
    <position forcerange="-1 1"/>
    <default class="proximal"><joint range="-0.26 1.57"/><position ctrlrange="-0.26 1.57"/></default>
    <default class="middle_distal"><joint range="0 1.57"/><position kp="0.5" ctrlrange="0 3.14"/></default>
  </default></default>
  <worldbody>
    <body name="palm" childclass="right_hand">
      <geom type="box" size="0.04 0.01 0.04" pos="0 0 -0.03"/><site name="anchor" pos="0 0 0"/>{thumb}{finger}
    </body>
  </worldbody>
  <tendon>{path}</tendon>
  <actuator>
    <position name="A_THJ2" joint="THJ2" class="proximal"/>
    <position name="A_THJ1" joint="THJ1" class="proximal"/>
    <position name="A_FFJ3" joint="FFJ3" class="proximal"/>
    <position name="A_FFJ0" tendon="FFJ0" class="middle_distal"/>
  </actuator>
</mujoco>
"""


def producible(hand, torques: dict[str, float]) -> bool:
    """Whether ``T tau = A a`` has a solution with ``0 <= a <= 1``: the joint torques are within the motors'
    reach (an LP, independent of how the capability was built)."""
    capability = hand.capability
    tau = np.array([torques.get(name, 0.0) for name in hand.joint_names])
    n = capability.torque_map.shape[1]
    result = linprog(np.zeros(n), A_eq=capability.torque_map, b_eq=capability.transmission @ tau, bounds=[(0, 1)] * n)
    return bool(result.status == 0)


def test_a_gripper_whose_jaws_one_tendon_drives_loads_as_one_motor(tmp_path):
    hand = load_hand(write_franka(tmp_path))
    assert sorted(hand.fingers) == ["left_finger", "right_finger"]
    jaws = [f.joints[0] for f in hand.fingers.values()]
    # MuJoCo's joint equality makes joint1 follow joint2 (q1 = q2)
    assert all(j.sliding for j in jaws) and jaws[0].coupled_to == "finger_joint2" and jaws[0].ratio == 1.0
    # one motor, the tendon's, whose 100 N split 0.5/0.5 moves the coupled pair by 0.5 + 0.5 per unit of q2
    assert hand.capability.actuators == ("split+", "split-")
    np.testing.assert_allclose(hand.capability.transmission, [[1.0, 1.0]])
    np.testing.assert_allclose(hand.capability.torque_map, [[100.0, -100.0]])
    assert producible(hand, {"finger_joint1": 60.0, "finger_joint2": 40.0})  # the pair shares the motor's force
    assert not producible(hand, {"finger_joint1": 60.0, "finger_joint2": 60.0})
    assert any("1 motor (motors)" in line for line in hand_lines(hand))


def test_a_finger_whose_last_two_joints_one_tendon_pulls(tmp_path):
    path = tmp_path / "shadow_like.xml"
    path.write_text(shadow_like())
    hand = load_hand(path)
    assert set(hand.joint_names) == {"THJ2", "THJ1", "FFJ3", "FFJ2", "FFJ1"}
    assert "FFJ0+" in hand.capability.actuators and not hand.capability.independent_motors
    # the tendon's force reaches J2 and J1 alike (coefficients 1, 1), up to 1 N.m; neither alone
    assert producible(hand, {"FFJ2": 0.6, "FFJ1": 0.6, "FFJ3": 0.9})
    assert not producible(hand, {"FFJ2": 0.6, "FFJ1": 0.2})
    assert not producible(hand, {"FFJ2": 1.2, "FFJ1": 1.2})
    table = joint_table(hand).set_index("joint")
    assert table.loc["FFJ1", "effort"] == "1 N.m (FFJ0)" and table.loc["FFJ3", "effort"] == "1 N.m"
    assert hand.effort_sources["FFJ0"] == "file"


def test_the_physics_scene_pulls_the_tendon_as_the_file_does(tmp_path):
    """The physics check drives the hand with its own actuators, one per motor of the capability: the tendon's
    is a fixed tendon over J2 and J1 with the file's coefficients."""
    import mujoco

    from grasptask.physics.scene import _add_actuators

    path = tmp_path / "shadow_like.xml"
    path.write_text(shadow_like())
    hand = load_hand(path)
    capability = hand.capability
    actuation = np.linalg.pinv(capability.transmission) @ capability.torque_map
    spec = mujoco.MjSpec.from_file(str(path))
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    _add_actuators(spec, hand.joint_names, actuation)
    model = spec.compile()
    data = mujoco.MjData(model)
    tendon = capability.actuators.index("FFJ0+")
    data.ctrl[:] = 0.0
    data.ctrl[tendon] = 1.0
    mujoco.mj_forward(model, data)
    torque = {name: float(data.qfrc_actuator[model.joint(name).dofadr[0]]) for name in hand.joint_names}
    assert torque["FFJ2"] == pytest.approx(1.0) and torque["FFJ1"] == pytest.approx(1.0)
    assert torque["FFJ3"] == pytest.approx(0.0) and torque["THJ1"] == pytest.approx(0.0)


def test_a_spatial_tendon_is_refused_naming_it(tmp_path, cli):
    path = tmp_path / "spatial.xml"
    path.write_text(shadow_like("spatial"))
    with pytest.raises(BadInputError, match="tendon 'FFJ0' is spatial"):
        load_hand(path)
    result = cli("hand", path)
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1


def test_a_tendon_motor_without_force_limit_names_the_efforts_key(tmp_path):
    path = tmp_path / "shadow_like.xml"
    path.write_text(shadow_like().replace('<position name="A_FFJ0" tendon="FFJ0" class="middle_distal"/>',
                                          '<motor name="A_FFJ0" tendon="FFJ0"/>'))  # fmt: skip
    with pytest.raises(BadInputError, match=r"tendon 'FFJ0': its motor's force limit must be positive.*efforts"):
        load_hand(path)
    (tmp_path / "hand.yaml").write_text("model: shadow_like.xml\nefforts: {FFJ0: 0.8}\n")
    hand = load_hand(tmp_path / "hand.yaml")
    assert hand.effort_sources["FFJ0"] == "hand.yaml efforts['FFJ0']"
    assert producible(hand, {"FFJ2": 0.7, "FFJ1": 0.7}) and not producible(hand, {"FFJ2": 0.9, "FFJ1": 0.9})
