"""Parsing and checking the CSV files of logs and programs (docs/files.md).

:mod:`rsp_inertia.plant.logs` reads through these functions: a table with exactly the
expected header and finite numbers, time stamps from 0 at the encoder's sample rate (a log's
within :data:`JITTER_LIMIT` of its grid, a program's regular), angles on the encoder grid, the
direction of a pass, integer counts of a wrapping counter unwrapped. Every fault is one
:class:`~rsp_inertia.infra.errors.InputError` line naming the file and the line (1-based
lines of the file, the header being line 1).
"""

from __future__ import annotations

import codecs
import itertools
import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.direction import Direction

__all__ = [
    "CHUNK_BYTES",
    "GRID_TOLERANCE",
    "JITTER_LIMIT",
    "MEAN_RATE_TOLERANCE",
    "RATE_TOLERANCE",
    "SETTLE_ANGLE",
    "SETTLE_COUNTS",
    "SPEED_MARGIN",
    "STEP_SLACK_COUNTS",
    "STOP_COUNTS",
    "STOP_MARGIN",
    "T0_TOLERANCE",
    "TORQUE_MARGIN",
    "TORQUE_SIGNIFICANCE",
    "EncoderLike",
    "Rows",
    "brakes_along_the_motion",
    "check_direction",
    "check_grid",
    "check_speed",
    "check_time",
    "check_torque",
    "read_header",
    "read_table",
    "settle_counts",
    "turning_point",
    "unterminated_last_line",
    "unwrap_counts",
]

T0_TOLERANCE = 1e-9
"""s, how far from 0 the first time stamp may be."""

RATE_TOLERANCE = 1e-3
"""Relative tolerance on every time step of a program against 1 / sample_rate."""

JITTER_LIMIT = 0.25
"""Fraction of a sample period by which a log's time stamp may be off the regular grid.

A log's time stamps are the instants at which the drive read the encoder and set the torque
(the torque of row k acts over [t_k, t_k+1)); they need not be regular. With every stamp
within +-JITTER_LIMIT of a period of its grid instant, a step of one sample lies between
1 - 2 JITTER_LIMIT = 0.5 and 1.5 periods, and a step of about n periods (n >= 2) is a gap of
n - 1 samples the logger dropped (:func:`rsp_inertia.plant.logs.dropped_samples`). A step
shorter than half a period is refused (a repeated row, or a sample rate that is not
device.toml's)."""

MEAN_RATE_TOLERANCE = 0.01
"""Relative tolerance on a log's mean sample period (its duration over the periods its steps
count, dropped samples included) against 1 / sample_rate; jitter moves it by at most
2 JITTER_LIMIT / periods."""

GRID_TOLERANCE = 1e-3
"""Counts, how far phi / q may be from a whole number."""


class EncoderLike(Protocol):
    """What the readers need of an encoder (``rsp_inertia.plant.config.Encoder`` has it)."""

    @property
    def quantum(self) -> float:
        """rad, q = 2 pi / counts_per_rev."""
        ...

    @property
    def sample_rate(self) -> float:
        """Hz."""
        ...


@dataclass(frozen=True)
class Rows:
    """Where a log's data rows are in its file, for messages: ``Rows(path)`` is a CSV whose
    data row 0 is the file's line 2 (the header line 1); ``first_line`` moves it (a header
    further down, a units row); None names rows, not lines (a binary file: TDMS, Parquet).
    ``left_out`` are the file's data rows the reader left out of the arrays it checks
    (glitches, rsp_inertia.plant.log_glitches): array row k names the k-th of the others.

    Examples
    --------
    >>> Rows("stage1/braking.csv").at(0)
    'stage1/braking.csv, line 2'
    >>> Rows("stage1/braking.parquet", first_line=None).at(0)
    'stage1/braking.parquet, row 1'
    >>> Rows("stage1/braking.csv").without([1]).at(1)
    'stage1/braking.csv, line 4'
    """

    path: str
    """The file, as the messages name it."""
    first_line: int | None = 2
    """The file's (1-based) line of data row 0; None: a binary file, whose rows are named."""
    left_out: tuple[int, ...] = ()
    """The file's data rows (0-based, increasing) missing from the arrays the rows of the
    messages index."""

    def at(self, k: int) -> str:
        """``"path, line N"`` (or ``"path, row N"``) of data row ``k`` (0-based)."""
        return f"{self.path}, {self.line(k)}"

    def line(self, k: int) -> str:
        """``"line N"`` (or ``"row N"``) of data row ``k`` (0-based), without the file."""
        k = self._file_row(k)
        if self.first_line is None:
            return f"row {k + 1}"
        return f"line {self.first_line + k}"

    def span(self, first: int, last: int) -> str:
        """``"path, lines N-M"`` (or ``"path, rows N-M"``) of data rows ``first`` to ``last``."""
        first, last = self._file_row(first), self._file_row(last)
        if self.first_line is None:
            return f"{self.path}, rows {first + 1}-{last + 1}"
        return f"{self.path}, lines {self.first_line + first}-{self.first_line + last}"

    def without(self, rows: Sequence[int]) -> Rows:
        """These rows after the arrays' ``rows`` (indices into them) are left out too."""
        dropped = sorted({self._file_row(int(k)) for k in rows} | set(self.left_out))
        return Rows(self.path, self.first_line, tuple(dropped))

    def _file_row(self, k: int) -> int:
        """The file's data row of array row ``k``."""
        for skipped in self.left_out:
            if skipped <= k:
                k += 1
        return k

    def __str__(self) -> str:
        return self.path


def as_rows(path: str | os.PathLike | Rows) -> Rows:
    """``path`` as :class:`Rows`: a path names a CSV whose data start on line 2."""
    return path if isinstance(path, Rows) else Rows(str(path))


CHUNK_BYTES = 1 << 22
"""Bytes of a table read at a time (about 65,000 rows of a log): with the float array of the
values, all the memory reading a table takes, whatever its length."""

_NOT_SPACE_FOR_FLOAT = "\x1c\x1d\x1e\x1f"
"""Separators numpy's text reader takes for white space around a number in ASCII text and
float() does not: a piece holding one is parsed field by field."""


