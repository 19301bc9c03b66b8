"""Profile files of any supported format: dispatch by suffix to ERD (``_erd.py``) or CSV/Parquet (``_profiles.py``)."""

from __future__ import annotations

from pathlib import Path

from ..core import unit_factor
from ..errors import InputError
from ._erd import read_erd, write_erd
from ._plausible import check_profile_plausible
from ._profiles import read_profile_table, refuse_erd_apl_signal, write_profile_table

__all__ = ["read_profile", "write_profile"]


def read_profile(path, *, units: str | None = None, tracks=None, distance_column: str | None = None):
    """Read a profile from CSV or Parquet, or ERD (suffix ``.erd``, or a file of any other suffix whose first line
    is the ERD identification ``ERDFILEV...``: ERD files named ``.txt``).

    Parameters
    ----------
    path : path-like
        ``.csv`` (``.txt`` is read as CSV; header row; ``#`` lines are comments), ``.parquet``, or ``.erd``
        (:func:`longprofile.io.read_erd`; also any non-Parquet file whose first line starts with ``ERDFILE``).
    units : {"m", "mm", "cm", "in", "ft"}, optional
        Unit of the elevation columns that do not carry one in their name. Never guessed: if a column has
        no unit and ``units`` is not given, :class:`UnitsError` is raised. If a column names its unit and
        ``units`` disagrees, :class:`UnitsError` too.
    tracks : str or sequence of str, optional
        Track (column base) names to read (default: every elevation column).
    distance_column : str, optional
        Name of the station column (default: the first of ``distance_<u>``, ``station_<u>``,
        ``chainage_<u>``, ``x_<u>``).

    Returns
    -------
    Profile
        Stations and elevations converted to metres. Columns ``<track>_std_<u>`` become ``Profile.std``
        (NaN for tracks without one). A ``road reconstruct`` output (columns exactly ``distance_m, elevation_m,
        std_m, raw_m, raw_std_m``) is read as its one profile track ``elevation`` with ``std_m`` as its std,
        unless ``tracks`` names others; a ``road simulate`` recording (exactly ``distance_m, true_m, apl_m``) as
        its true profile ``true``.

    Raises
    ------
    UnitsError
        Missing or unknown units; elevations no terrain has or a median grade above 100 % (millimetres under a
        metre label; ``io._plausible`` gives the limits).
    InputFormatError
        Unreadable file, no station column, non-numeric cell, stations not strictly increasing (the message
        names the line); stations decreasing throughout are a run driven against the stationing (a southbound lane),
        read in the order of the rows as the distance travelled from the first station (docs/file-formats.md), a standard-deviation column without its
        track, a last row cut short, title lines above the header.
    InputError
        A track asked for twice in ``tracks`` (any letter case); an APL trailer's raw signal as a track: ``apl``
        of a ``road simulate`` recording, or a column ``apl_<u>`` of a CSV/Parquet table unless ``tracks`` names
        it (``road reconstruct`` makes a profile of it).

    Notes
    -----
    Column naming: ``<name>_<unit>``, ``<name> [<unit>]`` or ``<name> (<unit>)``, e.g. ``distance_m, left_mm,
    right_mm``; the unit short or spelled out as in ERD headers (``LWP (inches)``, ``Distance (feet)``:
    :func:`longprofile.core.length_unit`). A CSV separated by ``;`` or tabs is read when its decimal mark is
    unambiguous (docs/file-formats.md §2).
    """
    path = Path(path)
    _check_unique(path, tracks)
    erd = path.suffix.lower() == ".erd" or _looks_erd(path)
    if not erd and path.suffix.lower() not in _TABLE_SUFFIXES and path.is_file():
        raise InputError(f"{path}: unknown profile format {path.suffix!r}; use .csv (.txt), .parquet or .erd (an ERD "
                         "file is read whatever its suffix when its first line is ERDFILEV2.00).")
    if erd:
        profile = read_erd(path, units=units, tracks=tracks)
        refuse_erd_apl_signal(path, profile.tracks, chosen=tracks is not None)  # as a table's apl_<unit>
    else:
        profile = read_profile_table(path, units=units, tracks=tracks, distance_column=distance_column)
    check_profile_plausible(profile, path)
    return profile


#: Suffixes of the table profiles :func:`read_profile` reads (``io._tables``).
_TABLE_SUFFIXES = (".csv", ".txt", ".parquet", ".pq")


def _looks_erd(path: Path) -> bool:
    """The file, whatever its suffix (not Parquet), starts with the ERD identification line (``ERDFILEV2.00``; a
    UTF-8 byte order mark and leading blanks allowed): ERD files are also distributed as ``.txt``."""
    if path.suffix.lower() in (".parquet", ".pq"):
        return False
    try:
        with open(path, "rb") as fh:
            head = fh.read(64)
    except OSError:  # the table reader reports it
        return False
    return head.removeprefix(b"\xef\xbb\xbf").lstrip().upper().startswith(b"ERDFILE")


def _check_unique(path: Path, tracks) -> None:
    """Refuse a track asked for twice (any letter case): an MRI or HRI of one track with itself."""
    names = [] if tracks is None or isinstance(tracks, str) else [str(t) for t in tracks]
    twice = [t for k, t in enumerate(names) if t.casefold() in {u.casefold() for u in names[:k]}]
    if twice:
        raise InputError(f"{path}: the track {twice[0]!r} is asked for twice ({', '.join(names)}); give each track "
                         "once.")


def write_profile(profile, path, *, units: str = "m", distance_units: str = "m") -> Path:
    """Write a profile as CSV, Parquet or ERD (by suffix) with its units in the header.

    Parameters
    ----------
    profile : Profile
    path : path-like
        ``.csv``, ``.parquet`` or ``.erd``; any other suffix raises :class:`OutputError`.
    units : str
        Elevation unit written (m, mm, cm, in, ft...).
    distance_units : str
        Station unit written (m, ft, km, mi...): ``distance_<unit>`` in CSV/Parquet, ``XUNITS`` in ERD (``feet``
        with inches elevations: a ProVAL US file).

    Returns
    -------
    Path

    Notes
    -----
    CSV/Parquet columns: ``distance_<distance_units>``, ``<track>_<units>`` per track, ``<track>_std_<units>`` when the
    profile has a standard deviation (read back by :func:`read_profile` to the same float64 values). ERD
    (:func:`longprofile.io.write_erd`) holds regular stations and elevations only: the standard deviation is
    not written.
    """
    path = Path(path)
    unit_factor(units)
    unit_factor(distance_units, what="distance")
    if path.suffix.lower() == ".erd":
        return write_erd(profile, path, units=units, distance_units=distance_units)
    return write_profile_table(profile, path, units=units, distance_units=distance_units)
