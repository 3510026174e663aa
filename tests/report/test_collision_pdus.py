"""The replayed capture with Collision PDUs: every original packet kept byte for byte and in order, the
added PDUs decoded by an independent DIS implementation (opendis), their frames by struct from the
RFCs, the contact locations against scipy's rotations, the velocities against pyproj's own ECEF."""

from __future__ import annotations

import struct

import numpy as np
import pyproj
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.dis import read_capture, trajectory_columns
from tankcd_cli.report.collision_pdus import MASS_KG, write_collision_pdus
from tankcd_cli.report.review import Review, Track
from tankcd_cli.vehicle import vehicle_preset
from tests.io import captures as C
from tests.io.test_dis import T0, ecef

CRS = "EPSG:32632"
PITCH, ROLL = np.radians(-3.0), np.radians(2.0)  # every pose tilted: the frame test sees all three axes


def _frames(entities, times, version=7):
    """(time s since 1970, frame) of an exercise: each entity's ES PDU at each time (driving east), an ARP
    and a Fire PDU between; entity 1:1:1 sends from 10.0.0.1:3000, the others from the helpers' default."""
    out = []
    for k, t in enumerate(times):
        for n, (site, app, ent) in enumerate(entities):
            lon = 10.0 + 1e-5 * (k * 8.0 + 0.5 * n)  # about 0.7 m per step east
            lat = 50.0 + 1e-5 * n
            pdu = (C.es_dis7(site, app, ent, ecef(lon, lat), (0.0, 0.0, 0.0), timestamp=(1000 + 2 * k) | 1)
                   if version == 7 else C.es_dis6(site, app, ent, ecef(lon, lat), (0.0, 0.0, 0.0)))
            ports = (3000, 3000) if n == 0 else (4001 + n, 3000)
            out.append((T0 + t + 1e-4 * n, C.ethernet(C.ipv4(C.udp(pdu, *ports)))))
        if k == 1:
            out.append((T0 + t + 0.01, C.arp()))
            out.append((T0 + t + 0.02, C.ethernet(C.ipv4(C.udp(C.other_pdu(), 3000, 3000)))))
    return out


def _review(states):
    """Tracks as a replay of ``states`` gives them (x, y, yaw from the reader; a height and a tilt of
    our own), and one event of each kind."""
    cols = trajectory_columns(states, CRS)
    tracks = []
    for name in dict.fromkeys(states.entity.tolist()):
        rows = np.flatnonzero(cols["entity"] == name)
        yaw = np.radians(cols["yaw_deg"][rows])
        from scipy.spatial.transform import Rotation

        q = Rotation.from_euler("ZYX", np.column_stack([yaw, np.full_like(yaw, PITCH), np.full_like(yaw, ROLL)]))
        xyzw = q.as_quat()
        quat = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
        quat *= np.where(quat[:, :1] < 0, -1, 1)
        tracks.append(Track(name, rows.astype(np.int64), cols["t"][rows], cols["x"][rows], cols["y"][rows],
                            150.0 + 0.1 * np.arange(len(rows)), cols["yaw_deg"][rows], quat,
                            np.zeros(len(rows), np.uint8)))
    return Review(tracks=tuple(tracks), events=[], crs_wkt=pyproj.CRS(CRS).to_wkt())


def _near(track, t, dx=(2.0, 0.5, 1.0)):
    """A world point near ``track`` at ``t`` (as the replay would find one)."""
    i = int(np.searchsorted(track.t, t, side="right") - 1)
    return [float(track.x[i] + dx[0]), float(track.y[i] + dx[1]), float(track.z[i] + dx[2])]


def _events(review):
    a, b = review.tracks[0], review.tracks[1]
    return [
        # the hull and a track of a in a wall over two rows: one collision
        {"step": int(a.step[2]), "t": float(a.t[2]), "kind": "obstacle", "a": "hull", "b": "wall", "entity": a.entity,
         "point": _near(a, a.t[2])},
        {"step": int(a.step[2]), "t": float(a.t[2]), "kind": "obstacle", "a": "track_left", "b": "wall",
         "entity": a.entity, "point": _near(a, a.t[2], (1.0, 1.5, 0.2))},
        {"step": int(a.step[3]), "t": float(a.t[3]), "kind": "obstacle", "a": "hull", "b": "wall", "entity": a.entity,
         "point": _near(a, a.t[3])},
        {"step": int(b.step[1]), "t": float(b.t[1]), "kind": "terrain", "a": "hull", "b": "terrain", "entity": b.entity,
         "depth": 0.02},
        {"step": int(a.step[1]), "t": float(a.t[1]), "kind": "internal", "a": "gun", "b": "drum_left",
         "entity": a.entity},
        {"step": int(b.step[3]), "t": float(b.t[3]), "kind": "off_terrain", "a": "vehicle", "b": "terrain",
         "entity": b.entity, "status": "off"},
        # between rows 0 and 1 of a (1.3 s into a 2 s step)
        {"step": int(a.step[0]), "t": round(float(a.t[0]) + 1.3, 6), "kind": "vehicle", "a": a.entity, "b": b.entity,
         "entity": a.entity, "between": True, "point": _near(a, a.t[0], (3.0, -1.0, 0.8)), "closing_speed": 1.0,
         "a_step": int(a.step[0]), "b_step": int(b.step[0])},
    ]


