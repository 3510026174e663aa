# The framing pass of dis.py: pcap records and pcapng packet blocks -> link layer -> IPv4/IPv6 -> UDP ->
# the DIS PDUs in the payload, walked by their length fields. Entity State PDUs come out as byte offsets
# (decoded afterwards by numpy over a structured dtype); everything else is counted. A loop over
# packets in Python walks about 1.7M bare pcap records a second before any parsing: too slow for
# the 1M PDUs a second dis.py must decode, hence this kernel.

from libc.stdint cimport int64_t, uint8_t, uint16_t, uint32_t, uint64_t

# counters (the order of dis.COUNT_NAMES)
cdef enum:
    C_PACKETS = 0
    C_NOT_IP = 1
    C_NOT_UDP = 2
    C_IPV6_EXT = 3
    C_FRAGMENTS = 4
    C_FIRST_FRAGMENTS = 5
    C_UDP_NOT_DIS = 6
    C_DIS_PACKETS = 7
    C_PDUS_CUT = 8
    C_TRAILING = 9
    C_ES = 10
    C_ES_V4 = 11
    C_MALFORMED = 12
    C_LINK_UNKNOWN = 13
    C_NO_TIME = 14
    C_TRUNCATED = 15

# statuses (dis.py names them)
cdef enum:
    S_OK = 0        # out of data or out of room: call again
    S_LONG = 1      # an Entity State PDU's length is longer than the UDP payload holds
    S_SHORT = 2     # ... shorter than its layout with its articulation records
    S_BLOCK = 3     # pcapng: a block that is not a packet block starts here (the caller reads it)
    S_CORRUPT = 4   # a record or block header that cannot be (err: packet, value)
    S_INTERFACE = 5 # pcapng: a packet on an interface no IDB described (err: packet, interface)
    S_TRAILER = 6   # pcapng: a block's trailing length is not its leading one (err: packet, leading, trailing)

MAX_RECORD = 1 << 22  # 4 MiB: a bigger record is a corrupt header (the outputs need room for its PDUs)
cdef int64_t _MAX_RECORD = MAX_RECORD


cdef inline uint32_t be16(const uint8_t* p) noexcept nogil:
    return (<uint32_t>p[0] << 8) | p[1]


cdef inline uint32_t be32(const uint8_t* p) noexcept nogil:
    return (<uint32_t>p[0] << 24) | (<uint32_t>p[1] << 16) | (<uint32_t>p[2] << 8) | p[3]


cdef inline uint32_t le32(const uint8_t* p) noexcept nogil:
    return (<uint32_t>p[3] << 24) | (<uint32_t>p[2] << 16) | (<uint32_t>p[1] << 8) | p[0]


cdef inline uint32_t rd32(const uint8_t* p, bint big) noexcept nogil:
    return be32(p) if big else le32(p)


cdef inline uint32_t rd16(const uint8_t* p, bint big) noexcept nogil:
    return ((<uint32_t>p[0] << 8) | p[1]) if big else ((<uint32_t>p[1] << 8) | p[0])


cdef inline bint _vlan(uint32_t etype) noexcept nogil:
    return etype == 0x8100 or etype == 0x88a8 or etype == 0x9100


cdef inline bint _ipv6_extension(uint32_t nh) noexcept nogil:
    return nh == 0 or nh == 43 or nh == 44 or nh == 60 or nh == 51 or nh == 50 or nh == 135 \
        or nh == 139 or nh == 140 or nh == 253 or nh == 254


