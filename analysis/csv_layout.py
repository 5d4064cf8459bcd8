"""How a lab's logger laid out a CSV file: the separator (stated as a stream's ``delimiter:`` or
detected), the header row and its column names, and the data rows that follow it.

Read as loggers write: a UTF-8 byte-order mark, ``#`` comment lines and blank lines anywhere, CRLF
line ends, names padded with spaces or quoted, a trailing separator (an empty last column), columns
separated by runs of spaces or tabs. ``DataLines`` hands pyarrow's reader only the data rows, with
runs of whitespace turned into commas, block by block in C-speed byte operations.
"""

from __future__ import annotations

import codecs
import csv
import dataclasses
import io
import re
from pathlib import Path

DELIMITERS = {",": ",", ";": ";", "\t": "\t", "tab": "\t", "|": "|", "whitespace": None}
"""What a stream's ``delimiter:`` may say → its separator (None: runs of spaces or tabs)."""
DETECTED = (",", ";", "\t", "|")
"""Separators tried, in this order, before runs of whitespace."""
HEAD_BYTES = 1 << 16
"""Bytes read to find the header and detect the separator (the header and up to ``SAMPLE_LINES`` rows)."""
SAMPLE_LINES = 20
BLOCK_BYTES = 1 << 20

_SKIPPED = re.compile(rb"(?m)^[ \t\r]*(?:#[^\n]*)?(?:\n|\Z)")
"""A comment line or a blank line, with its end."""
_SPACES = re.compile(rb"[ \t]+")
_EDGE_SPACES = re.compile(rb"(?m)^[ \t]+|[ \t]*(?=\r?$)")


class LayoutError(ValueError):
    """A CSV file whose layout cannot be read: one line naming the file and the line."""


def _skipped(line: str) -> bool:
    stripped = line.strip()
    return not stripped or stripped.startswith("#")


def split(line: str, delimiter: str | None) -> list[str]:
    """The fields of one line: stripped of spaces and of the quotes around them."""
    if delimiter is None:
        fields = line.split()
    else:
        fields = next(csv.reader([line.rstrip("\r\n")], delimiter=delimiter, skipinitialspace=True), [])
    return [f.strip().strip('"').strip("'").strip() for f in fields]


@dataclasses.dataclass
class CsvLayout:
    """A CSV file's layout: ``delimiter`` (None: whitespace), the header's ``names`` (one per field of
    a data row; "" for an unnamed one), the 1-based line of the header, the byte offset where the lines
    after it start, and ``how`` the separator was known."""
    path: Path
    delimiter: str | None
    names: list[str]
    header_line: int
    data_offset: int
    how: str

    def describe(self) -> str:
        name = {None: "whitespace", "\t": "tab"}.get(self.delimiter, repr(self.delimiter))
        return f"{self.path.name}: separator {name} ({self.how}), header on line {self.header_line}"

    def fields(self, line: str) -> list[str]:
        return split(line, self.delimiter)

    def data_lines(self) -> io.BufferedReader:
        """The data rows as bytes for pyarrow: comments and blank lines dropped, comma-separated if the
        file separates by whitespace."""
        return io.BufferedReader(DataLines(self.path, self.data_offset, self.delimiter is None), BLOCK_BYTES)

    def rows(self) -> int:
        """Data rows in the file (read through, at the speed of its bytes)."""
        count, last = 0, b"\n"
        with self.data_lines() as lines:
            while block := lines.read(16 << 20):
                count += block.count(b"\n")
                last = block[-1:]
        return count + (last != b"\n")

    def line_of_row(self, row: int) -> int:
        """The 1-based line of the file that holds data row ``row`` (1-based)."""
        with open(self.path, "rb") as f:
            f.seek(self.data_offset)
            line, seen = self.header_line, 0
            for raw in f:
                line += 1
                if not _skipped(raw.decode("utf-8", "replace")):
                    seen += 1
                    if seen == row:
                        return line
        return line

    def first_row(self) -> str | None:
        """The first data row's text, or None."""
        with open(self.path, "rb") as f:
            f.seek(self.data_offset)
            for raw in f:
                text = raw.decode("utf-8", "replace")
                if not _skipped(text):
                    return text
        return None

    def last_row(self) -> str | None:
        """The last data row's text, read from the file's end."""
        with open(self.path, "rb") as f:
            f.seek(0, io.SEEK_END)
            size = f.tell()
            start = max(self.data_offset, size - HEAD_BYTES)
            f.seek(start)
            lines = [x.decode("utf-8", "replace") for x in f.read().splitlines()]
        rows = [x for x in (lines[1:] if start > self.data_offset else lines) if not _skipped(x)]
        return rows[-1] if rows else None


