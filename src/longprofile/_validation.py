"""Shared argument validators (private).

All public functions validate their inputs here, once, and raise
:mod:`longprofile.errors` exceptions with actionable messages. Compiled kernels
trust their inputs.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .errors import InputError, ModelError, ShapeError

__all__ = [
    "as_float_array",
    "require_finite",
    "require_symmetric_psd",
    "validate_step",
    "require_positive",
    "time_resolution",
    "utc_offset_mix",
    "first_undecodable_line",
    "missing_value_code",
    "missing_value_codes",
    "constant_runs",
    "true_runs",
    "MISSING_PROFILE_HINT",
    "time_seconds",
    "check_time_order",
    "rounded_time_stamps",
    "uniform_time_step",
    "parse_column_renames",
    "renamed_columns",
]

#: What a refusal of a missing profile sample written as a number (a logger's code, a held or zero value) says to do:
#: one hint for the profile readers (``io``) and the road commands.
MISSING_PROFILE_HINT = ("write the missing samples as NaN (leave the cells empty), then analyse with --gaps restart (road "
                        "iri, road report, batch iri: the IRI over the measured parts) or cover them with an exclusion "
                        "zone (road acceptance: [exclusions] zones)")


def as_float_array(name: str, value, *, ndim: int | Sequence[int] | None = None,
                   allow_nan: bool = True) -> np.ndarray:
    """Convert ``value`` to a float64 ndarray and check its number of dimensions."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric array-like; got {type(value).__name__} ({exc}).") from None
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            want = " or ".join(f"{d}-D" for d in allowed)
            raise ShapeError(f"{name} must be {want}; got shape {arr.shape}.")
    if not allow_nan:
        require_finite(name, arr)
    elif np.isinf(arr).any():
        raise InputError(f"{name} contains infinite values; use NaN for missing samples or remove them.")
    return arr


def require_finite(name: str, arr: np.ndarray) -> None:
    """Raise :class:`InputError` if ``arr`` has NaN or infinite entries."""
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        first = tuple(int(i) for i in bad[0])
        raise InputError(f"{name} must be finite; {len(bad)} non-finite value(s), first at index {first}.")


def require_positive(name: str, value, *, strict: bool = True) -> float:
    """Return ``value`` as float after checking it is (strictly) positive and finite."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number; got {value!r}.") from None
    if not np.isfinite(v) or (v <= 0 if strict else v < 0):
        cmp = "> 0" if strict else ">= 0"
        raise InputError(f"{name} must be finite and {cmp}; got {value!r}.")
    return v


def require_symmetric_psd(name: str, mat: np.ndarray, *, rtol: float = 1e-8) -> None:
    """Check that ``mat`` (shape (..., n, n)) is symmetric positive semi-definite.

    Symmetry is checked to a relative tolerance ``rtol`` of the largest entry;
    positive semi-definiteness through the smallest eigenvalue, allowing
    ``-rtol * max|eig|`` for round-off.
    """
    if mat.shape[-1] != mat.shape[-2]:
        raise ShapeError(f"{name} must be square; got shape {mat.shape}.")
    require_finite(name, mat)
    scale = max(float(np.max(np.abs(mat), initial=0.0)), np.finfo(float).tiny)
    asym = float(np.max(np.abs(mat - np.swapaxes(mat, -1, -2)), initial=0.0))
    if asym > rtol * scale:
        raise ModelError(f"{name} must be symmetric; max |A - A^T| = {asym:.3g} (scale {scale:.3g}). "
                         "Symmetrise it, e.g. (A + A.T) / 2.")
    eig = np.linalg.eigvalsh(0.5 * (mat + np.swapaxes(mat, -1, -2)))
    emin = float(eig.min(initial=0.0))
    emax = float(np.max(np.abs(eig), initial=0.0))
    if emin < -rtol * max(emax, np.finfo(float).tiny) and emin < -1e-300:
        raise ModelError(f"{name} must be positive semi-definite; smallest eigenvalue is {emin:.3g}.")


def validate_step(step_name: str, step, positions_name: str, positions, n_samples: int) -> np.ndarray:
    """Return the sample positions from either a constant step or explicit positions.

    Exactly one of ``step`` (a positive scalar, e.g. ``dt`` in s or ``dx`` in m)
    and ``positions`` (a strictly increasing array of length ``n_samples``) must
    be given. The returned array has length ``n_samples``.
    """
    if (step is None) == (positions is None):
        raise InputError(f"give exactly one of {step_name} (constant step) and {positions_name} "
                         f"(sample positions); got {'both' if step is not None else 'neither'}.")
    if step is not None:
        h = require_positive(step_name, step)
        return np.arange(n_samples, dtype=np.float64) * h
    pos = as_float_array(positions_name, positions, ndim=1, allow_nan=False)
    if pos.shape[0] != n_samples:
        raise ShapeError(f"{positions_name} must have one entry per sample ({n_samples}); got {pos.shape[0]}.")
    if n_samples > 1 and np.any(np.diff(pos) <= 0):
        k = int(np.argmax(np.diff(pos) <= 0))
        raise InputError(f"{positions_name} must be strictly increasing; {positions_name}[{k + 1}] = {pos[k + 1]!r} "
                         f"<= {positions_name}[{k}] = {pos[k]!r}.")
    return pos


def time_resolution(t) -> float:
    """The float resolution of the time stamps ``t`` (s), to add to a sampling-uniformity tolerance: steps between
    Unix time stamps (~1.7e9 s) differ by +-2.4e-7 s from float64 rounding alone, which is not the logger's jitter."""
    t = np.asarray(t, float)
    return 4.0 * float(np.spacing(np.max(np.abs(t)))) if t.size else 0.0


