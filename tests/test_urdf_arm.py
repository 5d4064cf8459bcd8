"""A lab's own arm from its URDF (diagrams/urdf_arm.py, diagrams/arm_params.py): a 7-DoF arm written here
by hand, in a layout heft did not choose (the base below a pedestal, axes along ±x and ±y, a tool link
past the flange, no transmissions), is read with its limits and its chain serves the inverse kinematics;
a URDF lacking what heft needs is refused in one line naming the joint or link and what is missing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.math import RigidTransform, RollPitchYaw

from heft.diagrams.arm_params import ArmParams
from heft.diagrams.urdf_arm import ArmRefused, read_arm
from heft.systems.controller.chain_inverse_kinematics import ChainIk
from heft.systems.pose_vectors import pose_vector

MODELS = Path(__file__).resolve().parents[1] / "diagrams" / "models"

INERTIAL = ('<inertial><origin xyz="0 0 0.05"/><mass value="{m}"/>'
            '<inertia ixx="0.02" iyy="0.02" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>')
LINKS = ["pedestal", "arm_mount", "turret", "upper", "elbow_housing", "fore", "wrist_a", "wrist_b", "wrist_plate",
         "tool0"]
# (name, type, parent, child, origin xyz, origin rpy, axis, limit attributes)
JOINTS = [
    ("pedestal_to_mount", "fixed", "pedestal", "arm_mount", "0.1 -0.2 0.55", "0 0 0.7", None, None),
    ("yaw_1", "revolute", "arm_mount", "turret", "0 0 0.2", "0 0 0", "0 0 1",
     'lower="-2.9" upper="2.9" velocity="1.7" effort="180"'),
    ("pitch_2", "revolute", "turret", "upper", "0 0 0.15", "0 0 0", "0 -1 0",
     'lower="-2.0" upper="2.0" velocity="1.7" effort="180"'),
    ("roll_3", "revolute", "upper", "elbow_housing", "0 0 0.35", "0 0 0", "0 0 1",
     'lower="-2.9" upper="2.9" velocity="2.2" effort="90"'),
    ("pitch_4", "revolute", "elbow_housing", "fore", "0.02 0 0.05", "0 0 0", "1 0 0",
     'lower="-2.0" upper="2.0" velocity="2.2" effort="90"'),
    ("roll_5", "revolute", "fore", "wrist_a", "-0.02 0 0.3", "0 0 0", "0 0 -1",
     'lower="-2.9" upper="2.9" velocity="2.6" effort="30"'),
    ("pitch_6", "revolute", "wrist_a", "wrist_b", "0 0 0.05", "1.5707963267948966 0 0", "0 1 0",
     'lower="-2.0" upper="2.0" velocity="2.6" effort="30"'),
    ("roll_7", "revolute", "wrist_b", "wrist_plate", "0 -0.08 0", "1.5707963267948966 0 0", "0 0 1",
     'lower="-3.0" upper="3.0" velocity="3.1" effort="30"'),
    ("plate_to_tool", "fixed", "wrist_plate", "tool0", "0 0 0.02", "0 0 0", None, None),
]


def _urdf(joints=JOINTS, extra="") -> str:
    links = "".join(f'<link name="{name}">{INERTIAL.format(m=2.0)}</link>' for name in LINKS)
    text = ""
    for name, kind, parent, child, xyz, rpy, axis, limit in joints:
        text += (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                 f'<origin xyz="{xyz}" rpy="{rpy}"/>' + (f'<axis xyz="{axis}"/>' if axis else "")
                 + (f"<limit {limit}/>" if limit else "") + "</joint>\n")
    return f'<?xml version="1.0"?>\n<robot name="lab_arm">\n{links}\n{text}{extra}</robot>\n'


def _params(path, base="arm_mount", flange="wrist_plate", **kw) -> ArmParams:
    return ArmParams(urdf=str(path), base=base, flange=flange, **kw)


def _with(name, **changes):
    """JOINTS with joint ``name``'s fields changed (type, parent, child, limit)."""
    fields = ("name", "type", "parent", "child", "xyz", "rpy", "axis", "limit")
    return [tuple(changes.get(f, v) for f, v in zip(fields, row)) if row[0] == name else row for row in JOINTS]


