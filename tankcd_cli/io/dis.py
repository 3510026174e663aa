"""DIS captures in bulk: Entity State PDUs out of pcap and pcapng files, as arrays.

A capture is read in blocks of bytes (memory bounded whatever its size; a record may straddle
blocks). A compiled framing pass (``_dis.pyx``) walks the records or packet blocks, the link
layer (Ethernet with 802.1Q/802.1ad tags, Linux cooked SLL and SLL2, raw IP, BSD loopback),
IPv4 (options; fragments other than the first skipped and counted) or IPv6 (extension headers
counted and skipped) and UDP on any port, then the DIS PDUs of each payload back to back by
their length fields (DIS bundling). A payload is DIS when it starts with a PDU header of
protocol version 4-7, a PDU type, a protocol family 0-13 and a length that fits. The Entity
State PDUs (type 1, family 1; protocol version 5, 6 = IEEE 1278.1a-1998 or 7 = IEEE
1278.1-2012: one layout) come out as offsets, and numpy decodes them all at once: their fixed
144 bytes through one big-endian structured dtype (``ES_DTYPE``) and their 16-byte
articulation records through another (``PART_DTYPE``).

Articulated parts: the primary turret's azimuth is parameter type 4107 (4096 primary turret +
11 azimuth), the primary gun's elevation 4429 (4416 primary gun + 13 elevation), radians.
DIS 7 (VariableParameter, record type 0 = articulated part) holds the value as a float32 in the
first 4 bytes of the 8-byte value field (4 bytes of padding after). DIS 6 and 5
(ArticulationParameter, designator 0 = articulated part) call the field a 64-bit value:
senders write either a float32 with 4 zero bytes after it (the SISO enumerations' layout, as
DIS 7) or a float64 (Open-DIS's DIS 6 classes and Wireshark read it so). Here a DIS 6 value
whose last 4 bytes are zero is a float32, any other a float64, and once a sender (site,
application) has shown a float64 value, its values are read as float64 from then on (from the
start of that block: a float64 of a round value, 0.5 rad say, has 4 zero bytes too).

Times: ``t`` counts seconds from the first packet of the capture (whatever it holds), from
the integer timestamps (whole seconds and the fraction apart: no precision lost to the epoch).
pcapng interfaces each have their timestamp resolution (``if_tsresol``) and offset
(``if_tsoffset``); a simple packet block has no timestamp and takes the one before it.

For a replay: rows come in capture order, the entities interleaved as their PDUs arrived. A
capture's times normally rise, but a pcapng merged from several interfaces, or a capture
tool's buffering, can put a packet a little before the one ahead of it: an entity's ``t``
may then go back. The sender's dead-reckoning algorithm (``dr_algorithm``) and velocity come
along; between two updates tankcd's motion between rows (both ends known:
docs/formats.md#motion-between-rows) is used, not the sender's extrapolation from the first.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.input_bytes import PCAP_MAGIC, PCAPNG_SHB, open_trajectory_input

# the fixed part of an Entity State PDU (IEEE 1278.1 5.3.2 / 7.2.2): big-endian, 144 bytes
ES_DTYPE = np.dtype([
    ("version", "u1"), ("exercise", "u1"), ("pdu_type", "u1"), ("family", "u1"), ("timestamp", ">u4"),
    ("length", ">u2"), ("status", "u1"), ("padding", "u1"),
    ("site", ">u2"), ("application", ">u2"), ("entity", ">u2"), ("force", "u1"), ("n_parts", "u1"),
    ("kind", "u1"), ("domain", "u1"), ("country", ">u2"), ("category", "u1"), ("subcategory", "u1"),
    ("specific", "u1"), ("extra", "u1"),
    ("alternative_type", "V8"),
    ("velocity", ">f4", (3,)), ("location", ">f8", (3,)), ("orientation", ">f4", (3,)),
    ("appearance", ">u4"), ("dr_algorithm", "u1"), ("dr_other", "V15"), ("acceleration", ">f4", (3,)),
    ("angular_velocity", ">f4", (3,)), ("marking_charset", "u1"), ("marking", "S11"), ("capabilities", ">u4"),
])
assert ES_DTYPE.itemsize == 144
# one articulation record (DIS 6 ArticulationParameter / DIS 7 VariableParameter): 16 bytes
PART_DTYPE = np.dtype([("record_type", "u1"), ("change", "u1"), ("attached_to", ">u2"), ("parameter_type", ">u4"),
                       ("value32", ">f4"), ("low32", ">u4")])
PART_DTYPE64 = np.dtype([("head", "V8"), ("value64", ">f8")])
assert PART_DTYPE.itemsize == PART_DTYPE64.itemsize == 16

TURRET_AZIMUTH = 4096 + 11  # primary turret number 1, azimuth
GUN_ELEVATION = 4416 + 13   # primary gun number 1, elevation
EARTH_RADIUS_RANGE = (6.2e6, 6.5e6)  # m: |ECEF| of a place on the Earth's surface

# the framing pass's counters, in its order
COUNT_NAMES = ("packets", "not_ip", "not_udp", "ipv6_extension", "fragments", "first_fragments", "udp_not_dis",
               "dis_packets", "pdus_cut", "trailing_bytes", "entity_states", "entity_states_v4", "malformed",
               "link_unknown", "no_timestamp", "truncated")
# counted by the trajectory reader (rows it drops), not by the framing pass
ROW_COUNT_NAMES = ("duplicates",)
# |angle| beyond this (rad) is no orientation: float32's spacing there passes 2^-12 rad (docs/formats.md)
MAX_ANGLE = 1e3 * np.pi
MAX_BLOCK = 1 << 26  # bytes: a pcapng block that is not a packet (a section header, interface, name or statistics)


@dataclass
class CaptureCounts:
    """What a capture held besides the Entity State PDUs decoded (complete once it is read).

    ``packets`` every packet; ``not_ip`` frames whose link layer holds neither IPv4 nor IPv6 (ARP,
    ...); ``not_udp`` IP packets of another protocol (TCP, ICMP, ...); ``ipv6_extension`` IPv6
    packets with extension headers (not followed); ``fragments`` IPv4 fragments other than the
    first (skipped: no reassembly); ``first_fragments`` first fragments, read as far as they go;
    ``udp_not_dis`` UDP datagrams whose payload is not DIS; ``dis_packets`` those that are;
    ``pdus_cut`` PDUs cut short by the capture's snap length or by fragmentation; ``trailing_bytes``
    DIS payloads ending in bytes that are no PDU; ``entity_states`` ES PDUs decoded;
    ``entity_states_v4`` ES PDUs of protocol version 4 (skipped); ``malformed`` frames too short
    for their headers; ``link_unknown`` packets of a link type not read; ``no_timestamp`` simple
    packet blocks before any timestamp (given t = 0); ``truncated`` packets captured shorter than
    they were sent (a snap length: their whole PDUs are decoded, the rest counted in ``pdus_cut``);
    ``duplicates`` Entity State PDUs that repeat their entity's row before them exactly (same
    capture time, location, orientation, turret and gun: the trajectory reader drops them);
    ``pdu_types``: other DIS PDUs by type number.
    """

    packets: int = 0
    not_ip: int = 0
    not_udp: int = 0
    ipv6_extension: int = 0
    fragments: int = 0
    first_fragments: int = 0
    udp_not_dis: int = 0
    dis_packets: int = 0
    pdus_cut: int = 0
    trailing_bytes: int = 0
    entity_states: int = 0
    entity_states_v4: int = 0
    malformed: int = 0
    link_unknown: int = 0
    no_timestamp: int = 0
    truncated: int = 0
    duplicates: int = 0
    pdu_types: dict = field(default_factory=dict)

    def _load(self, counts: np.ndarray, types: np.ndarray) -> None:
        for name, value in zip(COUNT_NAMES, counts.tolist()):
            setattr(self, name, value)
        self.pdu_types = {int(k): int(types[k]) for k in np.flatnonzero(types)}

    def skipped(self) -> dict:
        """The non-zero counts of what was not decoded, by name (``pdu_type_N`` for other PDUs)."""
        out = {name: getattr(self, name) for name in COUNT_NAMES + ROW_COUNT_NAMES
               if name not in ("packets", "dis_packets", "entity_states", "first_fragments") and getattr(self, name)}
        out.update({f"pdu_type_{k}": v for k, v in sorted(self.pdu_types.items())})
        return out


@dataclass
class EntityStates:
    """Entity State PDUs decoded, N of them in capture order (angles in radians).

    t : (N,) float64 s since the first packet of the capture
    entity_id : (N, 3) uint16 (site, application, entity)
    entity : (N,) str ``site:application:entity``
    location : (N, 3) float64 ECEF (WGS 84) m
    orientation : (N, 3) float64 psi, theta, phi rad: Euler angles z-y-x from the ECEF axes to
        the DIS body frame (x forward, y right, z down)
    velocity : (N, 3) float64 ECEF m/s
    turret_azimuth, gun_elevation : (N,) float64 rad, NaN where the PDU has no such part
    packet : (N,) int64 1-based index of the packet in the capture (for messages)
    version : (N,) uint8 DIS protocol version (5, 6, 7)
    entity_type : (N, 7) uint16 kind, domain, country, category, subcategory, specific, extra
    marking : (N,) bytes (11) the entity's marking text, NUL padded
    dr_algorithm : (N,) uint8 the sender's dead-reckoning algorithm (1 static, 2-9 DRM(F|R)(P|V)(W|B))
    timestamp : (N,) uint32 the PDU's own DIS timestamp field (units of 3600/2^31 s; low bit absolute)
    """

    t: np.ndarray
    entity_id: np.ndarray
    entity: np.ndarray
    location: np.ndarray
    orientation: np.ndarray
    velocity: np.ndarray
    turret_azimuth: np.ndarray
    gun_elevation: np.ndarray
    packet: np.ndarray
    version: np.ndarray
    entity_type: np.ndarray
    marking: np.ndarray
    dr_algorithm: np.ndarray
    timestamp: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    @classmethod
    def concatenate(cls, blocks: list) -> "EntityStates":
        if not blocks:
            return _decode(np.zeros(144, np.uint8), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0),
                           set(), "")
        return cls(**{f: np.concatenate([getattr(b, f) for b in blocks]) for f in cls.__dataclass_fields__})


def entity_text(ids: np.ndarray) -> np.ndarray:
    """(N, 3) uint16 (site, application, entity) -> (N,) str ``site:application:entity``."""
    ids = np.asarray(ids, dtype=np.uint16).reshape(-1, 3)
    key = (ids[:, 0].astype(np.uint64) << 32) | (ids[:, 1].astype(np.uint64) << 16) | ids[:, 2]
    unique, inverse = np.unique(key, return_inverse=True)
    names = np.array([f"{k >> 32}:{(k >> 16) & 0xffff}:{k & 0xffff}" for k in unique.tolist()], dtype=str)
    return names[inverse.reshape(-1)] if len(unique) else np.zeros(0, dtype="U1")


def decode_entity_states(buf: np.ndarray, offsets: np.ndarray, packet: np.ndarray | None = None,
                         t: np.ndarray | None = None, float64_senders: set | None = None,
                         source: str = "") -> EntityStates:
    """Decode the Entity State PDUs that start at ``offsets`` (N,) in ``buf`` (uint8), all at once.

    Their lengths must have been checked (the framing pass does): 144 bytes and 16 per
    articulation record lie inside ``buf``. ``packet`` (N,) 1-based packet numbers and ``t`` (N,)
    times are carried through (default: 1..N and NaN). ``float64_senders``: the set of
    (site << 16 | application) known to write DIS 6 values as float64, updated (see the module).
    Raises InputError (``packet N``) for a non-finite location or orientation, or a location not
    near the Earth's surface.
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    n = len(offsets)
    packet = np.arange(1, n + 1, dtype=np.int64) if packet is None else np.asarray(packet, dtype=np.int64)
    t = np.full(n, np.nan) if t is None else np.asarray(t, dtype=np.float64)
    return _decode(np.asarray(buf, dtype=np.uint8), offsets, packet, t,
                   set() if float64_senders is None else float64_senders, source)


