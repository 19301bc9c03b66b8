"""File input and output (thin).

read_table   -- read a CSV or Parquet table with required/numeric column checks.
write_table  -- write a table as CSV or Parquet by suffix.
"""

from ._tables import read_table, write_table

__all__ = ["read_table", "write_table"]
