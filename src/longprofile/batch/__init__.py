"""Batch processing of survey networks: one task over thousands of profile files, on any executor.

A network survey is a file per lane and run (ERD, CSV or Parquet). This package maps the library calls of the
single-file commands over many files, in parallel, resumably, into one results folder (docs/batch.md).

Mapping (any executor)
----------------------
map_files -- apply a function to files; results in input order, a failing file is a recorded error (FileResult).
iter_files -- the same, yielded as files complete.
process_executor -- a process pool with BLAS threads pinned to 1 and the numba kernels warmed per worker.
open_executor -- "processes", "threads", "serial" or a Dask scheduler "tcp://HOST:PORT" (dask_client).

Tasks (the single-file commands)
--------------------------------
IRITask -- ``longprofile road iri``: read_profile -> IRI report -> segment table.
ReconstructTask -- ``longprofile road reconstruct``: APL recording -> reconstruct_profile -> profile + IRI.

Results folders
---------------
run_batch -- run a task into a folder: partitioned Parquet dataset + manifest, --resume / --overwrite.
expand_paths -- glob patterns (``**`` recursive) to files.
read_results -- the manifest and the segment dataset back (BatchResults).
summarize_network -- per-route and network tables for the network report (NetworkSummary).
EXIT_SOME_FAILED -- exit code of the CLI when the batch completed with failed files (3).

Nothing here imports numpy at import time: spawned workers pin their BLAS threads first.
"""

from ._map import (
                   BLAS_ENV,
                   SCHEDULERS,
                   FileResult,
                   dask_client,
                   error_message,
                   iter_files,
                   map_files,
                   open_executor,
                   process_executor,
)
from ._results import BatchResults, NetworkSummary, read_results, summarize_network
from ._run import (
                   EXIT_SOME_FAILED,
                   MANIFEST,
                   MANIFEST_COLUMNS,
                   PROFILES,
                   SEGMENTS,
                   BatchSummary,
                   expand_paths,
                   file_digest,
                   read_manifest,
                   run_batch,
)
from ._tasks import TASKS, IRITask, ReconstructTask, TaskOutput, options_hash

__all__ = ["map_files", "iter_files", "FileResult", "error_message", "process_executor", "open_executor",
           "dask_client", "BLAS_ENV", "SCHEDULERS", "IRITask", "ReconstructTask", "TaskOutput", "TASKS",
           "options_hash", "run_batch", "BatchSummary", "expand_paths", "file_digest", "read_manifest",
           "read_results", "BatchResults", "summarize_network", "NetworkSummary", "EXIT_SOME_FAILED", "MANIFEST",
           "MANIFEST_COLUMNS", "SEGMENTS", "PROFILES"]
