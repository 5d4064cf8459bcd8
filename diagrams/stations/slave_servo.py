"""The robot's own joint servo, as heft's stations model it.

Both stations drive the arm through the robot controller's setpoint filter
(``systems/station/setpoint_filter.py``) and then a stiff joint PD with gravity feed-forward:
τ = Kp·(q_f − q) + Kd·(q̇_f − q̇) + g(q), Kp the scenario's ``slave_servo_stiffness`` (or, where it states
none, M_jj·(2π·``SERVO_FREQUENCY``)²) and
Kd = 2ζ·√(Kp·M_jj) for the damping ratio ζ (``slave_servo_damping_ratio``) at each joint's
inertia M_jj (kg·m², the mass matrix's diagonal of arm and payload in the start pose)
(``slave_servo_gains``). The simulated station gives these gains to the plant's implicit PD.

The stand-in runs the filter and the servo on the arm's inertia in the start pose, M, the
gravity cancelled by the feed-forward: M·q̈ = Kp·(q_f − q) + Kd·(q̇_f − q̇), linear, stepped
exactly (``servo_step_matrices``, ``servo_step``); it leaves out the inertia's change with the pose
and the Coriolis and centrifugal torques. What this keeps of the plant is what matters to the
wrench at the wrist: the arm lags its filter as Drake's plant of it does, the joints pulling on each
other, and its acceleration stays continuous when the command jumps (a command that arrives late, or
two at once), as a real arm's does, instead of stepping with the filter's input.
"""

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from scipy.linalg import expm

from heft.diagrams.arm_params import SERVO_FREQUENCY
from heft.diagrams.plants import AddSlave
from heft.diagrams.scenario import Scenario
from heft.systems.compiled import compiled
from heft.systems.station.setpoint_filter import critically_damped_dynamics

SERVO_ROWS = 4
"""The rows of the arm's state in ``servo_step``: the filter's q_f, q̇_f and the joints' q, q̇ (rad, rad/s)."""


def slave_servo_gains(scenario: Scenario) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The joint servo's stiffness Kp (N·m/rad), damping Kd (N·m·s/rad) and the mass matrix M (kg·m²)
    they are sized at: arm and payload welded at S (``AddSlave``), in the start pose."""
    plant = MultibodyPlant(time_step=0.0)
    parts = AddSlave(plant, scenario)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, scenario.slave_initial_q)
    mass_matrix = plant.CalcMassMatrix(context)
    kp = np.asarray(scenario.slave_servo_stiffness or np.diag(mass_matrix) * (2 * np.pi * SERVO_FREQUENCY) ** 2,
                    dtype=float)
    if kp.shape != (parts.chain.num_joints,):
        raise ValueError(f"scenario field 'slave_servo_stiffness' needs {parts.chain.num_joints} gains (N·m/rad), "
                         f"one per joint, or none (ringing at {SERVO_FREQUENCY:g} Hz); got {kp.size}")
    return kp, 2 * scenario.slave_servo_damping_ratio * np.sqrt(kp * np.diag(mass_matrix)), mass_matrix


def servo_step_matrices(bandwidth_hz: float, kp, kd, mass_matrix, period: float):
    """The filter and the servo over ``period`` s with the setpoint u held, exactly: A (4n, 4n) steps the
    state [q_f; q̇_f; q; q̇] (flattened) as its deviation from rest at u, [u; 0; u; 0], for each
    joint's setpoint filter (``critically_damped_dynamics``) and M·q̈ = Kp·(q_f − q) + Kd·(q̇_f − q̇);
    C (n, 4n) gives q̈ = C·state (also of the deviation: C·[u; 0; u; 0] = 0)."""
    kp, kd = np.diag(np.asarray(kp, dtype=float)), np.diag(np.asarray(kd, dtype=float))
    n = kp.shape[0]
    C = np.linalg.solve(mass_matrix, np.hstack((kp, kd, -kp, -kd)))
    continuous = np.zeros((SERVO_ROWS * n, SERVO_ROWS * n))
    # The filter on every joint (its input term drops out of the deviation from rest), then the servo.
    continuous[:2 * n, :2 * n] = np.kron(critically_damped_dynamics(bandwidth_hz)[0], np.eye(n))
    continuous[2 * n:3 * n, 3 * n:] = np.eye(n)
    continuous[3 * n:] = C
    return expm(continuous * period), C


@compiled("void(float64[:, :], float64[:, :], float64[:], float64[:], float64[:], float64[:, :], float64[:], "
          "float64[:])")
def servo_step(A, C, max_step, command, setpoint, state, deviation, acceleration) -> None:
    """The arm one status step on, in place: the ``setpoint`` u (rad) moves toward the ``command`` by at
    most ``max_step`` (rad, each joint; the controller's speed limits), the ``state`` [q_f; q̇_f; q; q̇]
    (4, n) steps on it (``servo_step_matrices``: A, C; at rest at u it stays exactly there) and
    ``acceleration`` is the joints' q̈ (rad/s²) at the new state. ``deviation`` (4n) is working space."""
    n = setpoint.shape[0]
    for j in range(n):
        setpoint[j] += min(max(command[j] - setpoint[j], -max_step[j]), max_step[j])
        acceleration[j] = 0.0
        for row in range(SERVO_ROWS):
            deviation[row * n + j] = state[row, j] - (setpoint[j] if row % 2 == 0 else 0.0)
    for i in range(SERVO_ROWS * n):
        stepped = 0.0
        for k in range(SERVO_ROWS * n):
            stepped += A[i, k] * deviation[k]
        row, j = divmod(i, n)
        state[row, j] = stepped + (setpoint[j] if row % 2 == 0 else 0.0)
        for m in range(n):
            acceleration[m] += C[m, i] * stepped
