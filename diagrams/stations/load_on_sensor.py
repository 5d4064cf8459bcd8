"""Drake's own answer for the wrench at a wrist sensor: a free-floating sensor
body with a load welded at the sensor frame S, read through the plant's
``reaction_forces`` port. The independent reference for Eqs. 1–5."""

from __future__ import annotations

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import MultibodyForces, RotationalInertia, SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Adder, ConstantVectorSource, MatrixGain, Sine

from heft.systems.drake_conventions import wrench_from_spatial_force
from heft.systems.load_dynamics import GRAVITY_W, InertialParameters

# A JR3-sized aluminium puck (85 mm × 35 mm); only there so the sensor body has mass.
_SENSOR_INERTIA = SpatialInertia.SolidCylinderWithMass(0.55, 0.0425, 0.035, [0.0, 0.0, 1.0])


def spatial_inertia(load: InertialParameters) -> SpatialInertia:
    """Drake's SpatialInertia about S's origin, expressed in S, of ``load``."""
    I = load.inertia_com
    central = RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    return SpatialInertia.MakeFromCentralInertia(load.mass, load.com, central)


class LoadOnSensorPlant:
    """A continuous MultibodyPlant: world —(free joint)— sensor —(weld at S)— load.

    The sensor body's frame is S. State q = [quaternion R_WS (w,x,y,z); p_WS],
    v = [ω_WS_W; v_WS_W] (Drake's QuaternionFloatingJoint).
    """

    def __init__(self, load: InertialParameters, gravity_W=GRAVITY_W):
        load.require_physical("load")
        self.load = load
        plant = MultibodyPlant(time_step=0.0)
        self.sensor = plant.AddRigidBody("sensor", _SENSOR_INERTIA)
        self.load_body = plant.AddRigidBody("load", spatial_inertia(load))
        self.weld = plant.WeldFrames(self.sensor.body_frame(), self.load_body.body_frame(), RigidTransform())
        plant.mutable_gravity_field().set_gravity_vector(np.asarray(gravity_W, dtype=float))
        plant.Finalize()
        self.plant = plant
        self._context = plant.CreateDefaultContext()
        self._tau_port = plant.get_applied_generalized_force_input_port()

    def reaction_wrench(self, q, v, vdot) -> np.ndarray:
        """[f; τ] the sensor exerts on the load at S, in S, when the plant moves with
        (q, v, v̇): the generalized force that produces v̇ is applied, then the weld's
        reaction is read from the plant's forward dynamics."""
        plant, context = self.plant, self._context
        plant.SetPositions(context, q)
        plant.SetVelocities(context, v)
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        self._tau_port.FixValue(context, plant.CalcInverseDynamics(context, vdot, forces))
        reactions = plant.get_reaction_forces_output_port().Eval(context)
        return wrench_from_spatial_force(reactions[int(self.weld.index())])

    def motion_in_S(self, q, v, vdot):
        """(a, α, ω, g) of S, all expressed in S, for the given state and v̇."""
        plant, context = self.plant, self._context
        plant.SetPositions(context, q)
        plant.SetVelocities(context, v)
        A_WS_W = plant.CalcSpatialAccelerationsFromVdot(context, vdot)[int(self.sensor.index())]
        R_SW = plant.EvalBodyPoseInWorld(context, self.sensor).rotation().matrix().T
        omega_W = plant.EvalBodySpatialVelocityInWorld(context, self.sensor).rotational()
        g_W = plant.gravity_field().gravity_vector()
        return (R_SW @ A_WS_W.translational(), R_SW @ A_WS_W.rotational(), R_SW @ omega_W, R_SW @ g_W)

    def random_state(self, rng: np.random.Generator, scale: float = 3.0):
        """An arbitrary (q, v, v̇): uniform random orientation, normal v and v̇ of ``scale``."""
        quaternion = rng.normal(size=4)
        q = np.concatenate((quaternion / np.linalg.norm(quaternion), rng.normal(size=3)))
        return q, scale * rng.normal(size=6), scale * rng.normal(size=6)


def simulate_random_motion(load: InertialParameters, rng: np.random.Generator, duration: float = 2.0,
                           sample_period: float = 1e-3, gravity_W=GRAVITY_W):
    """Simulates the free sensor+load driven by random sinusoidal generalized forces
    (gravity's force cancelled, viscous damping on v) and samples, every ``sample_period`` s,
    the weld's reaction wrench (N, 6) and a, α, ω, g of S in S (N, 3 each), with v̇
    from the plant's own forward dynamics. Returns (t, wrench, a, alpha, omega, g)."""
    reference = LoadOnSensorPlant(load, gravity_W)
    plant = reference.plant
    builder = DiagramBuilder()
    builder.AddSystem(plant)
    total_mass = load.mass + _SENSOR_INERTIA.get_mass()
    hover = np.concatenate((np.zeros(3), -total_mass * plant.gravity_field().gravity_vector()))
    sine = builder.AddSystem(Sine(amplitudes=rng.uniform(0.5, 3.0, 6) * [1, 1, 1, 20, 20, 20],
                                  frequencies=2 * np.pi * rng.uniform(1.0, 8.0, 6),
                                  phases=rng.uniform(0, 2 * np.pi, 6)))
    # Viscous damping on v keeps the tumble bounded (the gravity torque is not cancelled).
    damping = builder.AddSystem(MatrixGain(np.hstack((np.zeros((6, 7)), -np.diag([1, 1, 1, 20, 20, 20])))))
    builder.Connect(plant.get_state_output_port(), damping.get_input_port())
    adder = builder.AddSystem(Adder(3, 6))
    builder.Connect(sine.get_output_port(0), adder.get_input_port(0))
    builder.Connect(builder.AddSystem(ConstantVectorSource(hover)).get_output_port(),
                    adder.get_input_port(1))
    builder.Connect(damping.get_output_port(), adder.get_input_port(2))
    builder.Connect(adder.get_output_port(), plant.get_applied_generalized_force_input_port())
    simulator = Simulator(builder.Build())
    plant_context = plant.GetMyContextFromRoot(simulator.get_mutable_context())
    q0, v0, _ = reference.random_state(rng, scale=1.0)
    plant.SetPositions(plant_context, q0)
    plant.SetVelocities(plant_context, v0)
    simulator.get_mutable_integrator().set_target_accuracy(1e-8)
    times = np.arange(1, int(round(duration / sample_period)) + 1) * sample_period
    wrench, a, alpha, omega, g = (np.empty((len(times), n)) for n in (6, 3, 3, 3, 3))
    reaction_port = plant.get_reaction_forces_output_port()
    vdot_port = plant.get_generalized_acceleration_output_port()
    weld = int(reference.weld.index())
    for k, t in enumerate(times):
        simulator.AdvanceTo(t)
        wrench[k] = wrench_from_spatial_force(reaction_port.Eval(plant_context)[weld])
        a[k], alpha[k], omega[k], g[k] = reference.motion_in_S(
            plant.GetPositions(plant_context), plant.GetVelocities(plant_context),
            vdot_port.Eval(plant_context))
    return times, wrench, a, alpha, omega, g
