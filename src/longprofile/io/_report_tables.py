"""Report tables with their metadata: CSV ``#`` header lines or Parquet schema metadata (thin)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd

from ..errors import InputError, InputFormatError, OutputError
from ._atomic import atomic_path

__all__ = ["METADATA_KEY", "write_report_table", "read_report_table"]

#: Key of the JSON metadata in the Parquet schema metadata (and ``frame.attrs``).
METADATA_KEY = "longprofile"


def report_metadata(frame: pd.DataFrame, metadata) -> dict:
    """``metadata`` (default: ``frame.attrs["longprofile"]``) checked to be a JSON-serialisable dict, NaN as None."""
    meta = frame.attrs.get(METADATA_KEY, {}) if metadata is None else metadata
    if not isinstance(meta, dict):
        raise InputError(f"metadata must be a dict of names to values; got {type(meta).__name__}.")
    try:
        json.dumps(meta)
    except (TypeError, ValueError) as exc:
        raise InputError(f"metadata must be JSON-serialisable (numbers, strings, booleans, lists): {exc}") from None
    return _finite(meta)


def _finite(value):
    """``value`` with every NaN or infinite float replaced by None: strict JSON (``null``; ``NaN`` is Python's
    extension, which other JSON readers refuse), e.g. the section IRI of a dead track."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def csv_metadata_lines(meta: dict) -> str:
    """The ``# key: <JSON value>`` lines of ``meta`` (one per entry, each ending with a newline)."""
    return "".join(f"# {key}: {json.dumps(value)}\n" for key, value in meta.items())


def write_report_table(frame: pd.DataFrame, path, metadata: dict | None = None) -> Path | None:
    """Write a report table as CSV or Parquet (by suffix) with its metadata.

    Parameters
    ----------
    frame : DataFrame
        The table (e.g. :meth:`longprofile.road.IRIReport.to_frame`).
    path : path-like or text stream
        ``.csv`` or ``.parquet`` file, or an open text stream (e.g. ``sys.stdout``) for CSV.
    metadata : dict, optional
        JSON-serialisable values (default: ``frame.attrs["longprofile"]``).

    Returns
    -------
    Path or None
        The path written (None for a stream).

    Notes
    -----
    CSV: one ``# key: <JSON value>`` line per entry before the header (``longprofile.io.read_table`` and
    ``pandas.read_csv(comment="#")`` skip them). Parquet: the dict as JSON under the schema metadata key
    ``b"longprofile"``, beside pandas' own metadata.
    """
    meta = report_metadata(frame, metadata)
    if hasattr(path, "write"):
        path.write(csv_metadata_lines(meta))
        frame.to_csv(path, index=False)
        return None
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise OutputError(f"{path}: unknown table format {path.suffix!r}; use .csv or .parquet.")
    if suffix == ".csv":
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
            fh.write(csv_metadata_lines(meta))
            frame.to_csv(fh, index=False)
        return path
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(frame, preserve_index=False)
    merged = dict(table.schema.metadata or {})
    merged[METADATA_KEY.encode()] = json.dumps(meta).encode()
    with atomic_path(path) as tmp:  # an existing file is replaced only once the new one is complete
        pq.write_table(table.replace_schema_metadata(merged), tmp)
    return path


def read_report_table(path) -> tuple[pd.DataFrame, dict]:
    """Read a table written by :func:`write_report_table`: ``(frame, metadata)``."""
    from ._tables import read_table

    path = Path(path)
    frame = read_table(path)
    meta: dict = {}
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        raw = (pq.read_schema(path).metadata or {}).get(METADATA_KEY.encode())
        if raw is not None:
            meta = json.loads(raw)
    else:
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                if not line.startswith("#"):
                    break
                key, sep, value = line[1:].strip().partition(": ")
                if not sep:
                    continue
                try:
                    meta[key] = json.loads(value)
                except ValueError:
                    raise InputFormatError(f"{path}: metadata line {line.strip()!r} is not 'key: JSON value'; "
                                           "rewrite it or remove it.") from None
    frame.attrs[METADATA_KEY] = meta
    return frame, meta