cdef int _packet(const uint8_t* d, int64_t caplen, int link, int64_t packet, int64_t sec, double frac,
                 int64_t base, int64_t* out_off, int64_t* out_pkt, int64_t* out_sec, double* out_frac,
                 int64_t* n_out, int64_t* counts, int64_t* types, int64_t* err, bint cut) noexcept nogil:
    """One captured packet ``d[:caplen]`` (at ``base`` in the buffer): count it, note its ES PDUs.
    ``cut``: the capture holds less of it than was sent (its snap length): counted as truncated, and
    where its captured bytes end before a header or a PDU's head, nothing else is said of it (its
    whole PDUs before that are decoded)."""
    cdef int64_t off = 0, ihl, total, ip_end, l4, ulen, declared, data_end, p, remd, L, need
    cdef uint32_t etype = 0, fam, frag, nh
    cdef int ipver = 0, ver, typ, pfam, nart
    cdef bint first_fragment = False, is_dis = False, es
    cdef const uint8_t* ip
    cdef const uint8_t* h
    if cut:
        counts[C_TRUNCATED] += 1
    # the link layer
    if link == 1 or link == 113:  # Ethernet (802.1Q/802.1ad tags), Linux cooked (SLL)
        off = 14 if link == 1 else 16
        if caplen < off:
            if not cut:
                counts[C_MALFORMED] += 1
            return S_OK
        etype = be16(d + off - 2)
        while _vlan(etype) and off + 4 <= caplen:
            etype = be16(d + off + 2)
            off += 4
        if etype == 0x0800:
            ipver = 4
        elif etype == 0x86dd:
            ipver = 6
    elif link == 276:  # Linux cooked v2 (SLL2): the protocol first
        off = 20
        if caplen < off:
            if not cut:
                counts[C_MALFORMED] += 1
            return S_OK
        etype = be16(d)
        if etype == 0x0800:
            ipver = 4
        elif etype == 0x86dd:
            ipver = 6
    elif link == 101 or link == 12 or link == 14 or link == 228 or link == 229:  # raw IP
        if caplen >= 1:
            ipver = d[0] >> 4
    elif link == 0 or link == 108:  # BSD loopback: the address family, host order (0) or network order (108)
        off = 4
        if caplen < off:
            if not cut:
                counts[C_MALFORMED] += 1
            return S_OK
        fam = be32(d) if link == 108 else le32(d)
        if fam > 0xffff:  # written on a host of the other byte order
            fam = le32(d) if link == 108 else be32(d)
        if fam == 2:
            ipver = 4
        elif fam == 10 or fam == 24 or fam == 28 or fam == 30:
            ipver = 6
    else:
        counts[C_LINK_UNKNOWN] += 1
        return S_OK
    if ipver != 4 and ipver != 6:
        if not (cut and caplen <= off):
            counts[C_NOT_IP] += 1
        return S_OK
    # the network layer
    ip = d + off
    if ipver == 4:
        if caplen - off < 20 or (ip[0] >> 4) != 4:
            if not (cut and caplen - off < 20):
                counts[C_MALFORMED] += 1
            return S_OK
        ihl = (ip[0] & 15) * 4
        total = be16(ip + 2)
        if ihl < 20 or caplen - off < ihl or total < ihl:
            if not (cut and ihl >= 20 and total >= ihl):
                counts[C_MALFORMED] += 1
            return S_OK
        frag = be16(ip + 6)
        if (frag & 0x1fff) != 0:  # not the first fragment: no UDP header here
            counts[C_FRAGMENTS] += 1
            return S_OK
        if ip[9] != 17:
            counts[C_NOT_UDP] += 1
            return S_OK
        first_fragment = (frag & 0x2000) != 0
        l4 = off + ihl
        ip_end = off + total
    else:
        if caplen - off < 40 or (ip[0] >> 4) != 6:
            if not (cut and caplen - off < 40):
                counts[C_MALFORMED] += 1
            return S_OK
        nh = ip[6]
        if nh != 17:
            if _ipv6_extension(nh):
                counts[C_IPV6_EXT] += 1
            else:
                counts[C_NOT_UDP] += 1
            return S_OK
        l4 = off + 40
        ip_end = l4 + be16(ip + 4)
    # UDP
    if l4 + 8 > caplen or l4 + 8 > ip_end:
        if not (cut and l4 + 8 > caplen and l4 + 8 <= ip_end):
            counts[C_MALFORMED] += 1
        return S_OK
    ulen = be16(d + l4 + 4)
    if ulen == 0 and ipver == 6:  # a jumbogram: the IP payload length says
        ulen = ip_end - l4
    if ulen < 8:
        counts[C_MALFORMED] += 1
        return S_OK
    declared = l4 + ulen  # the datagram's end as its header declares it
    if first_fragment:
        counts[C_FIRST_FRAGMENTS] += 1
    elif ip_end < declared:  # a UDP length beyond its IP packet: the payload is what the IP packet holds
        declared = ip_end
    data_end = caplen if caplen < ip_end else ip_end  # what the capture holds (the snap length, a fragment)
    # the PDUs, back to back
    p = l4 + 8
    while True:
        remd = declared - p
        if remd < 12:
            if remd > 0:
                if is_dis:
                    counts[C_TRAILING] += 1
                else:
                    counts[C_UDP_NOT_DIS] += 1
            break
        if p + 20 > data_end:
            if is_dis or (cut and data_end == caplen):  # a PDU's head cut by the snap length
                counts[C_PDUS_CUT] += 1
            else:
                counts[C_UDP_NOT_DIS] += 1
            break
        h = d + p
        ver = h[0]
        typ = h[2]
        pfam = h[3]
        L = be16(h + 8)
        if ver < 4 or ver > 7 or typ == 0 or pfam > 13:
            if is_dis:
                counts[C_TRAILING] += 1
            else:
                counts[C_UDP_NOT_DIS] += 1
            break
        es = typ == 1 and pfam == 1
        if es and ver >= 5:
            nart = h[19]
            need = 144 + 16 * nart
            if L > remd:
                err[0] = packet
                err[1] = L
                err[2] = remd
                err[3] = nart
                return S_LONG
            if L < need:
                err[0] = packet
                err[1] = L
                err[2] = need
                err[3] = nart
                return S_SHORT
            is_dis = True
            if p + L > data_end:
                counts[C_PDUS_CUT] += 1
                break
            out_off[n_out[0]] = base + p
            out_pkt[n_out[0]] = packet
            out_sec[n_out[0]] = sec
            out_frac[n_out[0]] = frac
            n_out[0] += 1
            counts[C_ES] += 1
        else:
            if L < 12 or L > remd:
                if is_dis:
                    counts[C_TRAILING] += 1
                else:
                    counts[C_UDP_NOT_DIS] += 1
                break
            is_dis = True
            if es:
                counts[C_ES_V4] += 1
            else:
                types[typ] += 1
            if p + L > data_end:
                counts[C_PDUS_CUT] += 1
                break
        p += L
    if is_dis:
        counts[C_DIS_PACKETS] += 1
    return S_OK