@dataclass(frozen=True)
class CsvDialect:
    """How a CSV table is written (device.toml ``[log]``'s CSV keys; program.csv: the
    defaults)."""

    delimiter: str = ","
    """The field delimiter; ``" "`` is any run of blanks."""
    decimal: str = "."
    """The decimal mark: ``"."`` or ``","`` (then the delimiter is not ``","``)."""
    header_line: int = 1
    """The (1-based) line of the column names; the lines before it are skipped."""
    skip_after_header: int = 0
    """Lines between the header and the data, skipped (a units row)."""

    @property
    def first_line(self) -> int:
        """The file's line of the first data row."""
        return self.header_line + self.skip_after_header + 1


@dataclass(frozen=True)
class CsvTable:
    """The columns :func:`read_columns` read, and where their rows are in the file."""

    values: np.ndarray
    """shape (n, len(columns)), float64, column-major (each column contiguous)."""
    rows: Rows
    """The file and the line of data row 0, for messages."""
    integers: np.ndarray | None
    """The ``integer`` column as int64, exactly, when every one of its fields is an integer;
    else None."""


def read_table(path: str | os.PathLike, columns: Sequence[str]) -> np.ndarray:
    """Parse a CSV with exactly ``columns`` as header into an (n, len(columns)) float array.

    Every value is ``float()`` of its field. The file is read as UTF-8 (a BOM is skipped)
    with any line end (\\n, \\r\\n, \\r); blank lines may end it; a last line of data
    without a line end is left out (:func:`unterminated_last_line`: it may be cut short).
    It is read twice, in pieces of :data:`CHUNK_BYTES`: once to check the encoding and count
    the lines, once to
    parse a piece at a time into the preallocated array (numpy's C reader; field by field
    where it may differ from float() or refuses the piece, to name the fault). The array is
    column-major: each column is contiguous. Line numbers in messages are 1-based lines of
    the file (the header is line 1); of several faults, the message names the first of the
    first kind in this order: header, field count or blank line, not a number, not finite.
    """
    return read_columns(path, columns).values


def read_columns(
    path: str | os.PathLike,
    columns: Sequence[str],
    dialect: CsvDialect = CsvDialect(),
    keys: Sequence[str] | None = None,
    integer: int | None = None,
) -> CsvTable:
    """Parse the named columns of a CSV in ``dialect`` into float arrays.

    As :func:`read_table`, in any dialect: the header on ``dialect.header_line`` (the lines
    before it skipped), ``dialect.skip_after_header`` lines after it skipped, fields split at
    ``dialect.delimiter`` (``" "``: any run of blanks), a decimal comma read as a point
    (the bytes translated once the delimiter is known not to be a comma). Line numbers in
    messages are the file's own lines. A file of plain numbers is read whole by pyarrow's
    CSV reader (:func:`_arrow_columns`, the same numbers about ten times faster); any other
    goes the careful way, in pieces, which names its fault.

    Parameters
    ----------
    path : str or path-like
        The file.
    columns : sequence of str
        The columns wanted, in the order of the result.
    dialect : CsvDialect
        How the file is written.
    keys : sequence of str, optional
        The device.toml key that names each column (``[log] torque_column``...): the header
        then may hold the columns in any order with others, which are ignored (each row must
        have the header's number of fields), names compared after stripping blanks and
        double quotes; a column not found names its key. None: the header must be exactly
        ``columns`` (program.csv).
    integer : int, optional
        The index in ``columns`` of a column also read exactly as int64 when all its fields
        are integers (epoch time stamps in ns exceed float64's 2^53).

    Returns
    -------
    CsvTable
        The values, where their rows are, and the integer column.

    Raises
    ------
    InputError
        One line naming the file and the line: as :func:`read_table`, a column not found (the
        header's names and the key to set), a field that is not a number (on the first data
        row: a units row, ``skip_after_header``).
    """
    ncol = len(columns)
    hints = keys is not None
    comma = dialect.decimal == ","
    try:
        unterminated = unterminated_last_line(path)
        pieces = _pieces_of_lines(path, unterminated)
        head, pieces = _head(pieces, dialect.first_line - 1)
        if not any(line.strip() for line in head) and not any(
            line.strip() for piece, _ in pieces for line in piece
        ):
            expected = "" if hints else f", expected a header {','.join(columns)!r}"
            raise InputError(f"{path}: the file is empty{expected}")
        if len(head) < dialect.header_line:
            raise InputError(
                f"{path}: {len(head)} line(s), the header is expected at line "
                f"{dialect.header_line} (set [log] header_line)"
            )
        header_line = head[dialect.header_line - 1]
        names = _split(header_line, dialect.delimiter)
        header = [name.strip().strip('"').strip() for name in names]
        if hints:
            where = _find_columns(path, header, header_line, columns, keys, dialect)
        elif header != list(columns):
            found = header_line.strip()
            shown = repr(found) if len(found) <= 80 else repr(found[:77]) + "..."
            raise InputError(
                f"{path}, line {dialect.header_line}: header is {shown}, expected "
                f"{','.join(columns)!r}"
            )
        else:
            where = list(range(ncol))
        if not unterminated:
            fast = _arrow_columns(path, where, len(header), dialect, integer)
            if fast is not None:
                return fast
        size = _count_line_breaks(path)
        values = np.empty((ncol, size))
        ints = np.empty(size, dtype=np.int64) if integer is not None else None
        table = _Table(path, columns, where, len(header), dialect, hints)

        rows = 0  # data rows so far, the last of them not blank
        first_blank = None  # line of the first blank line after the last row read
        not_a_number = not_finite = None  # the first fault of each kind, raised at the end
        exact = integer  # the integer column, while its fields all are integers
        for piece, fast in pieces:
            number = dialect.first_line + rows  # the file's line of piece[0]
            fast_piece = _translated(piece) if comma and fast else piece
            block = table.fast_rows(fast_piece) if fast and first_blank is None else None
            if block is None:
                block, first_blank, fault, whole = table.careful_rows(piece, number, first_blank)
                not_a_number = not_a_number or fault
                if exact is not None and ints is not None:
                    column = whole[:, where[exact]] if whole is not None else None
                    exact = _integers(column, ints, rows, exact)
            elif exact is not None and ints is not None:
                exact = table.fast_integers(fast_piece, exact, ints, rows)
            if not_finite is None:
                bad = np.argwhere(~np.isfinite(block))
                if bad.size:
                    row, col = bad[0]
                    not_finite = (
                        f"{path}, line {number + row}: {columns[col]} = "
                        f"{float(block[row, col])!r} is not finite"
                    )
            values[:, rows : rows + len(block)] = block.T
            rows += len(block)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file (byte {exc.start})") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None

    if not_a_number or not_finite:
        raise InputError(not_a_number or not_finite)
    if rows < 2:
        raise InputError(f"{path}: {rows} data row(s), at least 2 are needed")
    integers = ints[:rows] if exact is not None and ints is not None else None
    return CsvTable(values[:, :rows].T, Rows(str(path), dialect.first_line), integers)


