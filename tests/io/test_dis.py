"""DIS captures: Entity State PDUs written by opendis (DIS 7) or by hand from the standard's layout (DIS 6),
framed into pcap and pcapng by the test (tests/io/captures.py), read back by tankcd_cli.io.dis."""

import struct

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.dis import DisCapture, EntityStates, decode_entity_states, entity_text, read_capture
from tests.io import captures as C

T0 = 1_780_000_000  # s since 1970 of the captures' first packet


def ecef(lon_deg, lat_deg, h=150.0):
    """WGS 84 geodetic -> ECEF (the textbook formula; the geodesy tests check it against pyproj)."""
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    lon, lat = np.radians(lon_deg), np.radians(lat_deg)
    n = a / np.sqrt(1 - e2 * np.sin(lat) ** 2)
    return ((n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon), (n * (1 - e2) + h) * np.sin(lat))


def _write(tmp_path, data, name="c.pcap"):
    path = tmp_path / name
    path.write_bytes(data)
    return str(path)


def exercise():
    """Three tanks, asynchronous: 1:1:1 at 5 Hz from the start, 1:1:2 at 2 Hz with a phase, 7:3:9 (DIS 6)
    appearing late at 1 Hz; their states by time. Returns [(t, entity, pdu bytes, truth)]."""
    rng = np.random.default_rng(3)
    rows = []
    for ent, (site, app, num, hz, start, version) in {
            "1:1:1": (1, 1, 1, 5.0, 0.0, 7), "1:1:2": (1, 1, 2, 2.0, 0.13, 7), "7:3:9": (7, 3, 9, 1.0, 3.4, 6)}.items():
        for t in np.arange(start, 6.0, 1 / hz):
            loc = ecef(10 + rng.uniform(-0.01, 0.01), 50 + rng.uniform(-0.01, 0.01))
            ori = tuple(rng.uniform(-3, 3, 3))
            vel = tuple(rng.uniform(-10, 10, 3))
            tur, gun = rng.uniform(-3, 3), rng.uniform(-0.2, 0.3)
            parts = [(C.GUN_ELEVATION, gun), (5000, 1.5), (C.TURRET_AZIMUTH, tur)]
            if version == 7:
                pdu = C.es_dis7(site, app, num, loc, ori, vel, parts=parts)
            else:
                pdu = C.es_dis6(site, app, num, loc, ori, vel, parts=parts)
            rows.append((t, ent, pdu, dict(location=loc, orientation=np.float32(ori), velocity=np.float32(vel),
                                           turret=np.float32(tur), gun=np.float32(gun), version=version)))
    rows.sort(key=lambda r: r[0])
    return rows


def test_an_exercise_of_interleaved_asynchronous_entities_one_late_decodes_to_what_was_written(tmp_path):
    rows = exercise()
    frames = [(T0 + 0.05, C.arp())]  # the first packet is not DIS: t counts from it
    frames += [(T0 + 0.1 + t, C.ethernet(C.ipv4(C.udp(pdu)))) for t, _, pdu, _ in rows]
    path = _write(tmp_path, C.pcap(frames))
    states, counts = read_capture(path)
    assert len(states) == len(rows)
    np.testing.assert_allclose(states.t, [0.05 + t for t, *_ in rows], atol=1e-6)
    assert states.entity.tolist() == [e for _, e, _, _ in rows]
    assert [tuple(i) for i in states.entity_id.tolist()] == [tuple(map(int, e.split(":"))) for _, e, _, _ in rows]
    truth = [r[3] for r in rows]
    np.testing.assert_array_equal(states.location, [r["location"] for r in truth])
    np.testing.assert_array_equal(states.orientation, np.array([r["orientation"] for r in truth], dtype=np.float64))
    np.testing.assert_array_equal(states.velocity, np.array([r["velocity"] for r in truth], dtype=np.float64))
    np.testing.assert_array_equal(states.turret_azimuth, [float(r["turret"]) for r in truth])
    np.testing.assert_array_equal(states.gun_elevation, [float(r["gun"]) for r in truth])
    assert states.version.tolist() == [r["version"] for r in truth]
    assert states.packet.tolist() == list(range(2, len(rows) + 2))
    assert counts.packets == len(rows) + 1 and counts.not_ip == 1 and counts.entity_states == len(rows)
    late = states.entity == "7:3:9"
    assert states.t[late].min() == pytest.approx(0.05 + 3.4) and set(states.version[late].tolist()) == {6}


