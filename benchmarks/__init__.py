"""longprofile benchmarks (outside the package and the default test run).

Each ``bench_<area>.py`` module defines ``run(quick: bool) -> list[BenchRow]``. Timings are
always reported as ratios against a peer measured in the same run (or as throughput for
targets stated in samples/s). ``python -m benchmarks [--quick] [AREA ...]`` runs them.
"""
