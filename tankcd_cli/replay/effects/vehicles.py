"""Many vehicles in one world: every contact between two vehicles along their motions.

Each vehicle's motion is a sequence of rigid segments (``replay.between_rows.Segments``: its
sub-steps between two placements, with their time spans), produced chunk by chunk as the
trajectory streams. Two vehicles can touch only where both move, so the check runs over the
common spans of their segments:

1. **Time windows.** Windows lie on the grid ``k * WINDOW``. A window runs from a start bucket (a
   grid cell in which some segment begins) to the next one: a cell in which no segment begins holds
   only segments going on from the window before, and is checked with it, so the work follows the
   segments, not the exercise's time span (a billion seconds without a row cost nothing). A window
   [w0, w1) needs every segment with t0 < w1 and t1 >= w0; the segments reaching past w1 are kept
   for the next.

   *Rows in time order* (the vehicles interleaved, as simulators and captures send them): segments
   are buffered until every vehicle still sending rows has rows past a window's end (the watermark:
   the earliest last row time over the vehicles heard from within ``HORIZON`` seconds of the
   latest row); the window is then complete. Memory follows the window and the watermark's lag (a
   sender's gap between updates), not the exercise's length.

   *Rows in any other order* (grouped by vehicle, as per-vehicle loggers and ``sort`` write them; a
   vehicle silent past the horizon; any mix): a first pass over the times (``OrderCheck``, run by
   ``replay.run.in_time_order``) plays the watermark and finds the first row whose motion would
   come after its window closed. Then the segments are spilled to an unnamed temporary file by
   start bucket (``SegmentSpill``) as the chunks stream, and once the trajectory has ended the
   buckets are read back in time order through the same windows: the same events as the rows in
   time order (their steps each file's own), in memory of a few windows' segments. Input that
   cannot be read twice (standard input, a pipe, a one-pass iterator) is spilled.
2. **Broad phase** (``collision.broad_phase.candidate_pairs``): each segment's box (the box its
   groups' spheres sweep, ``collision.pair_gate``: hull, turret and gun each in a sphere that moves
   with the hull origin, so no point of the vehicle leaves the box over the segment) and time span
   clipped to the window; pairs of different vehicles whose boxes and spans overlap. The cost grows
   with the vehicles and the pairs that come close.

   *The pair gate* (``collision.pair_gate``; off with the gates): each pair of vehicles among the
   candidates is tested over the whole window (spheres of its rigid groups about one line per
   vehicle, apart under their relative motion), then span by span where that proves nothing; a
   span proven free of contact takes no narrow phase, and gives no event either way. Counted as
   the gate ``vehicle_pairs``.
3. **Narrow phase** (``collision.vehicles.first_vehicle_contacts``): both segments cut to their
   common span (still rigid motions), every group of one against every group of the other, both
   moving, with the guarantees of ``bvh.sweep``: never missed, a pass within 1 mm may count, the
   time of first contact to 0.5 mm of travel.
4. **One event per contact.** A span whose vehicles already touch at its start continues a
   contact (tested exactly at that instant) and gives no event, unless the span is where one of
   the two begins to exist (its first row, or a new piece of its motion): then the contact is
   there from the start and is reported at that instant. So a contact is reported once, in the
   span where it begins, whichever window, chunk or segment boundaries cut its time. A contact the
   sweep finds along the motion began between rows: ``"between": true``, as every other kind; one
   at the instant a vehicle begins to exist is at that row and carries none.

**Why any order gives the same events.** A window's events are a union over pairs of segments,
each pair's common span checked on its own, so they depend on the set of segments overlapping the
window and on the window's ends only, not on the order segments arrive in. The windows are the
same in both modes: their ends are the start buckets, a property of the segments. In time order
every segment with t0 < w1 is buffered when [w0, w1) closes: the window closes only once the next
start bucket at or after w1 is known and lies at or before the watermark, and a vehicle still
sending rows adds its next segment from its last row, at or after the watermark; a vehicle that
appears, or resumes after the horizon, starts its motion at or after the highest watermark so far
(``OrderCheck`` proves, before the replay, that no row breaks this). The spill holds every segment. The poses do
not depend on the order at all (each vehicle's motion is carried by its code).

With the first pass deciding, a segment that begins before the windows already checked cannot
arrive in the streaming mode; should one all the same (a caller feeding ``VehicleContacts`` itself),
its motion before those windows is not checked against the other vehicles, and a set-up warning
says so (``--strict``: exit 3), never silently.
"""