def utc_offset_mix(times) -> tuple[int, int] | None:
    """Among ISO 8601 date-time texts, the first index with a UTC offset (``Z``, ``+01:00``) and the first without,
    when both kinds occur (which zone the others are in cannot be known); None otherwise. Values that are not
    date-time texts are left to the parser. One rule for files (``rail settle``) and the service's batches."""
    import pandas as pd

    text = pd.Series(list(times) if not isinstance(times, pd.Series) else times, dtype=object)
    text = text.where(text.map(lambda v: isinstance(v, str))).str.strip()
    iso = text.str.match(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}", na=False).to_numpy(bool)
    has = text.str.contains(r"(?:[Zz]|[+-]\d{2}:?\d{2})$", regex=True, na=False).to_numpy(bool) & iso
    if not has.any() or not (iso & ~has).any():
        return None
    return int(np.flatnonzero(has)[0]), int(np.flatnonzero(iso & ~has)[0])


def time_zone(name):
    """The ``zoneinfo.ZoneInfo`` of the IANA zone ``name`` (``Europe/Paris``, ``UTC``; empty: UTC), an unknown one
    refused. One check for files (``rail settle --timezone``) and the service's site field."""
    from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

    try:
        return ZoneInfo(str(name).strip() or "UTC")
    except (ZoneInfoNotFoundError, ValueError):
        raise InputError(f"unknown time zone {str(name)[:64]!r}: give an IANA name such as Europe/Paris, "
                         "America/New_York or UTC.") from None


def first_undecodable_line(lines, codec: str = "utf-8") -> tuple[int, str] | None:
    """(1-based number, text as Latin-1) of the first of ``lines`` (bytes) that ``codec`` cannot decode; None if all
    can. For messages naming the line (pandas' and the codec's positions are within a chunk)."""
    for n, raw in enumerate(lines, start=1):
        try:
            raw.decode(codec)
        except UnicodeDecodeError:
            return n, raw.decode("latin-1").strip()
    return None


def missing_value_codes(values) -> np.ndarray:
    """Mask of the values that look like a logger's code for a missing value: a whole number of 9s, at least 999 in
    size (-9999, 99999). One rule for the rail tables and the road profile files."""
    a = np.abs(np.asarray(values, dtype=float))
    with np.errstate(invalid="ignore", divide="ignore"):
        whole = np.isfinite(a) & (a >= 999.0) & (a == np.round(a)) & (a < 1e15)
        return whole & (10.0 ** np.round(np.log10(np.where(whole, a + 1.0, 1.0))) == a + 1.0)


def missing_value_code(value: float) -> bool:
    """Whether one value looks like a logger's code for a missing value (:func:`missing_value_codes`)."""
    return bool(missing_value_codes([value])[0])


