"""`heft analyze passivity` on a real simulated log."""

import argparse
import dataclasses
import json

import numpy as np
import pytest

from heft.diagrams.commands import analyze_passivity
from heft.diagrams.running.simulation import true_load
from heft.diagrams.scenario import NOISE_OFF, overrides_text, resolve_scenario
from heft.diagrams.running.simulation import run_teleop, with_sigma
from heft.systems.controller.passivity_controller import PassivityParams


@pytest.fixture(scope="module")
def log_path(tmp_path_factory):
    """0.5 s of the fig8 scenario (the tool strikes the sheet spring at about 0.22 s)."""
    scenario = resolve_scenario("fig8", overrides_text({**NOISE_OFF, "duration": 0.5}))
    load, _ = true_load(scenario)
    path = tmp_path_factory.mktemp("passivity") / "log.npz"
    np.savez(path, **run_teleop(with_sigma(scenario, 1.0), load, quiet=True))
    return path


def run_command(argv):
    parser = argparse.ArgumentParser()
    analyze_passivity.add_arguments(parser)
    return analyze_passivity.run(parser.parse_args(argv))


def test_command_writes_report_consistent_with_the_log(log_path, tmp_path, capsys):
    assert run_command([str(log_path), "--out", str(tmp_path)]) == 0
    assert "PC:" in capsys.readouterr().out
    assert (tmp_path / "passivity.png").stat().st_size > 0
    report = json.loads((tmp_path / "passivity.json").read_text())
    log = dict(np.load(log_path))
    observed = log["passivity_energy"]
    for port in report["master_port"].values():
        # The observer's energy is the port energy, computed here from the logged master
        # angles, velocities and wrench, plus what the PC dissipated: to rounding.
        throughput = port["energy_in_J"] + port["energy_out_J"]
        assert throughput > 0
        assert port["observer_identity_gap_J"] < 1e-9 + 1e-9 * throughput
        assert port["final_J"] == pytest.approx(port["energy_in_J"] - port["energy_out_J"], abs=1e-12)
    # The sheet spring stores or dissipates what the tool does to it: net energy into it.
    environment = report["environment_port"]
    assert environment["energy_in_J"] > 0.01 and environment["final_J"] > -1e-3
    # The PC leaves a deficit only while its damping sits at the bound.
    bounds = PassivityParams()
    for i, bound in enumerate((bounds.max_translational_damping, bounds.max_rotational_damping)):
        deficit = observed[:, i] < -1e-12
        np.testing.assert_allclose(log["passivity_damping"][deficit, i], bound)


def test_missing_keys_are_named(tmp_path):
    path = tmp_path / "log.npz"
    np.savez(path, t=np.arange(5.0))
    with pytest.raises(ValueError, match="master_q"):
        run_command([str(path)])
    with pytest.raises(ValueError, match="no log"):
        run_command([str(tmp_path / "absent.npz")])


def test_passivity_params_unchanged_by_scenario():
    # The bounds the test above checks against are the scenario's own.
    assert dataclasses.asdict(resolve_scenario("fig8").controller.passivity) == dataclasses.asdict(PassivityParams())


