"""Poses CSV (the contract's output of ``replay``, input of ``collide``)."""

from __future__ import annotations

import numpy as np

COLUMNS = ("step", "t", "x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg", "qw", "qx", "qy", "qz",
           "region", "matcher", "penetration", "gap", "status")
REGION_NAMES = {0: "flat", 1: "general", 2: "uneven", 255: "unknown"}


def header() -> str:
    return ",".join(COLUMNS) + "\n"


def format_rows(step, t, poses, matcher_names, status_names) -> str:
    """CSV text of a chunk of poses. Numbers a pose does not have (status ``off``) are left empty."""
    deg = np.degrees
    cols = [step, t, poses.position[:, 0], poses.position[:, 1], poses.position[:, 2], deg(poses.roll),
            deg(poses.pitch), deg(poses.yaw), poses.quaternion[:, 0], poses.quaternion[:, 1],
            poses.quaternion[:, 2], poses.quaternion[:, 3]]
    fmts = ["%d", "%.6f", "%.4f", "%.4f", "%.4f", "%.5f", "%.5f", "%.5f", "%.8f", "%.8f", "%.8f", "%.8f"]
    text_cols = []
    for values, fmt in zip(cols, fmts):
        values = np.asarray(values)
        strs = np.char.mod(fmt, values) if values.dtype.kind != "f" else _fmt_float(values, fmt)
        text_cols.append(strs)
    text_cols.append(np.array([REGION_NAMES.get(int(r), "unknown") for r in poses.region], dtype=object))
    text_cols.append(np.asarray(matcher_names, dtype=object)[poses.matcher])
    text_cols.append(_fmt_float(poses.penetration, "%.4f"))
    text_cols.append(_fmt_float(poses.gap, "%.4f"))
    text_cols.append(np.asarray(status_names, dtype=object)[poses.status])
    rows = zip(*[c.tolist() for c in text_cols])
    return "".join(",".join(r) + "\n" for r in rows)


def _fmt_float(values: np.ndarray, fmt: str) -> np.ndarray:
    out = np.char.mod(fmt, np.nan_to_num(values, nan=0.0)).astype(object)
    out[~np.isfinite(values)] = ""
    return out
