"""Reading and writing tables (CSV, Parquet) with clear errors."""

from __future__ import annotations

import csv
import json
import mmap
import os
import re
from pathlib import Path
from typing import Iterable

import numpy as np
import pandas as pd

from .._validation import first_undecodable_line
from ..core import MISSING_TEXT
from ..errors import InputError, InputFormatError, OutputError
from ._atomic import atomic_path

__all__ = ["read_table", "write_table", "check_columns"]

#: Suffixes read: ``.txt`` is read as CSV (instrument exports), never written.
_READ_FORMATS = {".csv": "csv", ".txt": "csv", ".parquet": "parquet", ".pq": "parquet"}
#: Suffixes written.
_WRITE_FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}
#: The letter cases of ``core.MISSING_TEXT`` a CSV cell is read as missing in (pandas matches exactly).
_MISSING_VARIANTS = sorted({v for m in MISSING_TEXT for v in (m, m.upper(), m.title(), m.capitalize())})
#: pandas' default missing-value texts (its read_csv documentation), for the columns of a table that also has text
#: columns: those are read with only an empty cell as missing (a sensor named "NA" keeps its name).
_PANDAS_MISSING = ("", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN", "<NA>",
                   "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null")


def _format_of(path: Path) -> str:
    fmt = _READ_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{path}: unknown table format {path.suffix!r}; use .csv or .parquet.")
    return fmt


def _read_csv(path: Path, text_columns: Iterable[str] = (), dialect: bool = False) -> pd.DataFrame:
    """CSV with ``#`` comments, where an empty line inside the data is a row of missing values.

    pandas skips blank lines by default, which silently shifts every later sample of a one-column file with
    missing values (a logger or a spreadsheet writes an empty cell there as an empty line). Blank lines before
    the header and after the last data line are ignored; a last row of empty cells (``,,``, or ``""`` in a
    one-column file) is a row of missing values and is kept. Columns named in ``text_columns`` (any letter case) are
    read as written: ``007`` stays ``007`` and ``NA`` is a name; only an empty cell is missing there. With
    ``dialect``, a header separated by ``;`` or tabs is read so when its decimal mark is unambiguous
    (:func:`_dialect`); without, it is refused.
    """
    leading, header, header_line = None, "", 0
    with open(path, encoding="utf-8", errors="replace") as fh:
        for i, line in enumerate(fh):
            text = line.strip()
            if text and leading is None:
                leading = i  # blank lines before the first text line are skipped
            if text and not text.startswith("#"):
                header, header_line = text, i
                break
    # "#" starts a comment line; within a line it is text (a sensor "PK#12") unless the data have comment lines too
    comments = ({"comment": "#", "skiprows": leading or 0} if _comment_lines_after(path, header_line) else
                {"comment": None, "skiprows": header_line})
    sep, decimal = _dialect(path, header, header_line) if dialect else (_check_separator(path, header) or ",", ".")
    _check_title_lines(path, header_line, sep=sep)
    wanted = {t.lower() for t in text_columns}
    names = [n.strip() for n in next(csv.reader([header], skipinitialspace=True, delimiter=sep))] if wanted else []
    as_text = [n for n in names if n.lower() in wanted]
    kw = {"na_values": _MISSING_VARIANTS}  # with pandas' own: "NAN" (Campbell loggers), "NONE", "Null"...
    if as_text:
        kw = {"dtype": dict.fromkeys(as_text, str), "keep_default_na": False,
              "na_values": {n: [""] if n in as_text else [*_PANDAS_MISSING, *_MISSING_VARIANTS] for n in names}}
    df = pd.read_csv(path, skipinitialspace=True, skip_blank_lines=False, sep=sep, decimal=decimal, **comments, **kw)
    _check_last_row(path, df.shape[1], sep=sep)
    trailing = _trailing_blank_lines(path)
    if trailing:
        filled = df.notna().any(axis=1).to_numpy()
        empty_tail = len(df) - (int(filled.nonzero()[0][-1]) + 1 if filled.any() else 0)
        drop = min(trailing, empty_tail)
        if drop:
            return df.iloc[:len(df) - drop].reset_index(drop=True)
    return df