def _decode(buf, offsets, packet, t, float64_senders, source) -> EntityStates:
    from numpy.lib.stride_tricks import sliding_window_view

    n = len(offsets)
    if n:
        rec = sliding_window_view(buf, 144)[offsets].view(ES_DTYPE).reshape(n)
    else:
        rec = np.zeros(0, ES_DTYPE)
    version = rec["version"].copy()
    ids = np.column_stack([rec["site"], rec["application"], rec["entity"]]).astype(np.uint16)
    location = rec["location"].astype(np.float64)
    orientation = rec["orientation"].astype(np.float64)
    _check_states(location, orientation, packet, source)
    turret = np.full(n, np.nan)
    gun = np.full(n, np.nan)
    nparts = rec["n_parts"].astype(np.int64)
    total = int(nparts.sum())
    if total:
        owner = np.repeat(np.arange(n), nparts)
        first = np.cumsum(nparts) - nparts
        starts = offsets[owner] + 144 + 16 * (np.arange(total) - first[owner])
        raw = sliding_window_view(buf, 16)[starts]
        parts = raw.view(PART_DTYPE).reshape(total)
        value = parts["value32"].astype(np.float64)
        old = version[owner] < 7
        if old.any():
            sender = (ids[owner, 0].astype(np.int64) << 16) | ids[owner, 1]
            shows64 = old & (parts["low32"] != 0) & (parts["record_type"] == 0)
            float64_senders.update(np.unique(sender[shows64]).tolist())
            as64 = old & np.isin(sender, np.fromiter(float64_senders, np.int64, len(float64_senders)))
            value[as64] = raw[as64].view(PART_DTYPE64).reshape(-1)["value64"]
        articulated = parts["record_type"] == 0
        ours = np.flatnonzero(articulated & np.isin(parts["parameter_type"], (TURRET_AZIMUTH, GUN_ELEVATION)))
        _check_parts(value[ours], owner[ours], packet, source)
        for out, ptype in ((turret, TURRET_AZIMUTH), (gun, GUN_ELEVATION)):
            k = np.flatnonzero(articulated & (parts["parameter_type"] == ptype))[::-1]
            out[owner[k]] = value[k]  # reversed: a PDU with two such records keeps the first
    return EntityStates(
        t=t, entity_id=ids, entity=entity_text(ids), location=location, orientation=orientation,
        velocity=rec["velocity"].astype(np.float64), turret_azimuth=turret, gun_elevation=gun, packet=packet,
        version=version,
        entity_type=np.column_stack([rec[k] for k in ("kind", "domain", "country", "category", "subcategory",
                                                      "specific", "extra")]).astype(np.uint16).reshape(n, 7),
        marking=rec["marking"].copy(), dr_algorithm=rec["dr_algorithm"].copy(),
        timestamp=rec["timestamp"].astype(np.uint32))


