"""DIS captures as chunks (docs/formats.md, "DIS captures"): the ``pcap`` and ``pcapng`` formats of
``formats.INPUT_FORMATS``. ``io.dis`` reads the Entity State PDUs in blocks; here each
``site:application:entity`` is an entity, the packets put back in time order within
``REORDER_WINDOW`` (:class:`CaptureState`), duplicates dropped, turret and gun carried where a PDU
has none, positions converted to the terrain's CRS.
"""

from __future__ import annotations

from datetime import timedelta
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError, warn
from tankcd_cli.io.csv_kernels import Interner, carry
from tankcd_cli.io.dis import CaptureCounts, DisCapture, articulation_angles, trajectory_columns
from tankcd_cli.io.geodesy import dis_orientation_to_enu, ecef_to_geodetic
from tankcd_cli.io.trajectory.chunk import EPOCH, GUN_LIMIT_DEG, EntityOrder, ReadState, TrajectoryChunk
from tankcd_cli.io.trajectory.geographic_csv import check_crs
from tankcd_cli.io.trajectory.names import EntityNames

REORDER_WINDOW = 1.0  # s: a capture's packets this much out of time order are put back in order


def read_chunks(state: ReadState) -> Iterator[TrajectoryChunk]:
    """The chunks of the capture ``state.path``, ``state`` kept up to date (its clock from the first
    packet, its counts and what was skipped; the set-up warnings once read to the end)."""
    cap = DisCapture(state.path, block_pdus=state.chunk_rows)
    if state.convert:
        check_crs(state.crs, cap.name)
    state.counts = cap.counts
    rows = CaptureState(cap.name)
    step = 0
    for states in cap.blocks():
        first = cap.first_packet_time()
        if state.start is None and first is not None:
            sec, frac = first
            state.start = EPOCH + timedelta(seconds=sec, microseconds=round(frac * 1e6))
            state.time_origin = float(sec) + frac
        cap.counts.duplicates = rows.duplicates
        state.skipped = cap.counts.skipped()
        for chunk in rows.take(state, states, step):
            step += len(chunk)
            yield chunk
    for chunk in rows.flush(state, step):
        step += len(chunk)
        yield chunk
    cap.counts.duplicates = rows.duplicates
    state.counts = cap.counts
    state.skipped = cap.counts.skipped()
    warn_capture(cap.name, cap.counts, rows)


def warn_capture(name: str, counts: CaptureCounts, state: "CaptureState") -> None:
    """The set-up warnings of a capture read to its end: packets its snap length cut, duplicates dropped."""
    if counts.truncated:
        lost = f"; {counts.pdus_cut:,} PDUs in them cut short and not read" if counts.pdus_cut else \
            "; every Entity State PDU in them was whole and is read"
        warn(name, f"{counts.truncated:,} packets were captured shorter than they were sent (the capture's snap "
                   f"length){lost}")
    if state.duplicates:
        warn(name, f"{state.duplicates:,} duplicate Entity State PDUs dropped (each repeats its entity's row before "
                   f"it exactly: the same capture time, location, orientation, turret and gun; first at packet "
                   f"{state.first_duplicate}): a capture taken on two interfaces, or merged with itself?")


