"""A run's messages (``analysis.topics``, ``analysis.lcm_messages``) written as files: one MCAP
(JSON messages with their JSON Schemas, the live view's topics: a recorded run replays in the
same Foxglove layout) or one Parquet or CSV table per topic (nested fields flattened to
columns ``force.x``, ``position[0]``, after a ``log_time_ns`` column).

The sinks take (time (ns), topic, message) one at a time, so a long log streams through.
``McapSink`` writes through foxglove-sdk (the ``view`` extra), the tables through pyarrow.
"""

from __future__ import annotations

import json
from pathlib import Path

from heft.analysis.topics import encode

MCAP, PARQUET, CSV = "mcap", "parquet", "csv"
FORMATS = (MCAP, PARQUET, CSV)
VIEW_EXTRA = "pip install 'heft-teleop[view]' (foxglove-sdk, mcap)"
"""What to run when the ``view`` extra is missing."""
TABLE_BATCH = 20_000
"""Rows of a topic held before they are written to its table."""


def foxglove_sdk():
    """The ``foxglove`` module; a ValueError (one line: how to install it) without it."""
    try:
        import foxglove
    except ImportError:
        raise ValueError(f"the live view and MCAP files need foxglove-sdk: {VIEW_EXTRA}") from None
    return foxglove


def foxglove_channel(foxglove, context, topic: str, schema: tuple[str, dict, str]):
    """A JSON channel on ``topic`` in the foxglove ``context`` with ``schema`` (name, JSON Schema,
    what the topic shows: the channel's ``description``)."""
    name, body, doc = schema
    return foxglove.Channel(topic, schema=foxglove.Schema(name=name, encoding="jsonschema",
                                                         data=json.dumps(body).encode()),
                            message_encoding="json", context=context, metadata={"description": doc})


class McapSink:
    """Writes messages to the MCAP file at ``path`` (overwritten); ``schemas(topic)`` gives a
    topic's (schema name, JSON Schema, description) the first time it is written."""

    def __init__(self, path, schemas):
        foxglove = foxglove_sdk()
        from foxglove.mcap import MCAPWriteOptions

        self._foxglove, self._schemas = foxglove, schemas
        self._context = foxglove.Context()
        self._writer = foxglove.open_mcap(str(path), allow_overwrite=True, context=self._context,
                                          writer_options=MCAPWriteOptions(compression_threads=0))
        self._channels = {}

    def write(self, time: int, topic: str, message: dict) -> None:
        channel = self._channels.get(topic)
        if channel is None:
            channel = self._channels[topic] = foxglove_channel(self._foxglove, self._context, topic,
                                                               self._schemas(topic))
        channel.log(encode(message), log_time=time)

    def metadata(self, name: str, values: dict) -> None:
        """A metadata record ``name`` of ``values`` (as strings)."""
        self._writer.write_metadata(name, {key: str(value) for key, value in values.items()})

    def close(self) -> None:
        self._writer.close()


def flatten(message: dict, prefix: str = "") -> dict:
    """``message``'s numbers and strings as columns: objects as ``a.b``, arrays as ``a[i]``."""
    out = {}
    for key, value in message.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        elif isinstance(value, list):
            out.update(flatten({f"[{i}]": item for i, item in enumerate(value)}, name))
        else:
            out[name] = value
    return out


def table_name(topic: str) -> str:
    """A topic's table file stem: ``/wrench/contact`` → ``wrench.contact``."""
    return topic.strip("/").replace("/", ".")


class TableSink:
    """Writes one Parquet or CSV table per topic into the folder ``out`` (``fmt``: ``parquet`` or
    ``csv``); a topic's columns are those of its first batch of rows."""

    def __init__(self, out, fmt: str):
        self._out, self._fmt = Path(out), fmt
        self._rows, self._writers, self._schemas = {}, {}, {}
        self.files = []

    def write(self, time: int, topic: str, message: dict) -> None:
        rows = self._rows.setdefault(topic, [])
        rows.append({"log_time_ns": time, **flatten(message)})
        if len(rows) >= TABLE_BATCH:
            self._flush(topic)

    def _flush(self, topic: str) -> None:
        import pyarrow as pa

        rows, self._rows[topic] = self._rows[topic], []
        if not rows:
            return
        table = pa.Table.from_pylist(rows, schema=self._schemas.get(topic))
        writer = self._writers.get(topic)
        if writer is None:
            self._schemas[topic] = table.schema
            path = self._out / f"{table_name(topic)}.{self._fmt}"
            self.files.append(path)
            if self._fmt == PARQUET:
                import pyarrow.parquet as pq
                writer = pq.ParquetWriter(path, table.schema)
            else:
                import pyarrow.csv as pc
                writer = pc.CSVWriter(path, table.schema)
            self._writers[topic] = writer
        writer.write_table(table)

    def metadata(self, name: str, values: dict) -> None:
        """``values`` in ``NAME.json`` beside the tables."""
        path = self._out / f"{name}.json"
        path.write_text(json.dumps({key: str(value) for key, value in values.items()}, indent=2) + "\n")
        self.files.append(path)

    def close(self) -> None:
        for topic in list(self._rows):
            self._flush(topic)
        for writer in self._writers.values():
            writer.close()