def _check_states(location, orientation, packet, source) -> None:
    finite = np.isfinite(location).all(axis=1)
    bad = np.flatnonzero(~finite)
    if len(bad):
        k = bad[0]
        raise InputError(source, f"Entity State PDU has a non-finite ECEF location {_triple(location[k])}",
                         where=f"packet {packet[k]}")
    r = np.sqrt(np.einsum("ij,ij->i", location, location))
    lo, hi = EARTH_RADIUS_RANGE
    bad = np.flatnonzero((r < lo) | (r > hi))
    if len(bad):
        k = bad[0]
        raise InputError(source, f"Entity State PDU's ECEF location {_triple(location[k])} is not near the Earth's "
                                 f"surface (|r| = {r[k]:.0f} m, expected {lo:.1e} to {hi:.1e} m)",
                         where=f"packet {packet[k]}")
    bad = np.flatnonzero(~np.isfinite(orientation).all(axis=1))
    if len(bad):
        k = bad[0]
        raise InputError(source, f"Entity State PDU has a non-finite orientation {_triple(orientation[k])}",
                         where=f"packet {packet[k]}")
    bad = np.flatnonzero((np.abs(orientation) > MAX_ANGLE).any(axis=1))
    if len(bad):
        k = bad[0]
        raise InputError(source, f"Entity State PDU's orientation {_triple(orientation[k])} rad is no angle "
                                 f"(beyond +-{MAX_ANGLE:.0f} rad = 1000 pi; DIS angles lie within +-pi)",
                         where=f"packet {packet[k]}")


