"""The single-axis linear model's parameters (`heft.analysis.linear_teleoperator`) from a Scenario.

Where each number comes from, at the operating point ``slave_initial_q`` /
``master_initial_q`` of the simulated station (`MakeSimStation`: its own plants, so
the model sees what the simulation simulates):

- axis: the slave's sensor frame S along W's z (the sheet spring's direction of motion);
  the stylus E along R_RBᵀ·z in the master base B (what the motion scaling maps onto it).
- master_mass m_m = 1/(a·J M⁻¹ Jᵀ·a): the mass the hand feels pushing the free stylus
  along a, from the master plant's mass matrix M (Phantom links plus the operator's hand
  mass welded to the stylus) and E's translational Jacobian J in B.
- master_damping b_m = m_m²·a·J M⁻¹ D M⁻¹ Jᵀ·a with D the URDF's joint damping: the power
  q̇ᵀDq̇ the joints dissipate while the stylus moves along a as the free device does.
- slave_mass, slave_stiffness, slave_damping: the arm (with sensor and load) and its
  implicit joint PD servo projected on δq = J_S⁻¹·[0; e_z], the joint motion the
  inverse kinematics commands for a z step of S at fixed orientation (J_S the 6×6
  spatial Jacobian of S in W, [ω; v] rows): m_s = δqᵀMδq, K_s = δqᵀK_pδq, B_s = δqᵀK_dδq,
  with K_p, K_d the station's PdControllerGains read back from its plant.
- load_mass: the mass of the bodies welded below S, from the plant's spatial inertia.
- hand_stiffness, hand_damping: ``scenario.operator`` (translational).
- translation_scale, force_scale, sigma, gamma, mount_notch, mount_notch_quality:
  ``scenario.controller`` (motion k_t, feedback k_f, force σ, γ and the notch on c). The
  model has no compliant mount: the notch enters with its phase only.
- environment_stiffness, environment_damping: ``scenario.environment`` (the sheet
  spring, in contact, even for a scenario whose environment is "none"; the ball-plate contact,
  2·10⁵ N/m, is taken as rigid and the plate's mass, tens of grams against tens of kilograms of
  arm, as zero).
- period: ``scenario.controller_period``; setpoint_bandwidth: ``slave_setpoint_bandwidth``.
- forward_delay_ticks = 2: motion scaling and inverse kinematics each hold their result
  as state for one tick (`MotionScaling`, `SlaveInverseKinematics`) before the setpoint
  filter reads it. feedback_delay_ticks = 2: the wrist sensor's sample is state
  (`ForceTorqueSensorModel`), and so is the PO/PC's torque (`PassivityController`).
  Both plants then read these one tick later (their step equals the controller period).
"""

import dataclasses

import numpy as np
from heft.analysis.linear_teleoperator import LinearTeleoperatorParams
from heft.diagrams.scenario import Scenario
from heft.diagrams.plants import MakeSlavePlant
from heft.diagrams.stations.sim_station import MakeSimStation
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.multibody.tree import JacobianWrtVariable, JointActuatorIndex

SLAVE_AXIS_W = np.array([0.0, 0.0, 1.0])


@dataclasses.dataclass
class OperatingPoint:
    """Effective single-axis quantities of the station's plants (SI; module docstring)."""
    master_mass: float
    master_damping: float
    slave_mass: float
    slave_stiffness: float
    slave_damping: float
    load_mass: float
    slave_free_mass: float      # 1/(e_z·J M⁻¹ Jᵀ·e_z) of S with the servo off, for reference


