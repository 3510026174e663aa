"""Captures framed by hand for the DIS reader's tests: PDUs -> UDP -> IPv4/IPv6 -> link layer -> pcap or
pcapng, each layer built with ``struct`` from its specification (RFC 768, 791, 8200; IEEE 802.3/802.1Q;
the pcap and pcapng drafts), independently of the reader. DIS 7 PDUs come from opendis's own writer;
DIS 6 ones are built here from IEEE 1278.1a-1998's layout."""

from __future__ import annotations

import struct

import numpy as np

TURRET_AZIMUTH = 4096 + 11
GUN_ELEVATION = 4416 + 13


# -- DIS -----------------------------------------------------------------------------------------------
def es_dis7(site, app, ent, location, orientation, velocity=(0.0, 0.0, 0.0), parts=(), marking="T72",
            timestamp=0, kind=(1, 1, 222, 1, 2, 3, 0)):
    """An Entity State PDU (DIS 7) serialized by opendis, or where opendis is not installed by
    ``es_dis7_by_hand`` (the same bytes: test_dis checks). ``parts``: (parameter type, float value)."""
    try:
        import opendis  # noqa: F401
    except ImportError:
        return es_dis7_by_hand(site, app, ent, location, orientation, velocity, parts, marking, timestamp, kind)
    return es_dis7_opendis(site, app, ent, location, orientation, velocity, parts, marking, timestamp, kind)


def es_dis7_by_hand(site, app, ent, location, orientation, velocity=(0.0, 0.0, 0.0), parts=(), marking="T72",
                    timestamp=0, kind=(1, 1, 222, 1, 2, 3, 0)):
    """IEEE 1278.1-2012 7.2.2's Entity State PDU by hand (as es_dis7 fills it)."""
    body = struct.pack(">HHHBB", site, app, ent, 0, len(parts)) + struct.pack(">BBHBBBB", *kind) + bytes(8)
    body += struct.pack(">3f", *velocity) + struct.pack(">3d", *location) + struct.pack(">3f", *orientation)
    body += struct.pack(">I", 0) + struct.pack(">B15s3f3f", 4, bytes(15), 0, 0, 0, 0, 0, 0)
    body += struct.pack(">B11s", 1, marking.encode()) + struct.pack(">I", 0)
    for ptype, value in parts:  # VariableParameter, record type 0: articulated part
        body += struct.pack(">BBHIf4x", 0, 1, 0, ptype, value)
    return struct.pack(">BBBBIHBB", 7, 1, 1, 1, timestamp, 12 + len(body), 0, 0) + body


def es_dis7_opendis(site, app, ent, location, orientation, velocity=(0.0, 0.0, 0.0), parts=(), marking="T72",
                    timestamp=0, kind=(1, 1, 222, 1, 2, 3, 0)):
    """An Entity State PDU serialized by opendis (DIS 7)."""
    from io import BytesIO

    from opendis.DataOutputStream import DataOutputStream
    from opendis.dis7 import (ArticulatedParts, EntityID, EntityMarking, EntityStatePdu, EntityType, EulerAngles,
                              Vector3Double, Vector3Float)

    pdu = EntityStatePdu()
    # opendis 1.0's defaults that its own writer gets wrong: the PDU type and family (the base class's
    # zeros shadow the class's 1 and 1: its reader then ignores the PDU), the PDU status (an object
    # written as a byte), the appearance and capabilities (bytes written as integers)
    pdu.pduType = 1
    pdu.protocolFamily = 1
    pdu.pduStatus = 0
    pdu.entityAppearance = 0
    pdu.capabilities = 0
    pdu.protocolVersion = 7
    pdu.exerciseID = 1
    pdu.timestamp = timestamp
    pdu.entityID = EntityID(site, app, ent)
    pdu.entityType = EntityType(*kind)
    pdu.entityLocation = Vector3Double(*location)
    pdu.entityOrientation = EulerAngles(*orientation)
    pdu.entityLinearVelocity = Vector3Float(*velocity)
    pdu.marking = EntityMarking()
    pdu.marking.characterSet = 1
    pdu.marking.characters = list(marking.encode().ljust(11, b"\0"))
    pdu.deadReckoningParameters.deadReckoningAlgorithm = 4
    vps = []
    for ptype, value in parts:
        # opendis's ArticulatedParts writes its value as a signed 64-bit integer: give it the bits of the
        # standard's float32 followed by 4 bytes of padding
        bits = struct.unpack(">q", struct.pack(">f", value) + b"\0" * 4)[0]
        vps.append(ArticulatedParts(changeIndicator=1, partAttachedTo=0, parameterType=ptype, parameterValue=bits))
    pdu.variableParameters = vps
    pdu.length = 144 + 16 * len(vps)
    out = BytesIO()
    pdu.serialize(DataOutputStream(out))
    data = out.getvalue()
    assert len(data) == pdu.length
    return data


