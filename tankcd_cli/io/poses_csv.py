"""Poses CSV (docs/formats.md): the output of ``replay``, the input of ``collide``."""

from __future__ import annotations

import numpy as np

from tankcd_cli.io.fixed_text import table_text
from tankcd_cli.io.pose_table import COLUMNS, pose_table
from tankcd_cli.names import CLASS_NAMES, NO_CLASS, NO_CLASS_NAME, NO_MATCHER, PLACED_BY, STATUS

REGION_NAMES = {**dict(enumerate(CLASS_NAMES)), NO_CLASS: NO_CLASS_NAME}


def header(entity: bool = False) -> str:
    """The poses CSV's header line; with ``entity`` (a trajectory of many vehicles) an ``entity``
    column after ``step``."""
    return ",".join(COLUMNS[:1] + (("entity",) if entity else ()) + COLUMNS[1:]) + "\n"


_ROW = "%d,%.6f,%.4f,%.4f,%.4f,%.5f,%.5f,%.5f,%.8f,%.8f,%.8f,%.8f,%s,%s,%.4f,%.4f,%s\n"
_ROW_NO_MEASURE = "%d,%.6f,%.4f,%.4f,%.4f,%.5f,%.5f,%.5f,%.8f,%.8f,%.8f,%.8f,%s,%s,,,%s\n"


_DECIMALS = np.array([0, 6, 4, 4, 4, 5, 5, 5, 8, 8, 8, 8, 4, 4])
_NUMBERS = ("t", "x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg", "qw", "qx", "qy", "qz", "penetration", "gap")
# output columns in COLUMNS order: (0, j) is number j, (1, j) label column j (region, matcher, status)
_LAYOUT = np.array([(0, j) for j in range(12)] + [(1, 0), (1, 1), (0, 12), (0, 13), (1, 2)])


def format_rows(step, t, poses, matcher_names, status_names, entity=None, entity_names=(),
                row_ends: np.ndarray | None = None) -> str:
    """CSV text of a chunk of poses. Numbers a pose does not have (status ``off``) are left empty.
    ``entity`` (N,) codes into ``entity_names``: the ``entity`` column after ``step``.
    ``row_ends``: an (N,) int64 array that gets each row's end in the text, in characters (entity
    names are any text: UTF-8 in a file)."""
    table = pose_table(step, t, poses, matcher_names, status_names)  # the cells (``io.pose_table``)
    numbers = np.column_stack([table.step.astype(np.float64)] + [table.numbers[c] for c in _NUMBERS])
    labels = [*table.labels["region"], *table.labels["matcher"], *table.labels["status"]]
    columns = [table.codes["region"], len(table.labels["region"]) + table.codes["matcher"],
               len(table.labels["region"]) + len(table.labels["matcher"]) + table.codes["status"]]
    layout = _LAYOUT
    if entity is not None:
        columns.append(len(labels) + np.asarray(entity, dtype=np.int64))
        labels += list(entity_names)
        layout = np.concatenate([_LAYOUT[:1], [(1, 3)], _LAYOUT[1:]])
    text = table_text(numbers, _DECIMALS, np.column_stack(columns), labels, layout[:, 0], layout[:, 1], row_ends)
    if text is None:  # a number too large for fixed point (far beyond any terrain): printf does it
        text = format_rows_printf(step, t, poses, matcher_names, status_names, entity, entity_names)
        if row_ends is not None:
            row_ends[:] = np.flatnonzero(np.frombuffer(text.encode("utf-32-le"), np.uint32) == 10) + 1
    return text


def format_rows_printf(step, t, poses, matcher_names, status_names, entity=None, entity_names=()) -> str:
    """``format_rows`` by Python's printf-style formatting: the reference the compiled writer is tested against."""
    if entity is not None:  # the entity column after the step: the rest as without it
        plain = format_rows_printf(step, t, poses, matcher_names, status_names).splitlines(keepends=True)
        names = [entity_names[int(c)] for c in np.asarray(entity)]
        return "".join(line.replace(",", f",{name},", 1) for line, name in zip(plain, names))
    deg = np.degrees
    numbers = np.column_stack([t, poses.position, deg(poses.roll), deg(poses.pitch), deg(poses.yaw),
                               poses.quaternion, poses.penetration, poses.gap])
    region = [REGION_NAMES.get(int(r), "unknown") for r in poses.region.tolist()]
    status = [status_names[s] for s in poses.status.tolist()]
    matcher = [NO_MATCHER if s == "off" else matcher_names[m] for m, s in zip(poses.matcher.tolist(), status)]
    finite = np.isfinite(numbers).all(axis=1)
    out = []
    for i, (k, row) in enumerate(zip(np.asarray(step).tolist(), numbers.tolist())):
        if finite[i]:
            out.append(_ROW % (k, *row[:11], region[i], matcher[i], row[11], row[12], status[i]))
        elif np.isfinite(numbers[i, :11]).all():
            out.append(_ROW_NO_MEASURE % (k, *row[:11], region[i], matcher[i], status[i]))
        else:  # no pose: the row says why (status), its numbers stay empty
            out.append(f"{k},{row[0]:.6f},{row[1]:.4f},{row[2]:.4f},,,,{row[6]:.5f},,,,,{region[i]},{matcher[i]},,,{status[i]}\n")
    return "".join(out)