def _check_parts(values, owner, packet, source) -> None:
    """An articulated turret or gun value that is not finite or beyond ``MAX_ANGLE``: InputError naming the
    packet (a NaN would read as no value at all)."""
    bad = np.flatnonzero(~(np.abs(values) <= MAX_ANGLE))
    if len(bad):
        k = bad[0]
        raise InputError(source, f"Entity State PDU's articulated turret or gun angle {values[k]:.6g} rad is no "
                                 f"angle (non-finite or beyond +-{MAX_ANGLE:.0f} rad)",
                         where=f"packet {packet[owner[k]]}")


def _triple(v) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"


class DisCapture:
    """A pcap or pcapng capture, read as blocks of Entity State PDUs.

    ``for states in DisCapture(path).blocks(): ...`` yields :class:`EntityStates` of
    ``block_pdus`` PDUs (the last fewer), reading ``chunk_bytes`` of the file at a time: memory is
    bounded by those two, whatever the capture's size. ``counts`` (a :class:`CaptureCounts`) is
    complete once the blocks are exhausted; ``format`` is ``pcap`` or ``pcapng``. ``path``: a file, or
    '-' for standard input; gzip-compressed or not (``io.input_bytes``). Raises
    InputError for a file that is not a capture, a capture cut inside a packet, a PDU whose
    length lies, a bad location, and (at the end) a capture without any Entity State PDU.
    """

    def __init__(self, path: str, block_pdus: int = 65536, chunk_bytes: int = 1 << 23):
        self.path = path
        self.name = "<stdin>" if path == "-" else path  # for messages
        self.block_pdus = max(1, int(block_pdus))
        self.chunk_bytes = max(1 << 12, int(chunk_bytes))
        self.counts = CaptureCounts()
        self.format: str | None = None
        self._counts = np.zeros(len(COUNT_NAMES), np.int64)
        self._types = np.zeros(256, np.int64)
        self._err = np.zeros(4, np.int64)
        self._first_sec, self._first_frac = np.array([-1], np.int64), np.zeros(1)
        self._float64_senders: set = set()
        self._outs = None

    def blocks(self) -> Iterator[EntityStates]:
        _, fh = open_trajectory_input(self.path)
        with fh:
            buf = _Buffer(fh, self.chunk_bytes)
            buf.refill(0, 24)
            head = bytes(buf.view()[:4])
            if head in PCAP_MAGIC:
                self.format, walker = "pcap", self._pcap(buf, *PCAP_MAGIC[head])
            elif head == PCAPNG_SHB:
                self.format, walker = "pcapng", self._pcapng(buf)
            else:
                raise InputError(self.name, "not a pcap or pcapng capture (it starts with bytes "
                                            f"{head.hex(' ') or 'nothing'}; a capture starts with a pcap magic "
                                            "a1b2c3d4 or a1b23c4d in either byte order, or a pcapng section header "
                                            "0a0d0d0a)")
            for states in walker:
                self.counts._load(self._counts, self._types)
                yield states
            self.counts._load(self._counts, self._types)
        if self.counts.entity_states == 0:
            skipped = ", ".join(f"{k} {v}" for k, v in self.counts.skipped().items()) or "nothing else"
            raise InputError(self.name, f"no DIS Entity State PDU in {self.counts.packets} packets ({skipped})")

    def first_packet_time(self) -> tuple[int, float] | None:
        """The capture's first packet time (what ``t`` counts from) as (whole seconds since 1970, the
        fraction of a second), or None before a packet with a timestamp has been read."""
        if self._first_sec[0] < 0:
            return None
        return int(self._first_sec[0]), float(self._first_frac[0])

    def read(self) -> EntityStates:
        """Every Entity State PDU of the capture in one record (memory grows with the capture)."""
        return EntityStates.concatenate(list(self.blocks()))

    # -- the framing pass --------------------------------------------------------------------------------
    def _outputs(self):
        if self._outs is None:  # room for a block and for the PDUs of the largest record beside
            from tankcd_cli.io._dis import MAX_RECORD

            cap = self.block_pdus + MAX_RECORD // 144 + 1
            self._outs = (np.empty(cap, np.int64), np.empty(cap, np.int64), np.empty(cap, np.int64), np.empty(cap))
        return self._outs

    def _states(self, arr, n_out) -> EntityStates:
        off, pkt, sec, frac = (a[:n_out] for a in self._outs)
        sec0 = max(int(self._first_sec[0]), 0)
        t = (sec - sec0).astype(np.float64) + (frac - self._first_frac[0])
        t[sec < 0] = 0.0  # simple packet blocks before any timestamp
        return _decode(arr, off, pkt.copy(), t, self._float64_senders, self.name)

    def _fail(self, status: int):
        e = self._err.tolist()
        where = f"packet {e[0]}"
        if status == 1:
            raise InputError(self.name, f"Entity State PDU's length field says {e[1]} bytes, but the UDP payload holds "
                                        f"only {e[2]} from its start", where=where)
        if status == 2:
            raise InputError(self.name, f"Entity State PDU's length field says {e[1]} bytes, shorter than its layout "
                                        f"with {e[3]} articulation records ({e[2]} bytes)", where=where)
        if status == 4:
            raise InputError(self.name, f"corrupt capture: the header of packet {e[0]} says {e[1]} bytes", where=where)
        if status == 6:
            raise InputError(self.name, f"corrupt pcapng: the block of packet {e[0]} says {e[1]} bytes at its start "
                                        f"but {e[2]} at its end (a block cut short, or bytes that are no block)",
                         where=where)
        if status == 5:
            raise InputError(self.name, "corrupt capture: a packet on an interface no interface description block "
                                        f"describes (interface {max(e[1], 0)})", where=where)
        raise AssertionError(status)

    def _pcap(self, buf: "_Buffer", big: bool, nanos: bool) -> Iterator[EntityStates]:
        from tankcd_cli.io._dis import walk_pcap

        u32 = struct.Struct(">I" if big else "<I").unpack_from
        if buf.end < 24:
            raise InputError(self.name, f"capture ends inside its file header ({buf.end} of 24 bytes)")
        link = u32(buf.arr, 20)[0] & 0xffff  # the upper bits may say the FCS length
        outs = self._outputs()
        pos, packet = 24, 0
        while True:
            arr = buf.view()
            pos, packet, n_out, status = walk_pcap(arr, pos, big, nanos, link, packet, self.block_pdus, *outs,
                                                   self._counts, self._types, self._err, self._first_sec,
                                                   self._first_frac)
            if status:
                self._fail(status)
            if n_out:
                yield self._states(arr, n_out)
                continue  # a block is out: walk on before reading more
            have = buf.end - pos
            need = 16 - have if have < 16 else 16 + u32(arr, pos + 8)[0] - have
            if not buf.refill(pos, need):
                if buf.end == 0:
                    return
                if buf.end < 16:
                    raise InputError(self.name, f"capture ends inside the record header of packet {packet + 1} "
                                                f"({buf.end} of 16 bytes)", where=f"packet {packet + 1}")
                raise InputError(self.name, f"capture ends inside packet {packet + 1} (its record says "
                                            f"{u32(buf.arr, 8)[0]} bytes, {buf.end - 16} are there)",
                                 where=f"packet {packet + 1}")
            pos = 0

    def _pcapng(self, buf: "_Buffer") -> Iterator[EntityStates]:
        from tankcd_cli.io._dis import walk_pcapng

        outs = self._outputs()
        pos, packet = 0, 0
        big = False
        interfaces: list = []  # per interface: (link type, timestamp units per second, offset s, snap length)
        tables = None
        last_sec, last_frac = np.array([-1], np.int64), np.zeros(1)
        while True:
            arr = buf.view()
            status = 3
            if tables is not None:
                pos, packet, n_out, status = walk_pcapng(arr, pos, big, packet, self.block_pdus, *tables, last_sec,
                                                         last_frac, *outs, self._counts, self._types, self._err,
                                                         self._first_sec, self._first_frac)
                if status not in (0, 3):
                    self._fail(status)
                if n_out:
                    yield self._states(arr, n_out)
                    continue
            have = buf.end - pos
            at = buf.base + pos
            if status == 3 and have >= 12:  # a block that is not a packet: read here once it is all there
                btype = bytes(arr[pos:pos + 4])
                section_big = big
                if btype == PCAPNG_SHB:
                    bom = bytes(arr[pos + 8:pos + 12])
                    if bom not in (b"\x1a\x2b\x3c\x4d", b"\x4d\x3c\x2b\x1a"):
                        raise InputError(self.name, f"corrupt pcapng: a section header with byte-order magic "
                                                    f"{bom.hex()}", where=f"byte {at}")
                    section_big = bom == b"\x1a\x2b\x3c\x4d"
                fmt = ">I" if section_big else "<I"
                blen = struct.unpack_from(fmt, arr, pos + 4)[0]
                if blen < 12 or blen % 4 or blen > MAX_BLOCK:
                    raise InputError(self.name, f"corrupt pcapng: a block of length {blen}", where=f"byte {at}")
                if have >= blen:
                    trailer = struct.unpack_from(fmt, arr, pos + blen - 4)[0]
                    if trailer != blen:
                        raise InputError(self.name, f"corrupt pcapng: a block that says {blen} bytes at its start but "
                                                    f"{trailer} at its end (a block cut short, or bytes that are no "
                                                    "block)", where=f"byte {at}")
                    code = struct.unpack(fmt, btype)[0]
                    if btype == PCAPNG_SHB:
                        big, interfaces = section_big, []
                    elif code == 1:
                        interfaces.append(self._interface(bytes(arr[pos:pos + blen]), big, at))
                    elif code in (2, 3, 6):  # a packet before any interface description
                        self._err[:] = (packet + 1, -1, 0, 0)
                        self._fail(5)
                    tables = self._tables(interfaces)
                    pos += blen
                    continue
                need = blen - have
            elif status == 3 or have < 8:
                need = 12 - have
            else:
                need = struct.unpack_from(">I" if big else "<I", arr, pos + 4)[0] - have
            if not buf.refill(pos, max(need, 1)):
                if buf.end == 0:
                    return
                raise InputError(self.name, f"capture ends inside a block ({buf.end} bytes of it are there; it would "
                                            f"be packet {packet + 1} if it is a packet)", where=f"packet {packet + 1}")
            pos = 0

    def _interface(self, block: bytes, big: bool, at: int):
        return pcapng_interface(block, big, self.name, f"byte {at}")

    @staticmethod
    def _tables(interfaces):
        if not interfaces:
            return None
        link, units, offset, snap = zip(*interfaces)
        return (np.array(link, np.int64), np.array(units, np.uint64), np.array(offset, np.int64),
                np.array(snap, np.int64))


