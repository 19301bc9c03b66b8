"""File input and output (thin).

read_table   -- read a CSV or Parquet table with required/numeric column checks.
write_table  -- write a table as CSV or Parquet by suffix.
read_profile -- read a road profile (CSV/Parquet with unit-suffixed columns, or ERD); units never guessed.
read_apl_signal -- read an APL recording (distance_m + signal column, unit checked) as a Profile.
read_apl_recording -- the same with the stations absent from its grid (filled as missing samples): APLSignalFile.
read_sampled_column -- one column of a table sampled dx apart (stations checked), m.
read_apl_record -- an APL record with its towing speed (distance- or time-sampled), as road reconstruct reads it.
read_apl_speed -- an APL recording's towing speed column (speed_kmh, 'Speed [km/h]'), m/s; find_speed_column.
read_time_sampled_apl -- a time-sampled APL record (time, speed) taken at every dx of distance, stops removed.
backward_stations -- a profile table whose stations decrease throughout (read as distance travelled): its column,
                      first and last station.
is_reconstruct_output -- whether a table is a `road reconstruct` output (one profile track, 'elevation').
is_simulated_recording -- whether a table is a `road simulate` recording (one profile track, 'true'; apl_m is the
                      trailer's raw signal, not a profile).
write_profile -- write a profile as CSV, Parquet or ERD with its units in the header.
read_erd, write_erd -- UMTRI/ProVAL ERD text files (ERDFILEV2.00, several channels).
write_report_table, read_report_table -- a result table with its metadata ('#' header lines in CSV, schema
                      metadata in Parquet).
atomic_path, atomic_write_bytes, save_figure -- write through a temporary file in the target's folder, then
                      os.replace it (an older file survives a failed write).
read_rail_site -- read a rail inclinometer site (sensors, readings, survey, controls tables) and validate it.
read_rail_table -- one rail site table with canonical columns (any letter case; declared units converted).
read_rail_thresholds -- read graded alarm thresholds (quantity, level, value_mm) for rail settle.
read_rail_tables -- the four rail site tables read (readings long or wide), not yet validated.
read_rail_events -- the events table (re-installed / replaced sensors) of rail settle --events, checked.
"""

from .._lazy import lazy_namespace

_EXPORTS = {
    "._apl_speed": (
        "SpeedColumn", "TimeSampledRecording", "find_speed_column", "read_apl_speed", "read_time_sampled_apl",
        "APLRecord", "read_apl_record",
    ),
    "._atomic": (
        "atomic_path", "atomic_write_bytes", "save_figure",
    ),
    "._erd": (
        "read_erd", "write_erd",
    ),
    "._profile_files": (
        "read_profile", "write_profile",
    ),
    "._profiles": (
        "is_reconstruct_output", "is_simulated_recording", "read_apl_signal", "read_sampled_column",
        "read_apl_recording", "APLSignalFile", "backward_stations",
    ),
    "._rail": (
        "read_rail_site", "read_rail_table", "read_rail_thresholds", "read_rail_tables", "read_rail_events",
    ),
    "._report_tables": (
        "read_report_table", "write_report_table",
    ),
    "._tables": (
        "read_table", "write_table",
    ),
}

__all__ = ["read_table", "write_table", "read_profile", "write_profile", "read_erd", "write_erd",
           "write_report_table", "read_report_table", "read_apl_signal", "read_sampled_column", "read_apl_recording",
           "APLSignalFile", "is_reconstruct_output", "backward_stations",
           "is_simulated_recording", "atomic_path", "atomic_write_bytes", "save_figure", "read_rail_site",
           "read_rail_table", "read_rail_thresholds", "read_rail_tables", "read_rail_events", "SpeedColumn", "find_speed_column", "read_apl_speed",
           "TimeSampledRecording", "read_time_sampled_apl", "APLRecord", "read_apl_record"]

__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, __all__)