def true_runs(mask) -> list[tuple[int, int]]:
    """``(first, last)`` index of each run of True in a 1-D boolean mask."""
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist()))


def constant_runs(x, z, min_length: float) -> list[tuple[int, int]]:
    """``(first, last)`` sample indices of the runs of exactly equal, finite values of ``z`` over at least
    ``min_length`` of ``x`` (stations, increasing): a sensor holding one value (a dropout written as a number)."""
    x, z = np.asarray(x, dtype=float), np.asarray(z, dtype=float)
    if z.size < 2:
        return []
    same = np.isfinite(z[1:]) & (z[1:] == z[:-1])
    # steps i .. j equal: samples i .. j + 1
    return [(i, j + 1) for i, j in true_runs(same) if x[j + 1] - x[i] >= min_length]


# ---------------------------------------------------------------------------- time columns of sampled logs

#: An ISO 8601 date-time text (``2024-06-01T12:00:00.010``, ``2024-06-01 12:00:00Z``).
_ISO_DATETIME = r"^\s*\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}"


def _time_unit_row(frame, i: int) -> str:
    """The texts of row ``i`` of ``frame`` (its cells that are not numbers), for the units-row message."""
    import pandas as pd

    row = frame.iloc[i]
    texts = [str(v).strip() for v in row if isinstance(v, str) and pd.isna(pd.to_numeric(v, errors="coerce"))]
    return ", ".join(repr(v) for v in list(dict.fromkeys(texts))[:6])


def time_seconds(frame, column: str = "time", *, source: str = "log") -> tuple[np.ndarray, str | None]:
    """A log's time column as float64 seconds, and the absolute start (ISO text) when it held date-times.

    Numbers are returned as they are (float32 ones as the decimals they print as); ISO 8601 date-time texts and
    datetime64 columns (a Parquet timestamp) become seconds from the first sample (ASSUMPTION: one clock; a mix of
    times with and without a UTC offset is refused); blank cells are NaN (the caller's order check names them).

    Raises
    ------
    InputFormatError
        For a text that is neither a number nor a date-time (a units row under the header is named as such), or
        float32 times too coarse for the sample step (epoch seconds in float32 step by 128 s).
    """
    import pandas as pd

    from .errors import InputFormatError

    col = frame[column]
    if col.dtype.kind == "M":
        return _seconds_from_first(pd.Series(col)), str(col.iloc[0])
    if col.dtype.kind == "m":
        return col.dt.total_seconds().to_numpy(float), None
    if col.dtype.kind == "f" and col.dtype.itemsize < 8:
        return _float32_seconds(col.to_numpy(), column, source), None
    if col.dtype.kind in "iufb":
        return col.to_numpy(float), None
    num = pd.to_numeric(col, errors="coerce")
    text = (col.notna() & num.isna()).to_numpy()
    if not text.any():
        return num.to_numpy(float), None
    stripped = col.astype(str).str.strip()
    iso = stripped.str.match(_ISO_DATETIME, na=False).to_numpy() | col.isna().to_numpy()
    if iso.all():
        mix = utc_offset_mix(col)
        if mix is not None:
            raise InputFormatError(f"{source}: column {column!r} mixes date-times with a UTC offset (row {mix[0]}: "
                                   f"{col.iloc[mix[0]]!r}) and without (row {mix[1]}: {col.iloc[mix[1]]!r}); which "
                                   "zone the others are in cannot be known: write them all in one form.")
        try:
            stamps = pd.to_datetime(col, format="ISO8601", utc=bool(mix is None and stripped.str.contains(
                r"(?:[Zz]|[+-]\d{2}:?\d{2})$", regex=True, na=False).any()))
        except (ValueError, TypeError) as exc:
            raise InputFormatError(f"{source}: column {column!r} holds ISO 8601 date-times that cannot be read: "
                                   f"{str(exc).splitlines()[0]}") from None
        return _seconds_from_first(stamps), str(col.dropna().iloc[0]).strip()
    i = int(np.flatnonzero(text)[0])
    if i <= 1 and not text[i + 1:].any():
        raise InputFormatError(f"{source}: row {i} (the {'first' if i == 0 else 'second'} under the header) holds "
                               f"text ({_time_unit_row(frame, i)}): a units row? declare the units in the header "
                               "(time [s], yaw_rate [deg/s]) or with --units, and remove the row.")
    raise InputFormatError(f"{source}: column {column!r} holds {col.iloc[i]!r} at row {i}: neither a number of "
                           "seconds nor an ISO 8601 date-time (2024-06-01T12:00:00.010).")