def test_opendis_writes_the_bytes_the_standard_lays_out():
    """The PDUs the other tests use are opendis's; without opendis, the same bytes built by hand."""
    pytest.importorskip("opendis")
    args = (1, 2, 3, ecef(10, 50), (0.1, -0.2, 0.3), (1.5, 2.5, -3.5), [(C.TURRET_AZIMUTH, 0.7), (C.GUN_ELEVATION, -0.1)])
    assert C.es_dis7_opendis(*args) == C.es_dis7_by_hand(*args)


def test_opendis_reads_the_same_pdus_the_same(tmp_path):
    """The same packets through opendis's own reader: ids, location, orientation, velocity agree."""
    pytest.importorskip("opendis")
    from opendis.PduFactory import createPdu

    rows = [r for r in exercise() if r[3]["version"] == 7]
    path = _write(tmp_path, C.pcap([(T0 + t, C.ethernet(C.ipv4(C.udp(pdu)))) for t, _, pdu, _ in rows]))
    states, _ = read_capture(path)
    for k, (_, _, pdu, _) in enumerate(rows):
        theirs = createPdu(pdu)
        e = theirs.entityID
        assert (e.siteID, e.applicationID, e.entityID) == tuple(states.entity_id[k].tolist())
        loc = theirs.entityLocation
        assert (loc.x, loc.y, loc.z) == tuple(states.location[k])
        o = theirs.entityOrientation
        assert (o.psi, o.theta, o.phi) == tuple(states.orientation[k])
        v = theirs.entityLinearVelocity
        assert (v.x, v.y, v.z) == tuple(states.velocity[k])
        assert len(theirs.variableParameters) == 3


def test_bundled_pdus_in_one_datagram_are_walked_by_their_lengths(tmp_path):
    loc = ecef(10, 50)
    a = C.es_dis7(1, 1, 1, loc, (0.1, 0.2, 0.3), parts=[(C.TURRET_AZIMUTH, 0.25)])
    b = C.es_dis7(1, 1, 2, loc, (0.4, 0.5, 0.6))
    fire = C.other_pdu(2, 2, 96)
    d6 = C.es_dis6(2, 2, 2, loc, (0, 0, 0), parts=[(C.GUN_ELEVATION, -0.125)])
    path = _write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(a + fire + b + d6 + C.other_pdu(20, 5, 40)))))]))
    states, counts = read_capture(path)
    assert states.entity.tolist() == ["1:1:1", "1:1:2", "2:2:2"]
    assert states.turret_azimuth[0] == 0.25 and np.isnan(states.turret_azimuth[1:]).all()
    assert states.gun_elevation[2] == -0.125
    assert counts.pdu_types == {2: 1, 20: 1} and counts.dis_packets == 1 and counts.packets == 1


def test_link_layers_vlan_tags_ip_options_ipv6_and_the_packets_skipped_are_counted(tmp_path):
    loc = ecef(-70, -33)
    pdu = C.es_dis7(5, 6, 7, loc, (1, 0, 0))
    tagged = C.ethernet(C.ipv4(C.udp(pdu)), vlans=[(0x8100, 12)])
    qinq = C.ethernet(C.ipv4(C.udp(pdu)), vlans=[(0x88a8, 100), (0x8100, 12)])
    options = C.ethernet(C.ipv4(C.udp(pdu, sport=40000, dport=62040), options=bytes([1, 1, 1, 0, 7, 7, 0, 0])))
    v6 = C.ethernet(C.ipv6(C.udp(pdu)), ethertype=0x86DD)
    v6_ext = C.ethernet(C.ipv6(bytes([17, 0, 1, 4, 0, 0, 0, 0]) + C.udp(pdu), next_header=0), ethertype=0x86DD)
    not_dis = C.ethernet(C.ipv4(C.udp(b"hello, this is not DIS at all" * 3, dport=3000)))
    tcp = C.ethernet(C.ipv4(C.tcp(pdu), proto=6))
    frames = [tagged, qinq, options, v6, v6_ext, not_dis, tcp, C.arp()]
    states, counts = read_capture(_write(tmp_path, C.pcap([(T0 + k, f) for k, f in enumerate(frames)])))
    assert states.packet.tolist() == [1, 2, 3, 4]
    assert (counts.ipv6_extension, counts.udp_not_dis, counts.not_udp, counts.not_ip) == (1, 1, 1, 1)
    assert counts.skipped() == {"ipv6_extension": 1, "udp_not_dis": 1, "not_udp": 1, "not_ip": 1}