def walk_pcap(const uint8_t[::1] buf, Py_ssize_t pos, bint big, bint nanos, int link, int64_t packet, int64_t limit,
              int64_t[::1] out_off, int64_t[::1] out_pkt, int64_t[::1] out_sec, double[::1] out_frac,
              int64_t[::1] counts, int64_t[::1] types, int64_t[::1] err, int64_t[::1] first_sec,
              double[::1] first_frac):
    """Walk the pcap records of ``buf`` from ``pos`` (a record header) while they are complete and the
    ES PDUs out stay within ``limit`` (a first packet may exceed it) and the outputs' room. ``packet``:
    packets walked before. ``first_sec``/``first_frac``: the first packet's timestamp, set by the call
    that walks it (``first_sec[0] < 0`` before). Returns (pos, packet, n_out, status)."""
    cdef int64_t n = buf.shape[0], cap = out_off.shape[0], n_out = 0, caplen, sec, room
    cdef const uint8_t* d = &buf[0] if n else NULL
    cdef int status = S_OK
    cdef double scale = 1e-9 if nanos else 1e-6
    with nogil:
        while pos + 16 <= n:
            caplen = rd32(d + pos + 8, big)
            if caplen > _MAX_RECORD:
                err[0] = packet + 1
                err[1] = caplen
                status = S_CORRUPT
                break
            room = caplen // 144 + 1  # the most ES PDUs the packet can hold
            if pos + 16 + caplen > n or (n_out > 0 and n_out + room > limit) or n_out + room > cap:
                break
            packet += 1
            counts[C_PACKETS] += 1
            sec = rd32(d + pos, big)
            if first_sec[0] < 0:
                first_sec[0] = sec
                first_frac[0] = rd32(d + pos + 4, big) * scale
            status = _packet(d + pos + 16, caplen, link, packet, sec, rd32(d + pos + 4, big) * scale, pos + 16,
                             &out_off[0], &out_pkt[0], &out_sec[0], &out_frac[0], &n_out, &counts[0], &types[0],
                             &err[0], caplen < rd32(d + pos + 12, big))
            if status != S_OK:
                break
            pos += 16 + caplen
    return pos, packet, n_out, status