def _seconds_from_first(stamps) -> np.ndarray:
    """Seconds of datetime64 values from the first valid one (from the integer nanoseconds: no rounding)."""
    ns = stamps.to_numpy(dtype="datetime64[ns]") if stamps.dt.tz is None else \
        stamps.dt.tz_convert("UTC").dt.tz_localize(None).to_numpy(dtype="datetime64[ns]")
    valid = ~np.isnat(ns)
    out = np.full(ns.shape, np.nan)
    if valid.any():
        rel = (ns[valid] - ns[valid][0]).astype("int64")
        out[valid] = rel // 1_000_000_000 + (rel % 1_000_000_000) * 1e-9
    return out


def _float32_seconds(values: np.ndarray, column: str, source: str) -> np.ndarray:
    """float32 times as float64, each value as the decimal it prints as (0.01, not 0.00999999977: a logger's decimal
    times of up to 7 digits come back exactly); refused when the float32 resolution at the largest time is over 0.1 %
    of the sample step and those decimals are not uniformly spaced (epoch seconds in float32 step by 128 s)."""
    from .errors import InputFormatError

    t = values[np.isfinite(values)]
    if t.size < 2:
        return values.astype(float)
    top = float(np.max(np.abs(t)))
    resolution = float(np.spacing(np.float32(top)))
    step = float(abs(float(t[-1]) - float(t[0])) / (t.size - 1))
    decimals = np.array(values.astype(str), dtype=float)
    d = np.diff(decimals[np.isfinite(decimals)])
    if resolution > 1e-3 * step and (d.min() <= 0 or np.ptp(d) > 1e-3 * np.median(d)):  # not recovered as decimals
        what = "epoch times" if top > 1e7 else "times"
        raise InputFormatError(f"{source}: column {column!r} is float32: float32 {what} lose the samples' timing (at "
                               f"{top:.7g} s a float32 steps by {resolution:g} s"
                               f"{f', the rows are {step:.3g} s apart' if resolution < step else ''}): write the time "
                               "as float64 (double).")
    return decimals


def check_time_order(t, *, source: str = "log", column: str = "time", rows=None, resample_hint: bool = False) -> None:
    """Refuse a time column that is not finite and strictly increasing, naming the first bad row and the likely
    cause: a blank, time stamps rounded to a coarse step (a spreadsheet's 6 significant digits on epoch seconds),
    duplicated samples, a logger reset (the time goes back far) or rows out of order.

    ``rows``: the row number of each sample (default 0, 1, ...); ``resample_hint``: the duplicate message also offers
    ``--resample`` (the vehicle readers drop exact repeats when resampling).
    """
    from .errors import InputFormatError

    t = np.asarray(t, float)
    rows = np.arange(t.size) if rows is None else np.asarray(rows)
    bad = ~np.isfinite(t)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputFormatError(f"{source}: column {column!r} has no time at row {rows[i]}"
                               f"{f' (and {int(bad.sum()) - 1} more rows)' if bad.sum() > 1 else ''}: every sample "
                               "needs its time; cut the rows without one.")
    d = np.diff(t)
    if d.size == 0 or np.all(d > 0):
        return
    zeros, ahead = int(np.sum(d == 0)), d[d > 0]
    if zeros >= 0.3 * d.size and d.size >= 10:  # rounding is a many-row pattern; a few repeats are duplicates
        steps = f"rounded to {float(np.median(ahead)):.4g} s steps" if ahead.size else "all the same"
        hint = (" (epoch seconds saved with 6 significant digits, as a spreadsheet writes 1.71724E+09: save the "
                "column as numbers with full precision)" if np.max(np.abs(t)) > 1e7 else
                ": write the time with more digits")
        raise InputFormatError(f"{source}: column {column!r} has {np.unique(t).size} distinct time(s) for {t.size} "
                               f"rows: the time stamps are {steps}{hint}.")
    k = int(np.flatnonzero(d <= 0)[0])
    i, j = rows[k + 1], rows[k]
    quantum = rounded_time_stamps(t) if zeros == int(np.sum(d <= 0)) else None
    if quantum is not None:  # a logger faster than its stamps' resolution: the repeats are real samples
        mean = float((t[-1] - t[0]) / (t.size - 1))
        raise InputFormatError(f"{source}: column {column!r} repeats a time on {zeros} rows (row {i}: {t[k]:.10g} s) "
                               f"because its time stamps are rounded to {quantum:.4g} s while the rows are {mean:.6g} s "
                               f"apart ({1 / mean:.6g} Hz): write the time with more digits; the repeated rows are "
                               "samples, do not drop them.")
    if d[k] == 0:
        fix = "drop the repeated rows" + (", or --resample RATE (drops rows that repeat the one before exactly)"
                                          if resample_hint else "")
        raise InputFormatError(f"{source}: row {i} repeats the time of row {j} ({t[k]:.10g} s; {zeros} row(s) "
                               f"repeat the time before them): duplicated samples: {fix}.")
    step = float(np.median(ahead)) if ahead.size else 0.0
    cause = ("a logger reset? split the file there and use each part" if -d[k] > 10 * step else
             "rows out of order: sort the file by time")
    raise InputFormatError(f"{source}: the time goes back from {t[k]:.10g} s to {t[k + 1]:.10g} s at row {i} "
                           f"({cause}).")


