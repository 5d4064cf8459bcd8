"""The load estimator in the loop of Fig. 4, wired into the controller Diagram
(``MakeTeleopController`` with ``controller.estimator.mode: online``; docs/design.md §3)."""

from pydrake.systems.framework import DiagramBuilder, OutputPort

from heft.systems.accelerometer_reading import AccelerometerConvention, AccelerometerToMotion
from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.controller.estimator_gate import EstimatorGate
from heft.systems.controller.estimator_prefilter import EstimatorPrefilter
from heft.systems.controller.load_estimation_params import LoadEstimationParams
from heft.systems.controller.load_model import GraspSplit
from heft.systems.controller.rest_learner import RestLearner
from heft.systems.controller.rls_load_estimator import RlsLoadEstimator
from heft.systems.identification.regression_noise import NoiseLevels
from heft.systems.tick_system import TickSum


def AddOnlineLoadEstimator(builder: DiagramBuilder, params: LoadEstimationParams, contact: ContactThresholdParams,
                           phi, period: float, accelerometer: AccelerometerConvention, force_scaling, slave_kinematics,
                           offsets, phi_gripper) -> OutputPort:
    """Adds the online estimator of φ̂ (10), starting from ``phi``, to ``builder`` and returns its
    output: ``AccelerometerToMotion`` (the reading in ``accelerometer``'s convention → S's
    kinematic [a; α]), ``EstimatorGate`` (which samples it takes: their excitation judged on the
    prefiltered motion, contact by ``contact``), ``EstimatorPrefilter`` (unless ``params.prefilter`` is 0),
    ``RlsLoadEstimator`` and ``RestLearner`` (a grasp held still: the object's weight and static moment from the
    same inputs, handed to the estimator), ticking every ``period`` s. φ alone is
    estimated, from f − ô = c + V·φ̂ (``force_scaling``'s outputs): the offsets are the
    OffsetTracker's, so the weight cannot trade against the force offsets. ``slave_kinematics``
    gives ω and g in S. ``GraspSplit`` (``phi_gripper`` the scenario's φ_gr or None) splits φ̂ for
    ``force_scaling`` at a grasp and asks the estimator for a new load, or to restart from a new estimate, whose
    offsets it passes to ``offsets`` (the ``OffsetTracker``) for the same tick. Reads the Diagram input
    ``ft.acceleration_measured`` (exported already) and exports ``estimate`` (a new tool's), ``holding`` (1: the gripper
    holds an object), ``estimator_reset`` (1, a request counter: a new load) and
    ``input_age`` (1, s: the oldest reading's age; the gate refuses readings older than
    ``params.max_input_age``)."""
    to_motion = builder.AddNamedSystem("accelerometer_to_motion", AccelerometerToMotion(accelerometer))
    estimator = builder.AddNamedSystem("phi_hat", RlsLoadEstimator(params, phi, period))
    unbiased = builder.AddNamedSystem("wrench_without_offsets", TickSum(6))
    gate = builder.AddNamedSystem("estimator_gate", EstimatorGate(params, contact, period))
    omega, gravity = slave_kinematics.GetOutputPort("omega_S"), slave_kinematics.GetOutputPort("gravity_S")

    connect = builder.Connect
    builder.ConnectInput("ft.acceleration_measured", to_motion.GetInputPort("reading"))
    grasp = builder.AddNamedSystem("grasp", GraspSplit(phi_gripper, period))
    builder.ExportInput(grasp.GetInputPort("holding"), "holding")
    builder.ExportInput(grasp.GetInputPort("reset"), "estimator_reset")
    builder.ExportInput(grasp.GetInputPort("estimate"), "estimate")
    connect(grasp.GetOutputPort("estimate"), offsets.GetInputPort("estimate"))
    builder.ExportInput(gate.GetInputPort("input_age"), "input_age")
    connect(estimator.GetOutputPort("phi"), grasp.GetInputPort("phi"))
    connect(grasp.GetOutputPort("estimator_reset"), estimator.GetInputPort("reset"))
    connect(grasp.GetOutputPort("estimator_reset"), gate.GetInputPort("reset"))
    connect(grasp.GetOutputPort("estimator_restart"), estimator.GetInputPort("restart"))
    connect(grasp.GetOutputPort("phi_gripper"), force_scaling.GetInputPort("phi_gripper"))
    connect(grasp.GetOutputPort("split"), force_scaling.GetInputPort("split"))
    connect(force_scaling.GetOutputPort("wrench_contact"), unbiased.GetInputPort("u0"))
    connect(force_scaling.GetOutputPort("wrench_noncontact"), unbiased.GetInputPort("u1"))
    connect(gravity, to_motion.GetInputPort("gravity"))
    connect(omega, to_motion.GetInputPort("omega"))
    connect(force_scaling.GetOutputPort("wrench_contact"), gate.GetInputPort("wrench_contact"))
    connect(force_scaling.GetOutputPort("fault"), gate.GetInputPort("fault"))
    connect(gate.GetOutputPort("enable"), estimator.GetInputPort("enable"))

    inputs = {"wrench": unbiased.get_output_port(), "acceleration": to_motion.GetOutputPort("acceleration"),
              "omega": omega, "gravity": gravity}
    if params.prefilter > 0:
        prefilter = builder.AddNamedSystem("estimator_prefilter", EstimatorPrefilter(params.prefilter, period))
        for name, source in inputs.items():
            connect(source, prefilter.GetInputPort(name))
        inputs = {name: prefilter.GetOutputPort(name) for name in inputs}
    for name, source in inputs.items():
        connect(source, estimator.GetInputPort(name))
    for name in ("acceleration", "omega"):  # the excitation of the sample learned from
        connect(inputs[name], gate.GetInputPort(name))
    rest = builder.AddNamedSystem("rest_learner", RestLearner(params, period, NoiseLevels()))
    for name, source in inputs.items():
        connect(source, rest.GetInputPort(name))
    connect(estimator.GetOutputPort("phi"), rest.GetInputPort("phi"))
    connect(grasp.GetOutputPort("new_load"), rest.GetInputPort("grasps"))
    connect(grasp.GetOutputPort("estimator_reset"), rest.GetInputPort("resets"))
    connect(rest.GetOutputPort("sample"), estimator.GetInputPort("rest"))
    return estimator.GetOutputPort("phi")