@pytest.mark.parametrize("link,frame", [
    (113, lambda p: C.sll(C.ipv4(C.udp(p)))), (276, lambda p: C.sll2(C.ipv4(C.udp(p)))),
    (101, lambda p: C.ipv4(C.udp(p))), (101, lambda p: C.ipv6(C.udp(p))), (228, lambda p: C.ipv4(C.udp(p))),
    (0, lambda p: C.null(C.ipv4(C.udp(p)))), (0, lambda p: C.null(C.ipv6(C.udp(p)), family=30, big=True)),
    (108, lambda p: C.null(C.ipv4(C.udp(p)), big=True)), (113, lambda p: C.sll(C.ipv6(C.udp(p)), 0x86DD))])
def test_every_link_type(tmp_path, link, frame):
    pdu = C.es_dis7(1, 2, 3, ecef(0.5, 0.2), (0, 0, 0))
    states, counts = read_capture(_write(tmp_path, C.pcap([(T0, frame(pdu)), (T0 + 1, frame(pdu))], link=link)))
    assert len(states) == 2 and counts.packets == 2 and states.t.tolist() == [0.0, 1.0]


def test_an_unknown_link_type_is_counted_and_then_there_is_no_entity_state(tmp_path):
    pdu = C.es_dis7(1, 2, 3, ecef(0.5, 0.2), (0, 0, 0))
    with pytest.raises(InputError, match=r"no DIS Entity State PDU in 1 packets \(link_unknown 1\)"):
        read_capture(_write(tmp_path, C.pcap([(T0, C.ipv4(C.udp(pdu)))], link=147)))


@pytest.mark.parametrize("big", [False, True])
@pytest.mark.parametrize("nanos", [False, True])
def test_pcap_byte_orders_and_timestamp_resolutions(tmp_path, big, nanos):
    pdu = C.es_dis7(1, 2, 3, ecef(0.5, 0.2), (0, 0, 0))
    frames = [((T0, 0.123456), C.ethernet(C.ipv4(C.udp(pdu)))), ((T0 + 100, 0.987654), C.ethernet(C.ipv4(C.udp(pdu))))]
    states, _ = read_capture(_write(tmp_path, C.pcap(frames, big=big, nanos=nanos)))
    assert states.t[1] == pytest.approx(100 + 0.987654 - 0.123456, abs=1e-9)


@pytest.mark.parametrize("big", [False, True])
def test_pcapng_two_interfaces_of_different_resolutions_and_a_simple_packet_block(tmp_path, big):
    """Interface 0 in microseconds (the default), interface 1 in 2^-20 s (if_tsresol 0x94), interface 2 in
    nanoseconds (raw IP): times agree whatever the interface."""
    pdu = lambda e: C.es_dis7(1, 1, e, ecef(20, 60), (0, 0, 0))  # noqa: E731
    eth = lambda p: C.ethernet(C.ipv4(C.udp(p)))  # noqa: E731
    packets = [
        (0, T0 * 10**6 + 250_000, eth(pdu(1))),                   # t = 0
        (1, (T0 + 1) * 2**20 + 2**19, eth(pdu(2))),               # t = 1.25
        ("spb", None, eth(pdu(3))),                               # no timestamp: the one before, 1.25
        (2, (T0 + 2) * 10**9 + 1, C.ipv4(C.udp(pdu(4)))),         # t = 1.750000001
        (0, T0 * 10**6 + 250_001, eth(pdu(5))),                   # t = 1e-6 (interfaces need not be in order)
    ]
    path = _write(tmp_path, C.pcapng([(1, None, 0), (1, 0x80 | 20, 0), (101, 9, 0)], packets, big=big), "c.pcapng")
    capture = DisCapture(path)
    states = capture.read()
    assert capture.format == "pcapng"
    assert states.entity.tolist() == ["1:1:1", "1:1:2", "1:1:3", "1:1:4", "1:1:5"]
    np.testing.assert_allclose(states.t, [0, 1.25, 1.25, 1.750000001, 1e-6], atol=1e-12, rtol=0)