def _records(data: bytes):
    """pcap -> (file header, [(sec, usec, frame)]) by the format's own layout."""
    assert data[:4] == b"\xd4\xc3\xb2\xa1"
    out, pos = [], 24
    while pos < len(data):
        sec, sub, incl, orig = struct.unpack_from("<IIII", data, pos)
        assert incl == orig
        out.append((sec, sub, data[pos + 16:pos + 16 + incl]))
        pos += 16 + incl
    assert pos == len(data)
    return data[:24], out


def _ones_sum(data: bytes) -> int:
    data += b"\0" * (len(data) % 2)
    s = sum(struct.unpack(f">{len(data) // 2}H", data))
    while s >> 16:
        s = (s & 0xFFFF) + (s >> 16)
    return s


@pytest.fixture
def exercise(tmp_path):
    entities = [(1, 1, 1), (1, 1, 2), (2, 5, 9)]
    times = [0.0, 2.0, 4.0, 6.0, 8.0]
    path = tmp_path / "ex.pcap"
    path.write_bytes(C.pcap(_frames(entities, times)))
    states, _ = read_capture(str(path))
    review = _review(states)
    review.events.extend(_events(review))
    return path, review


def _vehicle_of(entity):
    return vehicle_preset("m1" if entity == "1:1:2" else "t72")


def _decode(frame):
    """Ethernet + IPv4 + UDP (checked: lengths, IP and UDP checksums) -> (ports, addresses, the PDU bytes)."""
    assert struct.unpack(">H", frame[12:14])[0] == 0x0800
    ip = frame[14:34]
    assert ip[0] == 0x45 and ip[9] == 17
    total = struct.unpack(">H", ip[2:4])[0]
    assert _ones_sum(ip) == 0xFFFF  # the header checksum holds
    udp = frame[34:14 + total]
    sport, dport, ulen, check = struct.unpack(">HHHH", udp[:8])
    assert ulen == len(udp) == total - 20
    assert check == 0 or _ones_sum(ip[12:20] + struct.pack(">BBH", 0, 17, ulen) + udp) == 0xFFFF
    return (sport, dport), (ip[12:16], ip[16:20]), udp[8:]


