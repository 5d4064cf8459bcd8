"""A log written by `heft … --hardware --record` as the files of a recording (docs/recordings.md):
the FT samples and the arm's joint angles, each on its driver's clock, as Parquet files.

``ft.parquet``: one row per FT sample (of ``heft_ft_sample`` or ``heft_ft_samples`` messages: ``ft_messages``):
``utime`` (µs), ``fx … tz`` (the sensor's sign, as the messages carry it),
``ax, ay, az`` (specific force, m/s², in S) and ``alpha_x … alpha_z`` (rad/s²). ``slave.parquet``:
``utime`` (µs) and ``q1 … qn`` (rad) of ``lcmt_iiwa_status``, n the joints of the log's first status (the
arm's: 6, or an iiwa's 7). As on hardware, a message that cannot be decoded is left out and counted, as is a
status of another joint count, a sample that carries NaN, an error flag or a saturated axis, or one stamped at
or before the last one kept (a late or repeated packet); none is fatal.
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
BATCH = 65536


def joint_columns(num_joints: int) -> tuple[str, ...]:
    """The columns of ``slave.parquet`` after ``utime``: q1 … qn (rad)."""
    return tuple(f"q{j + 1}" for j in range(num_joints))


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
    {"ft_samples": kept, "slave_samples": kept, "joint_columns": slave.parquet's after utime, "left_out":
    {channel: {reason: count}}}."""
    channels = channels or LcmChannels()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    ft = _Table(folder / "ft.parquet", FT_COLUMNS)
    slave = [None]  # the joints' table, opened at the first status (its joint count)
    left_out = {channels.ft_sample.name: Counter(), channels.slave_status.name: Counter()}
    try:
        for event in lcm.EventLog(str(log_path), "r"):
            if event.channel == channels.ft_sample.name:
                _take_ft(event.data, ft, left_out[event.channel])
            elif event.channel == channels.slave_status.name:
                _take_joints(event.data, slave, folder / "slave.parquet", left_out[event.channel])
    finally:
        ft.close()
        if slave[0] is not None:
            slave[0].close()
    for name, count in ((channels.ft_sample.name, ft.count), (channels.slave_status.name,
                                                              0 if slave[0] is None else slave[0].count)):
        if count < 2:
            raise ValueError(f"{log_path}: fewer than two usable {name} messages ({count}; left out: "
                             f"{dict(left_out[name])})")
    return {"ft_samples": ft.count, "slave_samples": slave[0].count, "joint_columns": list(slave[0].names[1:]),
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


def _take_joints(data: bytes, table: list, path: Path, left_out: Counter) -> None:
    """One status into ``table[0]``, the joints' ``_Table`` at ``path``, opened at the first status decoded with
    its joint count."""
    try:
        msg = lcmt_iiwa_status.decode(data)
    except Exception:  # whatever a malformed payload makes the generated decoder raise
        left_out["undecodable"] += 1
        return
    if table[0] is None and msg.num_joints > 0:
        table[0] = _Table(path, joint_columns(msg.num_joints))
    table = table[0]
    if table is None or msg.num_joints != len(table.names) - 1:
        left_out["joint count"] += 1
    elif not math.isfinite(sum(msg.joint_position_measured)):
        left_out["not finite"] += 1
    elif msg.utime <= table.last:
        left_out["stamped at or before the last"] += 1
    else:
        table.add(msg.utime, msg.joint_position_measured)