def test_pcapng_sections_and_unknown_blocks(tmp_path):
    """A second section (of the other byte order) resets the interfaces; other blocks are skipped."""
    pdu = C.es_dis7(1, 1, 1, ecef(20, 60), (0, 0, 0))
    one = C.pcapng([(1, None, 0)], [(0, T0 * 10**6, C.ethernet(C.ipv4(C.udp(pdu))))])
    name_block = struct.pack("<II", 4, 20) + struct.pack("<HH", 0, 0) + bytes(4) + struct.pack("<I", 20)
    two = C.pcapng([(101, 9, 0)], [(0, (T0 + 3) * 10**9, C.ipv4(C.udp(pdu)))], big=True)
    states, counts = read_capture(_write(tmp_path, one + name_block + two, "c.pcapng"))
    assert states.t.tolist() == [0.0, 3.0] and counts.packets == 2


def test_fragments_first_read_as_far_as_it_goes_others_counted(tmp_path):
    loc = ecef(10, 50)
    pdus = b"".join(C.es_dis7(1, 1, k, loc, (0, 0, 0)) for k in range(1, 4))  # 432 bytes
    datagram = C.udp(pdus)
    first = C.ipv4(datagram[:8 + 200], flags_offset=0x2000)  # holds PDU 1 and part of PDU 2
    second = C.ipv4(datagram[8 + 200:], flags_offset=(8 + 200) // 8)
    path = _write(tmp_path, C.pcap([(T0, C.ethernet(first)), (T0 + 0.001, C.ethernet(second))]))
    states, counts = read_capture(path)
    assert states.entity.tolist() == ["1:1:1"]
    assert (counts.first_fragments, counts.fragments, counts.pdus_cut) == (1, 1, 1)


def test_a_snap_length_cut_is_counted_not_an_error(tmp_path):
    loc = ecef(10, 50)
    frame = C.ethernet(C.ipv4(C.udp(C.es_dis7(1, 1, 1, loc, (0, 0, 0)) + C.es_dis7(1, 1, 2, loc, (0, 0, 0)))))
    data = bytearray(C.pcap([(T0, frame)]))
    cut = len(frame) - 50
    struct.pack_into("<I", data, 24 + 8, cut)  # incl_len < orig_len, as tcpdump -s writes
    path = _write(tmp_path, bytes(data[:24 + 16 + cut]))
    states, counts = read_capture(path)
    assert states.entity.tolist() == ["1:1:1"] and counts.pdus_cut == 1 and counts.truncated == 1


def _snapped(frame, keep, ng=False):
    """One packet captured to its first ``keep`` bytes (incl_len < orig_len), as pcap or a pcapng EPB."""
    if ng:
        data = C.pcapng([(1, None, 0)], [(0, T0 * 10**6, frame[:keep])])
        body_at = len(data) - (32 + len(frame[:keep]) + (-keep % 4))
        data = bytearray(data)
        struct.pack_into("<I", data, body_at + 24, len(frame))  # the original length
        return bytes(data)
    data = bytearray(C.pcap([(T0, frame)]))
    struct.pack_into("<I", data, 24 + 8, keep)
    return bytes(data[:24 + 16 + keep])


@pytest.mark.parametrize("ng", [False, True])
def test_a_snap_length_cut_anywhere_is_truncated_never_not_dis_and_whole_pdus_decode(tmp_path, ng):
    loc = ecef(10, 50)
    es = C.es_dis7(1, 1, 1, loc, (0, 0, 0))
    frame = C.ethernet(C.ipv4(C.udp(es + C.other_pdu(2, 2, 96))))
    head = 14 + 20 + 8  # Ethernet, IPv4, UDP
    good = C.ethernet(C.ipv4(C.udp(C.es_dis7(1, 1, 9, loc, (0, 0, 0)))))
    for keep, decoded, cut in ((head + len(es) + 30, ["1:1:1"], 1), (head + len(es), ["1:1:1"], 1),
                               (head + 10, [], 1), (head + 100, [], 1), (head - 4, [], 0), (20, [], 0), (6, [], 0)):
        snapped = _snapped(frame, keep, ng)
        other = _snapped(good, len(good), ng)  # a whole packet after it
        header = 24 if not ng else len(C.pcapng([(1, None, 0)], []))
        data = snapped + other[header:]
        states, counts = read_capture(_write(tmp_path, data, "s.pcapng" if ng else "s.pcap"))
        assert states.entity.tolist() == decoded + ["1:1:9"], keep
        assert counts.truncated == 1 and counts.pdus_cut == cut, keep
        assert counts.udp_not_dis == counts.malformed == counts.not_ip == 0, (keep, counts)


def test_pcapng_trailing_block_lengths_are_checked(tmp_path):
    pdu = C.es_dis7(1, 1, 1, ecef(10, 50), (0, 0, 0))
    frame = C.ethernet(C.ipv4(C.udp(pdu)))
    ng = C.pcapng([(1, None, 0)], [(0, T0 * 10**6 + k, frame) for k in range(3)])
    blen = 32 + len(frame) + (-len(frame) % 4)
    rng = np.random.default_rng(5)
    junk = bytes(rng.integers(0, 256, blen // 2, dtype=np.uint8))
    # the last block cut in its middle, junk after it making up its length
    with pytest.raises(InputError, match=r"c\.pcapng: packet 3: corrupt pcapng: the block of packet 3 says "
                                         rf"{blen} bytes at its start but \d+ at its end"):
        read_capture(_write(tmp_path, ng[:-(blen // 2)] + junk, "c.pcapng"))
    # a block of another kind (the interface description) whose trailing length lies
    bad = bytearray(ng)
    shb = struct.unpack_from("<I", bad, 4)[0]
    idb = struct.unpack_from("<I", bad, shb + 4)[0]
    struct.pack_into("<I", bad, shb + idb - 4, idb + 4)
    with pytest.raises(InputError, match=rf"byte {shb}: corrupt pcapng: a block that says {idb} bytes at its start"):
        read_capture(_write(tmp_path, bytes(bad), "c.pcapng"))
    # whatever the blocks the reads fall in
    for chunk in (4096, 1 << 20):
        capture = DisCapture(_write(tmp_path, ng[:-(blen // 2)] + junk, "c.pcapng"), block_pdus=1)
        capture.chunk_bytes = chunk
        with pytest.raises(InputError, match="packet 3: corrupt pcapng"):
            list(capture.blocks())


@pytest.mark.parametrize("value64", [False, True])
def test_dis6_articulation_values_float32_or_float64(tmp_path, value64):
    loc = ecef(10, 50)
    values = [0.5, 1.0, 0.123456789]  # 0.5 and 1.0 as float64 have four zero bytes too
    pdus = [C.es_dis6(3, 4, 5, loc, (0, 0, 0), parts=[(C.TURRET_AZIMUTH, v)], value64=value64) for v in values]
    if value64:  # the sender shows itself float64 by a value of eight significant bytes first
        pdus = pdus[::-1]
        values = values[::-1]
    path = _write(tmp_path, C.pcap([(T0 + k, C.ethernet(C.ipv4(C.udp(p)))) for k, p in enumerate(pdus)]))
    states, _ = read_capture(path)
    expected = values if value64 else [float(np.float32(v)) for v in values]
    assert states.turret_azimuth.tolist() == expected


def test_blocks_are_bounded_and_records_straddle_reads(tmp_path):
    rows = exercise()
    frames = [(T0 + t, C.ethernet(C.ipv4(C.udp(pdu)))) for t, _, pdu, _ in rows]
    path = _write(tmp_path, C.pcap(frames))
    whole, _ = read_capture(path)
    capture = DisCapture(path, block_pdus=7, chunk_bytes=1000)  # 1000 bytes: below a record's size
    capture.chunk_bytes = 300
    blocks = list(capture.blocks())
    assert max(len(b) for b in blocks) <= 7 and len(blocks) >= len(rows) // 7
    joined = EntityStates.concatenate(blocks)
    for f in EntityStates.__dataclass_fields__:
        np.testing.assert_array_equal(getattr(joined, f), getattr(whole, f))
    ng = _write(tmp_path, C.pcapng([(1, 9, 0)], [(0, int((T0 + t) * 1e9), f) for (t, f) in frames]), "c.pcapng")
    capture = DisCapture(ng, block_pdus=5)
    capture.chunk_bytes = 200
    blocks = list(capture.blocks())
    assert max(len(b) for b in blocks) <= 5
    np.testing.assert_allclose(EntityStates.concatenate(blocks).t, whole.t, atol=1e-6)


# -- bad input -----------------------------------------------------------------------------------------
def test_truncated_capture_names_the_packet(tmp_path):
    pdu = C.es_dis7(1, 1, 1, ecef(10, 50), (0, 0, 0))
    data = C.pcap([(T0 + k, C.ethernet(C.ipv4(C.udp(pdu)))) for k in range(3)])
    with pytest.raises(InputError, match=r"c\.pcap: packet 3: capture ends inside packet 3 \(its record says 186 bytes, 86"):
        read_capture(_write(tmp_path, data[:-100]))
    with pytest.raises(InputError, match=r"packet 3: capture ends inside the record header of packet 3"):
        read_capture(_write(tmp_path, data[:24 + 2 * (16 + 186) + 5]))
    ng = C.pcapng([(1, None, 0)], [(0, T0 * 10**6 + k, C.ethernet(C.ipv4(C.udp(pdu)))) for k in range(3)])
    with pytest.raises(InputError, match=r"packet 3: capture ends inside a block"):
        read_capture(_write(tmp_path, ng[:-30], "c.pcapng"))


def test_not_a_capture(tmp_path):
    with pytest.raises(InputError, match=r"not a pcap or pcapng capture \(it starts with bytes 74 2c 78 2c"):
        read_capture(_write(tmp_path, b"t,x,y,yaw_deg\n0,1,2,3\n", "c.csv"))
    with pytest.raises(InputError, match="starts with bytes nothing"):
        read_capture(_write(tmp_path, b""))


def test_a_pdu_whose_length_lies(tmp_path):
    loc = ecef(10, 50)
    long = C.es_dis6(1, 1, 1, loc, (0, 0, 0), length=400)
    with pytest.raises(InputError, match=r"packet 2: Entity State PDU's length field says 400 bytes, but the UDP "
                                         r"payload holds only 144"):
        read_capture(_write(tmp_path, C.pcap([(T0, C.arp()), (T0, C.ethernet(C.ipv4(C.udp(long))))])))
    short = C.es_dis6(1, 1, 1, loc, (0, 0, 0), parts=[(C.TURRET_AZIMUTH, 1.0)], length=144)
    with pytest.raises(InputError, match=r"packet 1: .*says 144 bytes, shorter than its layout with 1 articulation "
                                         r"records \(160 bytes\)"):
        read_capture(_write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(short))))])))


@pytest.mark.parametrize("location,what", [
    ((np.nan, 0.0, 0.0), "non-finite ECEF location"), ((0.0, 0.0, 0.0), r"not near the Earth's surface \(\|r\| = 0 m"),
    ((4e6, 3e6, 5e6), r"\|r\| = 7071068 m"), ((1e3, 2e3, 3e3), "not near the Earth's surface")])
def test_absurd_locations(tmp_path, location, what):
    pdus = [C.es_dis7(1, 1, 1, ecef(10, 50), (0, 0, 0)), C.es_dis7(1, 1, 2, location, (0, 0, 0))]
    with pytest.raises(InputError, match="packet 2: Entity State PDU.*" + what):
        read_capture(_write(tmp_path, C.pcap([(T0 + k, C.ethernet(C.ipv4(C.udp(p)))) for k, p in enumerate(pdus)])))


def test_a_non_finite_orientation(tmp_path):
    pdu = C.es_dis7(1, 1, 1, ecef(10, 50), (0, np.inf, 0))
    with pytest.raises(InputError, match="packet 1: Entity State PDU has a non-finite orientation"):
        read_capture(_write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(pdu))))])))