def walk_pcapng(const uint8_t[::1] buf, Py_ssize_t pos, bint big, int64_t packet, int64_t limit,
                const int64_t[::1] if_link, const uint64_t[::1] if_units, const int64_t[::1] if_offset,
                const int64_t[::1] if_snap, int64_t[::1] last_sec, double[::1] last_frac,
                int64_t[::1] out_off, int64_t[::1] out_pkt, int64_t[::1] out_sec, double[::1] out_frac,
                int64_t[::1] counts, int64_t[::1] types, int64_t[::1] err, int64_t[::1] first_sec,
                double[::1] first_frac):
    """Walk the packet blocks (EPB, SPB, the obsolete PB) of one pcapng section from ``pos`` while they
    are complete and the ES PDUs out stay within ``limit`` and the outputs' room; stop at any other block
    (status S_BLOCK, ``pos`` at it).
    Interface k: link type, timestamp units per second, offset (s) and snap length (0: none).
    ``last_sec``/``last_frac`` hold the latest timestamp (an SPB has none: it takes that one);
    ``first_sec``/``first_frac`` the first (set by the call that meets it; ``first_sec[0] < 0`` before).
    Returns (pos, packet, n_out, status)."""
    cdef int64_t n = buf.shape[0], cap = out_off.shape[0], n_out = 0, blen, caplen, sec, room, n_if = if_link.shape[0]
    cdef int64_t origlen
    cdef uint32_t btype, ifid
    cdef uint64_t ticks, units
    cdef double frac
    cdef const uint8_t* d = &buf[0] if n else NULL
    cdef const uint8_t* b
    cdef int status = S_OK, data
    with nogil:
        while pos + 8 <= n:
            b = d + pos
            btype = rd32(b, big)
            if btype != 6 and btype != 3 and btype != 2:
                status = S_BLOCK
                break
            blen = rd32(b + 4, big)
            if blen < 12 or blen % 4 != 0 or blen > _MAX_RECORD:
                err[0] = packet + 1
                err[1] = blen
                status = S_CORRUPT
                break
            room = blen // 144 + 1
            if pos + blen > n or (n_out > 0 and n_out + room > limit) or n_out + room > cap:
                break
            if <int64_t>rd32(b + blen - 4, big) != blen:  # a block cut short, or bytes that are no block
                err[0] = packet + 1
                err[1] = blen
                err[2] = rd32(b + blen - 4, big)
                status = S_TRAILER
                break
            if btype == 3:  # simple packet block: interface 0, no timestamp
                if blen < 16 or n_if == 0:
                    err[0] = packet + 1
                    err[1] = blen if n_if else -1
                    status = S_CORRUPT if n_if else S_INTERFACE
                    break
                ifid = 0
                caplen = rd32(b + 8, big)
                origlen = caplen
                if caplen > blen - 16:
                    caplen = blen - 16
                if if_snap[0] > 0 and caplen > if_snap[0]:
                    caplen = if_snap[0]
                data = 12
                sec = last_sec[0]
                frac = last_frac[0]
                if sec < 0:
                    counts[C_NO_TIME] += 1
            else:
                if blen < 32:
                    err[0] = packet + 1
                    err[1] = blen
                    status = S_CORRUPT
                    break
                ifid = rd32(b + 8, big) if btype == 6 else rd16(b + 8, big)
                caplen = rd32(b + 20, big)
                origlen = rd32(b + 24, big)
                if 28 + caplen + 4 > blen:
                    err[0] = packet + 1
                    err[1] = caplen
                    status = S_CORRUPT
                    break
                if ifid >= n_if:
                    err[0] = packet + 1
                    err[1] = ifid
                    status = S_INTERFACE
                    break
                data = 28
                ticks = (<uint64_t>rd32(b + 12, big) << 32) | rd32(b + 16, big)
                units = if_units[ifid]
                sec = <int64_t>(ticks // units) + if_offset[ifid]
                frac = <double>(ticks % units) / <double>units
                last_sec[0] = sec
                last_frac[0] = frac
                if first_sec[0] < 0:
                    first_sec[0] = sec
                    first_frac[0] = frac
            packet += 1
            counts[C_PACKETS] += 1
            status = _packet(b + data, caplen, <int>if_link[ifid], packet, sec, frac, pos + data,
                             &out_off[0], &out_pkt[0], &out_sec[0], &out_frac[0], &n_out, &counts[0], &types[0],
                             &err[0], caplen < origlen)
            if status != S_OK:
                break
            pos += blen
    return pos, packet, n_out, status
