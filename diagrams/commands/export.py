"""`heft export LOG --to mcap|parquet|csv`: a run's log as files other tools read, on the live
view's topics (``analysis.topics``), so that a recorded run replays in the same Foxglove layout.

Either kind of log (``analysis.run_log``): a simulation's log.npz gives one message per row on
each topic it has data for; an LCM log of ``heft teleop --hardware --record`` gives one per
controller tick (per ``HEFT_TELEOP_STATE``) on the same topics, timed by the tick's utime, and
every event of every channel on ``/lcm/CHANNEL`` (with the station status, load commands and
answers on ``/faults``, ``/load/command``, ``/load/status``), timed by the logger. A log's
constants (σ, …) and the reader's notes go to the metadata.
"""

from __future__ import annotations

import heapq
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from heft.diagrams.commands.console import logger
from heft.diagrams.master_params import DEFAULT_MASTER

if TYPE_CHECKING:
    from heft.diagrams.plants import Robot

say = logger(__name__)

HELP = ("a run's log (a simulation's log.npz, or an LCM log of `heft teleop --hardware --record`) as MCAP, "
        "Parquet or CSV, on the live view's topics")


def first_tick_utime(path, channels) -> int:
    """The utime (µs) of the earliest controller tick in the LCM log at ``path``: the run's t = 0."""
    import lcm

    from heft.hardware_interface.lcmtypes import heft_teleop_state

    utimes = []
    for event in lcm.EventLog(str(path), "r"):
        if event.channel == channels.teleop_state.name:
            try:
                utimes.append(heft_teleop_state.decode(event.data).utime)
            except Exception:  # as read_lcm_log: an undecodable payload is not a tick
                continue
    return min(utimes)


def constants(arrays: dict) -> dict:
    """The arrays of a log that are not one entry per row (``sigma``, ``phi_gripper_true``, …), as text."""
    n = len(arrays["t"])
    return {key: np.array2string(np.asarray(value), separator=", ", max_line_width=10**6)
            for key, value in arrays.items() if np.ndim(value) == 0 or len(value) != n}


def log_messages(path, robot: Robot, master: str = DEFAULT_MASTER):
    """(messages (time (ns), topic, message) in time order, topic → schema, metadata) of the log at ``path``;
    ``robot`` and ``master`` pose the scene."""
    from heft.analysis.lcm_messages import RAW_SCHEMA, lcm_log_messages, lcm_topic_schemas
    from heft.analysis.run_log import LCM, read_run_log
    from heft.analysis.topics import run_messages, schema_of
    from heft.diagrams.scene_poses import with_scene_poses
    from heft.hardware_interface.channels import LcmChannels

    run = read_run_log(path)
    arrays = with_scene_poses(run.arrays, robot, master)
    metadata = {**constants(arrays), "kind": run.kind, "notes": "; ".join(run.notes)}
    if run.kind != LCM:
        return run_messages(arrays), schema_of, metadata
    channels = LcmChannels()
    t0 = first_tick_utime(path, channels) * 1000
    lcm_schemas = lcm_topic_schemas(channels)

    def schemas(topic: str):
        if topic in lcm_schemas:
            return lcm_schemas[topic]
        try:
            return schema_of(topic)
        except KeyError:  # a channel heft does not know
            return RAW_SCHEMA

    merged = heapq.merge(run_messages(arrays, t0), lcm_log_messages(path, channels), key=lambda item: item[0])
    return merged, schemas, metadata


def export_log(path, to: str, out, robot: Robot = "rx90",
               master: str = DEFAULT_MASTER) -> tuple[list[Path], Counter]:
    """Writes the log at ``path`` as ``to`` (``analysis.run_export.FORMATS``) into the folder ``out``:
    ``LOG.mcap``, or a folder ``LOG`` of one table per topic (but ``/scene/wrenches``). Returns (the files
    written, messages per topic)."""
    from heft.analysis.run_export import MCAP, McapSink, TableSink
    from heft.analysis.topics import SCENE_WRENCHES

    out = Path(out)
    messages, schemas, metadata = log_messages(path, robot, master)
    stem = Path(path).stem
    out.mkdir(parents=True, exist_ok=True)
    if to == MCAP:
        files = [out / f"{stem}.mcap"]
        sink = McapSink(files[0], schemas)
    else:
        (out / stem).mkdir(exist_ok=True)
        sink = TableSink(out / stem, to)
    counts = Counter()
    for time, topic, message in messages:
        if to != MCAP and topic == SCENE_WRENCHES:  # drawing, not data: the wrench topics hold its values
            continue
        sink.write(time, topic, message)
        counts[topic] += 1
    sink.metadata("heft", metadata)
    sink.close()
    return (files if to == MCAP else sink.files), counts


def add_arguments(parser) -> None:
    from heft.analysis.run_export import FORMATS, MCAP

    parser.add_argument("log", help="log.npz or log_sigma*.npz of `heft simulate`, or the LCM log of "
                                    "`heft teleop --hardware --record`")
    parser.add_argument("--to", choices=FORMATS, default=MCAP,
                        help="mcap (default): one file, Foxglove's and Lichtblick's; parquet or csv: one table "
                             "per topic")
    from heft.diagrams.commands.options import add_out, add_scenario

    add_out(parser, "LOG.mcap, or LOG/TOPIC.parquet|csv", shown="the log's folder")
    add_scenario(parser, more="the run's, whose robot poses the 3-D scene")


def run(args) -> int:
    from heft.diagrams.scenario import resolve_scenario
    from heft.diagrams.plants import slave_arm

    out = Path(args.out) if args.out else Path(args.log).parent
    scenario = resolve_scenario(args.scenario)
    files, counts = export_log(args.log, args.to, out, slave_arm(scenario), scenario.master)
    where = files[0] if args.to == "mcap" else files[0].parent
    say.info(f"wrote {where}: {sum(counts.values())} messages on {len(counts)} topics")
    if args.to == "mcap":
        from heft.analysis.foxglove_layout import LAYOUT_FILE
        say.info(f"open it in Foxglove or Lichtblick with the layout {LAYOUT_FILE} (docs/live_view.md)")
    return 0