@pytest.mark.parametrize("orientation,parts,fragment", [
    ((0, 0, 1e30), (), r"orientation \(0, 0, 1e\+30\) rad is no angle \(beyond \+-3142 rad = 1000 pi"),
    ((-3200.0, 0, 0), (), "orientation .* is no angle"),
    ((0, 0, 0), ((C.TURRET_AZIMUTH, float("nan")),), "articulated turret or gun angle nan rad is no angle"),
    ((0, 0, 0), ((C.GUN_ELEVATION, 1e20),), "articulated turret or gun angle 1e\\+20 rad")])
def test_orientations_and_articulations_that_are_no_angle_are_refused_naming_the_packet(tmp_path, orientation, parts,
                                                                                         fragment):
    ok = C.es_dis7(1, 1, 1, ecef(10, 50), (3000.0, -3.1, 3141.0), parts=[(C.TURRET_AZIMUTH, -3000.0)])
    bad = C.es_dis7(1, 1, 1, ecef(10, 50), orientation, parts=list(parts))
    path = _write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(ok)))), (T0 + 1, C.ethernet(C.ipv4(C.udp(bad))))]))
    with pytest.raises(InputError, match="packet 2: Entity State PDU's " + fragment):
        read_capture(path)
    states, _ = read_capture(_write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(ok))))]), "ok.pcap"))
    assert states.orientation[0, 0] == 3000.0  # within the bound: an angle, read as it is