def rounded_time_stamps(t) -> float | None:
    """The rounding step q of time stamps that are a uniform grid rounded to q, coarser than their float resolution
    (a 1024 Hz logger writing whole milliseconds: steps of 0 and 1 ms; whole microseconds: 976 and 977 us); None
    when they are not.

    ASSUMPTION (the test): the steps take two or three values, consecutive multiples of q; the stamps stay within
    1.25 q (peak to peak) of their least-squares straight line (rounding keeps them within q; duplicated rows or a
    dropped sample shift every later stamp by a whole step, which a line through the record cannot follow); and at
    least 3 steps differ from the most common one (one or two repeats are duplicates, not a pattern).
    """
    t = np.asarray(t, float)
    if t.size < 8 or not np.all(np.isfinite(t)):
        return None
    d = np.diff(t)
    tol = max(time_resolution(t), 1e-12 * float(np.max(np.abs(d))))
    values = np.unique(d)
    centres = [float(v[0]) for v in np.split(values, np.flatnonzero(np.diff(values) > 4 * tol) + 1)]
    if not 2 <= len(centres) <= 3:
        return None
    q = centres[1] - centres[0]
    if q <= 8 * tol or (len(centres) == 3 and abs(centres[2] - centres[1] - q) > 4 * tol):
        return None
    counts = [int(np.sum(np.abs(d - c) <= 4 * tol)) for c in centres]
    if d.size - max(counts) < 3:
        return None
    k = np.arange(t.size, dtype=float)
    slope, offset = np.polyfit(k, t - t[0], 1)
    if np.ptp(t - t[0] - (offset + slope * k)) > 1.25 * q + 4 * tol:
        return None
    return float(f"{q:.6g}")