def test_what_the_clamp_withheld_is_counted_where_the_log_has_the_applied_wrench():
    """A hardware log carries the wrench applied on the hand after the device's clamp. The energy the hand
    put into the network is then −Σ f_applied·v·T (written out here), which the analysis finds as the port's
    energy of the desired wrench, plus what the PC dissipated, plus what the clamp withheld; and the
    observer, which counts the withheld power back, agrees with it."""
    rng = np.random.default_rng(9)
    ticks, period = 400, 5e-4
    q = np.array([0.1, 0.2, -0.3, 0.1, 0.2, 0.1]) + 0.1 * np.sin(np.linspace(0, 3, ticks))[:, None]
    v = rng.normal(0, 1.0, (ticks, 6))
    desired = rng.normal(0, 6.0, (ticks, 6)) * np.array([1, 1, 1, 0.02, 0.02, 0.02])
    damping = np.abs(rng.normal(0, [5.0, 0.01], (ticks, 2))) * (rng.uniform(size=(ticks, 1)) < 0.5)
    twist = analyze_passivity.stylus_twists(q, v)
    unclamped = desired - np.repeat(damping, 3, axis=1) * twist
    applied = unclamped.copy()
    for part, limit in ((slice(0, 3), 8.5), (slice(3, 6), 0.188)):
        norm = np.linalg.norm(unclamped[:, part], axis=1, keepdims=True)
        applied[:, part] *= np.minimum(1.0, limit / norm)
    assert (applied != unclamped).any(axis=1).mean() > 0.2  # the clamp acts on many ticks
    delivered = np.stack([-(applied[:, part] * twist[:, part]).sum(1) for part in (slice(0, 3), slice(3, 6))], 1)
    log = {"t": np.arange(ticks) * period, "hold": np.full(ticks, period), "master_q": q, "master_v": v,
           "master_force": desired, "master_force_applied": applied, "passivity_damping": damping,
           "passivity_energy": np.cumsum(delivered * period, axis=0)}
    report = analyze_passivity.analyze_log(log, observer_lag=0)
    for i, channel in enumerate(("translational", "rotational")):
        pc = report["passivity_controller"]
        withheld = pc[f"{channel}_clamp_withheld_J"]
        analysed = report["master_port"][channel]["final_J"] + pc[f"{channel}_dissipated_J"] + withheld
        assert withheld != 0.0
        assert analysed == pytest.approx(delivered[:, i].sum() * period, rel=1e-12, abs=1e-15)
        assert report["master_port"][channel]["observer_identity_gap_J"] < 1e-12


@pytest.mark.parametrize("robot", ["rx90", "ur5e", "iiwa14"])
def test_the_sensors_twist_is_drakes_on_every_bundled_arm(robot):
    """[v_S; ω_S] in S from the logged angles equals Drake's spatial velocity of S at the true joint rates."""
    from heft.diagrams.commands.analyze_passivity import sensor_twists
    from heft.diagrams.plants import MakeArmPlant

    plant, S = MakeArmPlant(robot)
    n = plant.num_positions()
    t = np.arange(200) * 0.0005
    amplitude, rate = np.linspace(0.1, 0.3, n), 2.0
    q = 0.2 + np.outer(np.sin(rate * t), amplitude)
    v = np.outer(rate * np.cos(rate * t), amplitude)
    twists = sensor_twists(robot, t, q)
    context = plant.CreateDefaultContext()
    for k in (50, 100, 150):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        R_SW = S.CalcPoseInWorld(context).rotation().inverse()
        V_WS = S.CalcSpatialVelocityInWorld(context)
        np.testing.assert_allclose(twists[k], np.concatenate((R_SW @ V_WS.translational(), R_SW @ V_WS.rotational())),
                                   atol=1e-6)


@pytest.mark.parametrize("master", ["phantom_premium_6dof", "touch"])
def test_the_stylus_twist_is_the_runs_masters(master):
    """The stylus twist of each bundled master is Drake's spatial velocity of its stylus frame E in B
    (``CalcJacobianSpatialVelocity`` of that master's plant, [ω; v] reordered to [v; ω]); the Touch's differs from
    the Phantom's at the same joints."""
    from pydrake.multibody.tree import JacobianWrtVariable

    from heft.diagrams.plants import MakeMasterPlant
    from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME

    rng = np.random.default_rng(4)
    q, v = rng.uniform(-0.4, 0.4, (5, 6)), rng.normal(0, 1.0, (5, 6))
    plant = MakeMasterPlant(master)
    context = plant.CreateDefaultContext()
    B, E = plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)
    expected = []
    for q_k, v_k in zip(q, v):
        plant.SetPositions(context, q_k)
        J = plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, E, np.zeros(3), B, B)
        expected.append(np.concatenate((J[3:] @ v_k, J[:3] @ v_k)))
    twist = analyze_passivity.stylus_twists(q, v, master)
    np.testing.assert_allclose(twist, expected, atol=1e-12)
    other = "touch" if master == "phantom_premium_6dof" else "phantom_premium_6dof"
    assert np.abs(analyze_passivity.stylus_twists(q, v, other) - twist).max() > 1e-3