class CaptureState:
    """A capture's rows on their way out, in an order that does not depend on how the capture is cut
    into blocks (docs/formats.md, "DIS captures"):

    each packet P gets the key k_P = max(t_P, L_P - W), L_P the latest capture time of the packets up
    to P (in capture order), W = ``REORDER_WINDOW``; the rows go out stably sorted by k. A packet at
    most W behind the latest before it keeps k = t (put back in time order); one further behind goes
    where the window had reached (k = L_P - W), and its entity's time going back there is the error.

    Proof that streaming gives that order: every packet Q after the ones read so far has k_Q >= L_Q -
    W >= L - W (L the latest so far; L is non-decreasing), and goes after every earlier packet of
    equal k (the sort is stable); so the rows read with k < L - W are a prefix of the whole capture's
    order, whatever the blocks. Then the rows go through each entity's time check, the duplicates
    (a row equal to its entity's row before it in time, position, orientation, turret and gun) are
    dropped and counted, the turret and gun carried where a PDU has none, and the rows cut into chunks."""

    def __init__(self, name: str = ""):
        self.name = name
        self.names = EntityNames()
        self.interner = None
        self.order = EntityOrder()
        self.pending: dict | None = None
        self.latest = -np.inf
        self.latest_packet = 0
        self.last_turret = np.zeros(16)
        self.last_gun = np.zeros(16)
        self.last_state = np.full((16, 9), np.nan)  # each entity's last row: t, location, orientation, parts
        self.duplicates = 0
        self.first_duplicate = 0
        self.has_turret = False

    def _codes(self, ids: np.ndarray) -> np.ndarray:
        """Codes of (N, 3) uint16 entity ids, through the compiled interner over their 6 bytes each."""
        if self.interner is None:
            self.interner = Interner()
        n = len(ids)
        raw = np.ascontiguousarray(ids, dtype=np.uint16).view(np.uint8).reshape(-1)
        at = np.arange(0, 6 * n, 6, dtype=np.int64)
        codes, first, _ = self.interner.codes(raw, np.column_stack([at, at + 6]), n)
        for k in range(first, len(self.interner)):
            site, app, ent = np.frombuffer(self.interner.name(k), np.uint16).tolist()
            self.names.add(f"{site}:{app}:{ent}")  # the same order: the same codes
        return codes

    def take(self, reader: ReadState, states, step: int):
        n = len(states)
        if not n:
            return
        if reader.convert:
            cols = trajectory_columns(states, reader.crs, source=self.name)
            block = {"t": states.t, "x": cols["x"], "y": cols["y"], "yaw_deg": cols["yaw_deg"],
                     "turret_deg": cols["turret_deg"], "gun_deg": cols["gun_deg"]}
        elif reader.lonlat:
            lon, lat, _ = ecef_to_geodetic(states.location)
            o = np.asarray(states.orientation, dtype=np.float64).reshape(-1, 3)
            yaw, _, _ = dis_orientation_to_enu(o[:, 0], o[:, 1], o[:, 2], lon, lat)
            turret, gun = articulation_angles(states.turret_azimuth, states.gun_elevation)
            block = {"t": states.t, "x": lon, "y": lat, "yaw_deg": np.degrees(yaw), "turret_deg": np.degrees(turret),
                     "gun_deg": np.degrees(gun)}
        else:
            turret, gun = articulation_angles(states.turret_azimuth, states.gun_elevation)
            nan = np.full(n, np.nan)
            block = {"t": states.t, "x": nan, "y": nan, "yaw_deg": nan, "turret_deg": np.degrees(turret),
                     "gun_deg": np.degrees(gun)}
        block["packet"] = states.packet
        block["code"] = self._codes(states.entity_id)
        block["state"] = np.column_stack([states.t, states.location, states.orientation, states.turret_azimuth,
                                          states.gun_elevation])
        # the latest capture time up to each packet (and that packet, for messages), across blocks
        t = states.t
        latest = np.maximum.accumulate(np.r_[self.latest, t])[1:]
        new_max = np.r_[self.latest, latest[:-1]] < t
        at = np.maximum.accumulate(np.where(new_max, np.arange(1, n + 1), 0))
        block["latest"] = latest
        block["latest_packet"] = np.where(at > 0, states.packet[np.maximum(at - 1, 0)], self.latest_packet)
        block["key"] = np.maximum(t, latest - REORDER_WINDOW)
        self.latest, self.latest_packet = float(latest[-1]), int(block["latest_packet"][-1])
        if self.pending is not None:
            block = {k: np.concatenate([self.pending[k], v]) for k, v in block.items()}
        key = block["key"]
        if np.any(key[1:] < key[:-1]):
            idx = np.argsort(key, kind="stable")
            block = {k: v[idx] for k, v in block.items()}
            key = block["key"]
        cut = int(np.searchsorted(key, self.latest - REORDER_WINDOW, side="left"))
        self.pending = {k: v[cut:] for k, v in block.items()}
        yield from self._emit(reader, {k: v[:cut] for k, v in block.items()}, step)

    def flush(self, reader: ReadState, step: int):
        if self.pending is not None:
            block, self.pending = self.pending, None
            yield from self._emit(reader, block, step)

    def _grow(self, ncodes: int) -> None:
        if len(self.last_turret) < ncodes:
            grow = max(ncodes, 2 * len(self.last_turret)) - len(self.last_turret)
            self.last_turret = np.r_[self.last_turret, np.zeros(grow)]
            self.last_gun = np.r_[self.last_gun, np.zeros(grow)]
            self.last_state = np.vstack([self.last_state, np.full((grow, 9), np.nan)])

    def _duplicates(self, block: dict) -> np.ndarray | None:
        """(N,) bool the rows equal to their entity's row before them (t, location, orientation, turret and
        gun as decoded; NaN equal to NaN), counted; None for none."""
        codes, state = block["code"], block["state"]
        n = len(codes)
        if n == 0:
            return None
        order = np.argsort(codes, kind="stable")  # each entity's rows together, in order
        c = codes[order]
        first = np.r_[True, c[1:] != c[:-1]]
        prev = np.empty_like(state)
        prev[1:] = state[order[:-1]]
        prev[first] = self.last_state[c[first]]
        cur = state[order]
        same = ((cur == prev) | (np.isnan(cur) & np.isnan(prev))).all(axis=1)
        last = np.r_[c[1:] != c[:-1], True]
        self.last_state[c[last]] = cur[last]
        if not same.any():
            return None
        drop = np.zeros(n, bool)
        drop[order[same]] = True
        if not self.duplicates:
            self.first_duplicate = int(block["packet"][np.flatnonzero(drop)[0]])
        self.duplicates += int(drop.sum())
        return drop

    def _emit(self, reader: ReadState, block: dict, step: int):
        n = len(block["t"])
        if not n:
            return
        codes = block["code"]
        ncodes = len(self.names.list)
        self._grow(ncodes)
        piece, bad = self.order.check(codes, block["t"], block["packet"], ncodes)
        k = n if bad < 0 else bad
        error = self._order_error(block, bad) if bad >= 0 else None
        far = np.flatnonzero(np.abs(block["gun_deg"][:k]) > GUN_LIMIT_DEG)  # NaN: no gun record, kept
        if len(far):
            k = bad = int(far[0])
            error = InputError(self.name, f"Entity State PDU's gun elevation {float(block['gun_deg'][k]):.6g} deg is "
                                          f"no elevation (beyond +-{GUN_LIMIT_DEG:g} deg)",
                               where=f"packet {int(block['packet'][k])}")
        if bad >= 0:
            block = {key: v[:k] for key, v in block.items()}
            piece = piece[:k]
        drop = self._duplicates(block)
        if drop is not None:  # a duplicate is never its entity's first row: the pieces stay as they are
            block = {key: v[~drop] for key, v in block.items()}
            piece = piece[~drop]
        codes = block["code"]
        k = len(codes)
        self.has_turret = self.has_turret or bool(np.isfinite(block["turret_deg"]).any()
                                                  or np.isfinite(block["gun_deg"]).any())
        turret = carry_values(block["turret_deg"], codes, self.last_turret)
        gun = carry_values(block["gun_deg"], codes, self.last_gun)
        names = self.names.tuple()
        for lo in range(0, k, reader.chunk_rows):
            hi = min(lo + reader.chunk_rows, k)
            yield TrajectoryChunk(np.arange(step + lo, step + hi), int(block["packet"][lo]), block["t"][lo:hi],
                                  block["x"][lo:hi], block["y"][lo:hi], block["yaw_deg"][lo:hi], turret[lo:hi],
                                  gun[lo:hi], self.has_turret, block["packet"][lo:hi], codes[lo:hi], names,
                                  piece[lo:hi], True, "packet", reader.time_origin)
        if error is not None:
            raise error

    def _order_error(self, block: dict, bad: int) -> InputError:
        code = int(block["code"][bad])
        prev = float(self.order.last_t[code])
        t = float(block["t"][bad])
        behind = float(block["latest"][bad]) - t
        return InputError(self.name, f"entity {self.names.list[code]!r}: capture time goes back {prev - t:.6f} s (t "
                                     f"{t!r} after {prev!r} at packet {int(self.order.last_line[code])}): the packet "
                                     f"is {behind:.6f} s behind the capture's latest time (packet "
                                     f"{int(block['latest_packet'][bad])}), more than the {REORDER_WINDOW:g} s this "
                                     "reader puts back in order; sort the capture by time first (Wireshark's "
                                     "reordercap does)",
                          where=f"packet {int(block['packet'][bad])}")


def carry_values(values: np.ndarray, codes: np.ndarray, last: np.ndarray) -> np.ndarray:
    """NaN values replaced by the same entity's value before them (``last[code]`` before its first row in
    these; ``last`` updated to each entity's last value)."""
    out = np.array(values, dtype=np.float64)
    carry(np.ascontiguousarray(codes, dtype=np.int64), out, last)
    return out