def test_a_seven_joint_arm_is_read_with_its_limits(tmp_path):
    (tmp_path / "lab_arm.urdf").write_text(_urdf())
    plant, chain = read_arm(_params("lab_arm.urdf"), relative_to=tmp_path)
    assert [j.name() for j in chain.joints] == ["yaw_1", "pitch_2", "roll_3", "pitch_4", "roll_5", "pitch_6", "roll_7"]
    assert chain.num_joints == 7 and plant.num_positions() == 7
    np.testing.assert_array_equal(chain.lower, [-2.9, -2.0, -2.9, -2.0, -2.9, -2.0, -3.0])
    np.testing.assert_array_equal(chain.upper, -chain.lower)
    np.testing.assert_array_equal(chain.velocity, [1.7, 1.7, 2.2, 2.2, 2.6, 2.6, 3.1])
    np.testing.assert_array_equal(chain.effort, [180, 180, 90, 90, 30, 30, 30])
    assert chain.base.name() == "arm_mount" and chain.flange.name() == "wrist_plate"
    # The base, below the pedestal in the file, is R = W: the pedestal hangs where the weld put it.
    context = plant.CreateDefaultContext()
    X_WR = plant.CalcRelativeTransform(context, plant.world_frame(), chain.base)
    assert X_WR.IsNearlyEqualTo(RigidTransform(), 1e-15)
    X_WP = plant.CalcRelativeTransform(context, plant.world_frame(), plant.GetFrameByName("pedestal"))
    expected = RigidTransform(RollPitchYaw(0, 0, 0.7), [0.1, -0.2, 0.55]).inverse()
    assert X_WP.IsNearlyEqualTo(expected, 1e-15)


def test_the_bundled_arms_pass_the_reader():
    for arm, n in (("ur5e", 6), ("iiwa14", 7)):
        _, chain = read_arm(_params(MODELS / f"{arm}.urdf", base=f"{arm}_base", flange="flange"))
        assert chain.num_joints == n and (chain.effort > 0).all()


def test_params_load_from_yaml_and_take_relative_paths_from_the_scenario(tmp_path):
    params = yaml_load_typed(schema=ArmParams, data=(
        "urdf: arms/lab_arm.urdf\nbase: arm_mount\nflange: wrist_plate\n"
        "X_FS: {translation: [0, 0, 0.03], rotation: !Rpy {deg: [0, 0, 90]}}\n"))
    params.validate()
    assert params.urdf_path(tmp_path) == tmp_path / "arms" / "lab_arm.urdf"
    assert params.urdf_path() == Path("arms/lab_arm.urdf")
    assert Path("/abs/arm.urdf") == ArmParams(urdf="/abs/arm.urdf").urdf_path(tmp_path)
    X_FS = params.X_FS.GetDeterministicValue()
    assert X_FS.IsNearlyEqualTo(RigidTransform(RollPitchYaw(0, 0, np.pi / 2), [0, 0, 0.03]), 1e-15)