POSE_REQUIRED = ("x", "y", "z")
POSE_OPTIONAL = ("step", "t", "roll_deg", "pitch_deg", "yaw_deg", "qw", "qx", "qy", "qz", "turret_deg", "gun_deg")


def read_poses(path: str, chunk_rows: int = 65536):
    """Yield (step (N,), t (N,), rotation (N, 3, 3), position (N, 3), valid (N,), turret (N,),
    gun (N,)) chunks of a poses CSV (turret and gun in radians: 0 without ``turret_deg``, ``gun_deg``).

    Needs x, y, z and either roll_deg, pitch_deg, yaw_deg or qw, qx, qy, qz. A row whose
    numbers are empty (a pose ``replay`` could not make: status off) is not valid and is skipped.
    """
    from tankcd_cli.errors import InputError
    from tankcd_cli.io.csv_columns import numeric_chunks
    from tankcd_cli.io.files import open_input
    from tankcd_cli.geometry.pose import rotation_matrix

    name, fh = open_input(path, text=True)
    blank = ("x", "y", "z", "roll_deg", "pitch_deg", "yaw_deg", "qw", "qx", "qy", "qz", "t", "turret_deg", "gun_deg")
    first = 0
    try:
        for rows, wanted, values in numeric_chunks(fh, name, POSE_REQUIRED, POSE_OPTIONAL, chunk_rows, blank,
                                                   hint=_trajectory_hint):
            col = {c: values[:, i] for i, c in enumerate(wanted)}
            n = len(values)
            if all(c in col for c in ("qw", "qx", "qy", "qz")):
                q = np.column_stack([col["qw"], col["qx"], col["qy"], col["qz"]])
                norm = np.linalg.norm(q, axis=1)
                bad = np.flatnonzero(np.isfinite(norm) & (np.abs(norm - 1) > 1e-3))
                if len(bad):
                    raise InputError(name, f"quaternion is not unit (norm {norm[bad[0]]:.6f})", where=f"line {rows[bad[0]]}")
                R = _rotation_from_quaternion(q / np.where(norm > 0, norm, 1)[:, None])
            elif all(c in col for c in ("roll_deg", "pitch_deg", "yaw_deg")):
                R = rotation_matrix(np.radians(col["roll_deg"]), np.radians(col["pitch_deg"]), np.radians(col["yaw_deg"]))
            else:
                raise InputError(name, "needs roll_deg, pitch_deg, yaw_deg or qw, qx, qy, qz columns", where="line 1")
            position = np.column_stack([col["x"], col["y"], col["z"]])
            valid = np.isfinite(position).all(axis=1) & np.isfinite(R.reshape(n, 9)).all(axis=1)
            step = col["step"].astype(np.int64) if "step" in col else np.arange(first, first + n)
            t = col.get("t", np.full(n, np.nan))
            first += n
            turret = np.radians(np.nan_to_num(col.get("turret_deg", np.zeros(n))))
            gun = np.radians(np.nan_to_num(col.get("gun_deg", np.zeros(n))))
            yield step, t, R, position, valid, turret, gun
    except UnicodeDecodeError:
        raise InputError(name, "not UTF-8 text (poses are a CSV file)") from None
    finally:
        if path != "-":
            fh.close()


def _rotation_from_quaternion(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], axis=1)


def _trajectory_hint(header: list, missing: list) -> str:
    """A trajectory (no heights yet) given where poses are expected: say what makes poses of it."""
    if "z" in missing and {"x", "y", "yaw_deg"} <= set(header):
        return "this looks like a trajectory: `tankcd replay` turns it into poses (with z) that collide reads"
    return ""


def pose_columns(step, t, poses, entity_names=None) -> dict:
    """The poses CSV's columns of a chunk as plain arrays (N,) each, keyed by ``COLUMNS``: the pose
    table's cells (``io.pose_table``) at full precision (NaN where the CSV leaves a cell empty: no
    pose, or not measured), and region, matcher and status as their names (str arrays). ``poses``
    None gives empty columns. ``entity_names`` (N,) str: an ``entity`` column after ``step``."""
    if poses is None:
        empty = {c: np.zeros(0) for c in COLUMNS}
        empty["step"] = np.zeros(0, dtype=np.int64)
        for c in ("region", "matcher", "status"):
            empty[c] = np.zeros(0, dtype=str)
        return empty
    table = pose_table(step, t, poses, PLACED_BY, STATUS)
    out = {c: table.step if c == "step" else table.named(c) if c in table.codes else table.numbers[c]
           for c in COLUMNS}
    if entity_names is not None:
        out = {"step": out.pop("step"), "entity": np.asarray(entity_names, dtype=str), **out}
    return out