def test_a_capture_without_entity_states(tmp_path):
    frames = [C.arp(), C.ethernet(C.ipv4(C.udp(C.other_pdu(2, 2, 96)))), C.ethernet(C.ipv4(C.udp(b"x" * 40)))]
    with pytest.raises(InputError, match=r"c\.pcap: no DIS Entity State PDU in 3 packets \(not_ip 1, udp_not_dis 1, "
                                         r"pdu_type_2 1\)"):
        read_capture(_write(tmp_path, C.pcap([(T0 + k, f) for k, f in enumerate(frames)])))
    with pytest.raises(InputError, match=r"no DIS Entity State PDU in 0 packets \(nothing else\)"):
        read_capture(_write(tmp_path, C.pcap([])))


def test_decode_entity_states_on_a_buffer_and_entity_text():
    loc = ecef(10, 50)
    a = C.es_dis7(1, 2, 3, loc, (1, 2, 3), parts=[(C.TURRET_AZIMUTH, 0.5)])
    b = C.es_dis6(65535, 0, 7, loc, (0, 0, 0))
    buf = np.frombuffer(b"pad" + a + b, np.uint8)
    states = decode_entity_states(buf, [3, 3 + len(a)])
    assert states.entity.tolist() == ["1:2:3", "65535:0:7"] and states.packet.tolist() == [1, 2]
    assert states.turret_azimuth[0] == 0.5 and states.marking.tolist() == [b"T72", b"BMP"]
    assert entity_text(np.zeros((0, 3))).shape == (0,)


