"""Trajectory CSV (the contract's input of ``replay``), read in chunks and validated strictly.

Header row required, column order free, extra columns ignored. Required:
``t`` (s, non-decreasing), ``x``, ``y`` (m), ``yaw_deg``; optional
``turret_deg``, ``gun_deg`` (0 when absent). Every bad row is exit 3 naming
the line and the column.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.files import open_input

REQUIRED = ("t", "x", "y", "yaw_deg")
OPTIONAL = ("turret_deg", "gun_deg")


@dataclass(frozen=True)
class TrajectoryChunk:
    """Consecutive rows: step (row index from 0), first_line (file line of the first row), columns (N,)."""

    step: np.ndarray
    first_line: int
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw_deg: np.ndarray
    turret_deg: np.ndarray
    gun_deg: np.ndarray
    has_turret: bool

    def __len__(self) -> int:
        return len(self.t)


def read_trajectory(path: str, chunk_rows: int = 65536) -> Iterator[TrajectoryChunk]:
    """Yield validated chunks of a trajectory CSV in file order."""
    name, fh = open_input(path, text=True)
    try:
        yield from _chunks(fh, name, chunk_rows)
    except UnicodeDecodeError:
        raise InputError(name, "not UTF-8 text (a trajectory is a CSV file)") from None
    finally:
        if path != "-":
            fh.close()


def _chunks(fh, name: str, chunk_rows: int) -> Iterator[TrajectoryChunk]:
    from tankcd_cli.io.csv_columns import numeric_chunks

    step = 0
    last_t = -np.inf
    for rows, wanted, values in numeric_chunks(fh, name, REQUIRED, OPTIONAL, chunk_rows):
        t = values[:, 0]
        order_bad = np.flatnonzero(np.diff(np.concatenate([[last_t], t])) < 0)
        error = None
        if len(order_bad):
            k = int(order_bad[0])
            prev = last_t if k == 0 else t[k - 1]
            error = InputError(name, f"time goes back ({t[k]!r} after {prev!r}); t must be non-decreasing",
                               where=f"line {rows[k]} column t")
            values, rows, t = values[:k], rows[:k], t[:k]
            if k == 0:
                raise error
        last_t = t[-1]
        n = len(t)
        turret = values[:, wanted.index("turret_deg")] if "turret_deg" in wanted else np.zeros(n)
        gun = values[:, wanted.index("gun_deg")] if "gun_deg" in wanted else np.zeros(n)
        yield TrajectoryChunk(np.arange(step, step + n), rows[0], t, values[:, 1], values[:, 2], values[:, 3],
                              turret, gun, any(c in wanted for c in OPTIONAL))
        step += n
        if error is not None:
            raise error
