"""``rail settle --events FILE``: declared re-installations and replacements of sensors (docs/rail.md, "Re-installed
sensors"; docs/file-formats.md, "Events table")."""

from __future__ import annotations

import typer

#: ``rail settle --events FILE``.
EVENTS_OPTION = typer.Option(None, "--events",
                             help="Events table: sensor_id, date, event (reinstalled or replaced_by), new_id: a sensor "
                                  "refitted after maintenance, or replaced by new_id, goes on with a new reference "
                                  "from that date (docs/rail.md, \"Re-installed sensors\").")


def read_site_with_events(events, sensors, readings, survey, controls, **options):
    """The site of ``rail settle`` and its checked events table (None without ``--events``).

    With a replacement (event ``replaced_by``) the replacing sensor's readings are merged into the replaced one's
    series before the site is validated, the merges named in the site's warnings
    (:func:`longprofile.rail.site_with_events`, what the monitoring service calls too). ``options``: those of
    :func:`longprofile.io.read_rail_site`.
    """
    from ..io import read_rail_events, read_rail_site, read_rail_tables
    from ..rail import site_with_events

    if events is None:
        return read_rail_site(sensors, readings, survey, controls, **options), None
    ev = read_rail_events(events)
    tables = read_rail_tables(sensors, readings, survey, controls, angle_unit=options.get("angle_unit", "deg"),
                              require_temperature=options.get("require_temperature", True))
    return site_with_events(*tables, ev, **options)