def read_layout(path: Path, stated: str | None, stream: str) -> CsvLayout:
    """The layout of the CSV file at ``path``: its separator ``stated`` (a key of ``DELIMITERS``) or
    detected from the header and the first rows; a ``LayoutError`` of one line if it cannot be read."""
    with open(path, "rb") as f:
        head = f.read(HEAD_BYTES)
    if head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        raise LayoutError(f"{path.name}: the {stream} file is UTF-16 text; heft reads UTF-8 (or ASCII): save it as "
                          "UTF-8 (e.g. `iconv -f UTF-16 -t UTF-8`)")
    nul = head.find(b"\0")
    if nul >= 0:
        raise LayoutError(f"{path.name}, byte {nul + 1}: the {stream} file holds binary data (a NUL byte), not CSV "
                          "text; a Parquet file needs the .parquet suffix")
    offset = len(codecs.BOM_UTF8) if head.startswith(codecs.BOM_UTF8) else 0
    header, header_line, data_offset, samples = None, 0, 0, []
    number = 0
    for raw in head[offset:].splitlines(keepends=True):
        complete = raw.endswith(b"\n")
        number += 1
        offset += len(raw)
        text = raw.decode("utf-8", "replace")
        if _skipped(text):
            continue
        if header is None:
            header, header_line, data_offset = text, number, offset
        elif complete or offset == len(head):
            samples.append((number, text))
        if len(samples) >= SAMPLE_LINES:
            break
    if header is None:
        raise LayoutError(f"{path}: the {stream} file has no header row of column names (it is empty or all comments)")
    if stated is not None:
        delimiter, how = DELIMITERS[stated], "stated"
    else:
        delimiter, how = _detect(path, header, header_line, samples), "detected"
    names = split(header, delimiter)
    if samples:
        names = _matched(path, names, header_line, samples, delimiter)
    return CsvLayout(path, delimiter, names, header_line, data_offset, how)


def _counts(lines, delimiter) -> list[int]:
    """Fields per line, a trailing empty field not counted."""
    out = []
    for text in lines:
        fields = split(text, delimiter)
        out.append(len(fields) - (len(fields) > 1 and fields[-1] == ""))
    return out


def _detect(path: Path, header: str, header_line: int, samples: list) -> str | None:
    """The separator under which the header has more than one field and most of the sampled rows (at
    least half) as many as the header: a row that differs is then named by the reader."""
    lines = [text for _, text in samples]
    best, best_agree = None, -1
    for delimiter in DETECTED + (None,):
        fields, *counts = _counts([header] + lines, delimiter)
        agree = sum(count == fields for count in counts)
        if fields > 1 and 2 * agree >= len(counts) and agree > best_agree:
            best, best_agree = delimiter, agree
    if best_agree >= 0:
        return best
    if all(count == 1 for d in DETECTED + (None,) for count in _counts([header] + lines, d)):
        return ","  # one column
    counts = {repr(d) if d else "whitespace": _counts([header] + lines, d)[:4] for d in DETECTED + (None,)}
    raise LayoutError(f"{path.name}, lines {header_line}–{samples[-1][0] if samples else header_line}: cannot tell "
                      f"the columns' separator (fields on the header and the first rows by separator: {counts}); "
                      "state it as the stream's delimiter: one of , ; tab | whitespace")


def _matched(path: Path, names: list, header_line: int, samples: list, delimiter) -> list[str]:
    """The header's names, one per field of the sampled rows (as most have them): a trailing separator
    on either side adds or drops an unnamed last column."""
    rows = [split(text, delimiter) for _, text in samples]
    lengths = [len(fields) for fields in rows]
    fields = max(set(lengths), key=lengths.count)
    if fields == len(names):
        return names
    if fields == len(names) - 1 and names[-1] == "":
        return names[:-1]
    if fields == len(names) + 1 and all(row[-1] == "" for row in rows if len(row) == fields):
        return names + [""]
    raise LayoutError(f"{path.name}, line {samples[lengths.index(fields)][0]}: {fields} fields where the header "
                      f"(line {header_line}) names {len(names)} columns")


class DataLines(io.RawIOBase):
    """The bytes of a CSV file from ``offset`` on, whole lines at a time, without comment lines or
    blank lines; with ``whitespace``, each line's runs of spaces and tabs turned into one comma."""

    def __init__(self, path: Path, offset: int, whitespace: bool):
        self._file = open(path, "rb")
        self._file.seek(offset)
        self._whitespace, self._carry, self._ready = whitespace, b"", b""

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        while not self._ready:
            block = self._file.read(BLOCK_BYTES)
            if not block and not self._carry:
                return 0
            text = self._carry + block
            end = text.rfind(b"\n") + 1 if block else len(text)
            if end == 0:
                self._carry = text
                continue
            self._carry, self._ready = text[end:], self._clean(text[:end])
        n = min(len(buffer), len(self._ready))
        buffer[:n] = self._ready[:n]
        self._ready = self._ready[n:]
        return n

    def _clean(self, lines: bytes) -> bytes:
        if b"#" in lines or b"\n\n" in lines or b"\n\r\n" in lines or lines[:1] in (b"\n", b"\r", b" ", b"\t") \
                or b"\n " in lines or b"\n\t" in lines:
            lines = _SKIPPED.sub(b"", lines)
        if self._whitespace:
            lines = _SPACES.sub(b",", _EDGE_SPACES.sub(b"", lines))
        return lines

    def close(self) -> None:
        self._file.close()
        super().close()
