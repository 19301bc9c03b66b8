"""``rail settle --events FILE``: declared re-installations and replacements of sensors (docs/rail.md, "Re-installed
sensors"; docs/file-formats.md, "Events table")."""

from __future__ import annotations

from dataclasses import replace

import typer

#: ``rail settle --events FILE``.
EVENTS_OPTION = typer.Option(None, "--events",
                             help="Events table: sensor_id, date, event (reinstalled or replaced_by), new_id: a sensor "
                                  "refitted after maintenance, or replaced by new_id, goes on with a new reference "
                                  "from that date (docs/rail.md, \"Re-installed sensors\").")


def read_site_with_events(events, sensors, readings, survey, controls, **options):
    """The site of ``rail settle`` and its checked events table (None without ``--events``).

    With a replacement (event ``replaced_by``) the sensors and readings tables are read, the replacing sensor's
    readings are merged into the replaced one's series (``rail.apply_replacements``), then the site is validated; the
    merges are named in the site's warnings. ``options``: those of :func:`longprofile.io.read_rail_site`.
    """
    from ..io import read_rail_site, read_rail_table, read_table
    from ..rail import apply_replacements, check_events, validate_site

    if events is None:
        return read_rail_site(sensors, readings, survey, controls, **options), None
    ev = check_events(read_table(events, required=("sensor_id", "date", "event"), text=("sensor_id", "new_id")))
    if not (ev["event"] == "replaced_by").any():
        return read_rail_site(sensors, readings, survey, controls, **options), ev
    s = read_rail_table(sensors, "sensors")
    r = read_rail_table(readings, "readings", angle_unit=options.get("angle_unit", "deg"),
                        require_temperature=options.get("require_temperature", True))
    sv = None if survey is None else read_rail_table(survey, "survey")
    ct = None if controls is None else read_rail_table(controls, "controls")
    s, r, notes = apply_replacements(s, r, ev)
    site = validate_site(s, r, sv, ct, **options)
    return replace(site, warnings=tuple(site.warnings) + tuple(notes)), ev