def test_collision_pdus_in_the_capture(exercise, tmp_path):
    opendis = pytest.importorskip("opendis")
    from opendis.PduFactory import createPdu
    from scipy.spatial.transform import Rotation, Slerp

    path, review = exercise
    out = tmp_path / "out.pcap"
    n = write_collision_pdus(review, str(path), str(out), _vehicle_of)
    assert n == 4  # the wall once (not the second part, not the next row), the ground, the vehicles twice

    head_in, rec_in = _records(path.read_bytes())
    head_out, rec_out = _records(out.read_bytes())
    assert head_out == head_in
    originals = [r for r in rec_out if not _is_collision(r[2])]
    added = [(k, r) for k, r in enumerate(rec_out) if _is_collision(r[2])]
    assert originals == rec_in  # every packet, byte for byte, in order
    assert len(added) == n
    times = [sec + sub * 1e-6 for sec, sub, _ in rec_out]
    assert times == sorted(times)  # inserted in time order
    first = rec_in[0][0] + rec_in[0][1] * 1e-6

    # what each PDU should say, worked out here
    tracks = {tr.entity: tr for tr in review.tracks}
    to_ecef = pyproj.Transformer.from_crs(pyproj.CRS(CRS).to_3d(), "EPSG:4978", always_xy=True)
    expected = []
    for ev in review.events:
        if ev["kind"] == "vehicle":
            expected += [(ev, ev["a"], ev["b"]), (ev, ev["b"], ev["a"])]
        elif ev["kind"] in ("obstacle", "terrain") and ev["a"] == "hull" and ev["step"] != tracks[ev["entity"]].step[3]:
            expected.append((ev, ev["entity"], None))  # the first of each run (the wall's next row goes on)
    assert len(expected) == n
    decoded = []
    for k, (sec, sub, frame) in added:
        ports, addresses, payload = _decode(frame)
        pdu = createPdu(payload)
        assert type(pdu).__name__ == "CollisionPdu" and pdu.pduType == 4 and pdu.length == 60 == len(payload)
        decoded.append((sec + sub * 1e-6, ports, pdu, rec_out[k - 1]))
    for ev, issuer, other in expected:
        ids = tuple(int(v) for v in issuer.split(":"))
        match = [d for d in decoded if (d[2].issuingEntityID.siteID, d[2].issuingEntityID.applicationID,
                                        d[2].issuingEntityID.entityID) == ids and abs(d[0] - first - ev["t"]) < 2e-6]
        assert len(match) == 1, (ev, issuer)
        when, ports, pdu, _ = match[0]
        assert pdu.protocolVersion == 7 and pdu.exerciseID == 1 and pdu.protocolFamily == 1
        assert ports == ((3000, 3000) if issuer == "1:1:1" else (4002, 3000))
        got_other = (pdu.collidingEntityID.siteID, pdu.collidingEntityID.applicationID, pdu.collidingEntityID.entityID)
        assert got_other == (tuple(int(v) for v in other.split(":")) if other else (0, 0, 0))
        assert pdu.eventID.simulationAddress.site == ids[0] and pdu.eventID.simulationAddress.application == ids[1]
        assert pdu.collisionType == 0
        assert pdu.mass == pytest.approx(MASS_KG["m1" if issuer == "1:1:2" else "t72"])
        # the contact point in the issuer's DIS entity frame (x forward, y right, z down)
        tr = tracks[issuer]
        i = int(np.searchsorted(tr.t, ev["t"], side="right") - 1)
        j = min(i + 1, len(tr) - 1)
        f = (ev["t"] - tr.t[i]) / (tr.t[j] - tr.t[i])
        xyz = np.column_stack([tr.x, tr.y, tr.z])
        origin = xyz[i] + f * (xyz[j] - xyz[i])
        rots = Rotation.from_quat(np.column_stack([tr.quaternion[:, 1:], tr.quaternion[:, :1]]))
        rot = Slerp(tr.t, rots)([ev["t"]])[0]
        if "point" in ev:
            body = rot.inv().apply(np.asarray(ev["point"]) - origin)
        else:
            body = np.array([0.0, 0.0, _vehicle_of(issuer).ground_clearance])
        loc = np.array([pdu.location.x, pdu.location.y, pdu.location.z])
        np.testing.assert_allclose(loc, body * [1, -1, -1], atol=1e-5)
        # the velocity: the two rows' places in pyproj's ECEF, over their time
        e0, e1 = (np.array(to_ecef.transform(*xyz[r])) for r in (i, j))
        vel = np.array([pdu.velocity.x, pdu.velocity.y, pdu.velocity.z])
        np.testing.assert_allclose(vel, (e1 - e0) / (tr.t[j] - tr.t[i]), rtol=1e-5, atol=1e-5)
    # a contact at a row of its issuer comes right after that row's packet (the wall at a's third row)
    wall = [d for d in decoded if d[2].collidingEntityID.entityID == 0 and d[2].issuingEntityID.entityID == 1]
    assert len(wall) == 1
    before = wall[0][3][2]
    assert before[42 + 2] == 1 and struct.unpack(">3H", before[42 + 12:42 + 18]) == (1, 1, 1)
    assert wall[0][0] == wall[0][3][0] + wall[0][3][1] * 1e-6
    # event numbers count per issuing site and application
    by_app = {}
    for d in sorted(decoded, key=lambda d: d[0]):
        key = (d[2].issuingEntityID.siteID, d[2].issuingEntityID.applicationID)
        by_app.setdefault(key, []).append(d[2].eventID.eventNumber)
    assert all(v == list(range(1, len(v) + 1)) for v in by_app.values())


def _is_collision(frame):
    return len(frame) >= 14 + 20 + 8 + 12 and frame[12:14] == b"\x08\x00" and frame[23] == 17 \
        and frame[42 + 2] == 4 and struct.unpack(">H", frame[42 + 8:42 + 10])[0] == 60


def test_the_reader_reads_the_same_entity_states(exercise, tmp_path):
    path, review = exercise
    out = tmp_path / "out.pcap"
    n = write_collision_pdus(review, str(path), str(out), _vehicle_of)
    before, c0 = read_capture(str(path))
    after, c1 = read_capture(str(out))
    for name in ("t", "entity", "location", "orientation", "velocity", "version", "timestamp"):
        np.testing.assert_array_equal(getattr(after, name), getattr(before, name), err_msg=name)
    assert c1.pdu_types.get(4, 0) == c0.pdu_types.get(4, 0) + n
    assert c1.packets == c0.packets + n