def _arrow_columns(
    path: str | os.PathLike,
    where: list[int],
    nfields: int,
    dialect: CsvDialect,
    integer: int | None,
) -> CsvTable | None:
    """The columns at the header's fields ``where`` read by pyarrow's CSV reader, the
    fastest there is (about 9 million rows a second here, single-threaded, against numpy's
    0.8): or None whenever the file is not plain numbers in every row, and the careful reader
    (:func:`read_columns`) then reads it, naming the fault and its line.

    Only what ``float()`` reads alike is taken: no quoting, no nulls, no booleans or dates,
    every row with the header's ``nfields`` fields (an empty line is a row of one), every
    value finite and at least two rows; each column parsed as int64 (every field an integer)
    or float64, which pyarrow rounds correctly, as ``float()`` does. A delimiter of any run
    of blanks (``" "``) is tried as a single space: a file with runs of blanks or tabs has
    rows of other field counts, or empty fields, and goes the careful way.
    """
    # pyarrow takes a few hundred ms to load: only when a log is read
    import pyarrow as pa
    import pyarrow.csv as pa_csv

    names = [f"c{k}" for k in range(nfields)]
    try:
        size = _count_line_breaks(path)  # at least the data rows (the encoding checked)
        reader = pa_csv.open_csv(
            path,
            read_options=pa_csv.ReadOptions(
                use_threads=False,
                skip_rows=dialect.first_line - 1,
                column_names=names,
                block_size=CHUNK_BYTES,
            ),
            parse_options=pa_csv.ParseOptions(
                delimiter=dialect.delimiter,
                quote_char=False,
                double_quote=False,
                escape_char=False,
                ignore_empty_lines=False,
            ),
            convert_options=pa_csv.ConvertOptions(
                include_columns=[names[k] for k in where],
                null_values=[],
                true_values=[],
                false_values=[],
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
                timestamp_parsers=[],
                decimal_point=dialect.decimal,
            ),
        )
        # A block at a time into the arrays (the memory of reading: theirs and one block's).
        values = np.empty((len(where), size))
        ints = np.empty(size, dtype=np.int64) if integer is not None else None
        rows = 0
        for batch in reader:
            m = batch.num_rows
            if rows + m > size or any(
                not (pa.types.is_float64(c.type) or pa.types.is_int64(c.type)) or c.null_count
                for c in batch.columns
            ):
                return None
            for k, column in enumerate(batch.columns):
                values[k, rows : rows + m] = column.to_numpy()
            if ints is not None:
                column = batch.columns[integer]
                if pa.types.is_int64(column.type):
                    ints[rows : rows + m] = column.to_numpy()
                else:
                    ints = None
            if not np.isfinite(values[:, rows : rows + m]).all():
                return None
            rows += m
    except (pa.ArrowException, OSError, ValueError):  # the careful reader names the fault
        return None
    finally:  # its arena's blocks back to the system, not kept beside the arrays after it
        pa.default_memory_pool().release_unused()
    if rows < 2:
        return None
    integers = None if ints is None else ints[:rows]
    return CsvTable(values[:, :rows].T, Rows(str(path), dialect.first_line), integers)


def _split(line: str, delimiter: str) -> list[str]:
    """A line's fields: split at ``delimiter``, or at runs of blanks for ``" "``."""
    return line.split() if delimiter == " " else line.split(delimiter)


def _translated(lines: list[str]) -> list[str]:
    """Lines with each decimal comma a point (no comma is a delimiter: the dialect's rule)."""
    return "\n".join(lines).replace(",", ".").split("\n")


def _find_columns(
    path: str | os.PathLike,
    header: list[str],
    line: str,
    columns: Sequence[str],
    keys: Sequence[str],
    dialect: CsvDialect,
) -> list[int]:
    """The header's index of each of ``columns``; a column not found, or found twice, is one
    line naming the header's names and the key to set."""
    where = []
    for column, key in zip(columns, keys, strict=True):
        found = [k for k, name in enumerate(header) if name == column]
        if len(found) == 1:
            where.append(found[0])
            continue
        at = f"{path}, line {dialect.header_line}"
        if found:
            raise InputError(f"{at}: column {column!r} appears {len(found)} times in the header")
        shown = ", ".join(repr(name) for name in header[:12]) + (", ..." if len(header) > 12 else "")
        others = [d for d in (",", ";", "\t") if d != dialect.delimiter and d in line]
        if len(header) == 1 and others:
            key = "delimiter"  # one field: the header is split at another character
        raise InputError(
            f"{at}: column {column!r} not found; the header has {shown}: set [log] {key}"
        )
    return where


def _head(
    pieces: Iterator[tuple[list[str], bool]], count: int
) -> tuple[list[str], Iterator[tuple[list[str], bool]]]:
    """The first ``count`` lines of the file (fewer if it is shorter), and the pieces of the
    lines after them (the first one's ``plain`` flag found again without the head lines)."""
    head: list[str] = []
    for lines, plain in pieces:
        take = count - len(head)
        head += lines[:take]
        rest = lines[take:]
        if len(head) < count:
            continue
        if rest:
            if not plain:
                text = "\n".join(rest)
                plain = text.isascii() and not any(c in text for c in _NOT_SPACE_FOR_FLOAT)
            return head, itertools.chain([(rest, plain)], pieces)
        return head, pieces
    return head, iter(())