def test_corrupted_and_cut_captures_give_input_errors_only(tmp_path):
    """Bytes flipped and files cut anywhere: the reader decodes or says InputError, never anything else
    (the framing pass reads untrusted lengths)."""
    rows = exercise()[:30]
    frames = [(T0 + t, C.ethernet(C.ipv4(C.udp(pdu + (C.other_pdu() if k % 3 else b""))))) for k, (t, _, pdu, _) in
              enumerate(rows)]
    good = [C.pcap(frames), C.pcap(frames, big=True, nanos=True),
            C.pcapng([(1, None, 0), (101, 9, 0)], [(k % 2, int((T0 + t) * (1e6 if k % 2 == 0 else 1e9)),
                                                   f if k % 2 == 0 else f[14:]) for k, (t, f) in enumerate(frames)])]
    rng = np.random.default_rng(12)
    outcomes = {"ok": 0, "error": 0}
    for data in good:
        for trial in range(150):
            bad = bytearray(data)
            if trial % 3 == 0:
                bad = bad[:rng.integers(0, len(bad))]
            else:
                for at in rng.integers(0, len(bad), rng.integers(1, 6)):
                    bad[at] = rng.integers(0, 256)
            path = _write(tmp_path, bytes(bad), "f.pcapng" if data is good[2] else "f.pcap")
            try:
                capture = DisCapture(path, block_pdus=8, chunk_bytes=512)
                capture.chunk_bytes = 512
                for block in capture.blocks():
                    assert len(block) <= 8
                outcomes["ok"] += 1
            except InputError:
                outcomes["error"] += 1
    assert outcomes["ok"] > 50 and outcomes["error"] > 50


