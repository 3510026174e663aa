"""Trajectories in (docs/formats.md, "Trajectory inputs: formats", "Trajectory CSV" and the formats
after it): one reader for every input a user holds, as chunks a replay streams.

``read_trajectory(path, chunk_rows, part, crs, fmt)`` reads any format of ``INPUT_FORMATS``, chosen
by ``fmt``, the suffix or the first bytes. Every chunk is a :class:`TrajectoryChunk`: rows in the
input's order, positions and headings in the terrain's CRS, each row's entity as a code into the
names seen so far, where each entity's pieces of motion start, and where the input has an
absolute clock the UTC instant of its t = 0 (``time_origin``). Every bad row or record is an
:class:`InputError` naming the file and the line (or point, or packet); the rows before it have
been yielded.

The package, a module a concept:

- ``chunk``: the chunk model (``TrajectoryChunk``, ``TrajectoryPart``, ``ReadState``), each entity's
  time order, ``utc_text``; ``names``: the entity-id rule and the names' codes;
- ``formats``: the registry ``INPUT_FORMATS`` (names, suffixes, magic numbers, readers) and how an
  input's format is told; ``reader``: ``TrajectoryReader``, ``read_trajectory``;
- one module a format: ``csv_input`` (with ``csv_rows``, the header and the compiled row pass),
  ``geographic_csv`` (lon, lat CSV), ``gpx_input``, ``capture_input`` (DIS, pcap and pcapng);
- ``parts`` (a CSV in parts, lead rows), ``info``, ``export``, ``merge`` (``replay --together``).
"""

from tankcd_cli.io.trajectory.capture_input import REORDER_WINDOW
from tankcd_cli.io.trajectory.chunk import (EPOCH, GUN_LIMIT_DEG, OPTIONAL, REQUIRED, ReadState, TrajectoryChunk,
                                            TrajectoryPart, utc_text)
from tankcd_cli.io.trajectory.csv_rows import epoch_seconds, iso_seconds
from tankcd_cli.io.trajectory.export import EXPORT_COLUMNS, EXPORT_NO_CRS, export_trajectory, is_wgs84
from tankcd_cli.io.trajectory.formats import (FORMAT_NAMES, INPUT_FORMATS, InputFormat, input_format,
                                              trajectory_format, trajectory_input)
from tankcd_cli.io.trajectory.geographic_csv import check_crs, geographic_to_crs
from tankcd_cli.io.trajectory.info import EntitySpan, TrajectoryInfo, trajectory_info
from tankcd_cli.io.trajectory.merge import merged_trajectories
from tankcd_cli.io.trajectory.names import entity_id_fault, entity_id_from, stem_name
from tankcd_cli.io.trajectory.parts import has_entity_column, lead_row, split_trajectory
from tankcd_cli.io.trajectory.reader import TrajectoryReader, read_trajectory

FORMATS = FORMAT_NAMES

__all__ = ["EPOCH", "EXPORT_COLUMNS", "EXPORT_NO_CRS", "FORMATS", "FORMAT_NAMES", "GUN_LIMIT_DEG", "INPUT_FORMATS",
           "OPTIONAL", "REORDER_WINDOW", "REQUIRED", "EntitySpan", "InputFormat", "ReadState", "TrajectoryChunk",
           "TrajectoryInfo", "TrajectoryPart", "TrajectoryReader", "check_crs", "entity_id_fault", "entity_id_from",
           "epoch_seconds", "export_trajectory", "geographic_to_crs", "has_entity_column", "input_format",
           "is_wgs84", "iso_seconds", "lead_row", "merged_trajectories", "read_trajectory", "split_trajectory",
           "stem_name", "trajectory_format", "trajectory_info", "trajectory_input", "utc_text"]
