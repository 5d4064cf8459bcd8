"""A run's log as the arrays the analyses read (``heft analyze passivity|replay``), from either
kind of log heft writes:

- ``npz``: a simulation's ``log.npz`` / ``log_sigma*.npz`` (``heft simulate``), read as it is;
- ``lcm``: the LCM event log ``heft teleop --hardware --record`` writes (``lcm-logger``'s
  format, ``diagrams.running.lcm_recording``).

The kind is told by the file's first bytes (``log_kind``), or given. From an LCM log, one
row per controller tick, i.e. per ``heft_teleop_state`` message (``hardware_interface.
teleop_state``), with the driver messages that tick read, found by their utimes, and the
commands it sent (NaN where the log lacks one: ``complete_rows``):

====================  =====  ========================================================================
key                   width  what (units, frame), and from which message
====================  =====  ========================================================================
t                     —      the tick's time (s) since the first row's (teleop state ``utime``)
hold                  —      the tick's duration the controller stepped with (s; ``dt``): the
                             passivity observer's hold
starts                —      controller starts so far (the observer restarts from 0 at each)
gain                  —      the watchdog's force gain (0..1)
master_q, master_v    6      Phantom joint positions (rad), velocities (rad/s): ``heft_haptic_state``
master_torque         6      joint torques sent (N·m, gain applied): ``heft_haptic_command``
master_force          6      the wrench on the hand as mapped, before the PC [f; τ] at E in B (N, N·m)
master_force_applied  6      the same after the PC and the device's limits
passivity_energy      2      the observer's [E_t, E_r] after the PC (J)
passivity_damping     2      the PC's [α_t (N·s/m), α_r (N·m·s/rad)]
slave_q, slave_v      6      arm joint positions (rad), velocities (rad/s): ``lcmt_iiwa_status``
slave_q_commanded     6      the arm command sent in the tick (rad): ``lcmt_iiwa_command``
wrench_measured       6      the sensor's wrench ON THE LOAD, at S in S (N, N·m): −the FT sample's ``wrench``
accel_measured        6      the accelerometer's reading as the driver reports it (m/s², rad/s²; in S)
wrench_contact        6      the controller's contact wrench (Eq. 13), on the load at S in S
wrench_noncontact     6      its non-contact wrench (Eq. 5), the same frame
====================  =====  ========================================================================

A hardware log holds no truth: ``wrench_contact_true`` (the simulation's contact force, for
the environment port of the passivity analysis) is missing, and said so in ``RunLog.notes``.
Timing differs from a simulation's in two respects: the simulated controller's passivity
observer's energy logged at row k comes from the stylus twist and the wrench of row k − 1 (a logger
publishes before the discrete updates of its instant), the hardware's from row k's (the tick's state
is sent after its update): ``RunLog.observer_lag`` 1 or 0;
and a hardware row holds for the tick's measured ``hold``, a simulated one for the period.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

NPZ, LCM = "npz", "lcm"
KINDS = (NPZ, LCM)
_MAGIC = {b"PK\x03\x04": NPZ, b"\xed\xa1\xda\x01": LCM}  # zip (numpy's .npz); LCM event log
WRITERS = "a log.npz of `heft simulate` or an LCM log of `heft teleop --hardware --record`"


@dataclasses.dataclass
class RunLog:
    """The arrays of a run (``arrays``, keys as ``heft simulate`` writes them), its ``kind``,
    ``observer_lag`` (rows between the stylus twist and wrench the passivity observer met and its energy) and
    ``notes``: what was left out, missing or chosen, one sentence each."""

    arrays: dict
    kind: str
    observer_lag: int
    notes: list


def log_kind(path) -> str:
    """``npz`` or ``lcm`` from the first bytes of the file at ``path``; a ValueError (one line,
    naming the file and what to give) for a missing, unreadable or other file."""
    path = Path(path)
    if not path.exists():
        raise ValueError(f"no log at {path}; give {WRITERS}")
    try:
        with open(path, "rb") as file:
            head = file.read(4)
    except OSError as error:
        raise ValueError(f"cannot read a log from {path} ({error.strerror}); give {WRITERS}") from None
    if head not in _MAGIC:
        raise ValueError(f"{path} is neither an .npz archive nor an LCM log; give {WRITERS}")
    return _MAGIC[head]


def read_run_log(path, kind: str | None = None) -> RunLog:
    """The run in the log at ``path`` (module docstring); ``kind`` ``npz`` or ``lcm``, or None:
    told by the file (``log_kind``). A ValueError (one line) names what is wrong."""
    found = log_kind(path)
    if kind is not None and kind != found:
        raise ValueError(f"{path} is an {found} log, not {kind}: drop --kind or give {WRITERS}")
    return _read_npz(Path(path)) if found == NPZ else read_lcm_log(path)


def _read_npz(path: Path) -> RunLog:
    try:
        with np.load(path) as archive:
            arrays = {key: archive[key] for key in archive.files}
    except (OSError, ValueError) as error:
        raise ValueError(f"cannot read {path} as a log.npz ({error}); write one with `heft simulate`") from None
    return RunLog(arrays, NPZ, 1, [])


def _by_utime(events, decode, name: str, notes: list) -> tuple[dict, set]:
    """``{utime: message}`` of one channel's ``events`` (``decode`` gives each payload's messages: an
    FT message holds several samples), and the utimes that more than one message carried (a second
    publisher: which one a tick read is unknown)."""
    messages, repeated, undecodable = {}, set(), 0
    for data in events:
        try:
            decoded = decode(data)
        except Exception:  # whatever a malformed payload makes the generated decoder raise
            undecodable += 1
            continue
        for msg in decoded:
            if msg.utime in messages:
                repeated.add(msg.utime)
            messages[msg.utime] = msg
    if undecodable:
        notes.append(f"{undecodable} undecodable {name} messages skipped")
    return messages, repeated


def read_lcm_log(path) -> RunLog:
    """The run recorded in the LCM log at ``path`` (module docstring), one row per tick. Where
    the log lacks a driver message or command a tick read (a packet the logger missed) or holds
    it twice (another publisher on the same stamp), that row's values from it are NaN, counted
    in the notes (``complete_rows`` keeps the rows an analysis can use)."""
    import lcm
    from drake import lcmt_iiwa_command, lcmt_iiwa_status

    from heft.hardware_interface.channels import LcmChannels
    from heft.hardware_interface.ft_messages import decode_samples
    from heft.hardware_interface.lcmtypes import heft_haptic_command, heft_haptic_state, heft_teleop_state

    def one(message_type):
        return lambda data: [message_type.decode(data)]

    channels = LcmChannels()
    decoders = {channels.teleop_state.name: one(heft_teleop_state),
                channels.master_state.name: one(heft_haptic_state),
                channels.master_command.name: one(heft_haptic_command),
                channels.slave_status.name: one(lcmt_iiwa_status),
                channels.slave_command.name: one(lcmt_iiwa_command),
                channels.ft_sample.name: decode_samples}
    payloads = {name: [] for name in decoders}
    try:
        for event in lcm.EventLog(str(path), "r"):
            if event.channel in payloads:
                payloads[event.channel].append(event.data)
    except OSError as error:
        raise ValueError(f"cannot read the LCM log {path} ({error}); give {WRITERS}") from None
    if not payloads[channels.teleop_state.name]:
        raise ValueError(f"{path} holds no {channels.teleop_state.name} messages: the controller's ticks are not in "
                         "it; record with `heft teleop --hardware --record LOG`")
    notes = []
    tables = {name: _by_utime(payloads[name], decode, name, notes) for name, decode in decoders.items()}
    ticks = sorted(tables.pop(channels.teleop_state.name)[0].values(), key=lambda msg: msg.utime)
    if len(ticks) < 3:
        raise ValueError(f"{path} holds {len(ticks)} controller ticks; an analysis needs 3 or more")
    stamp_of = {channels.master_state.name: lambda tick: tick.master_utime,
                channels.slave_status.name: lambda tick: tick.slave_utime,
                channels.ft_sample.name: lambda tick: tick.ft_utime,
                channels.master_command.name: lambda tick: tick.utime,
                channels.slave_command.name: lambda tick: tick.utime}
    read = {}
    for name, (messages, repeated) in tables.items():
        stamps = [stamp_of[name](tick) for tick in ticks]
        read[name] = [None if stamp in repeated else messages.get(stamp) for stamp in stamps]
        lacking = sum(message is None for message in read[name])
        if lacking:
            notes.append(f"{lacking} of {len(ticks)} ticks without their {name} message in the log (NaN)")
    notes.append("no wrench_contact_true: a hardware log holds no true contact force (environment port not computed)")
    return RunLog(_lcm_arrays(ticks, read, channels), LCM, 0, notes)


def _lcm_arrays(ticks, read: dict, channels) -> dict:
    """The arrays of the module docstring from the teleop states ``ticks`` and, per channel
    name, the message each tick read (``read``; None: NaN)."""

    def stack(messages, field, width=6, sign=1.0):
        nan = [np.nan] * width
        return sign * np.array([nan if msg is None else getattr(msg, field) for msg in messages], dtype=float)

    utime = np.array([tick.utime for tick in ticks], dtype=np.int64)
    master, slave, ft = (read[channels.master_state.name], read[channels.slave_status.name],
                         read[channels.ft_sample.name])
    master_command, slave_command = read[channels.master_command.name], read[channels.slave_command.name]
    return {
        "t": (utime - utime[0]) * 1e-6, "hold": np.array([tick.dt for tick in ticks]),
        "starts": np.array([tick.starts for tick in ticks], dtype=np.int64),
        "gain": np.array([tick.gain for tick in ticks]),
        "master_q": stack(master, "position"), "master_v": stack(master, "velocity"),
        "master_torque": stack(master_command, "torque"),
        "master_force": stack(ticks, "master_wrench"), "master_force_applied": stack(ticks, "applied_wrench"),
        "passivity_energy": stack(ticks, "energy", 2), "passivity_damping": stack(ticks, "damping", 2),
        "slave_q": stack(slave, "joint_position_measured"), "slave_v": stack(slave, "joint_velocity_estimated"),
        "slave_q_commanded": stack(slave_command, "joint_position"),
        "wrench_measured": stack(ft, "wrench", sign=-1.0), "accel_measured": stack(ft, "acceleration"),
        "wrench_contact": stack(ticks, "wrench_contact"), "wrench_noncontact": stack(ticks, "wrench_noncontact"),
    }


def complete_rows(run: RunLog, keys, why: str) -> RunLog:
    """The rows of ``run`` where every array of ``keys`` is finite (``why``: what the others
    miss, for the note); ``run`` itself if all are."""
    keep = np.ones(len(run.arrays["t"]), dtype=bool)
    for key in keys:
        values = np.asarray(run.arrays[key], dtype=float)
        keep &= np.isfinite(values.reshape(len(keep), -1)).all(axis=1)
    if keep.all():
        return run
    if keep.sum() < 3:
        raise ValueError(f"the log has {keep.sum()} rows with {', '.join(keys)}; an analysis needs 3 or more")
    arrays = {key: value[keep] for key, value in run.arrays.items()}
    note = f"{(~keep).sum()} of {len(keep)} rows left out: {why}"
    return RunLog(arrays, run.kind, run.observer_lag, [*run.notes, note])


def longest_start(run: RunLog) -> RunLog:
    """The rows of ``run`` from its longest stretch of one controller start (the passivity
    observer restarts from zero at each), with a note if others were left out; ``run`` itself
    if it has one (or is a simulation's)."""
    starts = run.arrays.get("starts")
    if starts is None or np.all(starts == starts[0]):
        return run
    values, counts = np.unique(starts, return_counts=True)
    keep = starts == values[np.argmax(counts)]
    t = run.arrays["t"]
    arrays = {key: value[keep] for key, value in run.arrays.items()}
    note = (f"the controller started {len(values)} times (after faults); analysed its longest stretch, "
            f"{t[keep][0]:.3f}–{t[keep][-1]:.3f} s ({keep.sum()} of {len(t)} ticks)")
    return RunLog(arrays, run.kind, run.observer_lag, [*run.notes, note])
