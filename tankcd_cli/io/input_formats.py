"""The trajectory inputs' formats under the name the command line and ``api`` import them by: the
registry and how a format is told live in ``io.trajectory.formats``, how an input is opened
(standard input, gzip) and its magic numbers in ``io.input_bytes``.
"""

from tankcd_cli.io.input_bytes import (GZIP_MAGIC, HEAD_BYTES, PCAP_MAGIC, PCAPNG_SHB, input_head,
                                       open_trajectory_input)
from tankcd_cli.io.trajectory.formats import (COMPRESSED_SUFFIXES, DEFAULT_FORMAT, FORMAT_NAMES, INPUT_FORMATS,
                                              InputFormat, TrajectoryInput, TrajectoryPath, check_format,
                                              format_of_head, format_of_suffix, trajectory_input, with_format)

TRAJECTORY_FORMATS = INPUT_FORMATS

__all__ = ["COMPRESSED_SUFFIXES", "DEFAULT_FORMAT", "FORMAT_NAMES", "GZIP_MAGIC", "HEAD_BYTES", "INPUT_FORMATS",
           "InputFormat", "PCAPNG_SHB", "PCAP_MAGIC", "TRAJECTORY_FORMATS", "TrajectoryInput", "TrajectoryPath",
           "check_format", "format_of_head", "format_of_suffix", "input_head", "open_trajectory_input",
           "trajectory_input", "with_format"]