from __future__ import annotations

import tempfile

import numpy as np

from tankcd_cli.collision.broad_phase import candidate_pairs
from tankcd_cli.collision.pair_gate import GroupSpheres, clear_spans, group_spheres, stretch_spheres
from tankcd_cli.collision.vehicles import SpanMotion, first_vehicle_contacts
from tankcd_cli.errors import warn
from tankcd_cli.gates import GateTally
from tankcd_cli.geometry.motion import quaternion_slerp
from tankcd_cli.replay.between_rows import Segments
from tankcd_cli.replay.effects.effect import Effect, Event, EventKind
from tankcd_cli.vehicle import Vehicle

WINDOW = 2.0  # s: the time windows vehicle contacts are searched in
HORIZON = 30.0  # s: a vehicle silent longer than this no longer holds the windows back


class VehicleContacts:
    """The exercise's vehicle-against-vehicle checks, fed chunk by chunk (``add``), emitting events as
    windows close (``ready``) and at the end (``finish``)."""

    def __init__(self, world, continuous: bool = True, window: float | None = None, horizon: float | None = None,
                 source: str = "trajectory", ordered: bool = True, gates: GateTally | None = None):
        self.world = world
        self.gates = GateTally() if gates is None else gates  # ``vehicle_pairs``: spans proven clear
        self.continuous = continuous
        self.window = WINDOW if window is None else window
        self.horizon = HORIZON if horizon is None else horizon
        self.buffer = []  # pieces (kind index, Segments sorted by start bucket, their buckets): ``_piece``
        self.names: tuple = ()
        self.last_t = np.zeros(0)  # each entity code's last row time
        self.done_k = None  # the windows before window done_k (index on the grid k * window) are processed
        self.end = -np.inf  # the latest segment end added
        self.spill = None if ordered else SegmentSpill(self.window)
        self.latest = -np.inf
        self.queries = 0
        self.late = 0  # segments that began before the windows already checked
        self.first_late = None  # (step, entity code, t0, windows checked up to) of the first, not yet said
        self.source = source

    # -- feeding -------------------------------------------------------------------------------
    def add(self, kind, segments) -> None:
        """A kind of vehicle's rigid segments from one chunk. Motion that begins before the windows
        already checked (a vehicle silent for longer than the horizon, or rows out of time order
        across vehicles: one vehicle's rows after another's) cannot be checked against the vehicles
        there any more: a set-up warning names the first such vehicle and row, ``finish`` how many
        more."""
        if segments is None or not len(segments):
            return
        self.end = max(self.end, float(segments.t1.max()))
        if self.spill is not None:
            self.spill.append(kind.index, segments)
            return
        self.buffer.append(self._piece(kind.index, segments))
        if self.done_until is not None:
            late = np.flatnonzero(segments.t0 < self.done_until)
            if len(late):
                if self.late == 0:
                    k = late[0]
                    self.first_late = (int(segments.step[k]), int(segments.entity[k]), float(segments.t0[k]),
                                       self.done_until)
                self.late += len(late)

    def _say_late(self) -> None:
        """The warning of the first late motion, once the names of the chunk that brought it are known."""
        if self.first_late is None:
            return
        step, code, t0, done = self.first_late
        self.first_late = None
        name = self.names[code] if code < len(self.names) else str(code)
        self._warn(f"row {step}: entity {name!r} moves from t = {t0:g} s, after the contacts between vehicles up "
                   f"to t = {done:g} s were checked (its rows came more than {self.horizon:g} s late, or the rows "
                   "are not in time order across vehicles): contacts with other vehicles before then are not "
                   "checked; give the rows in time order (sort by t), or replay the file itself")

    def _warn(self, what: str) -> None:
        warn(self.source, what)

    def add_rows(self, kind, chunk, poses) -> None:
        """Rows of a discrete replay: no motion between them, so no contact between vehicles is
        checked (they need the motion; the summary says the mode)."""

    def _observe(self, chunk) -> None:
        if chunk is None or not len(chunk):
            return
        self.names = chunk.entity_names
        codes = chunk.entity
        size = max(len(self.names), int(codes.max()) + 1)
        if size > len(self.last_t):
            self.last_t = np.concatenate([self.last_t, np.full(size - len(self.last_t), -np.inf)])
        np.maximum.at(self.last_t, codes, chunk.t)
        self.latest = max(self.latest, float(chunk.t.max()))
        if self.done_k is None:
            self.done_k = int(np.floor(chunk.t.min() / self.window))

    @property
    def done_until(self) -> float | None:
        """The time before which every window is processed (None before the first rows)."""
        return None if self.done_k is None else self.done_k * self.window

    def watermark(self) -> float:
        """The time up to which every vehicle still sending rows has sent them."""
        heard = self.last_t[np.isfinite(self.last_t)]
        live = heard[heard >= self.latest - self.horizon]
        return float(live.min()) if len(live) else self.latest

    def ready(self, chunk) -> list:
        """After a chunk: the contacts of every window the watermark has passed (none while spilling:
        they all come at ``finish``)."""
        self._observe(chunk)
        self._say_late()
        if self.done_k is None or self.spill is not None:
            return []
        return self._close(self.watermark())

    def _close(self, mark: float | None) -> list:
        """Close the windows whose segments are all known: every segment beginning before ``mark`` has
        been added (None: the trajectory has ended, every window). Windows run from one start bucket
        (a window in which a segment begins) to the next: a window in which none begins holds only
        segments going on from the one before it, and is checked with it (``_window`` over the span
        of both), so the cost follows the segments, not the exercise's time span."""
        events = []
        while self.buffer:
            # each piece's start buckets are sorted: its first is its least, and the first above k is found by search
            k = max(self.done_k, min(int(b[0]) for _, _, b in self.buffer))
            later = []
            for _, _, bucket in self.buffer:
                i = int(np.searchsorted(bucket, k, side="right"))
                if i < len(bucket):
                    later.append(int(bucket[i]))
            if later:
                m = min(later)
                if mark is not None and m * self.window > mark:
                    break
                events += self._window(k * self.window, m * self.window)
                self.done_k = m
            elif mark is None:
                m = int(np.floor(self.end / self.window)) + 1
                events += self._window(k * self.window, m * self.window, last=True)
                self.done_k = m
                self.buffer = []
            else:
                break
        if not self.buffer and mark is not None and np.isfinite(mark):
            # nothing buffered: no segment begins before the watermark in the windows up to it
            self.done_k = max(self.done_k, int(np.floor(mark / self.window)))
        return events

    def finish(self) -> list:
        """The contacts of every window left, once the trajectory has ended (all of them when the
        segments were spilled: the spill's buckets in time order, through the same windows)."""
        if self.done_k is None:
            self.close()
            return []
        if self.spill is not None:
            try:
                events = self._finish_spill()
            finally:
                self.close()
        else:
            events = self._close(None)
        self.buffer = []
        self._say_late()
        if self.late > 1:
            self._warn(f"{self.late:,} stretches of motion in all began before the contacts between vehicles "
                       "there were checked (see above)")
        return events

    def _finish_spill(self) -> list:
        """The spilled segments' windows: each start bucket's segments join the buffer (those going on
        from earlier windows), and the window runs to the next start bucket, as ``_close`` runs them."""
        events = []
        k = None
        for bucket, kinds, segments in self.spill.buckets():
            if k is not None:
                events += self._window(k * self.window, bucket * self.window)
            self.buffer += [self._piece(int(kind), segments.take(np.flatnonzero(kinds == kind)))
                            for kind in np.unique(kinds)]
            k = bucket
        if k is not None:
            events += self._window(k * self.window, (int(np.floor(self.end / self.window)) + 1) * self.window,
                                   last=True)
        return events

    def close(self) -> None:
        """Remove the spill file, if any (``finish`` does; a replay that fails calls it too)."""
        if self.spill is not None:
            self.spill.close()

    def close_window(self, w0: float, w1: float, last: bool = False) -> list:
        """The contacts that begin in the window [w0, w1) among the segments buffered (``add``), for a
        caller that decides itself when a window is complete (``replay.windows``: a task given every
        segment its windows need); the buffer keeps only what reaches past ``w1``, as ``ready`` does."""
        return self._window(w0, w1, last)

    # -- one window ----------------------------------------------------------------------------
    def _piece(self, kind: int, segments: Segments) -> tuple:
        """A piece of the buffer: a kind's segments sorted by their start bucket floor(t0 / window)
        (stable: within a bucket each vehicle's segments stay together, in time order), and the
        buckets, so that a window reads only each piece's head (``_window``)."""
        bucket = np.floor(segments.t0 / self.window).astype(np.int64)
        if len(bucket) > 1 and not (np.diff(bucket) >= 0).all():
            offset = bucket - bucket.min()
            # a chunk spans few windows: a 16-bit key sorts by radix, in linear time
            key = offset.astype(np.int16) if offset.max() < np.iinfo(np.int16).max else offset
            order = np.argsort(key, kind="stable")
            segments, bucket = segments.take(order), bucket[order]
        return kind, segments, bucket

    def _window(self, w0: float, w1: float, last: bool = False) -> list:
        """Every contact that begins in [w0, w1) (its end included at the last window)."""
        if not self.buffer:
            return []
        # only segments beginning before w1 (at w1 too, at the last window) can be in the window: each
        # piece's head. Division rounds monotonically, so a bucket below floor(w1 / window) holds only
        # starts before w1 and one above it only starts after w1; that bucket's own segments are
        # compared with w1. The rest of a piece waits untouched (a view), and of the head, what reaches
        # past w1 is kept: the later windows still need it
        edge = int(np.floor(w1 / self.window))
        kinds, parts, pieces, heads = [], [], [], {}
        for k, piece, bucket in self.buffer:
            p0, p1 = int(np.searchsorted(bucket, edge, "left")), int(np.searchsorted(bucket, edge, "right"))
            t0 = piece.t0[p0:p1]
            begun = t0 <= w1 if last else t0 < w1
            if begun.all() or not begun.any():
                p = p1 if begun.all() else p0
                head = piece.take(slice(0, p))
                rest, rest_bucket = piece.take(slice(p, None)), bucket[p:]
            else:  # some of the edge bucket's segments begin in the window, some after it (w1 off the grid)
                inside_edge = p0 + np.flatnonzero(begun)
                head = piece.take(np.r_[np.arange(p0), inside_edge])
                after = np.r_[p0 + np.flatnonzero(~begun), np.arange(p1, len(piece))]
                rest, rest_bucket = piece.take(after), bucket[after]
            if len(rest):
                base = rest.t0.base
                if base is not None and 2 * len(rest) < base.size:  # a view holding a chunk twice its size: copied
                    rest, rest_bucket = rest.take(np.arange(len(rest))), rest_bucket.copy()
                pieces.append((k, rest, rest_bucket))
            if len(head) == 0:
                continue
            inside = np.flatnonzero(head.t1 >= w0)
            parts.append(head.take(inside))
            kinds.append(np.full(len(inside), k, dtype=np.int64))
            going_on = np.flatnonzero(head.t1 >= w1)
            if len(going_on):
                heads.setdefault(k, []).append(head.take(going_on))
        pieces += [self._piece(k, Segments.join(h) if len(h) > 1 else h[0]) for k, h in heads.items()]
        self.buffer = pieces
        if sum(len(x) for x in parts) < 2:
            return []
        s = Segments.join(parts) if len(parts) > 1 else parts[0]
        k = np.concatenate(kinds)
        spheres = self._spheres(s, k)
        lo, hi = _sphere_boxes(spheres, s.c0, s.c1)
        t0 = np.maximum(s.t0, w0)
        t1 = np.minimum(s.t1, w1)
        pairs = candidate_pairs(lo, hi, t0, t1, s.entity)
        if len(pairs) == 0:
            return []
        i, j = pairs[:, 0], pairs[:, 1]
        u0 = np.maximum(t0[i], t0[j])
        u1 = np.minimum(t1[i], t1[j])
        # half-open windows: a span starting at w1 is the next window's (the last window keeps its end);
        # segments meeting end to start share an instant, which the span after it holds
        own = ((u0 < w1) | last) & (u1 > u0)
        i, j, u0, u1 = i[own], j[own], u0[own], u1[own]
        # the span begins where one of the two vehicles begins to exist: a contact there is new
        fresh = (s.fresh[i] & (u0 == s.t0[i])) | (s.fresh[j] & (u0 == s.t0[j]))
        if self.gates.enabled and len(i):
            keep = ~self._clear(s, spheres, i, j, u0, u1, w0, w1)
            i, j, u0, u1, fresh = i[keep], j[keep], u0[keep], u1[keep], fresh[keep]
        return self._spans(s, k, i, j, u0, u1, fresh)

    def _spheres(self, s, kinds) -> GroupSpheres:
        """The group spheres (``collision.pair_gate.group_spheres``) of the window's segments ``s``,
        each by its kind's body."""
        offset = np.zeros((len(s), 3, 3))
        radius = np.full((len(s), 3), np.nan)
        for kind in np.unique(kinds):
            sel = np.flatnonzero(kinds == kind)
            g = group_spheres(self.world.kinds[int(kind)].body, s.q0[sel], s.c0[sel], s.q1[sel], s.turret0[sel],
                              s.dturret[sel], s.gun0[sel], s.dgun[sel])
            offset[sel], radius[sel] = g.offset, g.radius
        return GroupSpheres(offset, radius)

    def _clear(self, s, spheres, i, j, u0, u1, w0, w1) -> np.ndarray:
        """(P,) bool: the common spans [u0, u1] of segments i and j that ``collision.pair_gate`` proves
        free of contact (they need no narrow phase): first each pair of vehicles over the whole window
        (each vehicle's spheres about one line, ``stretch_spheres``: one test for all the pair's
        spans), then span by span for the pairs that test leaves. Counted in the gates as
        ``vehicle_pairs``: per pair of vehicles with candidate spans in the window, asked about, and
        skipped when every one of its spans is proven clear. ``spheres``: the segments' group spheres."""
        offset, radius = spheres.offset, spheres.radius
        paired = np.zeros(len(s), dtype=bool)
        paired[i] = paired[j] = True
        # the window's vehicles, numbered 0..n-1, and the pairs of them
        segs = np.flatnonzero(paired)
        vehicles, owner = np.unique(s.entity[segs], return_inverse=True)
        code = np.zeros(len(s), dtype=np.int64)
        code[segs] = owner.reshape(-1)
        n = len(vehicles)
        va, vb = np.minimum(code[i], code[j]), np.maximum(code[i], code[j])
        pair, where = np.unique(va * n + vb, return_inverse=True)
        where = where.reshape(-1)
        line = stretch_spheres(code[segs], n, GroupSpheres(offset[segs], radius[segs]), s.t0[segs], s.t1[segs],
                               s.c0[segs], s.c1[segs], w0, w1)
        pa, pb = pair // n, pair % n
        ones = np.ones(len(pair))
        pair_clear = clear_spans(line.spheres.take(pa), line.t0[pa], line.t1[pa], line.c0[pa], line.c1[pa],
                                 line.spheres.take(pb), line.t0[pb], line.t1[pb], line.c0[pb], line.c1[pb],
                                 w0 * ones, w1 * ones)
        clear = pair_clear[where]
        rest = np.flatnonzero(~clear)
        if len(rest):
            a, b = i[rest], j[rest]
            clear[rest] = clear_spans(GroupSpheres(offset[a], radius[a]), s.t0[a], s.t1[a], s.c0[a], s.c1[a],
                                      GroupSpheres(offset[b], radius[b]), s.t0[b], s.t1[b], s.c0[b], s.c1[b],
                                      u0[rest], u1[rest])
        unproven = np.zeros(len(pair), dtype=bool)
        np.logical_or.at(unproven, where, ~clear)
        self.gates.add("vehicle_pairs", len(pair), int((~unproven).sum()))
        return clear

    def _spans(self, s, kinds, i, j, u0, u1, fresh) -> list:
        """The contacts that begin in the common spans [u0, u1] of segments i and j (``fresh``: the
        span begins where one of them begins to exist)."""
        events = []
        # each pair in the order of its entities' names, so that a is the first name
        names = np.asarray(self.names, dtype=object)
        swap = names[s.entity[i]] > names[s.entity[j]]
        i, j = np.where(swap, j, i), np.where(swap, i, j)
        for ka in np.unique(kinds[i]):
            for kb in np.unique(kinds[j]):
                sel = np.flatnonzero((kinds[i] == ka) & (kinds[j] == kb))
                if len(sel) == 0:
                    continue
                body_a = self.world.kinds[int(ka)].body
                body_b = self.world.kinds[int(kb)].body
                ma = _cut(s, i[sel], u0[sel], u1[sel])
                mb = _cut(s, j[sel], u0[sel], u1[sel])
                self.queries += len(sel)
                # a contact already there at the span's start continues one that began before it: the
                # exact test at that instant (one tree walk) spares such spans the sweep, which would
                # find them too (they touch at s = 0) and give no event
                every = np.arange(len(sel))
                at_start = np.zeros(len(sel), dtype=bool)
                at_start[first_vehicle_contacts(body_a, _still(ma, every), body_b, _still(mb, every),
                                                describe=False).span] = True
                sweep = np.flatnonzero(~at_start | fresh[sel])
                if len(sweep) == 0:
                    continue
                sel = sel[sweep]
                hits = first_vehicle_contacts(body_a, ma.take(sweep), body_b, mb.take(sweep))
                if len(hits.span) == 0:
                    continue
                at_first = at_start[sweep][hits.span]
                touching = at_first & ~fresh[sel[hits.span]]
                for h in np.flatnonzero(~touching):
                    q = sel[hits.span[h]]
                    a, b = i[q], j[q]
                    span = u1[q] - u0[q]
                    t = float(u0[q] if at_first[h] else u0[q] + hits.s[h] * span)
                    speed = float(hits.closing[h] / span) if span > 0 else 0.0
                    events.append(Event(int(s.step[a]), t, "vehicle", str(names[s.entity[a]]), str(names[s.entity[b]]),
                                        {"a_part": body_a.part_names[hits.part_a[h]],
                                         "b_part": body_b.part_names[hits.part_b[h]],
                                         "point": [round(float(c), 4) for c in hits.point[h]],
                                         "closing_speed": round(speed, 4), "a_step": int(s.step[a]),
                                         "b_step": int(s.step[b]),
                                         # found along the motion, not where a vehicle begins to exist (a row)
                                         **({} if at_first[h] else {"between": True}),
                                         "entity": str(names[s.entity[a]])},
                                        int(s.entity[a])))
        events.sort(key=lambda e: (e.t, e.a, e.b))
        return events


