"""File I/O speed (issue 11, part 2): ERD read/write, CSV write, and IRI of an ERD end to end.

Rows:
- ERD read throughput (MB/s of the whole file, header included) of ``longprofile.io.read_erd`` on a 10 km
  two-track profile at 25 mm written by ``write_erd`` (400 001 records, 4 decimals in mm); target >= 50 MB/s.
- Speed-up over the PEER ``old_pure_python_read_erd``: the reader as it was before this issue (a Python loop
  over lines and ``float()`` per token), kept verbatim below; target >= 10x. Both must give the same numbers.
- ERD write throughput (MB/s) of ``write_erd`` (reported).
- CSV write of a 2e6 x 5 float table by ``longprofile.io.write_table`` vs ``pandas.DataFrame.to_csv`` (speed-up,
  reported) and vs ``pyarrow.csv.write_csv`` of the same table (time ratio, target <= 1.25: "at pyarrow's
  speed"); the file is read back to check every float64 value.
- IRI of the 10 km two-track ERD end to end in-process: ``read_erd`` + ``longprofile.road.iri(profile,
  segment_length=100)``; target <= 0.5 s (IRI kernels warmed up first).

Quick mode: a 1 km ERD and a 1e5 x 5 table (seconds); fixed costs dominate there, so the speed-up, ratio and
IRI-time targets are only set for the full sizes.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python -m benchmarks io`` (full) or ``--quick``.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks._common import BenchRow, best_time

AREA = "io"


# --- PEER: the ERD reader before issue 11 (src/longprofile/io/_erd.py at 0a2b73b), verbatim but for the names

from longprofile.core import unit_factor  # noqa: E402
from longprofile.errors import InputError, InputFormatError, UnitsError  # noqa: E402


def _old_fields8(value: str, n: int) -> list[str]:
    """Split a value into n 8-character fields (the ERD convention), falling back to whitespace."""
    parts = [value[i:i + 8].strip() for i in range(0, 8 * n, 8)]
    if all(parts) and len(parts) == n:
        return parts
    return value.split()


def old_pure_python_read_erd(path, *, units: str | None = None, tracks=None, distance_units: str | None = None):
    """PEER: longprofile's ERD reader before issue 11 (pure-Python body loop), kept verbatim as the peer.

    Read a text ERD profile file.

    Parameters
    ----------
    path : path-like
    units : str, optional
        Elevation unit to use when the header has no ``UNITSNAM`` line (never guessed). If the header
        gives units and ``units`` disagrees, :class:`UnitsError`.
    tracks : str or sequence of str, optional
        Channels to keep, by ``SHORTNAM`` (default all; unnamed channels are ``ch1``, ``ch2``...).
    distance_units : str, optional
        Station unit when the header has no ``XUNITS`` line.

    Returns
    -------
    Profile
        Stations ``X0 + i DX`` and elevations, in metres.

    Raises
    ------
    InputFormatError
        Not an ERD file, bad second line, missing END, wrong number of values (line named).
    UnitsError
        Units missing (and not given) or unknown.

    Notes
    -----
    Second line: ``NCHAN, NPTS, ..., DX, X0``: fields 1, 2, 6 are the number of channels, the number of
    samples and the station step. Field 7 is used as the first station only when written as a real
    number (with a decimal point); an integer there (e.g. ``-1`` in LTPP files) is a flag and the first
    station is 0. Fields 3-5 (storage flags) are not interpreted; only text data are supported.
    """
    from longprofile.road import Profile

    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file.")
    try:
        lines = path.read_text(errors="strict").splitlines()
    except UnicodeDecodeError:
        raise InputFormatError(f"{path}: not a text file (binary ERD data are not supported).") from None
    if not lines or not lines[0].strip().upper().startswith("ERDFILEV2"):
        raise InputFormatError(f"{path}: line 1: expected 'ERDFILEV2.00', got {lines[0][:20]!r}." if lines else
                               f"{path}: empty file.")
    if len(lines) < 3:
        raise InputFormatError(f"{path}: the file ends after line {len(lines)}; an ERD header has at least 3 lines.")
    fields = [f.strip() for f in lines[1].split(",")]
    fields = [f for f in fields if f != ""]
    try:
        nchan, npts = int(fields[0]), int(fields[1])
        dx = float(fields[5])
    except (ValueError, IndexError):
        raise InputFormatError(f"{path}: line 2: expected 'NCHAN, NPTS, f3, f4, f5, DX, X0'; got {lines[1]!r}.") from None
    if nchan < 1 or npts < 2 or not dx > 0:
        raise InputFormatError(f"{path}: line 2: need NCHAN >= 1, NPTS >= 2, DX > 0; got {nchan}, {npts}, {dx}.")
    x0 = 0.0
    if len(fields) > 6 and any(ch in fields[6] for ch in ".eE"):
        try:
            x0 = float(fields[6])
        except ValueError:
            raise InputFormatError(f"{path}: line 2: field 7 (first station) is not a number: {fields[6]!r}.") from None
    keys: dict[str, str] = {}
    end = None
    for i in range(2, len(lines)):
        line = lines[i]
        if line.strip().upper() == "END":
            end = i
            break
        if line.strip():
            keys.setdefault(line[:8].strip().upper(), line[8:])
    if end is None:
        raise InputFormatError(f"{path}: no END line closing the header.")
    names = _old_fields8(keys["SHORTNAM"], nchan) if "SHORTNAM" in keys else [f"ch{k + 1}" for k in range(nchan)]
    if len(names) != nchan:
        raise InputFormatError(f"{path}: SHORTNAM names {len(names)} channel(s) but line 2 says NCHAN = {nchan}.")
    if "UNITSNAM" in keys:
        chan_units = _old_fields8(keys["UNITSNAM"], nchan)
        if len(chan_units) != nchan:
            raise InputFormatError(f"{path}: UNITSNAM gives {len(chan_units)} unit(s) for {nchan} channel(s).")
        if units is not None and any(u.lower() != units.lower() for u in chan_units):
            raise UnitsError(f"{path}: the header gives units {chan_units} but units={units!r} was given; remove the "
                             "option or fix the header.")
    elif units is None:
        raise UnitsError(f"{path}: the ERD header has no UNITSNAM line; pass --units m|mm (units=...) or add the "
                         "line. Units are never guessed.")
    else:
        chan_units = [units] * nchan
    factors = [unit_factor(u) for u in chan_units]
    xunit = keys.get("XUNITS", "").strip() or distance_units
    if not xunit:
        raise UnitsError(f"{path}: the ERD header has no XUNITS line; pass distance_units or add 'XUNITS  m'.")
    xfactor = unit_factor(xunit, what="distance")
    values = []
    for i in range(end + 1, len(lines)):
        text = lines[i].replace(",", " ").split()
        if not text:
            continue
        try:
            row = [float(t) for t in text]
        except ValueError:
            bad = next(t for t in text if not _old_is_float(t))
            raise InputFormatError(f"{path}: line {i + 1}: {bad!r} is not a number.") from None
        values.extend(row)
        if len(values) > nchan * npts:
            raise InputFormatError(f"{path}: line {i + 1}: more values than NCHAN x NPTS = {nchan} x {npts}.")
    if len(values) != nchan * npts:
        raise InputFormatError(f"{path}: the data have {len(values)} values; line 2 announces NCHAN x NPTS = "
                               f"{nchan} x {npts} = {nchan * npts}.")
    data = np.asarray(values).reshape(npts, nchan) * np.asarray(factors)
    keep = list(range(nchan)) if tracks is None else [_old_index(path, names, t) for t in
                                                      ([tracks] if isinstance(tracks, str) else tracks)]
    x = (x0 + dx * np.arange(npts)) * xfactor
    title = keys.get("TITLE", "").strip() or path.stem
    return Profile(distance=x, elevation=data[:, keep], tracks=tuple(names[k] for k in keep), name=title)


def _old_is_float(t: str) -> bool:
    try:
        float(t)
        return True
    except ValueError:
        return False


def _old_index(path, names, t):
    if t not in names:
        raise InputError(f"{path}: no channel {t!r}; the file has {names}.")
    return names.index(t)


# --- the benchmark ---------------------------------------------------------------------------------------------

def _erd_rows(tmp: Path, quick: bool) -> list[BenchRow]:
    from longprofile.io import read_erd, write_erd
    from longprofile.road import iri, iso8608_profile

    length = 1000.0 if quick else 10_000.0
    prof = iso8608_profile(length, 0.025, "C", rng=0, tracks=("left", "right"))
    path = tmp / "profile.erd"
    t_write = best_time(lambda: write_erd(prof, path), repeat=3)
    mb = path.stat().st_size / 1e6
    ours = {}
    t_read = best_time(lambda: ours.setdefault("p", read_erd(path)), repeat=5)
    peer = {}
    t_peer = best_time(lambda: peer.setdefault("p", old_pure_python_read_erd(path)), repeat=3 if quick else 1)
    diff = float(np.max(np.abs(ours["p"].elevation - peer["p"].elevation)))
    same_x = float(np.max(np.abs(ours["p"].distance - peer["p"].distance)))

    iri(ours["p"], segment_length=100.0)  # compile / warm the kernels
    t_iri = best_time(lambda: iri(read_erd(path), segment_length=100.0), repeat=3)
    what = f"{length / 1000:g} km two-track ERD at 25 mm, {prof.n_samples} records, {mb:.2f} MB"
    return [
        BenchRow(AREA, "ERD read throughput (read_erd)", mb / t_read, "MB/s", target=50.0,
                 detail=f"{what}; {t_read * 1e3:.0f} ms"),
        BenchRow(AREA, "ERD read speed-up vs the old pure-Python parser", t_peer / t_read, "x",
                 target=None if quick else 10.0,
                 detail=f"peer old_pure_python_read_erd {t_peer:.2f} s"),
        BenchRow(AREA, "ERD read: max |ours - old parser|", max(diff, same_x), "m", target=1e-12,
                 higher_is_better=False, detail="elevations and stations"),
        BenchRow(AREA, "ERD write throughput (write_erd)", mb / t_write, "MB/s",
                 detail=f"{what}; {t_write * 1e3:.0f} ms"),
        BenchRow(AREA, "IRI of the ERD end to end (read_erd + iri, 100 m)", t_iri, "s",
                 target=0.5 if not quick else None, higher_is_better=False, detail=what),
    ]


def _csv_rows(tmp: Path, quick: bool) -> list[BenchRow]:
    import pandas as pd
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from longprofile.io import write_table

    n = 100_000 if quick else 2_000_000
    rng = np.random.default_rng(0)
    df = pd.DataFrame({"distance_m": 0.025 * np.arange(n), "left_m": 1e-3 * rng.standard_normal(n).cumsum(),
                       "right_m": 1e-3 * rng.standard_normal(n).cumsum(), "left_std_m": 1e-4 * rng.random(n),
                       "right_std_m": 1e-4 * rng.random(n)})
    ours_path, pandas_path, arrow_path = tmp / "ours.csv", tmp / "pandas.csv", tmp / "arrow.csv"
    t_ours = best_time(lambda: write_table(df, ours_path), repeat=3 if quick else 2)
    t_arrow = best_time(lambda: pacsv.write_csv(pa.Table.from_pandas(df, preserve_index=False), arrow_path),
                        repeat=3 if quick else 2)
    t0 = time.perf_counter()
    df.to_csv(pandas_path, index=False)
    t_pandas = time.perf_counter() - t0
    back = pd.read_csv(ours_path)
    exact = list(back.columns) == list(df.columns) and bool((back.to_numpy() == df.to_numpy()).all())
    mb = ours_path.stat().st_size / 1e6
    size = f"{n:.0e} x 5 floats, {mb:.0f} MB"
    return [
        BenchRow(AREA, "CSV write speed-up vs pandas to_csv", t_pandas / t_ours, "x",
                 detail=f"{size}; ours {t_ours:.2f} s, pandas {t_pandas:.2f} s"),
        BenchRow(AREA, "CSV write time / pyarrow.csv.write_csv", t_ours / t_arrow, "ratio",
                 target=None if quick else 1.25,
                 higher_is_better=False, detail=f"pyarrow {t_arrow:.2f} s"),
        BenchRow(AREA, "CSV write: values read back exactly", float(exact), "bool", target=1.0,
                 detail="pandas.read_csv of the written file == the float64 table, same header"),
    ]


def run(quick: bool) -> list[BenchRow]:
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        return _erd_rows(tmp, quick) + _csv_rows(tmp, quick)
