"""Reading and writing tables (CSV, Parquet) with clear errors."""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

import pandas as pd

from ..errors import InputError, InputFormatError

__all__ = ["read_table", "write_table"]

_FORMATS = {".csv": "csv", ".txt": "csv", ".parquet": "parquet", ".pq": "parquet"}


def _format_of(path: Path) -> str:
    fmt = _FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise InputError(f"{path}: unknown table format {path.suffix!r}; use .csv or .parquet.")
    return fmt


def _read_csv(path: Path) -> pd.DataFrame:
    """CSV with ``#`` comments, where an empty line inside the data is a row of missing values.

    pandas skips blank lines by default, which silently shifts every later sample of a one-column file with
    missing values (a logger or a spreadsheet writes an empty cell there as an empty line). Blank lines before
    the header and after the last data line are ignored.
    """
    with open(path, encoding="utf-8", errors="replace") as fh:
        leading = 0
        for line in fh:
            if line.strip():
                break
            leading += 1
    df = pd.read_csv(path, comment="#", skipinitialspace=True, skip_blank_lines=False, skiprows=leading)
    filled = df.notna().any(axis=1).to_numpy()
    last = int(filled.nonzero()[0][-1]) + 1 if filled.any() else 0
    return df.iloc[:last].reset_index(drop=True) if last < len(df) else df


def read_table(path, *, required: Iterable[str] = (), numeric: Iterable[str] = ()) -> pd.DataFrame:
    """Read a CSV or Parquet table.

    Parameters
    ----------
    path : path-like
        ``.csv`` (comma separated, header row; lines starting with ``#`` are comments; an empty line
        among the data is a row of missing values: an empty cell of a one-column table) or ``.parquet``.
    required : iterable of str
        Columns that must be present.
    numeric : iterable of str
        Columns that must parse as numbers (empty cells become NaN).

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
        df = _read_csv(path) if fmt == "csv" else pd.read_parquet(path)
    except Exception as exc:  # pandas/pyarrow raise many types
        raise InputFormatError(f"{path}: cannot be read as {fmt}: {exc}") from None
    if fmt == "csv" and df.shape[1] == 1 and any(sep in str(df.columns[0]) for sep in (";", "\t")):
        sep = ";" if ";" in str(df.columns[0]) else "tab"
        raise InputFormatError(f"{path}: the header {str(df.columns[0])!r} is separated by {sep!r}, not commas; save the "
                               "file as comma-separated values with decimal points (e.g. 0.25, not 0,25).")
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
            line = f" line {i + 2}" if fmt == "csv" else f" row {i}"
            raise InputFormatError(f"{path}:{line}: column {col!r} has a non-numeric value {df[col].iloc[i]!r}.")
        df[col] = conv.astype(float)
    return df


def write_table(df: pd.DataFrame, path) -> Path:
    """Write ``df`` as CSV or Parquet according to the suffix of ``path``; return the path."""
    path = Path(path)
    fmt = _format_of(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "csv":
        df.to_csv(path, index=False)
    else:
        df.to_parquet(path, index=False)
    return path