def _sphere_boxes(spheres: GroupSpheres, c0: np.ndarray, c1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each segment's world box (lo, hi (M, 3) m) holding its vehicle throughout: the union over its
    groups of the box swept by the group's sphere, whose centre moves with the hull origin from c0
    to c1 (``collision.pair_gate``: every point of the group stays in that sphere over the segment).
    Tighter than the origin's two places grown by the body's radius (any articulation, 8.16 m for a
    T-72) wherever the parts lie to one side: two hulls 12 m abreast, turrets forward, do not pair."""
    lo = hi = None
    for g in range(spheres.offset.shape[1]):  # three groups: pairwise, not a reduction over a short axis
        r = spheres.radius[:, g, None]
        start, end = c0 + spheres.offset[:, g], c1 + spheres.offset[:, g]
        with np.errstate(invalid="ignore"):
            low, high = np.minimum(start, end) - r, np.maximum(start, end) + r
        # an absent group's NaN never decides
        lo, hi = (low, high) if lo is None else (np.fmin(lo, low), np.fmax(hi, high))
    return lo, hi


def _cut(s, idx, u0, u1):
    """Segments ``idx`` cut to the spans [u0, u1] (still rigid motions), as a SpanMotion."""
    length = s.t1[idx] - s.t0[idx]
    safe = np.where(length > 0, length, 1.0)
    a = np.where(length > 0, (u0 - s.t0[idx]) / safe, 0.0)
    b = np.where(length > 0, (u1 - s.t0[idx]) / safe, 0.0)
    q0, q1 = s.q0[idx], s.q1[idx]
    c0, c1 = s.c0[idx], s.c1[idx]
    return SpanMotion(quaternion_slerp(q0, q1, a), c0 + a[:, None] * (c1 - c0), quaternion_slerp(q0, q1, b),
                      c0 + b[:, None] * (c1 - c0), s.turret0[idx] + a * s.dturret[idx], (b - a) * s.dturret[idx],
                      s.gun0[idx] + a * s.dgun[idx], (b - a) * s.dgun[idx])


def _still(m, idx):
    """The motions ``idx`` frozen at their start (an instant: the exact test, no motion bound)."""

    z = np.zeros(len(idx))
    return SpanMotion(m.q0[idx], m.c0[idx], m.q0[idx], m.c0[idx], m.turret0[idx], z, m.gun0[idx], z)


class SegmentSpill:
    """The vehicles' segments of an exercise whose rows are not in time order, on disk until the
    trajectory has ended: one unnamed temporary file (the system's temp dir; gone when closed, and
    with the process), each batch of segments (a chunk's, of one kind) sorted by start bucket
    (``floor(t0 / window)``) and appended, with an index of (bucket group, offset, count) per batch.
    ``buckets`` then gives them back bucket by bucket in time order, reading one group of
    ``GROUP`` buckets at a time: memory follows the segments of ``GROUP`` windows and the index (a
    few numbers per chunk and group), not the exercise."""

    GROUP = 16  # windows read back at a time

    def __init__(self, window: float):
        self.window = window
        self.file = tempfile.TemporaryFile(prefix="tankcd-segments-")
        self.records = 0
        self.index: list = []  # (groups (E,), offsets (E,), counts (E,)) per batch

    def append(self, kind: int, segments) -> None:
        bucket = np.floor(segments.t0 / self.window).astype(np.int64)
        order = np.argsort(bucket, kind="stable")
        rec = np.empty(len(order), dtype=SPILL_DTYPE)
        rec["kind"] = kind
        for f in segments.__dataclass_fields__:
            rec[f] = getattr(segments, f)[order]
        rec["bucket"] = bucket[order]
        group = rec["bucket"] // self.GROUP
        first = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
        counts = np.diff(np.r_[first, len(group)])
        self.file.seek(self.records * SPILL_DTYPE.itemsize)
        rec.tofile(self.file)
        self.index.append((group[first], self.records + first, counts))
        self.records += len(rec)

    def buckets(self):
        """(bucket, kinds (M,), Segments) for every start bucket holding segments, in time order; within
        a bucket the segments in the order they were added."""
        if not self.index:
            return
        groups = np.concatenate([g for g, _, _ in self.index])
        offsets = np.concatenate([o for _, o, _ in self.index])
        counts = np.concatenate([c for _, _, c in self.index])
        order = np.argsort(groups, kind="stable")  # batches in the order added, within a group
        groups, offsets, counts = groups[order], offsets[order], counts[order]
        cut = np.flatnonzero(np.r_[True, groups[1:] != groups[:-1], True])
        fields = Segments.__dataclass_fields__
        for a, b in zip(cut[:-1], cut[1:]):
            parts = []
            for off, n in zip(offsets[a:b], counts[a:b]):
                self.file.seek(int(off) * SPILL_DTYPE.itemsize)
                parts.append(np.fromfile(self.file, dtype=SPILL_DTYPE, count=int(n)))
            rec = np.concatenate(parts)
            rec = rec[np.argsort(rec["bucket"], kind="stable")]
            edge = np.flatnonzero(np.r_[True, rec["bucket"][1:] != rec["bucket"][:-1], True])
            for i, j in zip(edge[:-1], edge[1:]):
                r = rec[i:j]
                yield int(r["bucket"][0]), r["kind"], Segments(*(np.ascontiguousarray(r[f]) for f in fields))

    def close(self) -> None:
        self.file.close()


SPILL_DTYPE = np.dtype([("kind", "<i8"), ("bucket", "<i8"), ("entity", "<i8"), ("step", "<i8"), ("t0", "<f8"),
                        ("t1", "<f8"), ("q0", "<f8", (4,)), ("c0", "<f8", (3,)), ("q1", "<f8", (4,)),
                        ("c1", "<f8", (3,)), ("turret0", "<f8"), ("dturret", "<f8"), ("gun0", "<f8"),
                        ("dgun", "<f8"), ("fresh", "?")])


class OrderCheck:
    """Whether an exercise's rows, read in its chunks, let the streaming windows (``VehicleContacts``
    fed in order) see every segment before its window closes: a pass over the times and entities
    only, playing the watermark. A segment starts at a vehicle's row and is added with the chunk of
    the vehicle's next row; every window closed by then ends at or before the highest watermark
    after the chunks before this one (``closed``: the watermark falls when a vehicle appears, but a
    closed window stays closed). So the rows are in time order here when every row's vehicle's
    previous row, or the row itself for a vehicle's first, is at or after ``closed`` (a vehicle
    silent past the horizon, a vehicle appearing after the others' windows closed, a vehicle's rows
    after another's: not in order). ``observe`` per chunk returns False at the first chunk that
    breaks it."""

    def __init__(self, horizon: float | None = None):
        self.horizon = HORIZON if horizon is None else horizon
        self.last_t = np.zeros(0)
        self.latest = -np.inf
        self.closed = -np.inf
        self.ordered = True

    def observe(self, chunk) -> bool:
        if not self.ordered or chunk is None or not len(chunk):
            return self.ordered
        codes = chunk.entity if chunk.entity is not None else np.zeros(len(chunk), dtype=np.int64)
        size = int(codes.max()) + 1
        if size > len(self.last_t):
            self.last_t = np.r_[self.last_t, np.full(size - len(self.last_t), -np.inf)]
        # the earliest motion each row can start: from the vehicle's previous row (in the chunk, or
        # the one carried from before), or from the row itself for the vehicle's first
        order = np.argsort(codes, kind="stable")
        c, t = codes[order], chunk.t[order]
        first = np.r_[True, c[1:] != c[:-1]]
        prev = np.where(first, self.last_t[c], np.r_[-np.inf, t[:-1]])
        start = np.where(np.isfinite(prev), prev, t)
        if float(start.min()) < self.closed:
            self.ordered = False
        np.maximum.at(self.last_t, codes, chunk.t)
        self.latest = max(self.latest, float(chunk.t.max()))
        heard = self.last_t[np.isfinite(self.last_t)]
        live = heard[heard >= self.latest - self.horizon]
        self.closed = max(self.closed, float(live.min()) if len(live) else self.latest)
        return self.ordered


class Vehicles(Effect):
    """Every two vehicles of an exercise against each other along their motions (``VehicleContacts``):
    not a vehicle's own check, so it has no row or motion check of its own; the run feeds it each
    kind's rigid segments (``replay.between_rows.Segments``) and takes its events as windows close.
    Run only when the trajectory has entities, and counted as the summary's ``vehicle_contacts``."""

    name = "vehicles"
    kinds = (EventKind("vehicle", True, None, "#000000", "contact between vehicles"),)
    stage = 3
    own = False

    def runs(self, vehicle: Vehicle, obstacles: bool, turret_moves: bool) -> bool:
        return False  # a vehicle alone: nothing to meet (an exercise starts it: ``start``)

    def start(self, world, continuous: bool, source: str, ordered: bool,
              gates: GateTally | None = None) -> VehicleContacts:
        """The checks between the vehicles of an exercise in ``world`` (``ordered``: its rows in time
        order across vehicles, else spilled and checked at the end; ``gates``: the run's tally, whose
        switch decides whether the pair gate runs)."""
        return VehicleContacts(world, continuous=continuous, source=source, ordered=ordered, gates=gates)


VEHICLES = Vehicles()