def test_trajectory_columns_in_a_utm_zone(tmp_path):
    """An entity at a known place, attitude and turret: the columns a trajectory CSV takes."""
    pyproj = pytest.importorskip("pyproj")
    from tankcd_cli.io.dis import articulation_angles, trajectory_columns
    from tankcd_cli.io.geodesy import dis_body_to_ecef, enu_basis

    lon, lat = 17.5, 48.2  # UTM 33N, 2.5 deg east of the central meridian
    yaw = np.radians(30.0)  # ENU yaw: 30 deg north of true east
    # the DIS body frame (x fwd, y right, z down) of a level vehicle with that yaw, in ECEF
    enu = np.array([[np.cos(yaw), np.sin(yaw), 0], [np.sin(yaw), -np.cos(yaw), 0], [0, 0, -1]]).T
    body = enu_basis([lon], [lat])[0].T @ enu
    psi, theta, phi = np.arctan2(body[1, 0], body[0, 0]), -np.arcsin(body[2, 0]), np.arctan2(body[2, 1], body[2, 2])
    assert np.allclose(dis_body_to_ecef(psi, theta, phi)[0], body)
    pdu = C.es_dis7(1, 2, 3, ecef(lon, lat, 200.0), (psi, theta, phi),
                    parts=[(C.TURRET_AZIMUTH, 0.5), (C.GUN_ELEVATION, 0.1)])
    states, _ = read_capture(_write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(pdu))))])))
    wkt = pyproj.CRS.from_epsg(32633).to_wkt()
    cols = trajectory_columns(states, wkt, source="c.pcap")
    x, y = pyproj.Transformer.from_crs("EPSG:4326", wkt, always_xy=True).transform(lon, lat)
    assert cols["x"][0] == pytest.approx(x, abs=1e-3) and cols["y"][0] == pytest.approx(y, abs=1e-3)
    conv = pyproj.Proj(pyproj.CRS.from_epsg(32633)).get_factors(lon, lat).meridian_convergence
    assert cols["yaw_deg"][0] == pytest.approx(30.0 + conv, abs=1e-4)  # float32 angles in the PDU
    assert cols["turret_deg"][0] == pytest.approx(-np.degrees(float(np.float32(0.5))), abs=1e-9)
    assert cols["gun_deg"][0] == pytest.approx(np.degrees(float(np.float32(0.1))), abs=1e-9)
    assert abs(cols["pitch_deg"][0]) < 1e-4 and abs(cols["roll_deg"][0]) < 1e-4
    assert cols["h"][0] == pytest.approx(200.0, abs=1e-3) and cols["entity"].tolist() == ["1:2:3"]
    with pytest.raises(InputError, match="c.pcap: geographic input needs a terrain with a CRS"):
        trajectory_columns(states, "", source="c.pcap")
    turret, gun = articulation_angles([np.pi / 2, -3.0, np.nan], [0.1, 0.0, np.nan])
    np.testing.assert_allclose(turret[:2], [-np.pi / 2, 3.0])
    assert np.isnan(turret[2]) and np.isnan(gun[2])


def test_dis_5_is_decoded_and_dis_4_counted(tmp_path):
    loc = ecef(10, 50)
    v5 = C.es_dis6(1, 1, 5, loc, (0.5, 0, 0), version=5)
    v4 = C.es_dis6(1, 1, 4, loc, (0.5, 0, 0), version=4)
    states, counts = read_capture(_write(tmp_path, C.pcap([(T0, C.ethernet(C.ipv4(C.udp(v5 + v4))))])))
    assert states.entity.tolist() == ["1:1:5"] and states.version.tolist() == [5]
    assert counts.entity_states_v4 == 1 and counts.skipped() == {"entity_states_v4": 1}


def test_the_first_packet_time_is_known_once_a_packet_is_read(tmp_path):
    """DisCapture.first_packet_time: what t counts from, (seconds since 1970, fraction), None before."""
    from tankcd_cli.io.dis import DisCapture

    pdu = C.es_dis7(1, 2, 3, ecef(10, 50), (0, 0, 0))
    frame = C.ethernet(C.ipv4(C.udp(pdu)))
    path = _write(tmp_path, C.pcap([((T0, 0.25), C.arp()), ((T0 + 2, 0.5), frame)]))
    cap = DisCapture(path)
    assert cap.first_packet_time() is None
    states = cap.read()
    assert cap.first_packet_time() == (T0, 0.25) and states.t.tolist() == [2.25]