def _integers(column: np.ndarray | None, ints: np.ndarray, start: int, index: int) -> int | None:
    """Store a piece's integer column, ``column`` its fields as text (None: no rows), into
    ``ints`` from ``start``; ``index`` while all are integers, else None."""
    if column is None:
        return index
    try:
        parsed = np.array([int(field) for field in column], dtype=np.int64)
    except (ValueError, OverflowError):
        return None
    ints[start : start + len(parsed)] = parsed
    return index


@dataclass(frozen=True)
class _Table:
    """The layout of a CSV's data rows, for the per-piece parsers of :func:`read_columns`."""

    path: str | os.PathLike
    columns: Sequence[str]
    where: list[int]
    """The header's index of each wanted column."""
    nfields: int
    """Fields per row: the header's."""
    dialect: CsvDialect
    hints: bool
    """Messages name device.toml's [log] keys."""

    @property
    def _delimiter(self) -> str | None:
        return None if self.dialect.delimiter == " " else self.dialect.delimiter

    @property
    def _usecols(self) -> list[int] | None:
        return None if self.where == list(range(self.nfields)) else self.where

    def fast_rows(self, lines: list[str]) -> np.ndarray | None:
        """The (len(lines), ncol) values by numpy's C reader, or None on any fault, a blank
        line (it skips empty ones) or a row with another number of fields than the header."""
        if not lines or not lines[0].strip():  # (none at all but blank ones: numpy warns)
            return None
        delimiter = self._delimiter
        # numpy checks only the columns it reads: count every row's delimiters at once
        fields = len(lines) * (self.nfields - 1)
        if delimiter is not None and self._usecols and "\n".join(lines).count(delimiter) != fields:
            return None
        try:
            block = np.loadtxt(
                lines, delimiter=delimiter, comments=None, ndmin=2, usecols=self._usecols
            )
        except ValueError:
            return None
        return block if block.shape == (len(lines), len(self.columns)) else None

    def fast_integers(
        self, lines: list[str], index: int, ints: np.ndarray, start: int
    ) -> int | None:
        """Column ``index`` of a piece parsed as int64 into ``ints`` from ``start``;
        ``index``, or None when a field is not an integer."""
        try:
            parsed = np.loadtxt(
                lines,
                delimiter=self._delimiter,
                comments=None,
                ndmin=1,
                usecols=[self.where[index]],
                dtype=np.int64,
            )
        except (ValueError, OverflowError):
            return None
        ints[start : start + len(parsed)] = parsed
        return index

    def careful_rows(
        self, lines: list[str], number: int, first_blank: int | None
    ) -> tuple[np.ndarray, int | None, str | None, np.ndarray | None]:
        """Parse lines field by field from line ``number`` on: the rows before any blank line
        (k, ncol), the first blank line if only blank lines follow it, the first field that
        is not a number (its message; NaN in the rows), and the rows' fields as text (None
        when there are none). A wrong field count, or a line after a blank one, raises at
        once."""
        path, columns, ncol = self.path, self.columns, len(self.columns)
        comma = self.dialect.decimal == ","
        numbers: list[float] = []
        texts: list[list[str]] = []
        fault = None
        for index, line in enumerate(lines):
            if not line.strip():
                if first_blank is None:
                    first_blank = number + index
                continue
            if first_blank is not None:
                raise InputError(f"{path}, line {first_blank}: blank line inside the data")
            fields = _split(line, self.dialect.delimiter)
            if len(fields) != self.nfields:
                expected = (
                    f"{self.nfields} (the header's)"
                    if self.hints
                    else f"{ncol} ({','.join(columns)})"
                )
                raise InputError(
                    f"{path}, line {number + index}: {len(fields)} fields, expected {expected}"
                )
            texts.append(fields)
            for col, k in enumerate(self.where):
                field = fields[k]
                try:
                    numbers.append(float(field.replace(",", ".") if comma else field))
                except ValueError:
                    numbers.append(math.nan)
                    fault = fault or self._not_a_number(number + index, columns[col], field)
        whole = np.array(texts, dtype=object) if texts else None
        block = np.array(numbers, dtype=np.float64).reshape(-1, ncol)
        return block, first_blank, fault, whole

    def _not_a_number(self, line: int, column: str, field: str) -> str:
        """The message of a field that is not a number, with the key that likely fixes it."""
        message = f"{self.path}, line {line}: {column} = {field.strip()!r} is not a number"
        if not self.hints:
            return message
        if line == self.dialect.first_line:
            return message + " (a units row? set [log] skip_after_header)"
        if self.dialect.decimal == "." and "," in field:
            return message + " (a decimal comma? set [log] decimal)"
        return message


def _byte_pieces(path: str | os.PathLike) -> Iterator[bytes]:
    """The file's bytes, BOM skipped, in pieces of about :data:`CHUNK_BYTES` that end just
    after a line feed (the last one at the end of the file)."""
    with open(path, "rb") as file:
        rest = file.read(3)
        if codecs.BOM_UTF8.startswith(rest):  # a BOM, or a file of a part of one: no text
            rest = b""
        while chunk := file.read(CHUNK_BYTES):
            chunk = rest + chunk
            cut = chunk.rfind(b"\n") + 1
            if cut:
                yield chunk[:cut]
            rest = chunk[cut:]
        if rest:
            yield rest


def _utf8_pieces(path: str | os.PathLike) -> Iterator[bytes]:
    """:func:`_byte_pieces`, each checked to be UTF-8.

    A line feed is never part of a multi-byte UTF-8 character, so the pieces decode on their
    own; a UnicodeDecodeError's ``start`` is counted from the start of the file (after a BOM),
    as when decoding it whole.
    """
    offset = 0
    for piece in _byte_pieces(path):
        if not piece.isascii():
            try:
                piece.decode("utf-8")
            except UnicodeDecodeError as exc:
                exc.start += offset
                raise
        offset += len(piece)
        yield piece