def test_the_pdu_time_and_dis_timestamp(exercise, tmp_path):
    path, review = exercise
    out = tmp_path / "out.pcap"
    write_collision_pdus(review, str(path), str(out), _vehicle_of)
    _, recs = _records(out.read_bytes())
    ev = next(e for e in review.events if e["kind"] == "vehicle")
    first = recs[0][0] * 10 ** 6 + recs[0][1]
    hits = [r for r in recs if _is_collision(r[2]) and r[0] * 10 ** 6 + r[1] == first + round(ev["t"] * 1e6)]
    assert len(hits) == 2
    hits = [r for r in hits if struct.unpack(">3H", r[2][42 + 12:42 + 18]) == (1, 1, 1)]
    # the sender's clock style: entity 1:1:1's ES PDUs say (1000 + 2k) | 1, absolute, 2 s apart (rows 0, 1)
    stamp = struct.unpack(">I", hits[0][2][42 + 4:42 + 8])[0]
    assert stamp & 1 == 1
    assert abs((stamp >> 1) - (500 + round(1.3 * 2 ** 31 / 3600))) <= 1


def test_pcapng_keeps_its_blocks_and_adds_enhanced_packet_blocks(tmp_path):
    frames = _frames([(1, 1, 1), (1, 1, 2)], [0.0, 2.0, 4.0, 6.0])
    packets = [(0, round(ts * 10 ** 9), f) for ts, f in frames]
    data = C.pcapng([(1, 9, 262144)], packets)
    path = tmp_path / "ex.pcapng"
    path.write_bytes(data)
    states, _ = read_capture(str(path))
    review = _review(states)
    review.events.extend(e for e in _events(review) if e["kind"] == "vehicle")
    out = tmp_path / "out.pcapng"
    assert write_collision_pdus(review, str(path), str(out), _vehicle_of) == 2
    got = out.read_bytes()
    blocks_in, blocks_out = _blocks(data), _blocks(got)
    assert [b for b in blocks_out if not (b[0] == 6 and _is_collision(b[1][28:]))] == blocks_in
    added = [b for b in blocks_out if b[0] == 6 and _is_collision(b[1][28:])]
    assert len(added) == 2
    ev = review.events[0]
    t0 = round(frames[0][0] * 10 ** 9)
    for _, raw in added:
        iface, hi, lo = struct.unpack("<III", raw[8:20])
        assert iface == 0 and abs(((hi << 32) | lo) - (t0 + ev["t"] * 1e9)) < 2e3  # t has 6 decimals
    after, _ = read_capture(str(out))
    np.testing.assert_array_equal(after.t, states.t)


def _blocks(data):
    out, pos = [], 0
    while pos < len(data):
        btype, blen = struct.unpack_from("<II", data, pos)
        out.append((btype, data[pos:pos + blen]))
        pos += blen
    return out


def test_a_dis6_capture_gets_dis6_pdus(tmp_path):
    opendis = pytest.importorskip("opendis")  # noqa: F841
    from opendis.PduFactory import createPdu

    path = tmp_path / "six.pcap"
    path.write_bytes(C.pcap(_frames([(3, 4, 5), (3, 4, 6)], [0.0, 2.0, 4.0, 6.0], version=6)))
    states, _ = read_capture(str(path))
    review = _review(states)
    review.events.extend(e for e in _events(review) if e["kind"] == "vehicle")
    out = tmp_path / "out.pcap"
    assert write_collision_pdus(review, str(path), str(out), _vehicle_of) == 2
    _, recs = _records(out.read_bytes())
    pdus = [createPdu(_decode(r[2])[2]) for r in recs if _is_collision(r[2])]
    assert [p.protocolVersion for p in pdus] == [6, 6]
    assert {(p.issuingEntityID.entityID, p.collidingEntityID.entityID) for p in pdus} == {(5, 6), (6, 5)}


def test_a_capture_that_was_not_replayed_is_refused(exercise, tmp_path):
    path, review = exercise
    other = tmp_path / "other.pcap"
    other.write_bytes(C.pcap(_frames([(7, 7, 7)], [0.0, 2.0])))
    with pytest.raises(InputError, match="none of its entities"):
        write_collision_pdus(review, str(other), str(tmp_path / "o.pcap"), _vehicle_of)
    shifted = tmp_path / "shifted.pcap"
    shifted.write_bytes(C.pcap(_frames([(1, 1, 1), (1, 1, 2), (2, 5, 9)], [0.0, 2.5, 4.0, 6.0, 8.0])))
    with pytest.raises(InputError, match="no packet at that time"):
        write_collision_pdus(review, str(shifted), str(tmp_path / "o.pcap"), _vehicle_of)
    assert not (tmp_path / "o.pcap").exists()


