"""Reading a CSV file into a :class:`~.checks._Table` (header, rows and their line numbers),
refusing files that are not comma-separated with a decimal point, with a message that says
what the file looks like instead."""

from __future__ import annotations

import csv
import re

from .checks import DataError, _Table


def read_table(path: str) -> _Table:
    """The CSV file at ``path`` as a table (a DataError for an unreadable or malformed file)."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            header: list[str] | None = None
            rows: list[list[str]] = []
            lines: list[int] = []
            for rec in reader:
                if not rec or (len(rec) == 1 and not rec[0].strip()):
                    continue  # blank line
                if header is None:
                    header = [name.strip() for name in rec]
                    header_line = reader.line_num
                    continue
                rows.append([cell.strip() for cell in rec])
                lines.append(reader.line_num)
    except FileNotFoundError:
        raise DataError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DataError(f"{path}: cannot read as a UTF-8 CSV file ({exc})") from None
    if header is None:
        raise DataError(f"{path}: the file is empty (no header line, no data rows)")
    _refuse_other_dialects(path, header, rows)
    table = _Table(path, header, rows, lines)
    seen: dict[str, int] = {}
    for k, name in enumerate(header):
        if not name:
            raise DataError(f"{path}, line {header_line}: column {k + 1} of the header is unnamed")
        if name in seen:
            raise DataError(
                f"{path}, column {name!r}: duplicate column name in the header (line "
                f"{header_line}, columns {seen[name] + 1} and {k + 1})"
            )
        seen[name] = k
    if not rows:
        raise DataError(f"{path}: the file has a header but no data rows")
    for i, row in enumerate(rows):
        if len(row) != len(header):
            raise table.error(f"has {len(row)} fields, the header has {len(header)}", row=i)
    return table


def _refuse_other_dialects(path: str, header: list[str], rows: list[list[str]]) -> None:
    """A ';'- or tab-separated file, or one with decimal commas, read as comma-separated: say
    what it looks like instead of failing later on a missing column."""
    for sep, name in ((";", "';'-separated"), ("\t", "tab-separated")):
        if len(header) <= 2 and any(sep in h for h in header):
            decimal = any(re.search(r"\d,\d", ",".join(r)) for r in rows[:20])
            extra = " with decimal commas" if decimal else ""
            raise DataError(
                f"{path}: the file looks {name}{extra} (header {sep.join(header)[:60]!r}); "
                "a case CSV is comma-separated with a decimal point: save it as CSV "
                "(e.g. 'CSV UTF-8' with '.' as the decimal separator)")
    sample = [r for r in rows[:20] if len(r) > len(header)]
    if sample and all(re.fullmatch(r"-?\d+", c) for r in sample for c in r[1:]):
        raise DataError(
            f"{path}: the data rows have more fields than the header ({len(sample[0])} against "
            f"{len(header)}) and hold only whole numbers: this looks like decimal commas "
            "(14,18 for 14.18); save the file with '.' as the decimal separator")
