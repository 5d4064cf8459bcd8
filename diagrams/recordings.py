"""A recording opened for the commands that read one (`heft compensate`, `heft identify --recording`):
its streams from files or from a log of `heft … --hardware --record`, the arm's kinematics for joint
angles, and the accelerometer's calibration from an estimate where the recording leaves it open."""

from __future__ import annotations

import dataclasses

from heft.analysis.recording import (
    ESTIMATE, AccelerometerStream, Clock, OrientationStream, Recording, WrenchStream, load_recording,
    with_accelerometer_calibration)
from heft.analysis.recording_merge import RecordingSource
from heft.diagrams.load_estimate import read_accelerometer_calibration


def open_recording(path, estimate_path=None, calibration=None, calibrated_by: str = "") -> RecordingSource:
    """A RecordingSource for a recording's YAML file: its lcm_log exported to files (``from_lcm_log``),
    the arm's kinematics where the orientation is joint angles, and, where the recording says R_SA or
    bias 'estimate', the accelerometer's ``calibration`` (found from static poses, ``calibrated_by``
    saying so) or else the one of ``estimate_path``."""
    recording = load_recording(path)
    log_choices = {}
    if recording.lcm_log is not None:
        recording, log_choices = from_lcm_log(recording)
    acc, calibrated = recording.accelerometer, ""
    if acc is not None and ESTIMATE in (acc.R_SA, acc.bias):
        if calibration is None:
            calibration = read_accelerometer_calibration(estimate_path) if estimate_path else None
            calibrated_by = estimate_path
        if calibration is None:
            raise ValueError(f"{path}: the accelerometer's R_SA or bias is 'estimate', and {estimate_path} has no "
                             "accelerometer calibration: identify with static poses (`heft identify --recording`) "
                             "or state them in the recording")
        recording, calibrated = with_accelerometer_calibration(recording, calibration), calibrated_by
    orientation, joints = recording.orientation, None
    if orientation is not None and orientation.kind == "joint_positions":
        from heft.diagrams.recording_kinematics import recording_joint_orientation
        joints = recording_joint_orientation(recording, orientation.robot, orientation.columns, "orientation")
    source = RecordingSource(recording, joints)
    source.choices.update(log_choices)
    if calibrated:
        source.choices["accelerometer"] += f" (calibration from {calibrated})"
    return source


def from_lcm_log(recording: Recording) -> tuple[Recording, dict]:
    """The recording with its streams read from its ``lcm_log`` (exported once into the folder
    ``<log>.streams`` beside it, ``hardware_interface.log_streams``), and what was left out. The wrench
    and the accelerometer share the FT sample's stamps; the joint angles (``orientation``, robot rx90
    unless the recording says; as many as the log's statuses carry) have the arm driver's, their offset stated
    or estimated as any stream's."""
    from heft.hardware_interface.log_streams import FT_COLUMNS, export_log_streams

    log = recording.path(recording.lcm_log)
    if not log.is_file():
        raise ValueError(f"{recording.source}: lcm_log {log} does not exist")
    folder = log.with_name(log.name + ".streams")
    summary = export_log_streams(log, folder)
    stamps = Clock(column="utime", unit="us")
    wrench = dataclasses.replace(recording.wrench or WrenchStream(), file=str(folder / "ft.parquet"), time=stamps,
                                 columns=list(FT_COLUMNS[:6]), exerted_on="sensor")
    acc = recording.accelerometer or AccelerometerStream()
    acc = dataclasses.replace(acc, file=str(folder / "ft.parquet"), time=stamps, columns=list(FT_COLUMNS[6:]),
                              unit="m/s^2")
    ori = recording.orientation or OrientationStream(kind="joint_positions", robot="rx90")
    ori = dataclasses.replace(ori, file=str(folder / "slave.parquet"), kind="joint_positions",
                              columns=summary["joint_columns"], robot=ori.robot or "rx90",
                              time=dataclasses.replace(stamps, offset=ori.time.offset))
    choices = {"lcm_log": f"{log}: {summary['ft_samples']} FT samples, {summary['slave_samples']} joint states "
                          f"(robot {ori.robot}); left out: {summary['left_out']}"}
    return dataclasses.replace(recording, wrench=wrench, accelerometer=acc, orientation=ori), choices