class _Buffer:
    """A window on a file: ``arr[:end]`` holds the bytes from file offset ``base`` on."""

    def __init__(self, fh, size: int):
        self.fh = fh
        self.arr = np.empty(size, np.uint8)
        self.end = 0
        self.base = 0

    def view(self) -> np.ndarray:
        return self.arr[:self.end]

    def refill(self, pos: int, need: int) -> bool:
        """Drop the bytes before ``pos``, then read at least ``need`` more (a whole chunk when it can);
        False when the file had nothing more."""
        keep = self.end - pos
        if keep + need > len(self.arr):
            grown = np.empty(max(keep + need, 2 * len(self.arr)), np.uint8)
            grown[:keep] = self.arr[pos:self.end]
            self.arr = grown
        elif pos:
            self.arr[:keep] = self.arr[pos:self.end]
        self.base += pos
        self.end = keep
        got = 0
        while self.end < len(self.arr):
            n = self.fh.readinto(memoryview(self.arr)[self.end:])
            if not n:
                break
            self.end += n
            got += n
            if got >= need:
                break
        return got > 0


def read_capture(path: str) -> tuple[EntityStates, CaptureCounts]:
    """Every Entity State PDU of a capture, and the counts of what else it held."""
    capture = DisCapture(path)
    states = capture.read()
    return states, capture.counts