def _count_line_breaks(path: str | os.PathLike) -> int:
    """Line ends in the file (at least its data rows), its encoding checked on the way."""
    breaks = 0
    for piece in _utf8_pieces(path):
        breaks += piece.count(b"\n")
        if b"\r" in piece:
            breaks += piece.count(b"\r") - piece.count(b"\r\n")
    return breaks


def unterminated_last_line(path: str | os.PathLike) -> bool:
    """Whether the file's last line is data without a line end: a logger stopped while
    writing it, or cut the file there, so its last number may be cut short. Such a line is
    left out by :func:`read_table` (a header without a line end, or a last line of blanks,
    is not one)."""
    try:
        with open(path, "rb") as file:
            file.seek(0, os.SEEK_END)
            size = file.tell()
            file.seek(max(size - TAIL_BYTES, 0))
            tail = file.read()
    except OSError:
        return False  # the reader says why
    if not tail or tail.endswith((b"\n", b"\r")):
        return False
    end = max(tail.rfind(b"\n"), tail.rfind(b"\r"))
    if end < 0 and size > TAIL_BYTES:
        return True  # a last line longer than the tail: not the header of a table
    return end >= 0 and bool(tail[end + 1 :].strip())


TAIL_BYTES = 4096
"""Bytes at the end of a file that :func:`unterminated_last_line` looks at."""


def _pieces_of_lines(
    path: str | os.PathLike, drop_unterminated: bool = False
) -> Iterator[tuple[list[str], bool]]:
    """The lines of the file (without their line end; an empty one after a final line end
    left out, and with ``drop_unterminated`` a last line without a line end) in pieces, each
    with whether numpy's C reader parses it as float() does (ASCII, none of the separators
    :data:`_NOT_SPACE_FOR_FLOAT`)."""
    for piece in _byte_pieces(path):
        text = piece.decode("utf-8")
        if "\r" in text:
            text = text.replace("\r\n", "\n").replace("\r", "\n")
        lines = text.split("\n")
        if text.endswith("\n") or drop_unterminated:
            lines.pop()  # the empty one after the last line end, or the unterminated line
        if lines:
            yield lines, text.isascii() and not any(c in text for c in _NOT_SPACE_FOR_FLOAT)


TORQUE_MARGIN = 10.0
"""A logged torque beyond this many times device.toml's ``motor.torque_limit`` is refused
(:func:`check_torque`, called by rsp_inertia.plant.logs.read_log): no drive produces it (a
short overload is a few times the limit), so it is a logging fault (a unit or scale error)
that would pass for real work. A one-row spike among neighbours that agree is a glitch,
left out before this check (rsp_inertia.plant.log_glitches)."""


def check_torque(path: str | os.PathLike | Rows, torque: np.ndarray, torque_limit: float) -> None:
    """Refuse the first row whose torque is beyond TORQUE_MARGIN x ``torque_limit``.

    Parameters
    ----------
    path : str or path-like
        The log, for the message.
    torque : np.ndarray, shape (n,), N m
        The log's torque column.
    torque_limit : float
        N m, device.toml's ``motor.torque_limit``.

    Raises
    ------
    InputError
        Naming the line of the first torque beyond the margin.
    """
    beyond = np.flatnonzero(np.abs(torque) > TORQUE_MARGIN * torque_limit)
    if beyond.size:
        k = int(beyond[0])
        raise InputError(
            f"{as_rows(path).at(k)}: torque = {float(torque[k])!r} N m is beyond what the drive "
            f"can produce (more than {TORQUE_MARGIN:g} x device.toml's motor.torque_limit = "
            f"{torque_limit:g} N m): a logging fault"
        )


SPEED_MARGIN = 20.0
"""A step of the angle between two rows faster than this many times the fastest
``stage.launch_speed`` of device.toml is refused (:func:`check_speed`, called by
rsp_inertia.plant.logs.read_log): a logging fault (a counter that skips) that would pass for
a real turn and its work. A single row off and back is a glitch, left out before this check
(rsp_inertia.plant.log_glitches).

Every run of the device is slower than about its stage's launch speed: a braking starts at
it and slows down, its reverse mirrors it, a pilot spins up to about it, a pendulum run
swings by a few degrees (the virtual device's logs, at 1 and 10 kHz, jittered, with dropped
rows and a wrapping counter, step at most 1.14 x the fastest launch speed). The margin
covers what may speed a body up beyond it (a spring or gravity giving back energy, the
reduced inertia falling along the turn: 20 x is 400 x the kinetic energy) and a pilot
logged before ``plan`` lowered the launch speeds (plan chooses them from an eighth of the
fastest its drive can keep a mirror at). The fastest stage bounds every log, as a pendulum
run has no launch speed of its own and a pilot may predate its stage's. On the default
device (12 rad/s, 1 kHz) a step of more than 0.48 rad between rows 1 ms apart is refused."""

STEP_SLACK_COUNTS = 8
"""Counts a step of the angle may exceed what the speed bound allows by: two readings of an
incremental encoder differ from the true turn between them by less than a count, and an
interpolating readhead's noise adds a few counts at most. It matters only where the speed
bound over a step is a few counts (a coarse encoder at a fast sample rate and a slow stage)."""

SPEED_BLOCK = 1 << 20
"""Steps checked at a time by :func:`check_speed`: its memory does not grow with the log."""