def uniform_time_step(t, *, source: str = "log", column: str = "time", rows=None, rtol: float = 1e-3,
                      max_gap_steps: float = 3.0, gap_fix: str = "cut the record at the gap and use each part",
                      rounded_fix: str = "write the time with more digits",
                      jitter_fix: str = "resample it onto a uniform time base") -> float:
    """The constant step of a time column (s: the mean step end to end), or a refusal saying why there is none.

    One rule for every command that needs a uniform time base (``differentiate``, the vehicle logs' readers):

    * the time must be finite and increasing (:func:`check_time_order`, which names rounded stamps, duplicated
      rows, a logger reset or rows out of order);
    * a step over ``max_gap_steps`` times the median step is a gap (lost samples): refused with its length and time;
    * every step within ``rtol`` of the mean step, plus the float resolution of the stamps (:func:`time_resolution`:
      Unix time stamps' rounding is not jitter); otherwise refused as stamps rounded too coarsely
      (:func:`rounded_time_stamps`) or as jitter.

    ``gap_fix``, ``rounded_fix`` and ``jitter_fix`` end the three messages with the caller's remedy.
    """
    from .errors import InputFormatError

    t = np.asarray(t, float)
    check_time_order(t, source=source, column=column, rows=rows)
    rows = np.arange(t.size) if rows is None else np.asarray(rows)
    d = np.diff(t)
    median = float(np.median(d))
    k = int(np.argmax(d))
    if d[k] > max_gap_steps * median:
        raise InputFormatError(f"{source}: column {column!r} has a gap of {d[k]:.6g} s after t = {t[k]:.6g} s (row "
                               f"{rows[k]}; the median step is {median:.6g} s): samples are missing there: {gap_fix}.")
    mean = float((t[-1] - t[0]) / (t.size - 1))
    if np.max(np.abs(d - mean)) <= rtol * mean + time_resolution(t):
        return mean
    quantum = rounded_time_stamps(t)
    if quantum is not None:
        raise InputFormatError(f"{source}: column {column!r} has time stamps rounded to {quantum:.4g} s (steps "
                               f"{d.min():.6g} to {d.max():.6g} s), coarser than {rtol:.2%} of its step ({mean:.6g} s, "
                               f"{1 / mean:.6g} Hz): {rounded_fix}.")
    raise InputFormatError(f"{source}: column {column!r} is not uniformly sampled (steps {d.min():.6g} to "
                           f"{d.max():.6g} s, median {median:.6g} s): {jitter_fix}.")


def parse_column_renames(texts, *, what: str = "column",
                         example: str = "--rename VehSpd_kph=speed --rename YawRate_degps=yaw_rate_degps"
                         ) -> dict[str, str]:
    """``--rename OLD=NEW[,OLD=NEW...]`` (one text, or several: the option repeated) as ``{old: new}``; a malformed
    pair, an old name given twice or two ``what`` (columns, tracks) renamed to one name (any letter case) is refused;
    ``example`` is the usage the refusal of a malformed pair shows."""
    if texts is None:
        return {}
    renames: dict[str, str] = {}
    for text in [texts] if isinstance(texts, str) else texts:
        for pair in (p.strip() for p in text.split(",") if p.strip()):
            old, sep, new = (s.strip() for s in pair.partition("="))
            if not sep or not old or not new:
                raise InputError(f"--rename takes OLD=NEW pairs separated by commas, or the option repeated (e.g. "
                                 f"{example}); got {pair!r}.")
            if old.casefold() in (o.casefold() for o in renames):
                raise InputError(f"--rename names the {what} {old!r} twice; rename each {what} once.")
            renames[old] = new
    news = [n.casefold() for n in renames.values()]
    twice = next((n for n in renames.values() if news.count(n.casefold()) > 1), None)
    if twice is not None:
        raise InputError(f"--rename gives two {what}s the name {twice!r}; each {what} needs its own name.")
    return renames


def renamed_columns(frame, renames: dict[str, str], *, source: str = "log"):
    """``frame`` with its columns renamed by ``renames`` ({old: new}; an old name matches a column exactly, else in
    any letter case when only one column matches). An old name the file does not have, or a new name that another
    column already holds, is refused naming the file's columns."""
    if not renames:
        return frame
    columns = [str(c) for c in frame.columns]
    mapping = {}
    for old, new in renames.items():
        found = [c for c in columns if c == old] or [c for c in columns if c.casefold() == old.casefold()]
        if len(found) != 1:
            why = "no column" if not found else f"{len(found)} columns in different letter cases ({found})"
            raise InputError(f"--rename {old}={new}: {source} has {why} named {old!r}; its columns are {columns}.")
        mapping[found[0]] = new
    kept = {c.casefold(): c for c in columns if c not in mapping}
    clash = next((n for n in mapping.values() if n.casefold() in kept), None)
    if clash is not None:
        raise InputError(f"--rename: {source} already has a column {kept[clash.casefold()]!r}; renaming another to "
                         f"{clash!r} would give two columns one name: rename or drop that one too.")
    return frame.rename(columns=mapping)