def _master_axis_quantities(plant, scenario: Scenario, axis_B: np.ndarray) -> tuple[float, float]:
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, scenario.master_initial_q)
    B, E = plant.GetFrameByName("phantom_base"), plant.GetFrameByName("stylus")
    J = axis_B @ plant.CalcJacobianTranslationalVelocity(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
    M_inv_Jt = np.linalg.solve(plant.CalcMassMatrix(context), J)
    mass = 1.0 / float(J @ M_inv_Jt)
    D = np.zeros(plant.num_velocities())
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        if joint.num_velocities():
            D[joint.velocity_start():joint.velocity_start() + joint.num_velocities()] = joint.GetDampingVector(context)
    return mass, mass ** 2 * float(M_inv_Jt @ (D * M_inv_Jt))


def operating_point(scenario: Scenario) -> OperatingPoint:
    """The station's plants reduced to the model's axis at the scenario's start pose."""
    scenario.validate()
    station = MakeSimStation(scenario)
    axis_B = RotationMatrix(RollPitchYaw(scenario.controller.motion.R_RB)).inverse() @ SLAVE_AXIS_W
    master_mass, master_damping = _master_axis_quantities(station.GetSubsystemByName("master_plant"),
                                                          scenario, axis_B)

    slave = station.GetSubsystemByName("slave_plant")
    arm = slave.GetModelInstanceByName(scenario.robot)
    gains = [slave.get_joint_actuator(JointActuatorIndex(i)).get_controller_gains()
             for i in range(slave.num_actuators())
             if slave.get_joint_actuator(JointActuatorIndex(i)).model_instance() == arm]
    kp, kd = np.array([g.p for g in gains]), np.array([g.d for g in gains])
    context = slave.CreateDefaultContext()
    slave.SetPositions(context, arm, scenario.slave_initial_q)
    arm_v = slave.GetVelocitiesFromArray(arm, np.arange(slave.num_velocities())).astype(int)
    M = slave.CalcMassMatrix(context)[np.ix_(arm_v, arm_v)]
    S, W = slave.GetFrameByName("S"), slave.world_frame()
    J = slave.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, S, np.zeros(3), W, W)[:, arm_v]
    dq = np.linalg.solve(J, np.concatenate((np.zeros(3), SLAVE_AXIS_W)))
    free_mass = 1.0 / float(J[3:][2] @ np.linalg.solve(M, J[3:][2]))

    # The load below S, as the station models it (a fresh plant with the same AddSlave).
    load_plant, parts = MakeSlavePlant(scenario)
    load_mass = load_plant.CalcTotalMass(load_plant.CreateDefaultContext(),
                                         list({b.model_instance() for b in parts.load_bodies}))
    return OperatingPoint(master_mass, master_damping, float(dq @ M @ dq), float(dq @ (kp * dq)),
                          float(dq @ (kd * dq)), float(load_mass), free_mass)


def linear_model_params(scenario: Scenario, environment_stiffness: float | None = None,
                        point: OperatingPoint | None = None) -> LinearTeleoperatorParams:
    """`LinearTeleoperatorParams` for ``scenario`` (module docstring), with the sheet spring's
    stiffness replaced by ``environment_stiffness`` (N/m) if given. ``point`` reuses an
    `operating_point` already computed for the same scenario."""
    if scenario.plant.time_step != scenario.controller_period:
        raise ValueError(f"the linear model assumes plant.time_step == controller_period (the plants read the "
                         f"controller once per tick); got {scenario.plant.time_step} and {scenario.controller_period}")
    if environment_stiffness is not None and not environment_stiffness > 0:
        raise ValueError(f"environment_stiffness must be > 0 (N/m); got {environment_stiffness}")
    point = point or operating_point(scenario)
    controller = scenario.controller
    return LinearTeleoperatorParams(
        master_mass=point.master_mass, master_damping=point.master_damping,
        hand_stiffness=scenario.operator.stiffness, hand_damping=scenario.operator.damping,
        translation_scale=controller.motion.translation_scale, force_scale=controller.feedback.force_scale,
        slave_mass=point.slave_mass, slave_stiffness=point.slave_stiffness, slave_damping=point.slave_damping,
        load_mass=point.load_mass,
        environment_stiffness=(scenario.environment.stiffness if environment_stiffness is None
                               else float(environment_stiffness)),
        environment_damping=scenario.environment.damping, period=scenario.controller_period,
        setpoint_bandwidth=scenario.slave_setpoint_bandwidth, sigma=controller.force.sigma,
        gamma=controller.force.gamma, mount_notch=controller.force.mount_notch,
        mount_notch_quality=controller.force.mount_notch_quality, master_filter=controller.motion.master_filter,
        master_notch=controller.motion.master_notch, master_notch_quality=controller.motion.master_notch_quality,
        communication_delay_ticks=round(controller.delay / scenario.controller_period)).validate()
