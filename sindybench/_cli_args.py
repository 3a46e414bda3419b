"""What the command line's commands share: argument types, the bounded CSV reader, model loading, file checks.

Below :mod:`sindybench.cli` and ``_cli_identify`` (both import it; it imports neither), so the
commands' modules import one way.
"""

import argparse
import contextlib
import csv
import math
import os
import sys
from pathlib import Path

import numpy as np

from ._limits import shown

__all__ = []  # private helpers of the command line


def _non_negative_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0; got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0; got {value}")
    return value


def _seed(text):
    value = _non_negative_int(text)
    if value >= 2**32:
        raise argparse.ArgumentTypeError(f"expected an integer in [0, 2**32 - 1] (a numpy seed); got {value}")
    return value


def _n_jobs(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer or -1 (all cores); got {text!r}") from None
    if value == 0 or value < -1:
        raise argparse.ArgumentTypeError(f"expected a positive integer or -1 (all cores); got {value}")
    return value


def _storage(text):
    from .model_selection import check_storage

    try:
        return check_storage(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


#: The largest CSV file ``simulate`` reads (its rows are held as text first: about 10 bytes of memory per byte),
#: and the longest line in it.
MAX_CSV_BYTES = 64 * 2**20
MAX_CSV_LINE = 2**20


def _bounded_lines(f, path, what):
    """The lines of the text file ``f``, refusing a line or a file longer than a CSV record can need."""
    total = 0
    while True:
        line = f.readline(MAX_CSV_LINE + 1)
        if not line:
            return
        total += len(line)
        if len(line) > MAX_CSV_LINE:
            raise ValueError(f"{what} {path} has a line longer than {MAX_CSV_LINE // 2**20} MiB (it does not end "
                             "within that length); expected a CSV file of one row per sample.")
        if total > MAX_CSV_BYTES:
            raise ValueError(f"{what} {path} is longer than {MAX_CSV_BYTES // 2**20} MiB; expected a CSV file of "
                             "at most that size (split a longer record).")
        yield line


def _csv_rows(path, what):
    """``[(line number, cells)]`` of a CSV file, blank lines at its end dropped; ``ValueError`` naming the line."""
    rows = []
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(_bounded_lines(f, path, what))
            start = 1
            try:
                for row in reader:
                    rows.append((start, row))
                    start = reader.line_num + 1
            except csv.Error as exc:
                raise ValueError(f"{what} {path}, line {reader.line_num}: {exc}; expected a CSV file.") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{what} {path} is not UTF-8 text ({exc.reason} at byte {exc.start}); "
                         "expected a CSV file.") from None
    while rows and not rows[-1][1]:
        rows.pop()
    return rows


def _number(text):
    """``float(text)`` for a number written plainly in ASCII, else None.

    Python's ``float`` also reads ``1_000`` (1000.0), Arabic-Indic and full-width digits
    (``'\u0663'``, ``'\uff13'``: 3.0): a cell that is not what it looks like in another program.
    """
    if not text.isascii() or "_" in text:
        return None
    try:
        return float(text)
    except ValueError:
        return None


def _read_csv(path, what):
    """``(header, data)`` of a CSV file; ``header`` is ``None`` when its first row is numbers.

    Every line up to the last non-blank one is a row: a blank line in the
    data is a sample with no values (an error), never skipped. Errors are
    ``ValueError`` naming the file, the line and the column.
    """
    rows = _csv_rows(path, what)
    if not rows:
        raise ValueError(f"{what} {path} is empty; expected one row per sample (after an optional header row).")
    if not rows[0][1]:
        raise ValueError(f"{what} {path}, line 1 is blank; expected a header row naming the columns, or the first "
                         "sample.")
    numbers = [_number(text) is not None for text in rows[0][1]]
    if all(numbers):
        header, body = None, rows  # no header row: the first row is a sample
    elif not any(numbers) and any(text.strip() for text in rows[0][1]):
        header, body = [name.strip() for name in rows[0][1]], rows[1:]
    else:  # a first sample with a bad cell must not pass for a header row (and the record lose a sample)
        raise ValueError(f"{what} {path}, line {rows[0][0]}: {rows[0][1]} is neither a header row (names, no numbers) "
                         "nor a sample (a number in every column); expected one of the two.")
    if not body:
        raise ValueError(f"{what} {path} has no samples; expected one row per sample (after an optional header row).")
    n_columns = len(header) if header is not None else len(body[0][1])
    names = header if header is not None else [f"column {j + 1}" for j in range(n_columns)]
    data = np.empty((len(body), n_columns))
    for i, (line, row) in enumerate(body):
        if n_columns == 1 and not row:
            row = [""]  # a blank line in a one-column file is an empty cell
        if len(row) != n_columns:
            source = f"the header {header}" if header is not None else "the first row"
            raise ValueError(f"{what} {path}, line {line}: {len(row)} values; expected {n_columns} "
                             f"(one per column of {source}).")
        for j, text in enumerate(row):
            value = _number(text)
            if value is None or not math.isfinite(value):
                column = f"column {names[j]!r}" if header is not None else names[j]
                raise ValueError(f"{what} {path}, line {line}, {column}: {shown(text.strip())}; expected a finite "
                                 "number in ASCII digits (no NaN, no empty cell, no digit separator).")
            data[i, j] = value
    return header, data


@contextlib.contextmanager
def _current_folder_importable(allow):
    """With ``allow``, modules in the current folder can be imported (as under ``python -m``), at lowest priority."""
    added = allow and os.getcwd() not in sys.path and "" not in sys.path
    if added:
        sys.path.append(os.getcwd())
    try:
        yield
    finally:
        if added and os.getcwd() in sys.path:
            sys.path.remove(os.getcwd())


def _load(path, allow_import):
    from . import load_model

    with _current_folder_importable(allow_import):
        try:
            return load_model(path, allow_import=allow_import)
        except ValueError as exc:  # the Python spelling of the option is not the command line's
            if "allow_import=True" not in str(exc):
                raise
            raise ValueError(str(exc).replace("pass allow_import=True", "pass --allow-import")
                             .replace("allow_import=True", "--allow-import")) from None


def _same_file(a, b):
    with contextlib.suppress(OSError):  # a file that does not exist yet
        if os.path.samefile(a, b):  # a hard link or a symbolic link to it too
            return True
    return Path(a).resolve() == Path(b).resolve()
