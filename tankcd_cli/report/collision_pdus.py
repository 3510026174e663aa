"""A replayed DIS capture with tankcd's contacts in it as Collision PDUs (docs/formats.md, "Outputs
for review", the ``.pcap`` output; docs/report_pdus.md).

The capture's packets are copied byte for byte and in order (the pcap file header and records, or
the pcapng blocks); a Collision PDU (IEEE 1278.1-2012 7.2.3; IEEE 1278.1a-1998 5.3.3.2: one 60-byte
layout) is inserted for each contact of one of its entities, in a UDP datagram framed as that
entity's Entity State PDUs were (the same link header, addresses and ports), at the capture time
of first contact. A logger or viewer of the exercise then shows tankcd's contacts beside the
entities that made them.

Frames: tankcd's vehicle frame is x forward, y left, z up (REP 103); DIS entity coordinates are
x forward, y right, z down: a vector (x, y, z) in the one is (x, -y, -z) in the other.

Masses (the standard asks for the issuing entity's, kg): combat weights of the presets.
- T-72: 41.5 t (T-72A/B combat weight; Wikipedia "T-72", Simple English Wikipedia "T-72").
- T-55: 36 t (Wikipedia "T-54/T-55": T-55 combat weight 36 t).
- M1 Abrams: 54.4 t (the M1's 60 short tons; Wikipedia "M1 Abrams": M1 54 t, M1A1 57 t, M1A2
  SEPv3 up to 66.8 t; the preset's dimensions are the M1's).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, replace
from typing import NamedTuple
from fractions import Fraction

import numpy as np

from tankcd_cli.errors import InputError

MASS_KG = {"t72": 41500.0, "t55": 36000.0, "m1": 54400.0}
# the events that are contacts with another entity (obstacles and the ground are the "entity" 0:0:0);
# ``internal`` (the gun on its own drums) is no collision between entities, ``off_terrain`` no contact
CONTACT_KINDS = ("obstacle", "terrain", "vehicle")
COLLISION_PDU_TYPE = 4
ENTITY_STATE_PDU_TYPE = 1
COLLISION_PDU_LENGTH = 60
INELASTIC = 0  # collision type (SISO-REF-010 UID 189)
NO_ENTITY = (0, 0, 0)
ROW_SNAP = 1e-6  # s: an event this close to a row of its issuer is at that row (events' t has 6 decimals)
TIME_TOLERANCE = 1e-5  # s: a track's t against its capture's (the poses CSV writes t to 6 decimals)
DIS_TIME_UNITS = (1 << 31) / 3600.0  # DIS timestamp units per second (3600 s / 2^31)
_PACKET_BLOCKS = (2, 3, 6)  # pcapng: packet, simple packet, enhanced packet blocks


@dataclass(frozen=True)
class CollisionPdu:
    """One Collision PDU to insert: issued by ``issuer`` at capture time ``t`` (s from the first packet).

    issuer, other : (site, application, entity); ``other`` (0, 0, 0) for an obstacle or the ground
    velocity : (3,) float64, the issuer's velocity, ECEF (WGS 84) axes, m/s
    location : (3,) float64, the contact point in the issuer's DIS entity coordinates (x forward,
        y right, z down, origin the footprint centre at track-bottom height), m
    mass : kg
    kind : the event's kind (for counting)
    """

    t: float
    issuer: tuple
    other: tuple
    velocity: np.ndarray
    location: np.ndarray
    mass: float
    kind: str


def write_collision_pdus(review, capture: str, path: str, vehicle_of) -> int:
    """Write ``capture`` (pcap or pcapng, the DIS capture that was replayed into ``review``) to ``path``
    with a Collision PDU for each contact of one of its entities; return the number of PDUs added.

    ``vehicle_of(entity) -> tankcd_cli.vehicle.Vehicle`` gives each vehicle's preset (its mass).
    Raises InputError naming ``capture`` when it is not the replayed one (no entity in common with
    the review's tracks, or an entity whose times disagree), or when it is no capture.
    """
    from tankcd_cli.io.atomic import atomic_path
    from tankcd_cli.io.dis import read_capture

    if capture == "-":  # read three times: its entity states, the framing of its PDUs, its copy
        raise InputError("<stdin>", "the replayed capture (--capture) must be a file, not standard input")
    states, _ = read_capture(capture)
    groups = _ByEntity(states)
    shift = _check_replayed(review, groups, capture)
    pdus = collision_pdus(review, set(groups.rows), vehicle_of, shift, capture)
    plan = _plan(pdus, groups)
    with atomic_path(path, ".pcap") as tmp:
        templates = _first_pass(capture, plan)
        with open(tmp, "wb", buffering=1 << 20) as out:
            _second_pass(capture, out, plan, templates)
    return len(pdus)


# -- which capture --------------------------------------------------------------------------------------
class _ByEntity:
    """The capture's Entity State PDUs grouped by entity, each group in time order (one sort for all)."""

    def __init__(self, states):
        names, inverse = np.unique(states.entity, return_inverse=True)
        order = np.lexsort((states.t, inverse))
        starts = np.searchsorted(inverse[order], np.arange(len(names) + 1))
        self.states = states
        self.rows = {str(n): order[starts[k]:starts[k + 1]] for k, n in enumerate(names)}

    def times(self, name: str) -> np.ndarray:
        return self.states.t[self.rows[name]]


def _check_replayed(review, groups: _ByEntity, capture: str) -> float:
    """The review's time minus the capture's (0 for a capture replayed alone; an exercise of several
    files aligned on their clocks shifts it), checked over every entity in common."""
    ours = {tr.entity: tr for tr in review.tracks}
    common = sorted(set(ours) & set(groups.rows))
    if not common:
        names = ", ".join(sorted(ours)[:3]) or "none"
        raise InputError(capture, f"not the replayed capture: none of its entities is a vehicle of the review "
                                  f"(the review's: {names})")
    shift = None
    for name in common:
        cap_t = groups.times(name)
        tr_t = ours[name].t[np.isfinite(ours[name].t)]
        if not len(tr_t):
            continue
        if shift is None:  # the first entity's first rows in both say how the clocks stand
            shift = float(tr_t.min() - cap_t[0])
        tr_t = tr_t - shift
        k = np.clip(np.searchsorted(cap_t, tr_t), 1, max(len(cap_t) - 1, 1))
        near = np.minimum(np.abs(cap_t[k - 1] - tr_t), np.abs(cap_t[np.minimum(k, len(cap_t) - 1)] - tr_t))
        bad = np.flatnonzero(near > TIME_TOLERANCE)
        if len(bad):
            i = bad[0]
            raise InputError(capture, f"not the replayed capture: entity '{name}' has a row at t = "
                                      f"{tr_t[i] + shift:.6f} s in the review and no packet at that time "
                                      f"in the capture (nearest {near[i]:.6f} s away)")
    return 0.0 if shift is None else shift


# -- the contacts ----------------------------------------------------------------------------------------
def entity_id(name: str):
    """``site:application:entity`` -> (site, application, entity), or None for another name."""
    parts = str(name).split(":")
    if len(parts) != 3 or not all(p.isdigit() for p in parts):
        return None
    ids = tuple(int(p) for p in parts)
    return ids if all(v < 65536 for v in ids) else None


def collision_pdus(review, dis_entities: set, vehicle_of, shift: float = 0.0, source: str = "") -> list:
    """The Collision PDUs of ``review``'s contacts whose issuer is one of ``dis_entities`` (names
    ``site:application:entity``), in time order; ``shift``: the review's time minus the capture's.

    An obstacle or terrain contact gives one PDU at the first event of a run of events of the
    issuer's consecutive rows with the same kind and other party (a wall touched over ten rows is one
    collision; the hull and both tracks in it, one); an event ``between`` rows starts a new run
    unless one began at the same row; a vehicle contact two (each vehicle issues one, naming the
    other, 0:0:0 when the other is no DIS entity).
    """
    tracks = {tr.entity: tr for tr in review.tracks}
    single = review.tracks[0].entity if len(review.tracks) == 1 else None
    last_row: dict = {}
    out = []
    for ev in sorted(review.events, key=lambda e: (e.get("t") is None, e.get("t") or 0.0)):
        kind = ev.get("kind")
        if kind not in CONTACT_KINDS or ev.get("t") is None:
            continue
        t = float(ev["t"])
        if kind == "vehicle":
            pairs = ((str(ev["a"]), str(ev["b"])), (str(ev["b"]), str(ev["a"])))
        else:
            issuer = ev.get("entity", single)
            if issuer is None:
                continue
            key = (issuer, kind, str(ev.get("b")))
            track = tracks.get(issuer)
            row = int(np.searchsorted(track.step, int(ev["step"]))) if track is not None else 0
            prev = last_row.get(key)
            last_row[key] = row
            # the same contact going on: at this row or the next (a contact begun along the motion is
            # new, unless another part of the vehicle began it in the same step)
            if prev is not None and (row <= prev if ev.get("between") else row <= prev + 1):
                continue
            pairs = ((str(issuer), None),)
        for issuer, other in pairs:
            if issuer not in dis_entities or issuer not in tracks:
                continue
            other_id = (entity_id(other) if other in dis_entities else None) if other else None
            out.append(_pdu_of(tracks[issuer], t, kind, ev.get("point"), other_id or NO_ENTITY,
                               vehicle_of(issuer), review.crs_wkt, shift, source))
    out.sort(key=lambda p: p.t)
    return out


def _pdu_of(track, t: float, kind: str, point, other: tuple, vehicle, crs_wkt: str, shift: float,
            source: str) -> CollisionPdu:
    origin, rotation, velocity = pose_at(track, t, crs_wkt, source)
    if point is not None and np.all(np.isfinite(point)) and np.all(np.isfinite(origin)):
        body = rotation.T @ (np.asarray(point, dtype=np.float64) - origin)
    else:  # the ground (no point in the event): the middle of the hull's bottom face
        body = np.array([0.0, 0.0, vehicle.ground_clearance])
    location = body * np.array([1.0, -1.0, -1.0])  # REP 103 (x fwd, y left, z up) -> DIS (x fwd, y right, z down)
    return CollisionPdu(t=t - shift, issuer=entity_id(track.entity), other=tuple(other),
                        velocity=velocity, location=location, mass=MASS_KG.get(vehicle.name, 0.0), kind=kind)


def pose_at(track, t: float, crs_wkt: str, source: str = ""):
    """The vehicle frame of ``track`` at time ``t`` and its velocity there.

    Returns origin (3,) world m, rotation (3, 3) vehicle frame -> world (columns the vehicle's
    axes), velocity (3,) ECEF m/s. Between two rows: the origin on the straight line, the attitude
    turning at a constant rate (the quaternions' slerp), the velocity the rows' difference over their
    time (converted to ECEF: each row's position as longitude, latitude and height). A row without a
    pose (off the terrain) takes its neighbour's; a track of one row stands still.
    """
    from tankcd_cli.io.geodesy import geodetic_to_ecef, lonlat_to_crs

    ts = track.t
    n = len(ts)
    i = int(np.clip(np.searchsorted(ts, t, side="right") - 1, 0, max(n - 2, 0)))
    j = min(i + 1, n - 1)
    span = ts[j] - ts[i]
    f = float(np.clip((t - ts[i]) / span, 0.0, 1.0)) if span > 0 else 0.0
    xyz = np.column_stack([track.x[[i, j]], track.y[[i, j]], track.z[[i, j]]]).astype(np.float64)
    q = np.asarray(track.quaternion[[i, j]], dtype=np.float64)
    for a, b in ((0, 1), (1, 0)):  # a row without a pose takes its neighbour's height and attitude
        if not np.isfinite(xyz[a, 2]):
            xyz[a, 2] = xyz[b, 2]
        if not np.isfinite(q[a]).all():
            q[a] = q[b]
    if not np.isfinite(q).all():
        yaw = np.radians(track.yaw_deg[[i, j]])
        q = np.column_stack([np.cos(yaw / 2), 0 * yaw, 0 * yaw, np.sin(yaw / 2)])
    z = np.nan_to_num(xyz[:, 2])
    origin = (1 - f) * xyz[0] + f * xyz[1]
    rotation = quaternion_matrix(slerp(q[0], q[1], f))
    if span > 0:
        lon, lat = lonlat_to_crs(crs_wkt, source).transform(xyz[:, 0], xyz[:, 1], direction="INVERSE")
        ecef = geodetic_to_ecef(np.asarray(lon), np.asarray(lat), z)
        velocity = (ecef[1] - ecef[0]) / span
    else:
        velocity = np.zeros(3)
    return origin, rotation, velocity


def slerp(q0: np.ndarray, q1: np.ndarray, f: float) -> np.ndarray:
    """Spherical interpolation of unit quaternions (qw, qx, qy, qz) (4,), the shorter way, at f in [0, 1]."""
    q0 = q0 / np.linalg.norm(q0)
    q1 = q1 / np.linalg.norm(q1)
    d = float(q0 @ q1)
    if d < 0:
        q1, d = -q1, -d
    if d > 0.9995:  # nearly the same attitude: the straight line, normalised
        q = q0 + f * (q1 - q0)
        return q / np.linalg.norm(q)
    w = np.arccos(d)
    return (np.sin((1 - f) * w) * q0 + np.sin(f * w) * q1) / np.sin(w)


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """Unit quaternion (qw, qx, qy, qz) -> rotation matrix (3, 3) (body -> world)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


# -- the PDU -------------------------------------------------------------------------------------------------
def collision_pdu_bytes(version: int, exercise: int, timestamp: int, pdu: CollisionPdu, event_number: int) -> bytes:
    """The 60 bytes of a Collision PDU (big-endian, IEEE 1278.1 7.2.3): header, issuing and colliding
    entity ids, event id (the issuer's site and application, ``event_number``), collision type
    (inelastic), padding, velocity, mass, location."""
    site, app, _ = pdu.issuer
    head = struct.pack(">BBBBIHBB", version, exercise, COLLISION_PDU_TYPE, 1, timestamp & 0xFFFFFFFF,
                       COLLISION_PDU_LENGTH, 0, 0)
    body = struct.pack(">3H3H3HBB3ff3f", *pdu.issuer, *pdu.other, site, app, event_number & 0xFFFF, INELASTIC, 0,
                       *np.asarray(pdu.velocity, np.float64), pdu.mass, *np.asarray(pdu.location, np.float64))
    return head + body


def dis_timestamp(es_timestamp: int, dt: float) -> int:
    """The issuer's clock ``dt`` s after one of its Entity State PDUs, in that PDU's timestamp style: 31
    bits of units of 3600 s / 2^31 within the hour, the low bit (absolute or relative) kept."""
    units = ((int(es_timestamp) >> 1) + int(round(dt * DIS_TIME_UNITS))) % (1 << 31)
    return (units << 1) | (int(es_timestamp) & 1)


# -- the capture's packets -----------------------------------------------------------------------------
@dataclass
class _Planned:
    pdu: CollisionPdu
    packet: int  # the issuer's Entity State packet framed like it (1-based, as the reader counts)
    es_t: float  # that packet's capture time, s
    es_timestamp: int  # its Entity State PDU's DIS timestamp
    event_number: int


def _plan(pdus: list, groups: _ByEntity) -> list:
    """Each PDU with the issuer's last Entity State packet at or before its time (its first when none)."""
    states = groups.states
    out = []
    counters: dict = {}
    for pdu in pdus:
        rows = groups.rows["%d:%d:%d" % pdu.issuer]
        times = states.t[rows]
        j = int(np.searchsorted(times, pdu.t))
        near = [i for i in (j - 1, j) if 0 <= i < len(times) and abs(times[i] - pdu.t) <= ROW_SNAP]
        if near:  # a contact at one of the issuer's rows (its t written to 6 decimals): at that packet's time
            pdu = replace(pdu, t=float(times[near[-1]]))
        k = rows[max(int(np.searchsorted(times, pdu.t, side="right")) - 1, 0)]
        key = pdu.issuer[:2]
        counters[key] = counters.get(key, 0) + 1
        out.append(_Planned(pdu, int(states.packet[k]), float(states.t[k]), int(states.timestamp[k]), counters[key]))
    return out


class _Record(NamedTuple):
    """One pcap record or pcapng block, as the file holds it, and where its packet lies."""

    raw: bytes  # the record (its 16-byte header and frame) or the whole block
    packet: int  # 1-based packet number as the reader counts them; 0 for a block that is no packet
    section: int  # pcapng section from 0 (0 for a pcap)
    interface: int  # the packet's interface in its section (-1: no packet)
    ticks: int | None  # its time in the interface's units since 1970 (less the interface's offset); None: none
    units: int  # the interface's timestamp units per second
    offset: int  # the interface's timestamp offset, s (if_tsoffset)
    data: int  # where the frame starts in ``raw``
    link: int  # the link type


_NO_PACKET = dict(packet=0, interface=-1, ticks=None, units=0, offset=0, data=0, link=0)


class _Walker:
    """The records of a pcap or the blocks of a pcapng, in file order, as ``_Record``s."""

    def __init__(self, capture: str):
        self.capture = capture

    def __iter__(self):
        from tankcd_cli.io.input_bytes import PCAP_MAGIC, PCAPNG_SHB, open_trajectory_input

        _, fh = open_trajectory_input(self.capture)
        with fh:
            head = fh.read(4)
            if head in PCAP_MAGIC:
                self.format = "pcap"
                yield from self._pcap(fh, head, *PCAP_MAGIC[head])
            elif head == PCAPNG_SHB:
                self.format = "pcapng"
                yield from self._pcapng(fh, head)
            else:
                raise InputError(self.capture, "not a pcap or pcapng capture")

    def _read(self, fh, n: int) -> bytes:
        data = fh.read(n)
        if len(data) != n:
            raise InputError(self.capture, "capture ends inside a record")
        return data

    def _pcap(self, fh, head, big, nanos):
        rest = self._read(fh, 20)
        e = ">" if big else "<"
        self.header = head + rest
        self.endian = e
        self.link = struct.unpack(e + "I", rest[16:20])[0] & 0xFFFF
        units = 10 ** 9 if nanos else 10 ** 6
        self.units = units
        packet = 0
        while True:
            rec = fh.read(16)
            if not rec:
                return
            if len(rec) < 16:
                raise InputError(self.capture, "capture ends inside a record header")
            sec, sub, incl, _ = struct.unpack(e + "IIII", rec)
            packet += 1
            yield _Record(rec + self._read(fh, incl), packet, 0, 0, sec * units + sub, units, 0, 16, self.link)

    def _pcapng(self, fh, first):
        from tankcd_cli.io.dis import pcapng_interface

        e = "<"
        section = -1
        interfaces: list = []
        packet = 0
        last = None
        btype_raw = first
        self.endian = e
        while True:
            if btype_raw is None:
                btype_raw = fh.read(4)
                if not btype_raw:
                    return
                if len(btype_raw) < 4:
                    raise InputError(self.capture, "capture ends inside a block")
            if btype_raw == b"\x0a\x0d\x0d\x0a":
                lenb = self._read(fh, 4)
                bom = self._read(fh, 4)
                e = ">" if bom == b"\x1a\x2b\x3c\x4d" else "<"
                blen = struct.unpack(e + "I", lenb)[0]
                raw = btype_raw + lenb + bom + self._read(fh, blen - 12)
                section += 1
                interfaces = []
                yield _Record(raw, section=section, **_NO_PACKET)  # the last section's PDUs go before it
                self.endian = e
                btype_raw = None
                continue
            lenb = self._read(fh, 4)
            btype, blen = struct.unpack(e + "II", btype_raw + lenb)
            raw = btype_raw + lenb + self._read(fh, blen - 8)
            btype_raw = None
            if btype == 1:
                interfaces.append(pcapng_interface(raw, e == ">", self.capture)[:3])
                yield _Record(raw, section=section, **_NO_PACKET)
            elif btype in _PACKET_BLOCKS:
                packet += 1
                if btype == 3:
                    iface, data = 0, 12
                    ticks = last[1] if last is not None and last[0] == 0 else None
                else:
                    iface = struct.unpack(e + ("I" if btype == 6 else "H"), raw[8:8 + (4 if btype == 6 else 2)])[0]
                    hi, lo = struct.unpack(e + "II", raw[12:20])
                    ticks, data = (hi << 32) | lo, 28
                    last = (iface, ticks)
                link, units, offset = interfaces[iface] if iface < len(interfaces) else (0, 10 ** 6, 0)
                yield _Record(raw, packet, section, iface, ticks, units, offset, data, link)
            else:
                yield _Record(raw, section=section, **_NO_PACKET)


@dataclass
class _Template:
    """What a Collision PDU copies from the issuer's Entity State packet."""

    link_header: bytes
    ip_version: int
    ip_header: bytes  # IPv4 with its options, or IPv6's 40 bytes
    ports: tuple
    version: int
    exercise: int
    section: int
    interface: int
    units: int
    offset: int


def _first_pass(capture: str, plan: list) -> dict:
    """The first packet's time (Fraction s since 1970) under key None, and each planned packet's
    framing under its packet number."""
    wanted = {p.packet: p.pdu.issuer for p in plan}
    out: dict = {None: None}
    walker = _Walker(capture)
    for raw, packet, section, iface, ticks, units, offset, data, link in walker:
        if packet and ticks is not None and out[None] is None:
            out[None] = Fraction(ticks, units) + offset
        if packet in wanted and packet not in out:
            if walker.format == "pcap":
                caplen = struct.unpack(walker.endian + "I", raw[8:12])[0]
            elif struct.unpack(walker.endian + "I", raw[:4])[0] == 3:
                caplen = min(struct.unpack(walker.endian + "I", raw[8:12])[0], len(raw) - 16)
            else:
                caplen = struct.unpack(walker.endian + "I", raw[20:24])[0]
            out[packet] = _template(raw[data:data + caplen], link, wanted[packet], section, iface, units, offset,
                                    capture, packet)
    if out[None] is None:
        out[None] = Fraction(0)
    return out


def _template(frame: bytes, link: int, issuer: tuple, section, iface, units, offset, capture, packet) -> _Template:
    if link in (1, 113):
        off = 14 if link == 1 else 16
        etype = struct.unpack(">H", frame[off - 2:off])[0]
        while etype in (0x8100, 0x88A8, 0x9100):
            etype = struct.unpack(">H", frame[off + 2:off + 4])[0]
            off += 4
    elif link == 276:
        off = 20
    elif link in (0, 108):
        off = 4
    else:  # raw IP (101, 12, 14, 228, 229)
        off = 0
    ipver = frame[off] >> 4
    if ipver == 4:
        ihl = (frame[off] & 15) * 4
        ip = frame[off:off + ihl]
    else:
        ihl = 40
        ip = frame[off:off + 40]
    l4 = off + ihl
    sport, dport, ulen = struct.unpack(">HHH", frame[l4:l4 + 6])
    # the issuer's Entity State PDU among the payload's PDUs: its protocol version and exercise
    p, end = l4 + 8, min(len(frame), l4 + ulen)
    while p + 12 <= end:
        version, exercise, ptype, _, _, length = struct.unpack(">BBBBIH", frame[p:p + 10])
        if ptype == ENTITY_STATE_PDU_TYPE and p + 18 <= end and struct.unpack(">3H", frame[p + 12:p + 18]) == issuer:
            return _Template(frame[:off], ipver, ip, (sport, dport), version, exercise, section, iface, units, offset)
        if length < 12:
            break
        p += length
    raise InputError(capture, "packet holds no Entity State PDU of entity %d:%d:%d where the reader found one"
                     % issuer, where=f"packet {packet}")


def _checksum(data: bytes) -> int:
    if len(data) % 2:
        data += b"\0"
    s = int(np.frombuffer(data, ">u2").astype(np.uint64).sum())
    while s >> 16:
        s = (s & 0xFFFF) + (s >> 16)
    return ~s & 0xFFFF


def _frame(tpl: _Template, pdu: bytes) -> bytes:
    """The link header, IP and UDP headers of the template around ``pdu``: lengths and checksums anew."""
    ulen = 8 + len(pdu)
    sport, dport = tpl.ports
    if tpl.ip_version == 4:
        ip = bytearray(tpl.ip_header)
        struct.pack_into(">H", ip, 2, len(ip) + ulen)
        struct.pack_into(">H", ip, 6, struct.unpack(">H", ip[6:8])[0] & 0x4000)  # whole: no fragment
        struct.pack_into(">H", ip, 10, 0)
        struct.pack_into(">H", ip, 10, _checksum(bytes(ip)))
        pseudo = bytes(ip[12:20]) + struct.pack(">BBH", 0, 17, ulen)
    else:
        ip = bytearray(tpl.ip_header)
        struct.pack_into(">H", ip, 4, ulen)
        ip[6] = 17
        pseudo = bytes(ip[8:40]) + struct.pack(">IxxxB", ulen, 17)
    udp = struct.pack(">HHHH", sport, dport, ulen, 0)
    check = _checksum(pseudo + udp + pdu) or 0xFFFF  # 0 means "none" in UDP
    return tpl.link_header + bytes(ip) + struct.pack(">HHHH", sport, dport, ulen, check) + pdu


def _second_pass(capture: str, out, plan: list, templates: dict) -> None:
    from collections import deque

    first = templates[None]
    walker = _Walker(capture)
    pending: dict = {}  # section -> its PDUs' (ticks in the template's interface units, order, frame, template)
    for k, item in enumerate(plan):
        tpl = templates[item.packet]
        ticks = round((first + Fraction(item.pdu.t) - tpl.offset) * tpl.units)
        stamp = dis_timestamp(item.es_timestamp, item.pdu.t - item.es_t)
        frame = _frame(tpl, collision_pdu_bytes(tpl.version, tpl.exercise, stamp, item.pdu, item.event_number))
        pending.setdefault(tpl.section, []).append((ticks, k, frame, tpl))
    pending = {s: deque(sorted(v, key=lambda p: (p[0], p[1]))) for s, v in pending.items()}
    started = False
    for raw, packet, section, iface, ticks, units, offset, data, link in walker:
        if not started and walker.format == "pcap":
            out.write(walker.header)
        started = True
        if packet and ticks is not None:  # a PDU goes before the first packet later than it
            queue = pending.get(section)
            while queue and _before(queue[0], ticks, units, offset):
                _write_pdu(out, walker, queue.popleft())
        elif section > 0 and raw[:4] == b"\x0a\x0d\x0d\x0a":  # a section ends: the rest of its PDUs
            for p in pending.pop(section - 1, ()):
                _write_pdu(out, walker, p)
        out.write(raw)
    if not started and walker.format == "pcap":  # a pcap of no packet: its header
        out.write(walker.header)
    for section in sorted(pending):
        for p in pending[section]:
            _write_pdu(out, walker, p)


def _before(p, ticks: int, units: int, offset: int) -> bool:
    tpl = p[3]
    if tpl.units == units and tpl.offset == offset:
        return p[0] < ticks
    return Fraction(p[0], tpl.units) + tpl.offset < Fraction(ticks, units) + offset


def _write_pdu(out, walker, p) -> None:
    ticks, _, frame, tpl = p
    e = walker.endian
    if walker.format == "pcap":
        sec, sub = divmod(ticks, tpl.units)
        out.write(struct.pack(e + "IIII", sec, sub, len(frame), len(frame)) + frame)
    else:
        body = struct.pack(e + "IIIII", tpl.interface, ticks >> 32, ticks & 0xFFFFFFFF, len(frame), len(frame))
        body += frame + bytes(-len(frame) % 4)
        size = 12 + len(body)
        out.write(struct.pack(e + "II", 6, size) + body + struct.pack(e + "I", size))
