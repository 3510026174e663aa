"""Reviews for the page's tests, built here (not by the report's reader): small ones by hand, and
one from a replay's poses CSV and events JSON Lines read with the csv and json modules."""

from __future__ import annotations

import csv
import json

import numpy as np

from tankcd_cli.report.review import STATUS, Review, Source, Track


def track(name: str, t, x, y, yaw_deg) -> Track:
    t = np.asarray(t, dtype=float)
    n = len(t)
    q = np.zeros((n, 4))
    q[:, 0] = 1.0
    return Track(name, np.arange(n, dtype=np.int64), t, np.asarray(x, dtype=float), np.asarray(y, dtype=float),
                 np.full(n, 100.0), np.asarray(yaw_deg, dtype=float), q, np.zeros(n, dtype=np.uint8))


def small_review() -> Review:
    """Three vehicles on a 240 m x 160 m terrain at (500000, 4500000): a weaving one, a straight
    one that starts later (off the terrain for 5 s, then partly off for 1 s), one that turns on
    the spot; four events of four kinds."""
    t = np.arange(0.0, 60.0, 0.1)
    alpha = track("alpha", t, 500020 + 2 * t, 4500050 + 10 * np.sin(t / 5), np.degrees(np.arctan2(2 * np.cos(t / 5), 2)))
    bravo = track("bravo", t + 5, 500150 - 1.5 * t, 4500040 + 0.5 * t, np.full(len(t), 160.0))
    bravo.status[100:150] = 2  # off the terrain, then partly off
    bravo.status[150:160] = 1
    charlie = track("charlie", t[:200], np.full(200, 500200.0), np.full(200, 4500120.0), np.linspace(170, 530, 200))
    events = [
        {"step": 100, "t": 10.0, "kind": "obstacle", "a": "hull", "b": "wall", "point": [500040.0, 4500050.0, 101.0],
         "contacts": 1, "entity": "alpha"},
        {"step": 300, "t": 35.25, "kind": "vehicle", "a": "alpha", "b": "bravo", "a_part": "hull", "b_part": "gun",
         "point": [500090.0, 4500060.0, 101.0], "closing_speed": 3.5, "a_step": 300, "b_step": 302, "between": True,
         "entity": "alpha"},
        {"step": 400, "t": 45.0, "kind": "terrain", "a": "hull", "b": "terrain", "depth": 0.02, "entity": "bravo"},
        {"step": 50, "t": 5.05, "kind": "internal", "a": "gun", "b": "drum_left", "turret_deg": 170.0, "gun_deg": -4.0,
         "between": True, "entity": "charlie"},
    ]
    return Review((alpha, bravo, charlie), events, "", (Source("poses", "poses.csv", "ab" * 32),
                                                        Source("events", "events.jsonl", "cd" * 32)),
                  {"matcher": "auto", "mode": "continuous"}, "0.1.0")


def read_replay(poses: str, events: str, sources=(), settings=None) -> Review:
    """A Review of a replay's poses CSV (one vehicle or an exercise) and events JSON Lines."""
    with open(poses, newline="") as fh:
        rows = list(csv.DictReader(fh))
    order: list = []
    by_entity: dict = {}
    for row in rows:
        name = row.get("entity", "")
        if name not in by_entity:
            by_entity[name] = []
            order.append(name)
        by_entity[name].append(row)
    tracks = []
    for name in order:
        rs = by_entity[name]

        def col(key, rs=rs):
            return np.array([float(r[key]) if r[key] != "" else np.nan for r in rs])

        q = np.stack([col(k) for k in ("qw", "qx", "qy", "qz")], axis=1)
        status = np.array([STATUS.index(r["status"]) for r in rs], dtype=np.uint8)
        tracks.append(Track(name, np.array([int(r["step"]) for r in rs], dtype=np.int64), col("t"), col("x"), col("y"),
                            col("z"), col("yaw_deg"), q, status))
    with open(events) as fh:
        evs = [json.loads(line) for line in fh if line.strip()]
    return Review(tuple(tracks), evs, "", tuple(sources), dict(settings or {}), "0.1.0")
