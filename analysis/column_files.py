"""One stream's file, read in chunks: a CSV (a header row of column names; its layout read by
``csv_layout``: the separator stated or detected, comments, a byte-order mark, CRLF) or a Parquet
file (``.parquet``), through pyarrow, so an hour at 8 kHz never sits in memory whole.

Every row is checked as it streams in: a missing column, a value that is not a number, NaN, a time
that repeats or goes back. Each problem is a ``RecordingError`` of one line naming the file, the
column and the row (1-based data row; in a CSV also the file's line).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq

from heft.analysis.csv_layout import CsvLayout, LayoutError, read_layout
from heft.analysis.recording import TIME_UNITS, Clock

CSV_BLOCK_BYTES = 1 << 20
"""Bytes of CSV text per chunk (8 000–17 000 rows of a wrench): 4 MB chunks took the peak memory of an
8 kHz recording from 290 to 490 MB, at no gain in speed."""
PARQUET_BATCH_ROWS = 65536


class RecordingError(ValueError):
    """Bad data in a recording's file: one line naming the file, the column and the row."""


class ColumnFile:
    """The ``columns`` of one stream's file and its time (s, on its own clock) in chunks.

    ``clock``: the stream's ``Clock`` (a time column and its unit, or a rate). ``stream``: the
    stream's name in the recording, for messages. ``delimiter``: the CSV's separator as the stream
    states it (``csv_layout.DELIMITERS``), None to detect it. Opening checks that the file and every
    column exist.
    """

    def __init__(self, path, clock: Clock, columns: list[str], stream: str, delimiter: str | None = None):
        self.path, self.clock, self.columns, self.stream = Path(path), clock, list(columns), stream
        if not self.path.is_file():
            raise RecordingError(f"{self.path}: the {stream} stream's file does not exist (paths are relative "
                                 "to the recording's YAML file)")
        self.parquet = self.path.suffix.lower() == ".parquet"
        self.layout: CsvLayout | None = None
        try:
            header = (list(pq.ParquetFile(self.path).schema_arrow.names) if self.parquet
                      else self._read_layout(delimiter))
        except (pa.ArrowException, OSError) as error:
            raise RecordingError(f"{self.path}: not a Parquet file pyarrow can read ({_first_line(error)})") from None
        wanted = self.columns + ([clock.column] if clock.column else [])
        missing = [c for c in wanted if c not in header]
        if missing:
            named = [name for name in header if name]
            raise RecordingError(f"{self.where(missing[0])}: no such column in the {stream} file "
                                 f"(it has {', '.join(named[:12])}{', …' if len(named) > 12 else ''})")
        twice = [c for c in wanted if header.count(c) > 1]
        if twice:
            raise RecordingError(f"{self.where(twice[0])}: the header names this column {header.count(twice[0])} "
                                 "times; rename one")
        self._index = {name: header.index(name) for name in wanted}
        self._scale = TIME_UNITS[clock.unit]

    def _read_layout(self, delimiter) -> list[str]:
        try:
            self.layout = read_layout(self.path, delimiter, self.stream)
        except LayoutError as error:
            raise RecordingError(str(error)) from None
        return self.layout.names

    def where(self, column: str | None = None, row: int | None = None) -> str:
        """The place of a problem for its message: the file, the column (or columns), the row (and a
        CSV's line)."""
        text = self.path.name
        if column is not None:
            text += f", column {column!r}" if "…" not in column else f", columns {column}"
        if row is not None:
            text += f", row {row}" + (f" (line {self.layout.line_of_row(row)})" if self.layout else "")
        return text

    # --- chunks --------------------------------------------------------------
    def _batches(self):
        """pyarrow record batches of the needed columns, as float64."""
        names = self.columns + ([self.clock.column] if self.clock.column else [])
        if self.parquet:  # without pre-buffering and threads: else pyarrow reads the whole file ahead
            batches = pq.ParquetFile(self.path, pre_buffer=False).iter_batches(
                batch_size=PARQUET_BATCH_ROWS, columns=names, use_threads=False)
            yield from batches
            return
        fields = [f"c{i}" for i in range(len(self.layout.names))]  # the file's names may repeat or be empty
        rename = {fields[self._index[name]]: name for name in names}
        # A Python file object: given a path, pyarrow reads the whole file ahead of the batches asked for.
        with self.layout.data_lines() as f:
            reader = pa_csv.open_csv(
                f, read_options=pa_csv.ReadOptions(block_size=CSV_BLOCK_BYTES, use_threads=False, column_names=fields),
                parse_options=pa_csv.ParseOptions(delimiter=self.layout.delimiter or ","),
                convert_options=pa_csv.ConvertOptions(include_columns=list(rename),
                                                      column_types={field: pa.float64() for field in rename},
                                                      strings_can_be_null=False))
            while True:
                try:
                    batch = reader.read_next_batch()
                except StopIteration:
                    return
                yield pa.RecordBatch.from_arrays(batch.columns, names=[rename[n] for n in batch.schema.names])

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
            raise RecordingError(f"{self.where(column)}: not numbers (type {array.type})")
        x = array.to_numpy(zero_copy_only=False).astype(float, copy=False)
        bad = ~np.isfinite(x)
        if bad.any():
            k = int(np.argmax(bad))
            raise RecordingError(f"{self.where(column, first_row + k)}: {x[k]} is not a finite number; "
                                 "drop or repair that row")
        return x

    def _check(self, t: np.ndarray, values: np.ndarray, first_row: int, last_t) -> None:
        previous = np.concatenate(([last_t], t[:-1])) if last_t is not None else np.concatenate(([-np.inf], t[:-1]))
        bad = t <= previous
        if bad.any():
            k = int(np.argmax(bad))
            what = "repeats the previous row's" if t[k] == previous[k] else "is before the previous row's"
            raise RecordingError(f"{self.where(self.clock.column or 'rate', first_row + k)}: time {t[k]:.9g} s "
                                 f"{what} {previous[k]:.9g} s; rows must be in increasing time, each once")

    def _conversion_message(self, text: str) -> str:
        """pyarrow's conversion or parse error ("In CSV column #3: Row #12: CSV conversion error to
        double: invalid value 'x'", "CSV parse error: Row #5: Expected 7 columns, got 6: …") as one line in
        the recording's terms. pyarrow counts the data rows from 1, as the messages do."""
        first = _first_line(text)
        column = re.search(r"In CSV column #(\d+)", first)
        row = re.search(r"Row #(\d+)", first)
        detail = re.sub(r"In CSV column #\d+: |CSV (parse|conversion) error( to \w+)?: |Row #\d+: ", "", first)
        comma = re.search(r"invalid value '[-+]?\d*,\d+'", first)
        return (f"{self.where(self._column_named(int(column[1])) if column else None, int(row[1]) if row else None)}: "
                f"{detail[:100]}; every row needs the header's fields, each a number"
                + (" with a decimal point" if comma else ""))

    def _column_named(self, index: int) -> str | None:
        names = self.layout.names if self.layout else []
        return names[index] if 0 <= index < len(names) else None

    # --- ends ------------------------------------------------------------------
    def span(self) -> tuple[float, float, int]:
        """(first time, last time, rows) in s on the stream's clock, read without the whole file."""
        rows = pq.ParquetFile(self.path).metadata.num_rows if self.parquet else self.layout.rows()
        if rows == 0:
            raise RecordingError(f"{self.path}: the {self.stream} file has no rows")
        if not self.clock.column:
            return self.clock.start, self.clock.start + (rows - 1) / self.clock.rate, rows
        return self._time_at_end(False, rows), self._time_at_end(True, rows), rows

    def _time_at_end(self, last: bool, rows: int) -> float:
        column = self.clock.column
        row = rows if last else 1
        if self.parquet:
            f = pq.ParquetFile(self.path)
            group = f.num_row_groups - 1 if last else 0
            values = f.read_row_group(group, columns=[column]).column(0).to_numpy(zero_copy_only=False)
            value = values[-1] if last else values[0]
        else:
            line = self.layout.last_row() if last else self.layout.first_row()
            fields = self.layout.fields(line or "")
            try:
                value = float(fields[self._index[column]])
            except (ValueError, IndexError):
                raise RecordingError(f"{self.where(column, row)}: {(line or '').strip()[:60]!r} has no number "
                                     "in the time column") from None
        if not np.isfinite(value):
            raise RecordingError(f"{self.where(column, row)}: {value} is not a finite time")
        return float(value) * self._scale


def _first_line(error) -> str:
    text = str(error).strip()
    return text.splitlines()[0] if text else type(error).__name__
