"""The pose table: replay's poses as every output format encodes them (the poses CSV, JSON-free
arrays for the Python API, Parquet): its columns in order, their types, the labels of its coded
columns, and the rule for cells without a value (docs/formats.md, "Poses CSV")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.names import CLASS_NAMES, NO_CLASS_NAME, NO_MATCHER, PLACED_BY, STATUS

COLUMNS = ("step", "t", "x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg", "qw", "qx", "qy", "qz",
           "region", "matcher", "penetration", "gap", "status")
# each column's type: int64, float64 (NaN: no value, the CSV's empty cell) or coded (labels by code)
TYPES = {"step": "int64", **{c: "float64" for c in COLUMNS[1:12]}, "region": "coded", "matcher": "coded",
         "penetration": "float64", "gap": "float64", "status": "coded"}
REGION_LABELS = CLASS_NAMES + (NO_CLASS_NAME,)  # a region outside the classes is the last
KEPT_WITHOUT_POSE = ("t", "x", "y", "yaw_deg")  # what a row without a pose (status off) still says


@dataclass
class PoseTable:
    """A chunk of poses as the table's columns (N rows).

    step : (N,) int64
    numbers : float64 (N,) arrays keyed t, x .. qz, penetration, gap (metres, seconds, degrees):
        NaN where the row has no value (a row without a pose keeps ``KEPT_WITHOUT_POSE``;
        penetration and gap only where both were measured on a pose)
    codes : int64 (N,) arrays keyed region, matcher, status: codes into ``labels``
    labels : the coded columns' labels (matcher ``none`` for a row without a pose)
    """

    step: np.ndarray
    numbers: dict
    codes: dict
    labels: dict

    def named(self, column: str) -> np.ndarray:
        """A coded column as its labels, (N,) str."""
        return np.array(self.labels[column])[self.codes[column]]


def pose_table(step, t, poses, matcher_names=PLACED_BY, status_names=STATUS) -> PoseTable:
    """The table of a chunk of poses (``matching.match.Poses``, angles in radians) at ``step``,
    ``t`` (N,) each."""
    deg = np.degrees
    pos = np.asarray(poses.position, dtype=np.float64)
    q = np.asarray(poses.quaternion, dtype=np.float64)
    numbers = {"t": np.asarray(t, dtype=np.float64), "x": pos[:, 0], "y": pos[:, 1], "z": pos[:, 2],
               "roll_deg": deg(poses.roll), "pitch_deg": deg(poses.pitch), "yaw_deg": deg(poses.yaw),
               "qw": q[:, 0], "qx": q[:, 1], "qy": q[:, 2], "qz": q[:, 3]}
    # a row has a pose when the pose's own numbers are finite (its time does not decide: ``api.place``
    # gives none; a replay's rows always have one)
    posed = np.logical_and.reduce([np.isfinite(v) for k, v in numbers.items() if k != "t"])
    for name in numbers:
        if name not in KEPT_WITHOUT_POSE:
            numbers[name] = np.where(posed, numbers[name], np.nan)
        else:
            numbers[name] = np.array(numbers[name], dtype=np.float64)
    penetration = np.asarray(poses.penetration, dtype=np.float64)
    gap = np.asarray(poses.gap, dtype=np.float64)
    measured = np.isfinite(penetration) & np.isfinite(gap) & posed
    numbers["penetration"] = np.where(measured, penetration, np.nan)
    numbers["gap"] = np.where(measured, gap, np.nan)
    region = np.asarray(poses.region, dtype=np.int64)
    status = np.asarray(poses.status, dtype=np.int64)
    # a row without a pose was placed by no matcher
    matcher = np.where(status == list(status_names).index("off"), len(matcher_names),
                       np.asarray(poses.matcher, dtype=np.int64))
    codes = {"region": np.where((region >= 0) & (region < 3), region, 3), "matcher": matcher, "status": status}
    labels = {"region": REGION_LABELS, "matcher": (*matcher_names, NO_MATCHER), "status": tuple(status_names)}
    return PoseTable(np.asarray(step, dtype=np.int64), numbers, codes, labels)