def _poses_review(poses_csv, crs):
    """The review's tracks read back from a replay's poses CSV (by the csv module, per entity)."""
    import csv

    with open(poses_csv, newline="") as fh:
        rows = list(csv.DictReader(fh))
    tracks = []
    for name in dict.fromkeys(r["entity"] for r in rows):
        mine = [r for r in rows if r["entity"] == name]
        col = {k: np.array([float(r[k]) if r[k] not in ("", "nan") else np.nan for r in mine])
               for k in ("step", "t", "x", "y", "z", "yaw_deg", "qw", "qx", "qy", "qz")}
        status = np.array([("ok", "partly_off", "off").index(r["status"]) for r in mine], np.uint8)
        tracks.append(Track(name, col["step"].astype(np.int64), col["t"], col["x"], col["y"], col["z"], col["yaw_deg"],
                            np.column_stack([col[k] for k in ("qw", "qx", "qy", "qz")]), status))
    return tuple(tracks)


def write_head_on(tmp_path):
    """(capture, terrain): two T-72s on flat ground 30 m apart driving at each other at 3 m/s for 5 s
    at 2 Hz, as DIS 7 Entity State PDUs in a pcap, over a flat UTM GeoTIFF."""
    import rasterio
    from rasterio.transform import from_origin

    from tests.io.test_geodesy import _dis_euler_from_enu

    to_geo = pyproj.Transformer.from_crs(CRS, "EPSG:4326", always_xy=True)
    x0, y0 = pyproj.Transformer.from_crs("EPSG:4326", CRS, always_xy=True).transform(10.0, 50.0)
    x0, y0 = np.round(x0), np.round(y0)
    tif = tmp_path / "flat.tif"
    with rasterio.open(tif, "w", driver="GTiff", height=100, width=100, count=1, dtype="float32", crs=CRS,
                       transform=from_origin(x0 - 100, y0 + 100, 2.0, 2.0)) as dst:
        dst.write(np.full((100, 100), 150.0, np.float32), 1)
    frames = []
    for k in range(11):  # 0 to 5 s, 2 Hz
        t = 0.5 * k
        for ent, (x, yaw) in ((1, (x0 - 15 + 3 * t, 0.0)), (2, (x0 + 15 - 3 * t, np.pi))):
            lon, lat = to_geo.transform(x, y0)
            ori = _dis_euler_from_enu(yaw, 0.0, 0.0, lon, lat)
            frames.append((T0 + t + 0.001 * ent,
                           C.ethernet(C.ipv4(C.udp(C.es_dis7(1, 3, ent, ecef(lon, lat), ori, timestamp=1))))))
    path = tmp_path / "head_on.pcap"
    path.write_bytes(C.pcap(frames))
    return path, tif


def test_two_tanks_driven_into_each_other_replayed_then_written_back(tmp_path):
    """A real replay: two T-72s on flat ground 30 m apart, driving at each other at 3 m/s; the capture
    written back holds their contact as two Collision PDUs at the event's time."""
    import json

    from tankcd_cli import api

    path, tif = write_head_on(tmp_path)
    poses, events = tmp_path / "p.csv", tmp_path / "e.jsonl"
    api.replay_to_files(str(path), poses=str(poses), events=str(events), terrain=str(tif))
    evs = [json.loads(line) for line in events.read_text().splitlines()]
    contact = [e for e in evs if e["kind"] == "vehicle"]
    assert len(contact) == 1 and contact[0]["a"] == "1:3:1" and contact[0]["b"] == "1:3:2"
    review = Review(tracks=_poses_review(poses, CRS), events=evs, crs_wkt=pyproj.CRS(CRS).to_wkt())
    out = tmp_path / "out.pcap"
    n = write_collision_pdus(review, str(path), str(out), lambda e: vehicle_preset("t72"))
    assert n == 2 + sum(e["kind"] in ("obstacle", "terrain") for e in evs)
    _, recs = _records(out.read_bytes())
    first = recs[0][0] + recs[0][1] * 1e-6
    pdus = [(r[0] + r[1] * 1e-6 - first, struct.unpack(">3H3H", _decode(r[2])[2][12:24]), _decode(r[2])[2])
            for r in recs if _is_collision(r[2])]
    ev = contact[0]
    both = [p for p in pdus if abs(p[0] - ev["t"]) < 2e-6]
    assert sorted(p[1] for p in both) == [(1, 3, 1, 1, 3, 2), (1, 3, 2, 1, 3, 1)]
    for _, ids, payload in both:
        vx, vy, vz, mass, lx, ly, lz = struct.unpack(">3ff3f", payload[32:60])
        assert mass == pytest.approx(41500.0)
        assert np.hypot(np.hypot(vx, vy), vz) == pytest.approx(3.0, rel=1e-3)  # 3 m/s, the rows' difference
        # head on, guns level and forward: the muzzles meet first, each at its tank's muzzle in its own
        # frame: ahead by the ring's place, the trunnion's and the tube's length, up (z down) by the trunnion
        v = vehicle_preset("t72")
        assert ev["a_part"] == ev["b_part"] == "gun"
        assert lx == pytest.approx(v.turret_x + v.trunnion_forward + v.gun_length, abs=0.02), (ids, lx, ly, lz)
        assert ly == pytest.approx(0.0, abs=v.gun_radius + 0.01)
        assert lz == pytest.approx(-v.trunnion_height, abs=v.gun_radius + 0.01)


