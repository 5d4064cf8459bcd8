"""What the lab's devices can report, from the scenario's models: the joint and speed limits
of the master's and the slave's URDFs and the wrist sensor's full scale."""

import numpy as np

from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant, slave_arm
from heft.diagrams.scenario import Scenario
from heft.hardware_interface.message_checks import DeviceLimits


def device_limits(scenario: Scenario) -> DeviceLimits:
    """The ``DeviceLimits`` of ``scenario``'s arm (``slave_arm``: one limit per joint), its master (``master``: a
    bundled one's URDF, every measured joint, actuated or not) and its sensor parameters."""
    master = MakeMasterPlant(scenario.master)
    slave, _ = MakeArmPlant(slave_arm(scenario))
    return DeviceLimits(
        master_lower=master.GetPositionLowerLimits(), master_upper=master.GetPositionUpperLimits(),
        master_velocity=master.GetVelocityUpperLimits(),
        slave_lower=slave.GetPositionLowerLimits(), slave_upper=slave.GetPositionUpperLimits(),
        slave_velocity=slave.GetVelocityUpperLimits(),
        wrench_full_scale=np.asarray(scenario.ft_sensor.full_scale, dtype=float),
        acceleration_full_scale=np.asarray(scenario.accelerometer.full_scale, dtype=float))