BROKEN = {
    "no velocity": (_urdf(_with("roll_3", limit='lower="-2.9" upper="2.9" effort="90"')),
                    ["roll_3", "no velocity"]),
    "no effort": (_urdf(_with("pitch_6", limit='lower="-2" upper="2" velocity="2.6"')), ["pitch_6", "no effort"]),
    "no limit": (_urdf(_with("yaw_1", limit=None)), ["yaw_1", "no <limit>"]),
    "no position limits": (_urdf(_with("pitch_4", limit='velocity="2.2" effort="90"')),
                           ["pitch_4", "no lower and no upper"]),
    "lower above upper": (_urdf(_with("roll_5", limit='lower="1" upper="-1" velocity="2.6" effort="30"')),
                          ["roll_5", "lower below upper"]),
    "infinite limit": (_urdf(_with("roll_5", limit='lower="-inf" upper="1" velocity="2.6" effort="30"')),
                       ["roll_5", "finite"]),
    "zero velocity": (_urdf(_with("pitch_2", limit='lower="-2" upper="2" velocity="0" effort="180"')),
                      ["pitch_2", "velocity='0'", "> 0"]),
    "negative effort": (_urdf(_with("roll_7", limit='lower="-3" upper="3" velocity="3.1" effort="-30"')),
                        ["roll_7", "effort='-30'"]),
    "continuous": (_urdf(_with("roll_7", type="continuous", limit=None)), ["roll_7", "continuous"]),
    "a planar joint": (_urdf(_with("roll_3", type="planar")), ["roll_3", "planar"]),
    "five joints": (_urdf([(*row[:1], "fixed", *row[2:7], None) if row[0] in ("roll_5", "pitch_6") else row
                           for row in JOINTS]), ["has 5 joints", "6 or 7"]),
    "a finger off the chain": (
        _urdf(extra='<link name="finger">' + INERTIAL.format(m=0.1) + '</link><joint name="finger_slide" '
              'type="prismatic"><parent link="wrist_plate"/><child link="finger"/><axis xyz="1 0 0"/>'
              '<limit lower="0" upper="0.04" velocity="0.1" effort="20"/></joint>'),
        ["finger_slide", "finger", "unbranched"]),
}


@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_urdf_lacking_what_heft_needs_is_refused_in_one_line(tmp_path, case):
    text, words = BROKEN[case]
    (tmp_path / "arm.urdf").write_text(text)
    with pytest.raises(ArmRefused) as refusal:
        read_arm(_params(tmp_path / "arm.urdf"))
    message = str(refusal.value)
    assert "\n" not in message and message.startswith(f"arm URDF {tmp_path / 'arm.urdf'}: "), message
    for word in words:
        assert word in message, message


@pytest.mark.parametrize("base, flange, urdf, words", [
    ("arm_mount", "gripper", None, ["no link 'gripper' for the flange", "wrist_plate"]),
    ("wrist_plate", "arm_mount", None, ["'arm_mount' is not below link 'wrist_plate'"]),
    ("arm_mount", "wrist_plate", "<robot><link", ["not readable as XML"]),
    ("arm_mount", "wrist_plate", '<robot name="r"><link name="a"/><joint name="j" type="revolute"><parent link="a"/>'
                                 '<child link="b"/></joint></robot>', ["Drake cannot parse it", "'b'"]),
])
def test_missing_links_and_unreadable_files_are_refused_in_one_line(tmp_path, base, flange, urdf, words):
    (tmp_path / "arm.urdf").write_text(_urdf() if urdf is None else urdf)
    with pytest.raises(ArmRefused) as refusal:
        read_arm(_params(tmp_path / "arm.urdf", base=base, flange=flange))
    message = str(refusal.value)
    assert "\n" not in message, message
    for word in words:
        assert word in message, message


def test_a_missing_file_and_empty_fields_are_refused(tmp_path):
    with pytest.raises(ArmRefused, match="no such file"):
        read_arm(_params(tmp_path / "none.urdf"))
    with pytest.raises(ArmRefused, match="^arm: flange must name a link"):
        read_arm(ArmParams(urdf="x.urdf", base="b"))


def test_the_chain_read_serves_the_inverse_kinematics(tmp_path):
    (tmp_path / "lab_arm.urdf").write_text(_urdf())
    plant, chain = read_arm(_params("lab_arm.urdf"), relative_to=tmp_path)
    q0 = np.array([0.2, 0.5, -0.3, 0.9, 0.4, -0.6, 0.1])
    ik = ChainIk(plant, chain.base, chain.flange, q0, lower=chain.lower, upper=chain.upper, velocity=chain.velocity)
    context = plant.CreateDefaultContext()

    def X_RF(q):
        plant.SetPositions(context, q)
        return plant.CalcRelativeTransform(context, chain.base, chain.flange)

    q, period = q0.copy(), 0.0005
    for k in range(400):
        X_target = X_RF(q0 + 0.2 * np.sin(np.pi * k * period + np.arange(7)) - 0.2 * np.sin(np.arange(7)))
        assert ik(pose_vector(X_target), q, period, q) == 0
        X = X_RF(q)
        assert np.abs(X.GetAsMatrix4() - X_target.GetAsMatrix4()).max() < 1e-8