def articulation_angles(turret_azimuth, gun_elevation) -> tuple[np.ndarray, np.ndarray]:
    """DIS articulated-part angles (rad) -> tankcd's turret and gun angles (rad).

    DIS turns articulated parts by the right-hand rule in the entity's frame (x forward, y right,
    z down): a positive azimuth about z (down) turns the gun from forward toward the right,
    clockwise seen from above; a positive elevation about y (right) turns it from forward toward
    -z, up. tankcd's turret azimuth turns counter-clockwise about the hull's +z (up), its
    gun elevation raises the muzzle (docs/formats.md#conventions-frames-units-signs):
    turret = -azimuth (to (-pi, pi]), gun = elevation. NaN stays NaN.
    """
    turret = -np.asarray(turret_azimuth, dtype=np.float64)
    turret = np.pi - np.mod(np.pi - turret, 2 * np.pi)
    return turret, np.asarray(gun_elevation, dtype=np.float64).copy()


def trajectory_columns(states: EntityStates, crs_wkt: str, source: str | None = None) -> dict:
    """Entity states -> the trajectory CSV's columns in the terrain's CRS (a dict of (N,) arrays, rows in
    capture order): ``t`` (s), ``entity`` (str), ``x``, ``y`` (m), ``yaw_deg`` (from grid east, the
    convergence applied), ``turret_deg``, ``gun_deg`` (NaN where a PDU had no such part), and for
    inspection ``h`` (m above the ellipsoid), ``pitch_deg``, ``roll_deg`` (REP 103, about the local
    level), ``lon``, ``lat`` (deg), ``packet``. A terrain without a CRS: InputError naming ``source``."""
    from tankcd_cli.io.geodesy import dis_to_terrain

    frame = dis_to_terrain(states.location, states.orientation, crs_wkt, source=source)
    turret, gun = articulation_angles(states.turret_azimuth, states.gun_elevation)
    return {"t": states.t, "entity": states.entity, "x": frame["x"], "y": frame["y"],
            "yaw_deg": np.degrees(frame["grid_yaw"]), "turret_deg": np.degrees(turret), "gun_deg": np.degrees(gun),
            "h": frame["h"], "pitch_deg": np.degrees(frame["pitch"]), "roll_deg": np.degrees(frame["roll"]),
            "lon": frame["lon"], "lat": frame["lat"], "packet": states.packet}


