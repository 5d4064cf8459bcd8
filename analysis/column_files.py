"""One stream's file, read in chunks: a CSV (header row, comma-separated) or a Parquet file
(``.parquet``), through pyarrow, so an hour at 8 kHz never sits in memory whole.

Every row is checked as it streams in: a missing column, a value that is not a number, NaN, a time
that repeats or goes back. Each problem is a ``RecordingError`` of one line naming the file, the
column and the row (1-based data row; in a CSV the line is one more, after the header).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from heft.analysis.recording import TIME_UNITS, Clock

CSV_BLOCK_BYTES = 4 << 20
"""Bytes of CSV text per chunk (about 70 000 rows of a 6-column wrench)."""
PARQUET_BATCH_ROWS = 65536


class RecordingError(ValueError):
    """Bad data in a recording's file: one line naming the file, the column and the row."""


def _where(path: Path, column: str | None, row: int | None) -> str:
    text = f"{path.name}"
    if column is not None:
        text += f", column {column!r}"
    if row is not None:
        text += f", row {row}" + (f" (line {row + 1})" if path.suffix.lower() != ".parquet" else "")
    return text


class ColumnFile:
    """The ``columns`` of one stream's file and its time (s, on its own clock) in chunks.

    ``clock``: the stream's ``Clock`` (a time column and its unit, or a rate). ``stream``: the
    stream's name in the recording, for messages. Opening checks that the file and every column exist.
    """

    def __init__(self, path, clock: Clock, columns: list[str], stream: str):
        self.path, self.clock, self.columns, self.stream = Path(path), clock, list(columns), stream
        if not self.path.is_file():
            raise RecordingError(f"{self.path}: the {stream} stream's file does not exist (paths are relative "
                                 "to the recording's YAML file)")
        self.parquet = self.path.suffix.lower() == ".parquet"
        header = self._header()
        wanted = self.columns + ([clock.column] if clock.column else [])
        missing = [c for c in wanted if c not in header]
        if missing:
            raise RecordingError(f"{_where(self.path, missing[0], None)}: no such column in the {stream} file "
                                 f"(it has {', '.join(header[:12])}{', …' if len(header) > 12 else ''})")
        self._scale = TIME_UNITS[clock.unit]

    def _header(self) -> list[str]:
        if self.parquet:
            return list(pq.ParquetFile(self.path).schema_arrow.names)
        with open(self.path, newline="") as f:
            line = f.readline()
        if not line.strip():
            raise RecordingError(f"{self.path}: the {self.stream} file is empty; it needs a header row of column names")
        return [name.strip() for name in next(csv.reader([line]))]

    # --- chunks --------------------------------------------------------------
    def _batches(self):
        """pyarrow record batches of the needed columns, as float64."""
        names = self.columns + ([self.clock.column] if self.clock.column else [])
        if self.parquet:
            yield from pq.ParquetFile(self.path).iter_batches(batch_size=PARQUET_BATCH_ROWS, columns=names)
            return
        types = {name: pa.float64() for name in names}
        # A Python file object: given a path, pyarrow reads the whole file ahead of the batches asked for.
        with open(self.path, "rb") as f:
            reader = pa_csv.open_csv(
                f, read_options=pa_csv.ReadOptions(block_size=CSV_BLOCK_BYTES, use_threads=False),
                convert_options=pa_csv.ConvertOptions(include_columns=names, column_types=types,
                                                      strings_can_be_null=False))
            while True:
                try:
                    yield reader.read_next_batch()
                except StopIteration:
                    return

    def chunks(self):
        """(t (n,) s, values (n, k), first row) per chunk, every row checked; rows are 1-based."""
        row, last_t = 1, None
        batches = self._batches()
        while True:
            try:
                batch = next(batches)
            except StopIteration:
                return
            except (pa.ArrowInvalid, OSError) as error:
                raise RecordingError(self._conversion_message(str(error))) from None
            n = batch.num_rows
            if n == 0:
                continue
            values = np.column_stack([self._numbers(batch, c, row) for c in self.columns])
            if self.clock.column:
                t = self._numbers(batch, self.clock.column, row) * self._scale
            else:
                t = self.clock.start + (np.arange(row - 1, row - 1 + n)) / self.clock.rate
            self._check(t, values, row, last_t)
            last_t = t[-1]
            yield t, values, row
            row += n

    def _numbers(self, batch, column: str, first_row: int) -> np.ndarray:
        array = batch.column(batch.schema.get_field_index(column))
        if not pa.types.is_floating(array.type) and not pa.types.is_integer(array.type):
            raise RecordingError(f"{_where(self.path, column, None)}: not numbers (type {array.type})")
        x = array.to_numpy(zero_copy_only=False).astype(float, copy=False)
        bad = ~np.isfinite(x)
        if bad.any():
            k = int(np.argmax(bad))
            raise RecordingError(f"{_where(self.path, column, first_row + k)}: {x[k]} is not a finite number; "
                                 "drop or repair that row")
        return x

    def _check(self, t: np.ndarray, values: np.ndarray, first_row: int, last_t) -> None:
        previous = np.concatenate(([last_t], t[:-1])) if last_t is not None else np.concatenate(([-np.inf], t[:-1]))
        bad = t <= previous
        if bad.any():
            k = int(np.argmax(bad))
            what = "repeats the previous row's" if t[k] == previous[k] else "is before the previous row's"
            raise RecordingError(f"{_where(self.path, self.clock.column or 'rate', first_row + k)}: time {t[k]:.9g} s "
                                 f"{what} {previous[k]:.9g} s; rows must be in increasing time, each once")

    def _conversion_message(self, text: str) -> str:
        """pyarrow's conversion error ("In CSV column #3: Row #12: CSV conversion error to double:
        invalid value 'x'") as one line in the recording's terms."""
        column, row = None, None
        for part in text.replace("\n", " ").split(":"):
            part = part.strip()
            if part.startswith("In CSV column #"):
                index = int(part.split("#")[1])
                column = self._file_column(index)
            elif part.startswith("Row #"):
                row = int(part.split("#")[1]) - 1  # pyarrow counts the header as row 1
        detail = text.strip().splitlines()[0].split(": ")[-1]
        return f"{_where(self.path, column, row)}: {detail}; every value of a stream's columns must be a number"

    def _file_column(self, index: int) -> str | None:
        header = self._header()
        return header[index] if 0 <= index < len(header) else None

    # --- ends ------------------------------------------------------------------
    def span(self) -> tuple[float, float, int]:
        """(first time, last time, rows) in s on the stream's clock, read without the whole file."""
        if self.parquet:
            meta = pq.ParquetFile(self.path).metadata
            rows = meta.num_rows
        else:
            rows = _count_rows(self.path)
        if rows == 0:
            raise RecordingError(f"{self.path}: the {self.stream} file has no rows")
        if not self.clock.column:
            return self.clock.start, self.clock.start + (rows - 1) / self.clock.rate, rows
        return self._time_at_end(False, rows), self._time_at_end(True, rows), rows

    def _time_at_end(self, last: bool, rows: int) -> float:
        column, row = self.clock.column, None
        if self.parquet:
            f = pq.ParquetFile(self.path)
            group = f.num_row_groups - 1 if last else 0
            values = f.read_row_group(group, columns=[column]).column(0).to_numpy(zero_copy_only=False)
            value, row = (values[-1], rows) if last else (values[0], 1)
        else:
            line = _last_line(self.path) if last else _first_data_line(self.path)
            header = self._header()
            fields = next(csv.reader([line]))
            row = rows if last else 1
            try:
                value = float(fields[header.index(column)])
            except (ValueError, IndexError):
                raise RecordingError(f"{_where(self.path, column, row)}: {line.strip()[:60]!r} has no number "
                                     "in the time column") from None
        if not np.isfinite(value):
            raise RecordingError(f"{_where(self.path, column, row)}: {value} is not a finite time")
        return float(value) * self._scale


def _first_data_line(path: Path) -> str:
    with open(path, newline="") as f:
        f.readline()
        return f.readline()


def _last_line(path: Path) -> str:
    with open(path, "rb") as f:
        f.seek(0, io.SEEK_END)
        size = f.tell()
        f.seek(max(0, size - 65536))
        lines = [x for x in f.read().splitlines() if x.strip()]
    return lines[-1].decode()


def _count_rows(path: Path) -> int:
    """Data rows of a CSV file (non-empty lines after the header)."""
    count, last = 0, b"\n"
    with open(path, "rb") as f:
        while block := f.read(16 << 20):
            count += block.count(b"\n")
            last = block[-1:]
    if last != b"\n":
        count += 1
    return count - 1