def es_dis6(site, app, ent, location, orientation, velocity=(0.0, 0.0, 0.0), parts=(), value64=False,
            marking="BMP", version=6, length=None, n_parts=None):
    """An Entity State PDU of IEEE 1278.1a-1998 (DIS 6) by hand: 5.3.3.1's fields in order.
    ``parts``: (parameter type, value); the value a float32 and 4 zero bytes, or a float64 (``value64``)."""
    body = struct.pack(">HHHBB", site, app, ent, 1, len(parts) if n_parts is None else n_parts)  # id, force, count
    body += struct.pack(">BBHBBBB", 1, 1, 222, 1, 2, 3, 0) + bytes(8)  # entity type, alternative type
    body += struct.pack(">3f", *velocity) + struct.pack(">3d", *location) + struct.pack(">3f", *orientation)
    body += struct.pack(">I", 0)  # appearance
    body += struct.pack(">B15s3f3f", 4, bytes(15), 0, 0, 0, 0, 0, 0)  # dead reckoning: 40 bytes
    body += struct.pack(">B11s", 1, marking.encode()) + struct.pack(">I", 0)  # marking, capabilities
    for ptype, value in parts:
        v = struct.pack(">d", value) if value64 else struct.pack(">f", value) + bytes(4)
        body += struct.pack(">BBHI", 0, 1, 0, ptype) + v
    size = 12 + len(body) if length is None else length
    return struct.pack(">BBBBIHH", version, 1, 1, 1, 0, size, 0) + body


def other_pdu(pdu_type=2, family=2, size=96, version=7):
    """Some other PDU (a Fire PDU by default): a header and zeros."""
    return struct.pack(">BBBBIHH", version, 1, pdu_type, family, 0, size, 0) + bytes(size - 12)


# -- transport, network, link ------------------------------------------------------------------------------
def udp(payload, sport=3000, dport=3000):
    return struct.pack(">HHHH", sport, dport, 8 + len(payload), 0) + payload


def tcp(payload, sport=5000, dport=3000):
    return struct.pack(">HHIIBBHHH", sport, dport, 1, 0, 5 << 4, 0x18, 65535, 0, 0) + payload


def ipv4(l4, proto=17, options=b"", flags_offset=0, total=None):
    ihl = 5 + len(options) // 4
    size = 4 * ihl + len(l4) if total is None else total
    return struct.pack(">BBHHHBBH4s4s", 0x40 | ihl, 0, size, 7, flags_offset, 64, proto, 0,
                       bytes([10, 0, 0, 1]), bytes([10, 0, 0, 255])) + options + l4


def ipv6(l4, next_header=17):
    return struct.pack(">IHBB16s16s", 6 << 28, len(l4), next_header, 64, bytes(15) + b"\1", bytes(15) + b"\2") + l4


def ethernet(l3, ethertype=0x0800, vlans=()):
    head = bytes(6) + bytes([2, 0, 0, 0, 0, 1])
    for tpid, vid in vlans:
        head += struct.pack(">HH", tpid, vid)
    frame = head + struct.pack(">H", ethertype) + l3
    return frame + bytes(max(0, 60 - len(frame)))  # padded to the minimum frame


def sll(l3, protocol=0x0800):
    return struct.pack(">HHH8sH", 0, 1, 6, bytes(8), protocol) + l3


def sll2(l3, protocol=0x0800):
    return struct.pack(">HHIHBB8s", protocol, 0, 2, 1, 0, 6, bytes(8)) + l3


def null(l3, family=2, big=False):
    return struct.pack(">I" if big else "<I", family) + l3


def arp():
    return ethernet(bytes(28), ethertype=0x0806)


# -- capture files -------------------------------------------------------------------------------------------
def pcap(packets, link=1, big=False, nanos=False):
    """``packets``: (time s as (sec, frac) or float, frame bytes)."""
    e = ">" if big else "<"
    magic = 0xA1B23C4D if nanos else 0xA1B2C3D4
    out = [struct.pack(e + "IHHiIII", magic, 2, 4, 0, 0, 262144, link)]
    for ts, frame in packets:
        sec, frac = _split(ts)
        sub = round(frac * (1e9 if nanos else 1e6))
        out.append(struct.pack(e + "IIII", sec, sub, len(frame), len(frame)) + frame)
    return b"".join(out)


def _split(ts):
    if isinstance(ts, tuple):
        return ts
    sec = int(np.floor(ts))
    return sec, ts - sec


def _block(e, btype, body):
    body += bytes(-len(body) % 4)
    size = 12 + len(body)
    return struct.pack(e + "II", btype, size) + body + struct.pack(e + "I", size)


def _option(e, code, value):
    return struct.pack(e + "HH", code, len(value)) + value + bytes(-len(value) % 4)


def pcapng(interfaces, packets, big=False, sections=None):
    """``interfaces``: (link type, tsresol byte or None, snap length); ``packets``: (interface or 'spb',
    ticks (int, in that interface's units) or None, frame)."""
    e = ">" if big else "<"
    out = [_block(e, 0x0A0D0D0A, struct.pack(e + "IHHq", 0x1A2B3C4D, 1, 0, -1))]
    for link, tsresol, snap in interfaces:
        opts = b""
        if tsresol is not None:
            opts += _option(e, 9, bytes([tsresol]))
        if opts:
            opts += _option(e, 0, b"")
        out.append(_block(e, 1, struct.pack(e + "HHI", link, 0, snap) + opts))
    for iface, ticks, frame in packets:
        if iface == "spb":
            out.append(_block(e, 3, struct.pack(e + "I", len(frame)) + frame))
        else:
            out.append(_block(e, 6, struct.pack(e + "IIIII", iface, ticks >> 32, ticks & 0xFFFFFFFF, len(frame),
                                                len(frame)) + frame))
    return b"".join(out)
