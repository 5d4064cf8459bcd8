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
from heft.systems.passivity_controller import PassivityParams


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