def check_speed(
    path: str | os.PathLike | Rows,
    t: np.ndarray,
    phi: np.ndarray,
    launch_speed: float,
    encoder: EncoderLike,
) -> None:
    """Refuse the first angle step that no speed of the device explains.

    A step from row k to k + 1 is refused when ``|phi[k+1] - phi[k]|`` exceeds
    ``SPEED_MARGIN x launch_speed x (t[k+1] - t[k] + 1 / sample_rate)`` plus
    :data:`STEP_SLACK_COUNTS` counts: the extra period covers stamps off the sampling grid
    (:data:`JITTER_LIMIT`), a gap of dropped rows has its whole time, and the counts cover
    the quantization and the encoder's noise. ``phi`` is the unwrapped angle (a counter's
    wraps taken out), ``t`` strictly increasing (:func:`check_time` first).

    Parameters
    ----------
    path : str or path-like
        The log, for the message.
    t, phi : np.ndarray, shape (n,)
        s and rad, the log's columns.
    launch_speed : float
        rad/s, the fastest ``stage.launch_speed`` of device.toml.
    encoder : encoder-like
        ``quantum`` (rad) and ``sample_rate`` (Hz).
    """
    limit = SPEED_MARGIN * float(launch_speed)
    period = 1.0 / float(encoder.sample_rate)
    slack = STEP_SLACK_COUNTS * float(encoder.quantum)
    for start in range(0, len(t) - 1, SPEED_BLOCK):
        stop = min(start + SPEED_BLOCK, len(t) - 1) + 1
        steps = np.abs(np.diff(phi[start:stop]))
        times = np.diff(t[start:stop])
        beyond = np.flatnonzero(steps > limit * (times + period) + slack)
        if beyond.size:
            k = int(beyond[0])
            step, time = float(steps[k]), float(times[k])
            raise InputError(
                f"{as_rows(path).at(start + k + 1)}: the angle jumps by {step:.3g} rad in "
                f"{time:.3g} s from the row before ({step / time:.3g} rad/s), faster than any "
                f"speed the device's runs can have (limit {limit:g} rad/s, {SPEED_MARGIN:g} x "
                f"device.toml's fastest stage.launch_speed = {float(launch_speed):g} rad/s): "
                "a logging fault"
            )


def check_time(
    path: str | os.PathLike | Rows, t: np.ndarray, encoder: EncoderLike, regular: bool = True
) -> None:
    """t from 0, strictly increasing, at the encoder's sample rate.

    Parameters
    ----------
    path : str or path-like
        The file, for the message.
    t : np.ndarray, shape (n,), s
        Its time column.
    encoder : encoder-like
        ``sample_rate`` (Hz).
    regular : bool
        One step per encoder sample (a program), else a log's sampling instants
        (:data:`JITTER_LIMIT`: jitter and dropped samples).

    Raises
    ------
    InputError
        Naming the line (or the file, for a median or mean step off the sample rate).
    """
    rows = as_rows(path)
    if abs(t[0]) > T0_TOLERANCE:
        raise InputError(
            f"{rows.at(0)}: t = {float(t[0])!r} s, the first row must be at t = 0"
        )
    steps = np.diff(t)
    not_increasing = np.flatnonzero(steps <= 0.0)
    if not_increasing.size:
        k = not_increasing[0]
        now, before = float(t[k + 1]), float(t[k])
        raise InputError(
            f"{rows.at(k + 1)}: t = {now!r} s is not after t = {before!r} s of the row before; "
            "t must be strictly increasing"
        )
    rate = float(encoder.sample_rate)
    if not regular:
        median = float(np.median(steps))
        if median * rate >= 1.0 + 2 * JITTER_LIMIT:
            raise InputError(
                f"{path}: median time step {median:.6g} s, expected {1.0 / rate:.6g} s "
                f"(encoder sample rate {rate:g} Hz)"
            )
        short = np.flatnonzero(steps * rate < 1.0 - 2 * JITTER_LIMIT)
        if short.size:
            k = short[0]
            raise InputError(
                f"{rows.at(k + 1)}: time step {steps[k]:.6g} s at t = {float(t[k + 1])!r} s "
                f"is less than half the sample period {1.0 / rate:.6g} s (time stamps may be "
                f"off the sampling grid by at most {JITTER_LIMIT:g} of a period)"
            )
        periods = int(np.rint(steps * rate).sum())
        mean = float(t[-1] - t[0]) / periods
        if abs(mean * rate - 1.0) > MEAN_RATE_TOLERANCE:
            raise InputError(
                f"{path}: mean sample period {mean:.6g} s over {periods} periods, expected "
                f"{1.0 / rate:.6g} s (encoder sample rate {rate:g} Hz)"
            )
        return
    off_rate = np.flatnonzero(np.abs(steps * rate - 1.0) > RATE_TOLERANCE)
    if off_rate.size:
        k = off_rate[0]
        raise InputError(
            f"{rows.at(k + 1)}: time step {steps[k]:.6g} s, expected {1.0 / rate:.6g} s "
            f"(encoder sample rate {rate:g} Hz)"
        )


def read_header(path: str | os.PathLike) -> list[str] | None:
    """The first line's column names, or None if the file cannot be read (the full reader
    then says why)."""
    try:
        with open(path, encoding="utf-8-sig") as file:
            return [name.strip() for name in file.readline().split(",")]
    except (OSError, UnicodeDecodeError):
        return None