def _comment_lines_after(path: Path, header_line: int) -> bool:
    """Whether a line after the header (line ``header_line``, 0-based) starts with "#" (a comment line among the
    data): a byte search, no parsing."""
    with open(path, "rb") as fh:
        if os.fstat(fh.fileno()).st_size == 0:
            return False
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            pos = 0
            for _ in range(header_line + 1):
                pos = mm.find(b"\n", pos) + 1
                if pos == 0:
                    return False
            if mm.find(b"#", pos) < 0:  # the usual data file: one memchr pass, no regex
                return False
            return re.compile(rb"\n[ \t]*#").search(mm, pos - 1) is not None


def _check_separator(path: Path, header: str) -> None:
    """Refuse a header separated by semicolons or tabs (no comma in it): a spreadsheet's export in a locale with
    decimal commas, whose rows the comma parser would split at every decimal comma (or read as one column)."""
    if "," in header:
        return
    for sep, name in ((";", "';'"), ("\t", "tab")):
        if sep in header:
            raise InputFormatError(f"{path}: the header {header!r} is separated by {name}, not commas; save the file "
                                   "as comma-separated values with decimal points (e.g. 0.25, not 0,25).")


def _dialect(path: Path, header: str, header_line: int) -> tuple[str, str]:
    """(separator, decimal mark) of a CSV whose header line is ``header`` (line ``header_line``, 0-based).

    A header with a comma is comma-separated with decimal points, as before. A header separated by tabs or by ``;``
    (a spreadsheet's export in a decimal-comma locale, a profiler's tab-separated text) is read so when its data
    lines (``#`` comments aside) settle the decimal mark: commas and no point anywhere, decimal commas; points and
    no comma, decimal points; neither, whole numbers. Data holding both (``1.234,5``, or ``0.5;1,5``) are refused:
    the mark would be a guess. ASSUMPTION (docs/file-formats.md): in such a file a ``.`` is a decimal point, never
    a thousands separator (profile exports write none).
    """
    if "," in header or not (";" in header or "\t" in header):
        return ",", "."
    if ";" in header and "\t" in header:
        raise InputFormatError(f"{path}: the header {header!r} holds both ';' and tabs: the separator cannot be told; "
                               "save the file as comma-separated values with decimal points.")
    sep, name = ("\t", "tab") if "\t" in header else (";", "';'")
    with open(path, "rb") as fh:
        body = fh.read()
    for _ in range(header_line + 1):
        body = body[body.find(b"\n") + 1:] if b"\n" in body else b""
    if b"#" in body:
        body = re.sub(rb"(?m)^[ \t]*#.*$", b"", body)
    if b"." in body and b"," in body:
        raise InputFormatError(f"{path}: the file is separated by {name} and its values hold both '.' and ',': the "
                               "decimal mark cannot be told; save it as comma-separated values with decimal points "
                               "(e.g. 0.25, not 0,25).")
    return sep, ("," if b"," in body else ".")


def _check_title_lines(path: Path, header_line: int, *, scan: int = 50, sep: str = ",") -> None:
    """Refuse title lines above the header (an export's preamble, ``Project: I-95 resurfacing``, then the column names).

    Within the first ``scan`` text lines from line ``header_line`` (0-based; comments and blank lines skipped): the
    first line that has more fields than the first one, that are all names (no number) and that the next line
    matches in count, is taken for the header. pandas stops on such a file with "Error tokenizing data" (or reads
    its first column as an index); nothing is skipped on a guess.
    """
    rows: list[tuple[int, list[str]]] = []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for i, line in enumerate(fh):
            text = line.strip().lstrip("\ufeff")
            if i < header_line or not text or text.startswith("#"):
                continue
            rows.append((i + 1, next(csv.reader([text], skipinitialspace=True, delimiter=sep), [])))
            if len(rows) >= scan:
                break
    widths = [len(fields) for _, fields in rows]
    k = next((j for j, w in enumerate(widths) if w > widths[0]), None)
    if k is None or k + 1 >= len(rows) or widths[k + 1] != widths[k]:
        return
    names = [f.strip() for f in rows[k][1] if f.strip()]
    if len(names) < 2 or any(_is_number(f) for f in names):
        return
    raise InputFormatError(f"{path}: line {rows[0][0]} looks like a title, not a header ({', '.join(rows[0][1])!r}): "
                           f"the column names seem to be on line {rows[k][0]} ({', '.join(names)}); remove the lines "
                           "above the header (or start them with #).")


