"""Identification on hardware: the commander's schedule, and the whole run against
the stand-in over LCM (memq://) with the estimate checked against the station's truth."""

import lcm
import numpy as np
import pytest
from heft.diagrams.device_limits import device_limits
from heft.diagrams.running.hardware_identify import HardwareIdentification, IdentificationAborted
from heft.diagrams.identify import design_excitation, identify
from heft.diagrams.scenario import resolve_scenario
from heft.diagrams.stations.stand_in import FaultInjection, StandIn
from heft.hardware_interface.channels import LcmChannels
from heft.systems.identification.excitation import ExcitationSettings, FourierTrajectory
from heft.systems.identification.excitation_commander import (
    QUINTIC_PEAK_SPEED,
    ExcitationCommander,
    Phase,
    approach_time,
    excitation_command,
)

PERIOD = 0.001
LIMITS = np.array([2.0, 2.0, 3.0, 4.0, 4.0, 5.0])
TRAJECTORY = FourierTrajectory.from_rest_coordinates(
    0.5, np.random.default_rng(3).normal(scale=0.05, size=(6, 3)), [0.1, -0.4, 1.0, 0.2, 0.7, -0.3])
Q_START = np.array([0.4, -0.1, 0.8, -0.2, 0.9, 0.3])


def test_approach_is_a_rest_to_rest_quintic_within_the_speed_limits():
    fraction = 0.2
    duration = approach_time(Q_START, TRAJECTORY.position(0.0), LIMITS, fraction, minimum=0.1)
    t = np.linspace(0.0, duration, 4001)[:-1]  # the approach only
    q = np.array([excitation_command(ti, Q_START, TRAJECTORY, duration, 0.5, 2.0)[0] for ti in t])
    speed = np.abs(np.diff(q, axis=0)) / np.diff(t)[:, None]
    ratio = speed.max(axis=0) / (fraction * LIMITS)
    assert ratio.max() == pytest.approx(1.0, abs=1e-3)  # the slowest-allowed joint sets the time
    np.testing.assert_allclose(q[0], Q_START)
    np.testing.assert_allclose(q[-1], TRAJECTORY.position(0.0), atol=1e-4)
    assert speed[0].max() < 1e-3 and speed[-1].max() < 1e-2  # starts and ends at rest
    s = np.linspace(0.0, 1.0, 1001)
    assert QUINTIC_PEAK_SPEED == pytest.approx(np.max(30 * s**2 * (1 - s) ** 2))  # d/ds of 10s³ − 15s⁴ + 6s⁵


def test_schedule_phases_and_excitation():
    approach, settle, duration = 1.0, 0.5, 2.0
    phases = [excitation_command(t, Q_START, TRAJECTORY, approach, settle, duration)[1]
              for t in (0.0, 0.99, 1.2, 1.5, 2.7, 3.6)]
    assert phases == [Phase.APPROACHING, Phase.APPROACHING, Phase.SETTLING, Phase.EXCITING, Phase.EXCITING,
                      Phase.DONE]
    q, _ = excitation_command(2.7, Q_START, TRAJECTORY, approach, settle, duration)
    np.testing.assert_allclose(q, TRAJECTORY.position(1.2))


def test_commander_waits_for_healthy_hardware_then_aborts_on_a_fault():
    commander = ExcitationCommander(TRAJECTORY, 2.0, LIMITS, settle=0.2, minimum_approach=0.3)
    t = 0.0

    def run(duration, healthy):
        nonlocal t
        for _ in range(round(duration / PERIOD)):
            t += PERIOD
            commander.step(t, healthy, Q_START)

    run(0.5, False)
    np.testing.assert_array_equal(commander.command, Q_START)
    assert commander.phase == Phase.WAITING
    run(0.1, True)
    assert commander.phase == Phase.APPROACHING
    assert commander.elapsed == pytest.approx(0.1 - PERIOD)  # time counts from the first healthy tick
    frozen_at = commander.command.copy()
    run(0.1, False)
    assert commander.phase == Phase.ABORTED
    np.testing.assert_array_equal(commander.command, frozen_at)
    run(0.1, True)  # an aborted run stays aborted: its recording is unusable
    assert commander.phase == Phase.ABORTED


def run_in_process(scenario, trajectory, duration, faults=None):
    """``HardwareIdentification`` against the stand-in on one memq:// bus, both stepped on one
    clock at the controller rate; returns (stand-in, identification run)."""
    bus = lcm.LCM("memq://")
    stand_in = StandIn(scenario, bus, LcmChannels(), faults or FaultInjection())
    period, now = scenario.controller_period, 0.0
    run = HardwareIdentification(trajectory, duration, period, bus, LcmChannels(), device_limits(scenario))
    done = False
    while not done:
        now += period
        stand_in.step(now)
        done = run.tick(now, period)
    return stand_in, run


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["rx90", "iiwa14"])
def test_identification_against_the_stand_in_recovers_the_load(tmp_path, robot):
    """The full path over LCM: stand-in (noise, offsets, accelerometer) ↔ hardware station ↔
    commander, on the RX90 and on the iiwa (its 7 joints on the channels); estimates against the stand-in's
    own truth."""
    scenario = resolve_scenario("fig6", f"{{robot: {robot}}}")
    settings = ExcitationSettings(base_frequency=0.5, harmonics=3, samples=40, constraint_samples=100,
                                  max_iterations=40)
    excitation = design_excitation(scenario, settings)
    stand_in, run = run_in_process(scenario, excitation.trajectory, 2.0)
    recording = run.recording(scenario.controller_period)
    assert recording.q.shape[1] == len(scenario.slave_initial_q)
    metrics = identify(scenario, tmp_path, lambda trajectory, duration: (recording, {}), settings=settings)
    truth = stand_in.phi_true
    tls = metrics["estimates"]["tls"]
    assert tls["phi"][0] == pytest.approx(truth[0], rel=0.01)
    np.testing.assert_allclose(np.asarray(tls["phi"][1:4]) / tls["phi"][0], truth[1:4] / truth[0], atol=2e-3)
    assert (tmp_path / "estimate.yaml").exists()
    # The model explains the measurement down to about the sensor's noise.
    assert max(metrics["residual_rms"]["tls"][:3]) < 5 * max(scenario.ft_sensor.noise_rms[:3])


def test_a_lab_that_dies_during_the_excitation_aborts_with_the_reason():
    scenario = resolve_scenario("fig6")
    stand_in, run = run_in_process(scenario, TRAJECTORY, 2.0, FaultInjection(die_at_s=1.0))
    assert run.commander.phase == Phase.ABORTED
    with pytest.raises(IdentificationAborted, match="faulted at t = 1.0[0-9]* s.*ft_sample"):
        run.recording(scenario.controller_period)
