"""The stand-in's arm (``slave_servo``): its filter and joint servo on the arm's inertia against
Drake's own plant of the arm, and its acceleration when the commands arrive unevenly."""

import numpy as np
from scipy.integrate import solve_ivp
from pydrake.multibody.plant import MultibodyPlant

from heft.diagrams.plants import AddSlave
from heft.diagrams.stations.slave_servo import slave_servo_gains
from test_stand_in import CHANNELS, Lab, quiet_scenario

PERIOD = 1.0 / CHANNELS.slave_status.rate  # s, the arm's step
STROKE = np.array([0.05, -0.05, 0.05, 0.1, -0.1, 0.1])  # rad, each joint's command amplitude


def commands(scenario, scale: float, steps: int) -> np.ndarray:
    """A smooth command from the start pose, (1 − cos) strokes of ``scale``·STROKE at 2 Hz, one per step."""
    t = np.arange(steps) * PERIOD
    return np.asarray(scenario.slave_initial_q) + scale * np.outer(1 - np.cos(2 * np.pi * 2.0 * t), STROKE)


def run_lab(scenario, sent: list[list[np.ndarray]]):
    """The stand-in stepped once per arm period, the commands ``sent[k]`` arriving before step k; its
    joints' q, the filter's q_f and the joints' q̈ after each step."""
    lab = Lab(scenario)
    q, q_f, qdd = [], [], []
    for k, arrivals in enumerate(sent):
        for command in arrivals:
            lab.command_slave(command)
        lab.step((k + 1) * PERIOD)
        q.append(lab.stand_in.slave_position.copy())
        q_f.append(lab.stand_in._slave[0].copy())
        qdd.append(lab.stand_in._qdd.copy())
    return np.array(q), np.array(q_f), np.array(qdd)


def test_the_arm_lags_its_filter_as_drakes_plant_of_the_arm_does():
    """Driven by the same filter, the stand-in's joints lag it as Drake's plant of arm and load does
    under the servo's PD (gravity cancelled, as by the feed-forward; its mass matrix and bias terms
    at every state, integrated by scipy): to within 1 % of the largest lag in a small motion, where
    what the stand-in leaves out (the inertia's change with the pose, the velocity terms) is small."""
    scenario = quiet_scenario({"environment.kind": "none"})
    sent = commands(scenario, 0.01, 400)
    q, q_f, _ = run_lab(scenario, [[command] for command in sent])

    plant = MultibodyPlant(0.0)
    AddSlave(plant, scenario)
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    plant.Finalize()
    context = plant.CreateDefaultContext()
    kp, kd, _ = slave_servo_gains(scenario)
    w = 2 * np.pi * scenario.slave_setpoint_bandwidth

    def dynamics(t, x):
        u = sent[min(int(t / PERIOD + 1e-9), len(sent) - 1)]  # the setpoint held over the step
        filtered, filtered_rate, position, rate = x.reshape(4, 6)
        plant.SetPositions(context, position)
        plant.SetVelocities(context, rate)
        torque = kp * (filtered - position) + kd * (filtered_rate - rate) - plant.CalcBiasTerm(context)
        return np.concatenate((filtered_rate, w * w * (u - filtered) - 2 * w * filtered_rate, rate,
                               np.linalg.solve(plant.CalcMassMatrix(context), torque)))

    start = np.concatenate((sent[0], np.zeros(6), sent[0], np.zeros(6)))
    reference = solve_ivp(dynamics, (0.0, len(sent) * PERIOD), start, t_eval=(np.arange(len(sent)) + 1) * PERIOD,
                          rtol=1e-9, atol=1e-12, max_step=PERIOD).y.reshape(4, 6, -1)
    np.testing.assert_allclose(q_f, reference[0].T, atol=1e-9)  # the same filter
    lag, expected = q - q_f, (reference[2] - reference[0]).T
    assert np.abs(expected).max() > 1e-5  # the servo lags (rad)
    assert np.abs(lag - expected).max() < 0.01 * np.abs(expected).max()


def test_commands_that_arrive_unevenly_step_the_arms_acceleration_far_less_than_its_filters():
    """The same command stream sent one per step, then in pairs every other step (as a stand-in
    running late receives it): the setpoint then moves in double steps. The filter's own acceleration
    q̈_f = ω²(u − q_f) − 2ω·q̇_f, what the arm had without its servo, steps by ω² times each extra
    move; the joints' acceleration behind the servo steps by under a third of that (the servo's
    damping passes some of the filter's velocity on within a step)."""
    scenario = quiet_scenario({"environment.kind": "none"})
    sent = commands(scenario, 1.0, 400)
    _, _, even = run_lab(scenario, [[command] for command in sent])
    paired = [[] if k % 2 == 0 else [sent[k - 1], sent[k]] for k in range(len(sent))]
    _, _, uneven = run_lab(scenario, paired)
    step_even, step_uneven = (np.abs(np.diff(a[100:], axis=0)).max() for a in (even, uneven))
    w = 2 * np.pi * scenario.slave_setpoint_bandwidth
    step_filter = w * w * np.abs(np.diff(sent[100:], axis=0)).max()
    print(f"q̈ steps (rad/s²): {step_even:.2f} even, {step_uneven:.2f} uneven, the filter's {step_filter:.1f}")
    assert step_uneven > 5 * step_even  # the unevenness reaches the arm
    assert step_uneven < 0.3 * step_filter