def _link_frames(link_of, entities, times):
    """The exercise's frames with the IPv4 datagrams re-framed by ``link_of(ip_packet)``."""
    out = []
    for ts, frame in _frames(entities, times):
        if frame[12:14] == b"\x08\x00":
            ip = frame[14:14 + struct.unpack(">H", frame[16:18])[0]]
            out.append((ts, link_of(ip)))
        else:
            out.append((ts, frame))
    return out


def _as_ipv6(ip4):
    """An IPv4 UDP datagram as the same UDP datagram over IPv6 (checksum 0 as the helpers write it)."""
    return C.ipv6(ip4[20:])


@pytest.mark.parametrize("link, link_of, ip_at", [
    (113, C.sll, 16), (276, C.sll2, 20), (101, lambda ip: ip, 0), (0, C.null, 4),
    (1, lambda ip: C.ethernet(ip, vlans=((0x8100, 7),)), 18),
    (1, lambda ip: C.ethernet(_as_ipv6(ip), ethertype=0x86DD), 14),
], ids=["sll", "sll2", "raw", "null", "vlan", "ipv6"])
def test_every_link_layer_the_reader_takes(tmp_path, link, link_of, ip_at):
    path = tmp_path / "l.pcap"
    frames = _link_frames(link_of, [(1, 1, 1), (1, 1, 2)], [0.0, 2.0, 4.0, 6.0])
    path.write_bytes(C.pcap(frames, link=link))
    states, c0 = read_capture(str(path))
    review = _review(states)
    review.events.extend(e for e in _events(review) if e["kind"] == "vehicle")
    out = tmp_path / "out.pcap"
    assert write_collision_pdus(review, str(path), str(out), _vehicle_of) == 2
    _, rec_in = _records(path.read_bytes())
    _, rec_out = _records(out.read_bytes())
    added = [r for r in rec_out if r not in rec_in]
    assert [r for r in rec_out if r in rec_in] == rec_in and len(added) == 2
    for sec, sub, frame in added:  # the issuer's own packet's link header, then a whole IP packet
        issuer = struct.unpack(">3H", frame[-60 + 12:-60 + 18])
        es = next(f for _, _, f in rec_in if len(f) > 144 and struct.unpack(">3H", f[-144 + 12:-144 + 18]) == issuer)
        assert frame[:ip_at] == es[:ip_at]
        ip = frame[ip_at:]
        if ip[0] >> 4 == 4:
            assert struct.unpack(">H", ip[2:4])[0] == len(ip) and _ones_sum(ip[:20]) == 0xFFFF
            pseudo = ip[12:20] + struct.pack(">BBH", 0, 17, len(ip) - 20)
            udp = ip[20:]
        else:
            assert struct.unpack(">H", ip[4:6])[0] == len(ip) - 40 and ip[6] == 17
            udp = ip[40:]
            pseudo = ip[8:40] + struct.pack(">IxxxB", len(udp), 17)
        assert struct.unpack(">H", udp[4:6])[0] == len(udp) == 68
        assert _ones_sum(pseudo + udp) == 0xFFFF  # the UDP checksum holds
    after, c1 = read_capture(str(out))
    np.testing.assert_array_equal(after.t, states.t)
    assert c1.pdu_types.get(4, 0) == 2 and c1.udp_not_dis == c0.udp_not_dis