def pcapng_interface(block: bytes, big: bool, source: str | None = None, where: str | None = None) -> tuple:
    """(link type, time units a second, time offset s, snap length) of a pcapng Interface Description
    Block (``block``: the whole block; ``big``: the section's byte order). Its options
    ``if_tsresol`` (10^-v s, or 2^-v s with the high bit set; 10^-6 without) and ``if_tsoffset``
    (0 without); a resolution finer than 2^-63 or 10^-19 s is an InputError naming ``source``."""
    fmt = ">" if big else "<"
    link, _, snap = struct.unpack(fmt + "HHI", block[8:16])
    units, offset = 10 ** 6, 0
    k = 16
    while k + 4 <= len(block) - 4:
        code, size = struct.unpack(fmt + "HH", block[k:k + 4])
        value = block[k + 4:k + 4 + size]
        if code == 0:
            break
        if code == 9 and size >= 1:
            v = value[0]
            exp = v & 0x7f
            if exp > (63 if v & 0x80 else 19):
                raise InputError(source, f"pcapng interface timestamp resolution {v:#x} is finer than this "
                                         "reader takes (2^-63 or 10^-19 s)", where=where)
            units = (1 << exp) if v & 0x80 else 10 ** exp
        elif code == 14 and size >= 8:
            offset = struct.unpack(fmt + "q", value[:8])[0]
        k += 4 + size + (-size % 4)
    return link, units, offset, snap
