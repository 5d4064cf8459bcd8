"""`analysis.run_log`: a hardware run's LCM log read into the arrays of a simulated log.

The log is the traffic of the controller against the stand-in on one memq:// bus (as in
test_hardware_teleop), written here by the test's own subscriber with python-lcm's
``EventLog``, as ``lcm-logger`` writes it; what the reader finds is checked against what the
hardware station and the controller held at each tick. Bad input: a one-line error naming
the file and what to give.
"""

import argparse

import lcm
import numpy as np
import pytest
from heft.analysis.run_log import complete_rows, log_kind, read_run_log
from heft.diagrams.commands import analyze_passivity, replay
from heft.diagrams.scenario import overrides_text, resolve_scenario
from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.lcm_mailbox import pump
from test_hardware_teleop import PERIOD, Lab

TICKS = 400


class Recorder:
    """Every message on the bus, as (channel, payload), in the order they were handled."""

    def __init__(self, bus):
        self.events = []
        bus.subscribe(".*", lambda channel, data: self.events.append((channel, data)))

    def write(self, path, skip=lambda channel, index: False):
        """An LCM event log at ``path``, leaving out the events ``skip`` (channel, its index on the
        channel) names (as a logger that missed them)."""
        log, seen = lcm.EventLog(str(path), "w", overwrite=True), {}
        for i, (channel, data) in enumerate(self.events):
            seen[channel] = seen.get(channel, -1) + 1
            if not skip(channel, seen[channel]):
                log.write_event(1000 * i, channel, data)
        log.close()
        return path


@pytest.fixture(scope="module")
def lab_run():
    """The controller against the stand-in, the operator moving from the start and holding the clutch from
    0.05 s, for 0.2 s; per tick what the
    station read and the controller computed, and the traffic."""
    lab = Lab(resolve_scenario("fig6", overrides_text({"operator.start_time": 0.0})), clutch_at=0.05)
    recorder = Recorder(lab.bus)
    station, controller = lab.teleop.station, lab.teleop.controller
    held = {key: [] for key in ("master_q", "master_v", "slave_q", "wrench", "energy", "damping", "contact", "torque")}
    for _ in range(TICKS):
        lab.run(PERIOD)
        if not station.healthy:  # the controller did not step: no tick in the log
            continue
        for key, value in (("master_q", station.master_position), ("master_v", station.master_velocity),
                           ("slave_q", station.slave_position), ("wrench", station.wrench),
                           ("energy", controller.energy), ("damping", controller.damping),
                           ("contact", controller.wrench_contact), ("torque", station.torque_sent)):
            held[key].append(np.array(value))
    pump(lab.bus)
    assert len(held["energy"]) > TICKS - 10
    return recorder, {key: np.array(value) for key, value in held.items()}


def test_every_tick_reads_back_as_the_station_and_controller_held_it(lab_run, tmp_path):
    recorder, held = lab_run
    run = read_run_log(recorder.write(tmp_path / "run.lcmlog"))
    arrays = run.arrays
    assert run.kind == "lcm" and run.observer_lag == 0 and len(arrays["t"]) == len(held["energy"])
    np.testing.assert_allclose(np.diff(arrays["t"]), PERIOD, atol=1.5e-6)  # µs stamps
    np.testing.assert_allclose(arrays["hold"], PERIOD)
    for key, held_key in (("master_q", "master_q"), ("master_v", "master_v"), ("slave_q", "slave_q"),
                          ("wrench_measured", "wrench"), ("passivity_energy", "energy"),
                          ("passivity_damping", "damping"), ("wrench_contact", "contact"),
                          ("master_torque", "torque")):
        np.testing.assert_array_equal(arrays[key], held[held_key], err_msg=key)
    assert np.ptp(arrays["master_q"], axis=0).max() > 1e-3 and np.abs(arrays["master_torque"]).max() > 0
    assert run.notes == ["no wrench_contact_true: a hardware log holds no true contact force (environment port "
                         "not computed)"]
    # Nothing lost: the observer's energy is the port energy plus what the PC dissipated, to rounding.
    report = analyze_passivity.analyze_log(arrays, observer_lag=0)
    translational = report["master_port"]["translational"]
    assert translational["energy_in_J"] + translational["energy_out_J"] > 1e-6  # energy flowed
    for port in report["master_port"].values():
        assert port["observer_identity_gap_J"] < 1e-12


def test_a_message_the_logger_missed_leaves_nan_and_a_note(lab_run, tmp_path):
    recorder, held = lab_run
    channels = LcmChannels()
    path = recorder.write(tmp_path / "lossy.lcmlog",
                          skip=lambda channel, index: channel == channels.master_state.name and index == 100)
    run = read_run_log(path)
    lacking = ~np.isfinite(run.arrays["master_q"]).all(axis=1)
    assert lacking.any() and np.isfinite(run.arrays["slave_q"]).all()
    assert any(f"{lacking.sum()} of {len(lacking)} ticks without their HEFT_MASTER_STATE" in note for note in run.notes)
    kept = complete_rows(run, ("master_q",), "no master state")
    assert len(kept.arrays["t"]) == len(lacking) - lacking.sum()
    np.testing.assert_array_equal(kept.arrays["master_q"], held["master_q"][~lacking])


def _cli(module, *argv):
    parser = argparse.ArgumentParser()
    module.add_arguments(parser)
    return module.run(parser.parse_args([str(a) for a in argv]))


@pytest.mark.parametrize("module", [analyze_passivity, replay])
def test_bad_input_is_one_line_naming_the_file_and_what_to_give(module, tmp_path):
    garbage = tmp_path / "notes.txt"
    garbage.write_text("not a log\n")
    foreign = tmp_path / "other.lcmlog"
    log = lcm.EventLog(str(foreign), "w", overwrite=True)
    log.write_event(0, "SOME_OTHER_CHANNEL", b"\x00" * 8)
    log.close()
    np.savez(tmp_path / "log.npz", t=np.arange(3.0))
    for path, kind, expected in ((tmp_path / "absent.lcmlog", None, "no log at .*absent.lcmlog; give a log.npz"),
                                 (garbage, None, "notes.txt is neither an .npz archive nor an LCM log"),
                                 (foreign, None, "no HEFT_TELEOP_STATE messages.*--hardware --record"),
                                 (tmp_path / "log.npz", "lcm", "is an npz log, not lcm")):
        with pytest.raises(ValueError, match=expected) as error:
            _cli(module, path, *(("--kind", kind) if kind else ()))
        assert "\n" not in str(error.value)
    assert log_kind(foreign) == "lcm" and log_kind(tmp_path / "log.npz") == "npz"