def _is_number(text: str) -> bool:
    """Whether ``text`` reads as a float (a data value, not a column name)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _tail(path: Path, size: int = 65536) -> tuple[int, bytes]:
    """The last ``size`` bytes of a file and the offset where they start."""
    with open(path, "rb") as fh:
        start = max(0, fh.seek(0, 2) - size)
        fh.seek(start)
        return start, fh.read()


def _check_last_row(path: Path, n_columns: int, *, sep: str = ",") -> None:
    """Refuse a last data row with fewer fields than the header: a file cut while copying or logging.

    pandas fills the missing fields of a short row with NaN, which a reader would then bridge as a gap (or
    take the part of a number that survived as a value). A last row of empty cells (``,,``) has all its
    fields and is a row of missing values, not a cut. A last line of text holding no number (``End of data``) is
    an export's footer, refused as such (ASSUMPTION: never skipped; the user deletes it).
    """
    import csv

    if n_columns < 2:
        return
    start, tail = _tail(path)
    lines = tail.split(b"\n")
    data = [j for j, ln in enumerate(lines) if ln.strip() and not ln.strip().startswith(b"#")]
    if len(data) < 2:
        return
    last = lines[data[-1]].decode("utf-8", errors="replace").rstrip("\r")
    fields = next(csv.reader([last], skipinitialspace=True, delimiter=sep), [])
    if len(fields) < n_columns:
        with open(path, "rb") as fh:
            before = fh.read(start).count(b"\n")
        if not any(_is_number(f.replace(",", ".")) or not f.strip() for f in fields):
            raise InputFormatError(f"{path}: line {before + data[-1] + 1} (the last) is text, not data "
                                   f"({last.strip()[:60]!r}): a footer the export wrote? delete that line (or start "
                                   "it with #).")
        raise InputFormatError(f"{path}: line {before + data[-1] + 1} (the last) has {len(fields)} of the header's "
                               f"{n_columns} fields: the file looks cut short (an interrupted copy or logger); remove "
                               "that line or export the file again.")


def _trailing_blank_lines(path: Path) -> int:
    """Number of whitespace-only lines at the end of a text file (comment lines between them not counted)."""
    lines = _tail(path)[1].split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()  # the final newline ends the last line
    count = 0
    for line in reversed(lines):
        text = line.strip()
        if text.startswith(b"#"):
            continue
        if text:
            break
        count += 1
    return count


def read_table(path, *, required: Iterable[str] = (), numeric: Iterable[str] = (), text: Iterable[str] = (),
               dialect: bool = False) -> pd.DataFrame:
    """Read a CSV or Parquet table.

    Parameters
    ----------
    path : path-like
        ``.csv`` (comma separated, header row; lines starting with ``#`` are comments; an empty line
        among the data is a row of missing values: an empty cell of a one-column table) or ``.parquet``.
    required : iterable of str
        Columns that must be present; a column that differs only in letter case (``SENSOR_ID``) is renamed to
        the required spelling when it is the only one of that name.
    numeric : iterable of str
        Columns that must parse as numbers (empty cells become NaN).
    text : iterable of str
        Columns of names or ids (any letter case), read from a CSV as written: ``007`` is not 7 and ``NA`` is not
        missing; only an empty cell is.
    dialect : bool
        Read a CSV separated by ``;`` or tabs when its decimal mark is unambiguous (:func:`_dialect`: the profile
        readers); False refuses such a header, saying how to save the file.

    Raises
    ------
    InputFormatError
        If the file is missing, unreadable, lacks a required column, or a numeric column has a
        non-numeric cell (the message names the column and the line).
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file.")
    fmt = _format_of(path)
    if path.is_file() and path.stat().st_size == 0:
        raise InputFormatError(f"{path}: the file is empty; expected a header row and one row per sample.")
    try:
        df = _read_csv(path, text, dialect) if fmt == "csv" else pd.read_parquet(path)
    except InputFormatError:
        raise
    except UnicodeDecodeError:
        raise InputFormatError(_not_utf8(path)) from None
    except Exception as exc:  # pandas/pyarrow raise many types
        raise InputFormatError(f"{path}: cannot be read as {fmt}: {exc}") from None
    return check_columns(df, path, required=required, numeric=numeric)