def unwrap_counts(
    path: str | os.PathLike | Rows, counts: np.ndarray, encoder: EncoderLike
) -> np.ndarray:
    """Integer counts, a counter of ``encoder.counter_bits`` unwrapped.

    A step between two samples is taken modulo 2**bits into [-2**(bits-1), 2**(bits-1)): a
    counter wraps, the body does not turn half a counter's range in one sample. Where the
    counter stood before the log began is unknown by whole wraps, so counts_per_rev must
    divide 2**bits for the angle modulo a turn (the nodes) to be defined.

    Parameters
    ----------
    path : str or path-like
        The log, for the message.
    counts : np.ndarray, shape (n,)
        The log's counts column.
    encoder : encoder-like
        ``counter_bits`` (None or absent: no wrapping counter) and ``counts_per_rev``.

    Returns
    -------
    np.ndarray, shape (n,)
        The counts unwrapped (float), or ``counts`` itself without a counter.

    Raises
    ------
    InputError
        A count that is not an integer or is outside the counter, or a counter whose range
        is not a whole number of turns.
    """
    rows = as_rows(path)
    bad = np.flatnonzero(counts != np.round(counts))
    if bad.size:
        k = int(bad[0])
        raise InputError(f"{rows.at(k)}: counts = {float(counts[k])!r} is not an integer")
    bits = getattr(encoder, "counter_bits", None)
    if bits is None:
        return counts
    span = 2**bits
    if span % int(encoder.counts_per_rev):
        raise InputError(
            f"{path}: counts wrap at 2^{bits} (device.toml encoder.counter_bits), which is not "
            f"a whole number of turns of {encoder.counts_per_rev} counts: the angle is undefined"
        )
    out_of_range = np.flatnonzero((counts < 0) | (counts >= span))
    if out_of_range.size:
        k = int(out_of_range[0])
        raise InputError(
            f"{rows.at(k)}: counts = {counts[k]:.0f} is outside the {bits}-bit counter "
            f"(0 to {span - 1})"
        )
    step = np.mod(np.diff(counts) + span // 2, span) - span // 2
    return counts[0] + np.concatenate([[0.0], np.cumsum(step)])


def check_grid(path: str | os.PathLike | Rows, phi: np.ndarray, encoder: EncoderLike) -> None:
    """phi a whole number of encoder counts (within GRID_TOLERANCE).

    Parameters
    ----------
    path : str or path-like
        The log, for the message.
    phi : np.ndarray, shape (n,), rad
        The log's angle column.
    encoder : encoder-like
        ``quantum`` (rad).

    Raises
    ------
    InputError
        Naming the line of the first angle off the grid.
    """
    q = float(encoder.quantum)
    counts = phi / q
    off_grid = np.flatnonzero(np.abs(counts - np.round(counts)) > GRID_TOLERANCE)
    if off_grid.size:
        k = off_grid[0]
        value = float(phi[k])
        raise InputError(
            f"{as_rows(path).at(k)}: phi = {value!r} is not on the encoder grid (q = {q:.4g} rad)"
        )


def check_direction(
    path: str | os.PathLike | Rows,
    phi: np.ndarray,
    kind: str,
    direction: Direction,
    torque: np.ndarray | None = None,
) -> None:
    """A forward braking runs up from the release to rest and its reverse pass back down; a
    backward run is the other way round.

    A braking log that runs the wrong way is refused with its likely cause, from its torque
    (a motor torque is positive where it turns phi up, docs/method.md §1): a braking torque
    against the logged motion means a run of the other direction (a backward braking in a
    forward one's file, or a mislabelled log); a constant torque along it, beyond its noise
    (it would speed the body up as logged, not brake it), means the encoder counts against
    the motor's torque (:func:`brakes_along_the_motion`).

    Parameters
    ----------
    path : str or path-like
        The log, for the message.
    phi : np.ndarray, shape (n,), rad
        The log's angle column.
    kind : str
        One of rsp_inertia.plant.logs.LOG_KINDS; only a braking and a reverse are checked.
    direction : Direction
        The stage's run.
    torque : np.ndarray, shape (n,), N m, optional
        The log's torque column, to name the cause on a braking (None: the direction alone).

    Raises
    ------
    InputError
        Naming the last line, when the log ends on the wrong side of its start.
    """
    if kind not in ("braking", "reverse"):
        return
    last_line = as_rows(path).at(len(phi) - 1)
    increases = (kind == "braking") == (direction is Direction.FORWARD)
    if (phi[-1] > phi[0]) if increases else (phi[-1] < phi[0]):
        return
    span = f"phi goes from {float(phi[0])!r} to {float(phi[-1])!r} rad"
    if kind == "braking" and torque is not None and brakes_along_the_motion(phi, torque):
        raise InputError(
            f"{last_line}: {span} and the braking torque (median "
            f"{float(np.median(torque)):.4g} N m) has the sign of that motion: as logged it "
            "would speed the body up, not brake it: the encoder counts backwards (or the "
            "torque's sign is reversed): phi must increase where a positive motor torque "
            "turns the shaft (docs/method.md §1); reverse the encoder's counting direction in "
            "the drive"
        )
    run = "a braking" if kind == "braking" else "a reverse"
    if direction is Direction.BACKWARD:
        run = f"a backward {kind}"
    end = "larger" if increases else "smaller"
    why = ""
    if direction is Direction.BACKWARD:
        moves = "increases" if increases else "decreases"
        why = f" (phi {moves} during a backward {kind})"
    raise InputError(
        f"{last_line}: {run} log must end at a {end} phi than it starts{why}, "
        f"but {span}"
    )


TORQUE_SIGNIFICANCE = 3.0
"""Noise stds (of the torque's sample-to-sample scatter) by which a braking's median torque
must differ from zero, and within which its torques must scatter about it, for
:func:`brakes_along_the_motion` to read its sign."""


def brakes_along_the_motion(phi: np.ndarray, torque: np.ndarray) -> bool:
    """Whether a braking log's torque, constant as a braking's is (its robust scatter about
    its median within :data:`TORQUE_SIGNIFICANCE` of its sample-to-sample noise; a reverse
    pass's program is not), is of the sign of the logged motion phi[-1] - phi[0] and beyond
    that noise from zero: as logged, it would speed the body up, not brake it.

    Parameters
    ----------
    phi : np.ndarray, shape (n,), rad
        The log's angle column.
    torque : np.ndarray, shape (n,), N m
        Its torque column.

    Returns
    -------
    bool
        The torque is a braking's and along the logged motion.

    Examples
    --------
    >>> brakes_along_the_motion(np.array([0.0, -0.1, -0.2]), np.array([-0.005] * 3))
    True
    >>> brakes_along_the_motion(np.array([0.0, -0.1, -0.2]), np.array([0.005] * 3))
    False
    """
    u = float(np.median(torque))
    d = np.diff(torque)
    noise = float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))
    spread = float(1.4826 * np.median(np.abs(torque - u)))
    limit = TORQUE_SIGNIFICANCE * noise
    return u * float(phi[-1] - phi[0]) > 0.0 and abs(u) > limit and spread <= limit


STOP_COUNTS = 8
"""K, the encoder counts before a stay at one reading over which :func:`turning_point`
measures the deceleration to rest."""

