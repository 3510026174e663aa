"""Trajectory CSV (the contract's input of ``replay``), read in chunks and validated strictly.

Header row required, column order free, extra columns ignored. Required:
``t`` (s, non-decreasing), ``x``, ``y`` (m), ``yaw_deg``; optional
``turret_deg``, ``gun_deg`` (0 when absent). Every bad row is exit 3 naming
the line and the column.
"""

from __future__ import annotations

import itertools
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
    header_line = fh.readline()
    lineno = 1
    while header_line and not header_line.strip():
        header_line = fh.readline()
        lineno += 1
    if not header_line:
        raise InputError(name, "file is empty (a trajectory needs a header row: t,x,y,yaw_deg)")
    if "\x00" in header_line:
        raise InputError(name, "not a text file", where="line 1")
    header = [h.strip().strip('"').strip() for h in header_line.rstrip("\r\n").split(",")]
    missing = [c for c in REQUIRED if c not in header]
    if missing:
        raise InputError(name, f"header lacks the required column{'s' if len(missing) > 1 else ''} "
                               f"{', '.join(missing)} (found: {', '.join(header)[:200]})", where=f"line {lineno}")
    dup = sorted({h for h in header if header.count(h) > 1 and h in REQUIRED + OPTIONAL})
    if dup:
        raise InputError(name, f"column {dup[0]} appears twice in the header", where=f"line {lineno}")
    wanted = list(REQUIRED) + [c for c in OPTIONAL if c in header]
    cols = [header.index(c) for c in wanted]
    width = len(header)
    has_turret = any(c in header for c in OPTIONAL)
    step = 0
    last_t = -np.inf
    while True:
        lines = list(itertools.islice(fh, chunk_rows))
        if not lines:
            return
        start_line = lineno + 1
        rows = []
        numbers = []
        for k, line in enumerate(lines):
            body = line.rstrip("\r\n")
            if not body.strip():
                continue
            parts = body.split(",")
            if len(parts) != width:
                raise InputError(name, f"expected {width} columns as in the header, found {len(parts)}",
                                 where=f"line {start_line + k}")
            rows.append(start_line + k)
            numbers.append([parts[i] for i in cols])
        lineno += len(lines)
        if not numbers:
            continue
        try:
            values = np.array(numbers, dtype=np.float64)
        except ValueError:
            values = None
        if values is None or not np.isfinite(values).all():
            _raise_first_bad(numbers, rows, wanted, name)
        t = values[:, 0]
        order_bad = np.flatnonzero(np.diff(np.concatenate([[last_t], t])) < 0)
        if len(order_bad):
            k = int(order_bad[0])
            prev = last_t if k == 0 else t[k - 1]
            raise InputError(name, f"time goes back ({t[k]!r} after {prev!r}); t must be non-decreasing",
                             where=f"line {rows[k]} column t")
        last_t = t[-1]
        n = len(t)
        turret = values[:, wanted.index("turret_deg")] if "turret_deg" in wanted else np.zeros(n)
        gun = values[:, wanted.index("gun_deg")] if "gun_deg" in wanted else np.zeros(n)
        # the rows of a chunk may skip blank lines: first_line is the first row's line
        yield TrajectoryChunk(np.arange(step, step + n), rows[0], t, values[:, 1], values[:, 2], values[:, 3],
                              turret, gun, has_turret)
        step += n


def _raise_first_bad(numbers, rows, wanted, name):
    for k, row in enumerate(numbers):
        for j, text in enumerate(row):
            try:
                value = float(text)
            except ValueError:
                raise InputError(name, f"not a number: {text.strip()[:40]!r}",
                                 where=f"line {rows[k]} column {wanted[j]}") from None
            if not np.isfinite(value):
                raise InputError(name, f"non-finite value {text.strip()!r}", where=f"line {rows[k]} column {wanted[j]}")
    raise InputError(name, "unparseable rows")  # pragma: no cover