@pytest.mark.parametrize("big", [False, True])
def test_a_big_endian_nanosecond_pcap_and_pcapng(tmp_path, big):
    frames = _frames([(1, 1, 1), (1, 1, 2)], [0.0, 2.0, 4.0, 6.0])
    for name, data in (("n.pcap", C.pcap(frames, big=big, nanos=True)),
                       ("n.pcapng", C.pcapng([(1, 9, 0)], [(0, round((ts - T0) * 1e9) + T0 * 10 ** 9, f)
                                                          for ts, f in frames], big=big))):
        path = tmp_path / name
        path.write_bytes(data)
        states, _ = read_capture(str(path))
        review = _review(states)
        review.events.extend(e for e in _events(review) if e["kind"] == "vehicle")
        out = tmp_path / ("out." + name)
        assert write_collision_pdus(review, str(path), str(out), _vehicle_of) == 2
        got = out.read_bytes()
        assert got[:24] == data[:24]
        after, counts = read_capture(str(out))
        np.testing.assert_array_equal(after.t, states.t)
        assert counts.pdu_types == {2: 1, 4: 2}
        e = ">" if big else "<"
        if name.endswith(".pcap"):  # the PDUs' times in nanoseconds: the first packet's + 1.3 s exactly
            pos, stamps = 24, []
            while pos < len(got):
                sec, sub, incl, _ = struct.unpack_from(e + "IIII", got, pos)
                if _is_collision(got[pos + 16:pos + 16 + incl]):
                    stamps.append(sec * 10 ** 9 + sub)
                pos += 16 + incl
            assert stamps == [T0 * 10 ** 9 + 1_300_000_000] * 2


def test_the_other_vehicle_when_it_is_no_dis_entity_is_0_0_0(exercise):
    from tankcd_cli.report.collision_pdus import collision_pdus

    _, review = exercise
    a = review.tracks[0]
    ev = {"step": int(a.step[1]), "t": float(a.t[1]), "kind": "vehicle", "a": a.entity, "b": "B", "entity": a.entity,
          "point": _near(a, a.t[1])}
    extra = Track("B", a.step, a.t, a.x + 5, a.y, a.z, a.yaw_deg, a.quaternion, a.status)
    both = Review(tracks=review.tracks + (extra,), events=[ev], crs_wkt=review.crs_wkt)
    pdus = collision_pdus(both, {t.entity for t in review.tracks}, _vehicle_of)
    assert [(p.issuer, p.other) for p in pdus] == [((1, 1, 1), (0, 0, 0))]


def test_standard_input_is_refused(exercise, tmp_path):
    _, review = exercise
    with pytest.raises(InputError, match="must be a file"):
        write_collision_pdus(review, "-", str(tmp_path / "o.pcap"), _vehicle_of)


def test_a_pcapng_of_two_sections_gets_each_pdu_in_its_issuers_section(tmp_path):
    frames = _frames([(1, 1, 1), (1, 1, 2)], [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0])
    ticks = [(round((ts - T0) * 1e6) + T0 * 10 ** 6, f) for ts, f in frames]
    cut = next(k for k, (tk, _) in enumerate(ticks) if tk >= (T0 + 7) * 10 ** 6)
    one = C.pcapng([(1, None, 0)], [(0, tk, f) for tk, f in ticks[:cut]])
    two = C.pcapng([(101, None, 0), (1, None, 0)], [(1, tk, f) for tk, f in ticks[cut:]], big=True)
    path = tmp_path / "two.pcapng"
    path.write_bytes(one + two)
    states, _ = read_capture(str(path))
    review = _review(states)
    a, b = review.tracks[0], review.tracks[1]
    for t in (1.3, 9.3, 12.5):  # the last after every packet: at the end of the second section
        review.events.append({"step": 0, "t": t, "kind": "vehicle", "a": a.entity, "b": b.entity,
                              "entity": a.entity, "point": _near(a, t)})
    out = tmp_path / "out.pcapng"
    assert write_collision_pdus(review, str(path), str(out), _vehicle_of) == 6
    got = out.read_bytes()
    assert got.startswith(one[:28])  # its section header
    head_two = got.index(two[:12])
    first, second = _blocks(got[:head_two]), got[head_two:]
    pos, blocks_two = 0, []
    while pos < len(second):
        btype, blen = struct.unpack_from(">II", second, pos)
        blocks_two.append((btype, second[pos:pos + blen]))
        pos += blen
    assert sum(b[0] == 6 and _is_collision(b[1][28:]) for b in first) == 2
    added_two = [b for b in blocks_two if b[0] == 6 and _is_collision(b[1][28:])]
    assert len(added_two) == 4 and all(struct.unpack(">I", b[1][8:12])[0] == 1 for b in added_two)
    assert blocks_two[-1] in added_two  # the one after every packet closes its section
    assert [b for b in first if not (b[0] == 6 and _is_collision(b[1][28:]))] == _blocks(one)
    after, counts = read_capture(str(out))
    np.testing.assert_array_equal(after.t, states.t)
    assert counts.pdu_types[4] == 6


