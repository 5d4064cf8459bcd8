"""A log written by `heft … --hardware --record` as the files of a recording (docs/recordings.md):
the FT samples and the arm's joint angles, each on its driver's clock, as Parquet files.

``ft.parquet``: one row per FT sample (of ``heft_ft_sample`` or ``heft_ft_samples`` messages: ``ft_messages``):
``utime`` (µs), ``fx … tz`` (the sensor's sign, as the messages carry it),
``ax, ay, az`` (specific force, m/s², in S) and ``alpha_x … alpha_z`` (rad/s²). ``slave.parquet``:
``utime`` (µs) and ``q1 … q6`` (rad) of ``lcmt_iiwa_status``. As on hardware, a message that cannot
be decoded is left out and counted, as is a sample that carries NaN, an error flag or a saturated axis,
or is stamped at or before the last one kept (a late or repeated packet); none is fatal.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import lcm
import pyarrow as pa
import pyarrow.parquet as pq
from drake import lcmt_iiwa_status

from heft.hardware_interface.channels import LcmChannels
from heft.hardware_interface.ft_messages import decode_samples

FT_COLUMNS = ("fx", "fy", "fz", "tx", "ty", "tz", "ax", "ay", "az", "alpha_x", "alpha_y", "alpha_z")
JOINT_COLUMNS = ("q1", "q2", "q3", "q4", "q5", "q6")
BATCH = 65536


class _Table:
    """Rows gathered and written as Parquet in batches."""

    def __init__(self, path: Path, names):
        self.names = ("utime",) + tuple(names)
        schema = pa.schema([("utime", pa.int64())] + [(n, pa.float64()) for n in names])
        self._writer, self._schema = pq.ParquetWriter(path, schema), schema
        self._rows, self.count, self.last = [], 0, -math.inf

    def add(self, utime: int, values) -> None:
        self._rows.append((utime, *values))
        self.count += 1
        self.last = utime
        if len(self._rows) == BATCH:
            self._flush()

    def _flush(self) -> None:
        if self._rows:
            columns = list(zip(*self._rows))
            self._writer.write_table(pa.Table.from_arrays([pa.array(c) for c in columns], schema=self._schema))
            self._rows = []

    def close(self) -> None:
        self._flush()
        self._writer.close()


def export_log_streams(log_path, folder, channels: LcmChannels | None = None) -> dict:
    """Writes ``ft.parquet`` and ``slave.parquet`` into ``folder`` from the LCM log ``log_path``; returns
    {"ft_samples": kept, "slave_samples": kept, "left_out": {channel: {reason: count}}}."""
    channels = channels or LcmChannels()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    ft = _Table(folder / "ft.parquet", FT_COLUMNS)
    slave = _Table(folder / "slave.parquet", JOINT_COLUMNS)
    left_out = {channels.ft_sample.name: Counter(), channels.slave_status.name: Counter()}
    try:
        for event in lcm.EventLog(str(log_path), "r"):
            if event.channel == channels.ft_sample.name:
                _take_ft(event.data, ft, left_out[event.channel])
            elif event.channel == channels.slave_status.name:
                _take_joints(event.data, slave, left_out[event.channel])
    finally:
        ft.close()
        slave.close()
    if ft.count < 2:
        raise ValueError(f"{log_path}: fewer than two usable {channels.ft_sample.name} samples "
                         f"({ft.count}; left out: {dict(left_out[channels.ft_sample.name])})")
    return {"ft_samples": ft.count, "slave_samples": slave.count,
            "left_out": {channel: dict(counts) for channel, counts in left_out.items()}}


def _take_ft(data: bytes, table: _Table, left_out: Counter) -> None:
    try:
        samples = decode_samples(data)
    except ValueError:
        left_out["undecodable"] += 1
        return
    for msg in samples:
        values = list(msg.wrench) + list(msg.acceleration)
        if msg.error:
            left_out["error flag"] += 1
        elif msg.saturated:
            left_out["saturated"] += 1
        elif not math.isfinite(sum(values)):
            left_out["not finite"] += 1
        elif msg.utime <= table.last:
            left_out["stamped at or before the last"] += 1
        else:
            table.add(msg.utime, values)


def _take_joints(data: bytes, table: _Table, left_out: Counter) -> None:
    try:
        msg = lcmt_iiwa_status.decode(data)
    except Exception:  # whatever a malformed payload makes the generated decoder raise
        left_out["undecodable"] += 1
        return
    if msg.num_joints != len(JOINT_COLUMNS):
        left_out["joint count"] += 1
    elif not math.isfinite(sum(msg.joint_position_measured)):
        left_out["not finite"] += 1
    elif msg.utime <= table.last:
        left_out["stamped at or before the last"] += 1
    else:
        table.add(msg.utime, msg.joint_position_measured)
