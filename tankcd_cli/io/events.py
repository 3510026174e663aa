"""Events as JSON Lines: one object per line with at least step, t, kind, a, b."""

from __future__ import annotations

import json
import math


def event_line(step: int, t: float, kind: str, a: str, b: str, **extra) -> str:
    record = {"step": int(step), "t": None if t is None or not math.isfinite(t) else round(float(t), 6),
              "kind": kind, "a": a, "b": b}
    for key, value in extra.items():
        record[key] = value
    return json.dumps(record, separators=(",", ":")) + "\n"