def _not_utf8(path: Path) -> str:
    """The message for a CSV that is not UTF-8 text: its first such line (pandas' own position is within a chunk)."""
    with open(path, "rb") as fh:
        bad = first_undecodable_line(fh)
    if bad is None:
        return f"{path}: the file is not UTF-8 text; save it as UTF-8."
    return (f"{path}: line {bad[0]} is not UTF-8 text ({bad[1][:60]!r}, e.g. Latin-1 or Windows-1252 accents): save "
            "the file as UTF-8 (a spreadsheet's \"CSV UTF-8\"; or iconv -f cp1252 -t utf-8).")


def check_columns(df: pd.DataFrame, path, *, required: Iterable[str] = (), numeric: Iterable[str] = ()):
    """The checks of :func:`read_table` on a table already read from ``path`` (e.g. after a reader renamed a
    column declared with another unit): required columns (any letter case), numeric columns as float."""
    path = Path(path)
    df = _match_case(df, required)
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise InputFormatError(f"{path}: missing column(s) {missing}; the file has {list(df.columns)}.")
    for col in numeric:
        if col not in df.columns:
            continue
        conv = pd.to_numeric(df[col], errors="coerce")
        bad = conv.isna() & df[col].notna()
        if bad.any():
            i = int(bad.to_numpy().nonzero()[0][0])
            line = f" line {i + 2}" if path.suffix.lower() in (".csv", ".txt") else f" row {i}"
            raise InputFormatError(f"{path}:{line}: column {col!r} has a non-numeric value {df[col].iloc[i]!r}.")
        df[col] = conv.astype(float)
    return df


def _match_case(df: pd.DataFrame, required) -> pd.DataFrame:
    """``df`` with each absent required column's only case variant renamed to it (``SENSOR_ID`` -> ``sensor_id``);
    two variants of one name are left alone (reported missing)."""
    folds: dict[str, list] = {}
    for c in df.columns:
        folds.setdefault(str(c).casefold(), []).append(c)
    rename = {}
    for name in required:
        found = folds.get(name.casefold(), [])
        if name not in df.columns and len(found) == 1:
            rename[found[0]] = name
    return df.rename(columns=rename) if rename else df