@pytest.mark.parametrize("suffix", ["pcap", "pcapng"])
def test_wireshark_decodes_the_collision_pdus_with_good_checksums(tmp_path, suffix):
    """Wireshark's own DIS dissector (tshark, where installed) on the output: every Collision PDU whole,
    its IP and UDP checksums good, its ids and time as the events say; nothing malformed."""
    import shutil
    import subprocess

    tshark = shutil.which("tshark")
    if tshark is None:
        pytest.skip("tshark (Wireshark) not installed")
    frames = _frames([(1, 1, 1), (1, 1, 2), (2, 5, 9)], [0.0, 2.0, 4.0, 6.0, 8.0])
    path = tmp_path / f"ex.{suffix}"
    path.write_bytes(C.pcap(frames) if suffix == "pcap" else
                     C.pcapng([(1, 6, 0)], [(0, round((ts - T0) * 1e6) + T0 * 10 ** 6, f) for ts, f in frames]))
    states, _ = read_capture(str(path))
    review = _review(states)
    review.events.extend(_events(review))
    out = tmp_path / f"out.{suffix}"
    assert write_collision_pdus(review, str(path), str(out), _vehicle_of) == 4
    dis = ["-d", "udp.port==3000,dis", "-d", "udp.port==4002,dis", "-d", "udp.port==4003,dis"]
    got = subprocess.run([tshark, "-r", str(out), *dis, "-o", "ip.check_checksum:TRUE", "-o", "udp.check_checksum:TRUE",
                          "-Y", "dis.pdu_type==4", "-T", "fields", "-e", "frame.time_epoch", "-e", "ip.checksum.status",
                          "-e", "udp.checksum.status", "-e", "dis.proto_ver", "-e", "dis.entity_id_site",
                          "-e", "dis.entity_id_application", "-e", "dis.entity_id_entity"],
                         capture_output=True, text=True, check=True).stdout.split("\n")
    rows = sorted(line.split("\t") for line in got if line)
    want = sorted([[f"{T0 + 1}.300000000", "1", "1", "7", "1,1", "1,1", "1,2"],
                   [f"{T0 + 1}.300000000", "1", "1", "7", "1,1", "1,1", "2,1"],
                   [f"{T0 + 2}.000100000", "1", "1", "7", "1,0", "1,0", "2,0"],  # the ground under 1:1:2's row
                   [f"{T0 + 4}.000000000", "1", "1", "7", "1,0", "1,0", "1,0"]])  # the wall at 1:1:1's row
    assert rows == want
    bad = subprocess.run([tshark, "-r", str(out), *dis, "-Y", "_ws.malformed or _ws.expert.severity >= error"],
                         capture_output=True, text=True, check=True).stdout
    assert bad.strip() == ""


def test_one_pdu_where_a_contact_begins(exercise):
    from tankcd_cli.report.collision_pdus import collision_pdus

    _, review = exercise
    a = review.tracks[0]

    def wall(row, t, part="hull", between=False, b="wall"):
        ev = {"step": int(a.step[row]), "t": t, "kind": "obstacle", "a": part, "b": b, "entity": a.entity,
              "point": _near(a, a.t[row])}
        return {**ev, "between": True} if between else ev

    review = Review(tracks=review.tracks, crs_wkt=review.crs_wkt, events=[
        wall(0, 0.5, between=True), wall(0, 0.6, "track_left", between=True),  # begins along 0-1, two parts
        wall(1, float(a.t[1])), wall(2, float(a.t[2])),  # going on at rows 1 and 2
        wall(2, float(a.t[2]), b="tree"),  # another obstacle: its own
        wall(3, float(a.t[3]) + 0.5, between=True),  # off the wall at row 3, on again along 3-4
        wall(4, float(a.t[4]), "track_right"),  # going on
    ])
    pdus = collision_pdus(review, {a.entity}, _vehicle_of)
    assert [p.t for p in pdus] == [0.5, float(a.t[2]), float(a.t[3]) + 0.5]


def test_no_contact_gives_the_capture_byte_for_byte(exercise, tmp_path):
    path, review = exercise
    quiet = Review(tracks=review.tracks, crs_wkt=review.crs_wkt,
                   events=[e for e in review.events if e["kind"] in ("internal", "off_terrain")])
    out = tmp_path / "same.pcap"
    assert write_collision_pdus(quiet, str(path), str(out), _vehicle_of) == 0
    assert out.read_bytes() == path.read_bytes()