STOP_MARGIN = 1.5
"""Factor on the longest stay at one reading that a constant deceleration allows
(:func:`turning_point`): room for the deceleration's change over a few counts and the
encoder's uneven counts."""

SETTLE_COUNTS = 8
"""Counts (at least; :data:`SETTLE_ANGLE` if more) by which a braking log's reading may move
after its turning point, either way: a held body's reading dithers by a count and settles
back through the drive's backlash by a few (:func:`turning_point`)."""

SETTLE_ANGLE = 3e-3
"""rad (10 arcmin, a plain gearbox's backlash): the same bound as an angle, for a fine
encoder (:func:`settle_counts`)."""


def settle_counts(encoder: EncoderLike) -> int:
    """Counts a braking log's reading may move after its turning point (:func:`turning_point`):
    the larger of :data:`SETTLE_COUNTS` and :data:`SETTLE_ANGLE` in counts (31 on a 16-bit
    encoder, 8 on a 12-bit one)."""
    return max(SETTLE_COUNTS, math.floor(SETTLE_ANGLE / float(encoder.quantum)))


def turning_point(
    path: str | os.PathLike | Rows,
    t: np.ndarray,
    phi: np.ndarray,
    increases: bool,
    encoder: EncoderLike,
) -> int:
    """The row at which a braking's motion in its direction ends: the log's last row when it
    ends at the stop, else the first row at the reading where it stopped (docs/files.md, Logs).

    A braking log ends at the stop (the virtual device's), or a real drive logs on while it
    holds the body: the reading stays put, dithers by a count, or settles back through the
    backlash a few counts and is still. Near rest the deceleration a is constant to first
    order, so a body that enters its last count (a count of width q) comes to rest within
    sqrt(2 q / a); having taken Delta to cover the K = :data:`STOP_COUNTS` counts before, with
    a constant deceleration it stays at most Delta / (sqrt(K + 1) - 1) (the bound is reached
    when it stops at the count's far edge). A stay at one reading longer than
    :data:`STOP_MARGIN` times that plus a sample period is a stop. The motion is the furthest
    reading so far in the pass's direction, so a reading that dithers or settles back below
    it (or an interpolating readhead's noise) neither ends nor prolongs a stay; but a last
    stay, however short, in which the reading goes back is a stop too (the braking's reading
    never goes back: the drive logged on). The turning point is the first row at the furthest
    reading of the first stop, and the log goes on after the stop when there is one. Its rows after the turning point must keep within
    :func:`settle_counts` of its reading, either way; otherwise the body moved on after a
    stop or went back further than a held body settles, and which point ends the braking is
    ambiguous. (A reading that turns back inside the motion and goes on is no stop here:
    rsp_inertia.plant.logs.check_braking_monotone refuses it.)

    Parameters
    ----------
    path : str or path-like
        The log, for the message.
    t : np.ndarray, shape (n,), s
        The log's time stamps, strictly increasing (:func:`check_time` first).
    phi : np.ndarray, shape (n,), rad
        Its angle, on the encoder grid (:func:`check_grid`), unwrapped.
    increases : bool
        The braking's direction: phi increases (a forward run) or decreases (backward).
    encoder : encoder-like
        ``quantum`` (rad) and ``sample_rate`` (Hz).

    Returns
    -------
    int
        The index of the turning point's row: ``n - 1`` when the log ends at the stop, else
        the rows after it are the drive's logging after the stop.

    Raises
    ------
    InputError
        Naming the file, the turning point's line and the first line beyond
        :func:`settle_counts` of its reading.

    Examples
    --------
    >>> class Encoder:
    ...     quantum, sample_rate = 1.0, 1000.0
    >>> t = np.arange(12) * 1e-3
    >>> phi = np.array([0, 40, 72, 96, 112, 120, 120, 119, 120, 119, 119, 119], float)
    >>> turning_point("braking.csv", t, phi, True, Encoder())
    5
    >>> turning_point("braking.csv", t[:6], phi[:6], True, Encoder())
    5
    """
    rows = as_rows(path)
    q = float(encoder.quantum)
    c = np.rint(phi / q).astype(np.int64)
    if not increases:
        np.negative(c, out=c)
    n = len(c)
    # The motion in the pass's direction: the furthest reading so far, and the stays at each
    # of its values (a reading that dithers or settles back below it does not end a stay).
    top = np.maximum.accumulate(c)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(top)) + 1])  # first row of a value
    ends = np.concatenate([starts[1:] - 1, [n - 1]])  # and the last row before the next
    # A stay longer than the constant deceleration allows (docstring), measured from the
    # first row reaching K counts less (before it: no estimate, no stop).
    before = np.searchsorted(top, top[starts] - STOP_COUNTS, side="left") - 1
    known = before >= 0
    delta = t[starts] - t[np.maximum(before, 0)]
    allowed = STOP_MARGIN * delta / (math.sqrt(STOP_COUNTS + 1) - 1) + 1.0 / encoder.sample_rate
    stays = np.flatnonzero(known & (t[ends] - t[starts] > allowed))
    if stays.size:
        m = int(starts[stays[0]])
    elif np.any(c[starts[-1] :] < top[-1]):
        m = int(starts[-1])  # the last stay goes back: short, but after the stop
    else:
        return n - 1
    settle = settle_counts(encoder)
    off = c[m + 1 :] - c[m]
    beyond = np.flatnonzero(np.abs(off) > settle)
    if beyond.size:
        j = m + 1 + int(beyond[0])
        moved = int(off[beyond[0]])
        if moved > 0:
            what = (
                f"then runs on {moved} counts past it by {rows.line(j)}: the speed reverses "
                "inside the braking, or the body moved on after it stopped"
            )
        else:
            what = (
                f"then goes back {-moved} counts by {rows.line(j)}: the body was not held where "
                "it stopped, or the angle jumps"
            )
        raise InputError(
            f"{rows.span(m, j)}: the braking's turning point is ambiguous: its "
            f"motion stops or turns at {rows.line(m)} and {what} (after its stop a held body's "
            f"reading may dither and settle back by up to {settle} counts, docs/files.md)"
        )
    return m
