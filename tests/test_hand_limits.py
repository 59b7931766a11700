"""Joint limits as hand files state them, or fail to: a URDF exported from CAD with every effort 0 loads through
a hand YAML's ``efforts`` (by name or pattern), and says where each came from; mimic loops, absurd multipliers,
a NaN velocity and a planar joint in a finger are one line naming the joint, exit 2, before anything runs."""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

from grasptask.errors import BadInputError
from grasptask.hand import load_hand
from grasptask.report.hand_view import hand_lines, joint_table
from tests.test_robot_hands import TWO_FINGERS

BARRETT = Path(__file__).parents[1] / "configs" / "hands" / "barrett_bh8_282.urdf"


def zero_effort_barrett(folder: Path) -> Path:
    """The BarrettHand as a CAD export publishes it: every joint's effort 0."""
    text = re.sub(r'effort="[^"]*"', 'effort="0"', BARRETT.read_text())
    path = folder / "bh_cad.urdf"
    path.write_text(text)
    return path


def test_a_urdf_whose_efforts_are_all_zero_is_refused_naming_the_key(tmp_path, cli):
    path = zero_effort_barrett(tmp_path)
    result = cli("hand", path)
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert "\n" not in line and "bh_cad.urdf" in line and "efforts:" in line and "model: bh_cad.urdf" in line, line


def test_efforts_by_name_and_pattern_load_the_hand_and_say_where_each_came_from(tmp_path):
    zero_effort_barrett(tmp_path)
    yaml = tmp_path / "bh.yaml"
    yaml.write_text('model: bh_cad.urdf\nefforts: {"j*2": 1.5, "j1*": 0.9, j12: 2.0}\nvelocities: {"j*": 1.2}\n')
    hand = load_hand(yaml)
    limits = dict(
        zip(
            [a[:-1] for a in hand.capability.actuators if a.endswith("+")],
            hand.capability.torque_map.max(axis=0),
            strict=False,
        )
    )
    # j12 by its own name; j11 by the later pattern j1*; j22, j32 by j*2; the distal joints mimic their motors
    assert limits["j12"] == pytest.approx(2.0) and limits["j11"] == pytest.approx(0.9)
    assert limits["j22"] == pytest.approx(1.5) and limits["j32"] == pytest.approx(1.5)
    assert hand.effort_sources["j12"] == "bh.yaml efforts['j12']"
    assert hand.effort_sources["j11"] == "bh.yaml efforts['j1*']"
    assert any(line.startswith("motor efforts:") and "bh.yaml efforts['j*2']" in line for line in hand_lines(hand))
    table = joint_table(hand).set_index("joint")
    assert table.loc["j12", "effort from"] == "bh.yaml efforts['j12']" and table.loc["j12", "velocity"] == "1.2 rad/s"
    assert table.loc["j13", "effort from"].startswith("its motor's")
    # the file's own efforts, where it has them, are said as the file's
    assert set(load_hand(BARRETT).effort_sources.values()) == {"file"}


def test_an_effort_pattern_that_matches_no_joint_is_named(tmp_path, cli):
    zero_effort_barrett(tmp_path)
    (tmp_path / "bh.yaml").write_text('model: bh_cad.urdf\nefforts: {"finger_*_prox_joint": 1.0}\n')
    result = cli("hand", tmp_path / "bh.yaml")
    assert result.exit_code == 2
    assert "field 'efforts.finger_*_prox_joint': matches no moving joint (the file has: j32, j33, j11" in result.output
    (tmp_path / "bh.yaml").write_text('model: bh_cad.urdf\nefforts: {"j1*": 1.0}\n')  # j2*, j3* still 0
    result = cli("hand", tmp_path / "bh.yaml")
    assert result.exit_code == 2 and "joint 'j32': effort must be a positive torque" in result.output
    (tmp_path / "bh.yaml").write_text('model: bh_cad.urdf\nefforts: {"j1*": -1.0}\n')
    assert cli("hand", tmp_path / "bh.yaml").exit_code == 2


def _hostile(tmp_path, cli, text: str, *expected: str) -> None:
    path = tmp_path / "hand.urdf"
    path.write_text(text)
    started = time.monotonic()
    result = cli("hand", path)
    assert time.monotonic() - started < 30
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    for part in expected:
        assert part in lines[0], lines[0]


MIMIC = '<axis xyz="0 -1 0"/><mimic joint="{master}" multiplier="{m}" offset="{o}"/>'


def test_mimic_loops_and_absurd_multipliers_are_one_line(tmp_path, cli):
    looped = TWO_FINGERS.replace('<axis xyz="0 1 0"/>', MIMIC.format(master="j2", m=1, o=0).replace("0 -1 0", "0 1 0"))
    looped = looped.replace('<axis xyz="0 -1 0"/>', MIMIC.format(master="j1", m=1, o=0))
    _hostile(tmp_path, cli, looped, "mimic each other in a loop (j1 -> j2 -> j1)")
    for multiplier, said in (("1e308", "mimic multiplier 1e+308 of 'j1' is out of range (0.001 to 1000"),
                             ("0", "mimic multiplier 0 would never move it"),
                             ("nan", "mimic multiplier nan is not a finite number")):  # fmt: skip
        text = TWO_FINGERS.replace('<axis xyz="0 -1 0"/>', MIMIC.format(master="j1", m=multiplier, o=0))
        _hostile(tmp_path, cli, text, "joint 'j2'", said)
    text = TWO_FINGERS.replace('<axis xyz="0 -1 0"/>', MIMIC.format(master="j1", m=1, o=1e6))
    _hostile(tmp_path, cli, text, "mimic offset 1e+06 is beyond 10")


def test_a_nan_velocity_and_a_planar_finger_joint_are_named(tmp_path, cli):
    _hostile(tmp_path, cli, TWO_FINGERS.replace('velocity="1"', 'velocity="nan"', 1), "joint 'j1': velocity nan")
    _hostile(
        tmp_path, cli, TWO_FINGERS.replace('velocity="1"', 'velocity="-2"', 1), "joint 'j1': velocity -2 is negative"
    )
    for kind in ("planar", "floating"):
        text = TWO_FINGERS.replace('<joint name="j2" type="revolute">', f'<joint name="j2" type="{kind}">')
        _hostile(tmp_path, cli, text, f"joint 'j2' is {kind}: only revolute, continuous and prismatic joints")


def test_a_mimic_of_multiplier_zero_is_not_read_as_one(tmp_path):
    path = tmp_path / "hand.urdf"
    path.write_text(TWO_FINGERS.replace('<axis xyz="0 -1 0"/>', MIMIC.format(master="j1", m="-0.5", o="0.1")))
    hand = load_hand(path)
    joint = hand.fingers["f2"].joints[0]
    assert (joint.coupled_to, joint.ratio, joint.coupling_offset) == ("j1", -0.5, 0.1)
    np.testing.assert_allclose(hand.apply_coupling(np.array([0.4, 0.0]))[1], -0.5 * 0.4 + 0.1)
    path.write_text(TWO_FINGERS.replace('<axis xyz="0 -1 0"/>', MIMIC.format(master="j1", m="0", o="0")))
    with pytest.raises(BadInputError, match="multiplier 0 would never move it"):
        load_hand(path)