def write_table(df: pd.DataFrame, path, *, metadata: dict | None = None) -> Path:
    """Write ``df`` as CSV or Parquet according to the suffix of ``path``; return the path.

    Parameters
    ----------
    df : pandas.DataFrame
        Written without its index; column names are written as they are.
    path : path-like
        ``.csv`` or ``.parquet`` (``.pq``). Any other suffix (``.txt`` included: it would be ambiguous) is
        refused before anything is written.
    metadata : dict, optional
        JSON-serialisable provenance (e.g. how a profile was made), written as
        :func:`longprofile.io.write_report_table` writes it: one ``# key: <JSON value>`` line per entry before a
        CSV header, or JSON under the Parquet schema metadata key ``b"longprofile"``. Every table reader skips it;
        :func:`longprofile.io.read_report_table` returns it.

    Raises
    ------
    OutputError
        Unknown suffix, or the file cannot be written.

    Notes
    -----
    CSV of a table whose columns are all numbers (profiles, estimates) is formatted by pyarrow's CSV writer,
    several times faster than ``DataFrame.to_csv``: floats in their shortest exact form, so the text reads back
    (:func:`read_table`, pandas, numpy) to the same float64 values; NaN as an empty cell; a float column
    whose values are all whole numbers keeps its ``.0`` so it reads back as floats; booleans as ``True`` /
    ``False``, as pandas writes them. Other tables (text, dates) are written by ``DataFrame.to_csv``, as before.
    """
    path = Path(path)
    fmt = _WRITE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise OutputError(f"{path}: unknown table format {path.suffix!r} for writing; use .csv or .parquet "
                          f"(e.g. {path.with_suffix('.csv')}).")
    if metadata:
        from ._report_tables import METADATA_KEY, csv_metadata_lines, report_metadata

        metadata = report_metadata(df, metadata)
    try:
        with atomic_path(path) as tmp:  # an existing file is replaced only once the new one is complete
            if fmt == "parquet" and metadata:
                import pyarrow as pa
                import pyarrow.parquet as pq

                table = pa.Table.from_pandas(df, preserve_index=False)
                merged = {**(table.schema.metadata or {}), METADATA_KEY.encode(): json.dumps(metadata).encode()}
                pq.write_table(table.replace_schema_metadata(merged), tmp)
            elif fmt == "parquet":
                df.to_parquet(tmp, index=False)
            elif not _write_numeric_csv(df, tmp, csv_metadata_lines(metadata) if metadata else ""):
                with open(tmp, "w", encoding="utf-8", newline="") as fh:
                    fh.write(csv_metadata_lines(metadata) if metadata else "")
                    df.to_csv(fh, index=False)
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}.") from None
    return path


def _numeric_columns(df: pd.DataFrame) -> list[np.ndarray] | None:
    """The columns as float/int/bool NumPy arrays, or None when one is anything else (then pandas writes it)."""
    if df.shape[1] == 0 or isinstance(df.columns, pd.MultiIndex):
        return None
    columns = []
    for j in range(df.shape[1]):
        col = df.iloc[:, j]
        if not isinstance(col.dtype, np.dtype) or col.dtype.kind not in "fiub":
            return None
        columns.append(col.to_numpy())
    return columns


def _arrow_column(values: np.ndarray):
    """A pyarrow array printing like ``DataFrame.to_csv`` reads: NaN as an empty cell, whole floats with ``.0``."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if values.dtype.kind == "b":  # as DataFrame.to_csv writes them (pyarrow would write true / false)
        return pc.if_else(pa.array(values), "True", "False")
    if values.dtype.kind != "f":
        return pa.array(values)
    if values.size and np.all(np.isfinite(values)) and np.all(values == np.trunc(values)) \
            and np.max(np.abs(values)) < 2.0**53:
        # pyarrow prints 3.0 as "3": that column would read back as integers
        text = pc.binary_join_element_wise(pc.cast(pa.array(values.astype(np.int64)), pa.string()), ".0", "")
        negative_zero = (values == 0) & np.signbit(values)
        return pc.if_else(pa.array(negative_zero), "-0.0", text) if negative_zero.any() else text
    return pa.array(values, from_pandas=True)


def _write_numeric_csv(df: pd.DataFrame, path: Path, prefix: str = "") -> bool:
    """Write an all-numeric frame with pyarrow's CSV writer (header by the csv module, after ``prefix``, e.g. the
    ``#`` metadata lines); False if not numeric."""
    import csv
    import io

    import pyarrow as pa
    import pyarrow.csv as pacsv

    columns = _numeric_columns(df)
    if columns is None or (len(columns) == 1 and columns[0].dtype.kind == "f" and np.isnan(columns[0]).any()):
        return False  # one column with NaN: an empty cell would be a blank line, which pandas writes as ""
    names = [str(c) for c in df.columns]
    header = io.StringIO(prefix)
    header.seek(0, io.SEEK_END)
    csv.writer(header, lineterminator="\n").writerow(names)
    table = pa.Table.from_arrays([_arrow_column(v) for v in columns], names=[f"c{j}" for j in range(len(names))])
    with open(path, "wb") as fh:
        fh.write(header.getvalue().encode("utf-8"))
        pacsv.write_csv(table, fh, write_options=pacsv.WriteOptions(include_header=False,
                                                                   quoting_style="none"))
    return True
