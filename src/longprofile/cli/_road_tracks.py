"""Which tracks of a profile file the road commands read, and ``--rename``: one rule for every command."""

from __future__ import annotations

from pathlib import Path

import typer

from .._validation import parse_column_renames
from ..errors import InputError
from ._common import console, parse_tracks

#: ``--rename`` of ``road convert`` and ``road compare`` (one syntax and meaning).
RENAME = typer.Option(None, "--rename", help="Rename tracks, OLD=NEW[,OLD=NEW...] (e.g. elevation=left): tracks are "
                      "matched by name wherever profiles meet (road compare, the MRI of left and right). Applied "
                      "after reading, so --track names the file's tracks in road convert and the new names in road "
                      "compare.")


def file_tracks(track: str | None, file: Path | None, *, verb: str = "analysing") -> list[str] | None:
    """The tracks to read from ``file``: ``--track`` when given; else the one profile of a ``road reconstruct``
    output (``elevation``) or of a ``road simulate`` recording (``true``; its ``apl_m`` is the trailer's raw
    signal), each with a note on the console naming what is read; else None (every track)."""
    if file is not None:
        _note_backward_stations(file)
    if track is not None:
        return parse_tracks(track)
    if file is None:
        return None
    from ..io import is_reconstruct_output, is_simulated_recording

    if is_reconstruct_output(file):
        console.print(f"note: {file} is a `road reconstruct` output: {verb} its profile track 'elevation' "
                      "(std_m and the undetrended raw_m are not tracks; pass --track to choose).", markup=False,
                      soft_wrap=True)
        return ["elevation"]
    if is_simulated_recording(file):
        console.print(f"note: {file} is a `road simulate` recording: {verb} its true profile, track 'true' (apl_m is "
                      "the trailer's raw signal, not a profile; `longprofile road reconstruct "
                      f"{file} -o profile.csv` gives the profile the trailer measured).", markup=False, soft_wrap=True)
        return ["true"]
    return None


def _note_backward_stations(file: Path) -> None:
    """A warning on the console when ``file``'s stations decrease throughout: read in the order of its rows (the
    direction of travel) as the distance travelled from its first station (docs/file-formats.md)."""
    from ..io import backward_stations

    found = backward_stations(file)
    if found:
        column, first, last = found
        console.print(f"warning: {file}: the stations in {column!r} decrease ({first:g} .. {last:g}): a run driven "
                      "against the stationing (e.g. a southbound lane); read in the order of the rows, the direction "
                      f"of travel, as the distance travelled from station {first:g} (distance = {first:g} - "
                      "station): stations in the results are distances from the start; reverse the rows first if "
                      "the file lists the run backwards.", markup=False,
                      soft_wrap=True)


def parse_renames(text: str | None) -> dict[str, str]:
    """``--rename OLD=NEW[,OLD=NEW...]`` as ``{old: new}`` (empty when not given); a malformed pair, an old name
    given twice or two tracks renamed to one name is refused (:func:`longprofile._validation.parse_column_renames`,
    the vehicle commands' option)."""
    return parse_column_renames(text, what="track", example="--rename elevation=left")


def renamed(profile, renames: dict[str, str], *, source, strict: bool = True):
    """``profile`` with the ``renames`` whose old name is one of its tracks (any letter case, as ``--track``) applied.

    ``strict``: an old name that is not a track of the profile is refused, naming ``source`` (the file) and its
    tracks; otherwise it is skipped (``road compare``, where a name may be in some of the files only).
    """
    if not renames:
        return profile
    by_lower = {t.casefold(): t for t in profile.tracks}
    mapping = {}
    for old, new in renames.items():
        name = old if old in profile.tracks else by_lower.get(old.casefold())
        if name is not None:
            mapping[name] = new
        elif strict:
            raise InputError(f"--rename {old}={new}: {source} has no track {old!r}; its tracks are "
                             f"{list(profile.tracks)}.")
    try:
        return profile.renamed(mapping)
    except InputError as exc:
        raise InputError(f"--rename on {source}: {exc}") from None
