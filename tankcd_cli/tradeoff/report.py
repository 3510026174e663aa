"""Run every stage on one scene and write tradeoff.md, tradeoff.csv and tradeoff.png."""

from __future__ import annotations

import csv
import datetime
import io
import os
import tempfile
from typing import Callable

import numpy as np

from tankcd_cli.tradeoff.measure import CONTACT_KINDS, rate_stage
from tankcd_cli.tradeoff.stages import (
    FULL,
    QUICK,
    Results,
    collision_stage,
    curvature_stage,
    headline_stage,
    internal_stage,
    matching_stage,
)
from tankcd_cli.tradeoff.timing import cost_text, machine, ratio_text, spread_flag

STAGES = ("curvature", "matching", "collision", "internal")


def run_tradeoff(out_dir: str, scene_path: str | None = None, trajectory: str | None = None, quick: bool = False,
                 progress: Callable[[str], None] | None = None, command: str = "tankcd tradeoff") -> Results:
    """Measure every stage on the scene (default: the sample battlefield) and write the report into out_dir."""
    from tankcd_cli.collision.obstacles import placed_triangles
    from tankcd_cli.scene import load_scene
    from tankcd_cli.terrain import synthetic
    from tankcd_cli.terrain.open import open_terrain

    say = progress or (lambda s: None)
    budget = QUICK if quick else FULL
    res = Results()
    res.machine = machine()
    with tempfile.TemporaryDirectory(prefix="tankcd-tradeoff-") as tmp:
        if scene_path is None:
            from tankcd_cli.sample import write_sample

            say("writing the sample battlefield")
            write_sample(tmp)
            scene_path = os.path.join(tmp, "scene.toml")
            if trajectory is None:
                trajectory = os.path.join(tmp, "patrol.csv")
            scene_name = "sample battlefield"
        else:
            scene_name = os.path.basename(scene_path)
        scene = load_scene(scene_path)
        scene.required_terrain()
        vehicle = scene.vehicle
        say(f"terrain: {scene.terrain_path}")
        surface = open_terrain(scene.terrain_path, up=scene.terrain_up, vehicle=vehicle).surface
        obstacle_tris = [placed_triangles(spec)[0] for spec in scene.obstacles]
        columns = None
        if trajectory is not None:
            columns = _trajectory_columns(trajectory)
            x, y, yaw = columns["x"], columns["y"], np.radians(columns["yaw_deg"])
            traj_name = os.path.basename(trajectory)
        else:
            x, y, yaw = _lawnmower(surface, vehicle)
            traj_name = "a lawnmower drive over the terrain"
        res.inputs = {"scene": scene_name, "terrain": os.path.basename(scene.terrain_path), "vehicle": vehicle.name,
                      "obstacles": [spec.name for spec in scene.obstacles], "trajectory": traj_name,
                      "mode": "quick" if quick else "full", "repeats": budget.repeats, "pairs": budget.pair_repeats,
                      "command": command,
                      "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
        course = synthetic.surface_of(synthetic.dem_terrain(synthetic.obstacle_course(0.5), name="obstacle course",
                                                            spacing=0.5), vehicle)
        headline_stage(res, surface, vehicle, x, y, yaw, budget, say, traj_name)
        curvature_stage(res, vehicle, budget, say)
        matching_stage(res, [(scene_name, surface), ("obstacle course (crests, ditch, step, craters)", course)],
                               vehicle, budget, say)
        collision_stage(res, surface, vehicle, obstacle_tris, budget, say)
        internal_stage(res, vehicle, budget, say)
        if columns is None or columns["entities"] > 1 or columns["pieces"] > 1:
            res.inputs["rate_skipped"] = ("the lawnmower drive has no times" if columns is None else
                                          "the trajectory names several vehicles" if columns["entities"] > 1 else
                                          "the trajectory's motion comes in several pieces")
        else:
            from tankcd_cli.replay.world import WorldSpec

            from tankcd_cli.tradeoff.gates import gates_stage

            say("rate: loading the world")
            world = WorldSpec(scene=scene_path).load()
            rate_stage(res, world, columns, budget, say, traj_name)
            gates_stage(res, world, trajectory, columns, tmp, budget, say, traj_name)
        if quick:
            res.inputs["corpus_skipped"] = True  # its 45 s would be most of a quick run; its own test holds it
        else:
            from tankcd_cli.tradeoff.corpus import measure_corpus

            say("corpus: which key-point matcher each region class gets")
            res.corpus = measure_corpus(vehicle)
    write_report(res, out_dir)
    return res


def _trajectory_columns(path: str) -> dict:
    """The trajectory's t, x, y, yaw_deg, turret_deg, gun_deg (N,) and how many vehicles it names."""
    from tankcd_cli.io.trajectory import read_trajectory

    chunks = list(read_trajectory(path))
    if not chunks:
        from tankcd_cli.errors import InputError

        raise InputError(path, "has no rows: the headline needs a trajectory to replay")
    cat = lambda name: np.concatenate([getattr(c, name) for c in chunks])  # noqa: E731
    cols = {name: cat(name) for name in ("t", "x", "y", "yaw_deg", "turret_deg", "gun_deg")}
    cols["has_turret"] = any(c.has_turret for c in chunks)
    cols["entities"] = len(np.unique(cat("entity"))) if chunks[0].entity is not None else 1
    starts = cat("piece_start") if chunks[0].piece_start is not None else np.zeros(1, dtype=bool)
    cols["pieces"] = max(int(np.count_nonzero(starts[1:])) + 1, 1)
    return cols


def _lawnmower(surface, vehicle, lanes: int = 6, step: float = 0.5):
    """Back-and-forth lanes across the terrain, ``step`` m apart along each lane."""
    lo, hi = surface.bounds()
    lo, hi = lo + vehicle.hull_length, hi - vehicle.hull_length
    xs, ys, yaws = [], [], []
    for k, lane_y in enumerate(np.linspace(lo[1], hi[1], lanes)):
        x = np.arange(lo[0], hi[0], step)
        if k % 2:
            x = x[::-1]
        xs.append(x)
        ys.append(np.full(len(x), lane_y))
        yaws.append(np.full(len(x), np.pi if k % 2 else 0.0))
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(yaws)


# --- writing ------------------------------------------------------------------------------

CSV_COLUMNS = ("stage", "case", "variant", "measure", "value", "unit", "spread_lo", "spread_hi", "truth")


def write_report(res: Results, out_dir: str) -> None:
    """tradeoff.csv, tradeoff.md and tradeoff.png into out_dir, each written atomically."""
    from tankcd_cli.io.atomic import atomic_path

    os.makedirs(out_dir, exist_ok=True)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in res.records:
        w.writerow([r.stage, r.case, r.variant, r.measure, _num(r.value), r.unit, _num(r.spread_lo), _num(r.spread_hi),
                    r.truth])
    with atomic_path(os.path.join(out_dir, "tradeoff.csv"), ".csv") as tmp:
        with open(tmp, "w") as fh:
            fh.write(buf.getvalue())
    with atomic_path(os.path.join(out_dir, "tradeoff.png"), ".png") as tmp:
        plot(res, tmp)
    with atomic_path(os.path.join(out_dir, "tradeoff.md"), ".md") as tmp:
        with open(tmp, "w") as fh:
            fh.write(markdown(res))


def _num(v: float) -> str:
    return "" if v is None or not np.isfinite(v) else f"{v:.6g}"


def fmt_value(value: float, unit: str) -> str:
    if not np.isfinite(value):
        return "-"
    if unit == "s":
        if value < 1e-3:
            return f"{value * 1e6:.3g} us"
        return f"{value * 1e3:.3g} ms" if value < 1 else f"{value:.3g} s"
    if unit == "1":
        return f"{value:.3g}"
    return f"{value:.3g} {unit}"


def headline_table(res: Results) -> str:
    h = res.headline
    if not h:
        return ""
    lines = [f"Headline: `auto` (the key-point matcher its rule gives each region class), plain (`--no-escalate`) and "
             f"escalated (replay's default), against always `reference`, "
             f"replaying {h['trajectory']} ({h['poses']:,} poses, penetration and gap measured as replay does).", "",
             "| | auto, plain | auto, escalated | reference |", "| --- | --- | --- | --- |",
             f"| time (median, min-max) | {fmt_value(h['auto_seconds'], 's')} ({fmt_value(h['auto_spread'][0], 's')}"
             f"-{fmt_value(h['auto_spread'][1], 's')}) | {fmt_value(h['escalated_seconds'], 's')} "
             f"({fmt_value(h['escalated_spread'][0], 's')}-{fmt_value(h['escalated_spread'][1], 's')}) | "
             f"{fmt_value(h['reference_seconds'], 's')} "
             f"({fmt_value(h['reference_spread'][0], 's')}-{fmt_value(h['reference_spread'][1], 's')}) |",
             f"| time per pose | {fmt_value(h['auto_seconds'] / h['poses'], 's')} | "
             f"{fmt_value(h['escalated_seconds'] / h['poses'], 's')} | "
             f"{fmt_value(h['reference_seconds'] / h['poses'], 's')} |",
             f"| attitude error median / p95 / max | {h['attitude_error_median_deg']:.3g} / "
             f"{h['attitude_error_p95_deg']:.3g} / {h['attitude_error_max_deg']:.3g} deg | "
             f"{h['escalated_attitude_error_median_deg']:.3g} / {h['escalated_attitude_error_p95_deg']:.3g} / "
             f"{h['escalated_attitude_error_max_deg']:.3g} deg | 0 (the truth) |",
             f"| height error median / p95 / max | {h['height_error_median_m'] * 1000:.3g} / "
             f"{h['height_error_p95_m'] * 1000:.3g} / {h['height_error_max_m'] * 1000:.3g} mm | "
             f"{h['escalated_height_error_median_m'] * 1000:.3g} / {h['escalated_height_error_p95_m'] * 1000:.3g} / "
             f"{h['escalated_height_error_max_m'] * 1000:.3g} mm | 0 (the truth) |",
             f"| penetration p95 | {h['penetration_p95_auto_m'] * 1000:.3g} mm | "
             f"{h['escalated_penetration_p95_m'] * 1000:.3g} mm | {h['penetration_p95_reference_m'] * 1000:.3g} mm |",
             "",
             f"Escalation re-solved {100 * h['escalated_share']:.1f} % of the poses by the reference (those whose "
             "key-point plane differs from the lowest supporting plane at its tilt, or under the untilted "
             f"patches, by more than {h['escalation_tolerance_m'] * 1000:.1f} mm at a footprint corner, or from the "
             f"first by more than {h['attitude_tolerance_deg']:g} deg of attitude): escalated "
             f"auto takes {cost_text(h['escalation_cost'], *h['escalation_cost_spread'], 'plain auto')}"
             " (it does plain auto's work and more; timed in turn with it, pair by pair).", "",
             f"**plain auto is {ratio_text(h['speedup'], *h['speedup_spread'], 'faster', 'slower', 'reference')} than "
             f"reference, for a median attitude error of {h['attitude_error_median_deg']:.2f} deg and a median height "
             f"error of {h['height_error_median_m'] * 1000:.1f} mm.** Matchers auto chose: "
             + ", ".join(f"{m} {c:,}" for m, c in h["matchers_used"].items()) + "."]
    return "\n".join(lines) + "\n"


def _kind_counts(counts: dict) -> str:
    shown = [f"{kind} {counts[kind]}" for kind in CONTACT_KINDS if counts.get(kind)]
    return ", ".join(shown) if shown else "0"


def ratio_cell(value: float, lo: float, hi: float) -> str:
    """A ratio in a table: the median of the pairs, their range, and why the range cannot support it."""
    flag = spread_flag(lo, hi)
    return f"{value:.2f}x ({lo:.2f}-{hi:.2f}x)" + (f" **{flag}**" if flag else "")


def rate_table(res: Results) -> str:
    """The sampling-rate section: per rate, what the continuous check finds, what the rows alone miss,
    and what each costs."""
    inp = res.inputs
    if not res.rates:
        reason = inp.get("rate_skipped")
        return ("## Sampling rate: what a check at the rows alone misses\n\nSkipped" +
                (f" ({reason})." if reason else ".") + "\n") if reason else ""
    lines = ["## Sampling rate: what a check at the rows alone misses", "",
             f"The motion of {inp.get('trajectory')} logged at each rate (rows every 1 / rate s, each the state "
             "of the motion between the trajectory's own rows there: docs/formats.md, \"Motion between rows\"), "
             "replayed in the scene along the motion (the default) and at the rows alone (`--discrete`). "
             "A contact is a run of rows in contact with one thing (an obstacle, a drum, the ground), or one "
             "that begins between two rows and runs on through the rows after it in contact; the continuous "
             "check at the same rate is the truth. Missed: no row of the contact has its event in the rows-only "
             "replay. Seen late: the contact began between rows and the rows-only replay first reports it at a "
             "later row (the longest delay in brackets). Times: one whole replay in this process (the world "
             "loaded once), each mode once for its events, then the two in turn, each turn replaying again until "
             "0.1 s has passed (the mean replay counts); the ratio is continuous over rows only, pair by pair "
             "(median, lowest-highest).", "",
             "| rate | rows | contacts (continuous) | missed by the rows alone | seen late (longest delay) | "
             "continuous | rows only | continuous / rows only |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in res.rates:
        c, d = r.continuous, r.discrete
        late = sum(r.late.values())
        lines.append(f"| {r.hz:g} Hz | {r.rows:,} | {_kind_counts(r.contacts)} | {_kind_counts(r.missed)} | "
                     f"{late}" + (f" ({r.lag_max:.2f} s)" if late else "") + f" | {fmt_value(c[0], 's')} "
                     f"({fmt_value(c[1], 's')}-{fmt_value(c[2], 's')}) | {fmt_value(d[0], 's')} "
                     f"({fmt_value(d[1], 's')}-{fmt_value(d[2], 's')}) | "
                     f"{ratio_cell(r.ratio, r.ratio_lo, r.ratio_hi)} |")
    worst = max(res.rates, key=lambda r: (sum(r.missed.values()), -r.hz))
    clean = [r.hz for r in res.rates if not sum(r.missed.values())]
    lines += ["", f"At {worst.hz:g} Hz the rows alone miss {sum(worst.missed.values())} of "
              f"{sum(worst.contacts.values())} contacts" + (f"; from {min(clean):g} Hz on, none." if clean else "; "
                                                              "at every rate some.")]
    return "\n".join(lines) + "\n"


def gates_table(res: Results) -> str:
    """The gates' section: per replay, each gate's share of its work proven to need no exact work, the
    time with and without the gates, and whether the outputs are the same."""
    if not res.gates:
        return ""
    lines = ["## What the gates skip", "",
             "Each gate (docs/formats.md, \"Gates\") proves, from bounds alone, that some exact work can "
             "find nothing, and skips only that work: the poses and events must be the same bytes with the gates "
             "off (`--no-gates`), the truth here. The trajectory alone, and a column of vehicles driving it one "
             "after another (the checks between vehicles and their gate); each replayed once a mode for its "
             "outputs, then the two in turn (the ratio is gates on over off, pair by pair: median, "
             "lowest-highest). Shares: of the work items each gate was asked about (certificate: key-point "
             "poses; vehicle_pairs: pairs of vehicles in a window; drum_window: the gun at a row and along an "
             "interval), those it proved need no exact work.", "",
             "| replay | rows | vehicles | skipped by gate | gates on | gates off | on / off | outputs |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in res.gates:
        shares = ", ".join(f"{g} {v['share_skipped']:.1%} of {v['checked']:,}" for g, v in r.tally.items()) or "none ran"
        lines.append(f"| {r.case} | {r.rows:,} | {r.vehicles} | {shares} | {fmt_value(r.on[0], 's')} "
                     f"({fmt_value(r.on[1], 's')}-{fmt_value(r.on[2], 's')}) | {fmt_value(r.off[0], 's')} "
                     f"({fmt_value(r.off[1], 's')}-{fmt_value(r.off[2], 's')}) | "
                     f"{ratio_cell(r.ratio, r.ratio_lo, r.ratio_hi)} | {'the same' if r.identical else '**differ**'} |")
    return "\n".join(lines) + "\n"


def markdown(res: Results) -> str:
    m, inp = res.machine, res.inputs
    out = ["# What accuracy costs in time", "",
           f"{inp.get('date', '')}, `{inp.get('command', '')}` ({inp.get('mode')} mode: times are medians of "
           f"{inp.get('repeats')} runs after a warm-up, min-max in brackets; every ratio is the median of "
           f"{inp.get('pairs')} pairs run in turn (each turn at least 0.1 s of calls), their range beside it, and said "
           "where that range cannot "
           "support it: it holds 1.0x, or spans more than a factor of 1.5).", "",
           f"Machine: {m.get('cpu')}, {m.get('cores')} cores ({m.get('threads')} kernel threads), {m.get('os')}. "
           f"Versions: tankcd {m.get('tankcd')}, Python {m.get('python')}, numpy {m.get('numpy')}, "
           f"scipy {m.get('scipy')}, python-fcl {m.get('python-fcl')}, coal {m.get('coal')}.", "",
           f"Inputs: scene {inp.get('scene')} (terrain {inp.get('terrain')}, vehicle {inp.get('vehicle')}, obstacles "
           f"{', '.join(inp.get('obstacles') or []) or 'none'}), trajectory {inp.get('trajectory')}; generated "
           "analytic surfaces and an obstacle course.", "", headline_table(res),
           "![error versus time](tradeoff.png)", "", rate_table(res), gates_table(res)]
    if inp.get("corpus_skipped"):
        out += ["## Which matcher each region class gets", "",
                "Not measured in quick mode (the corpus alone takes most of a minute): run without `--quick`, or "
                "`python -m tankcd_cli.tradeoff.corpus` for the table alone.", ""]
    if res.corpus:
        from tankcd_cli.tradeoff.corpus import corpus_table

        out += ["## Which matcher each region class gets", "",
                "The rule `auto` ships (`AUTO_RULE`) is this table's: per class, the key-point matcher with the "
                "lowest median attitude error against the reference (within 1 %, the one fewest poses fail the "
                "certificate with). Regenerate it alone "
                "with `python -m tankcd_cli.tradeoff.corpus`.", "", corpus_table(res.corpus)]
    notes = {
        "curvature": "Error against the closed-form H (interior: more than 3 m from the border); class_changed_share "
                     "is the share of vertices whose region class differs from the class the exact H gives.",
        "matching": "Against the reference on the same poses, per region class; penetration and gap are each "
                    "variant's own (ground above its plane under the tracks, its plane above the ground at the six "
                    "key points). "
                    "Jitter: attitude change from one step to the next along a straight drive (no truth needed: "
                    "a large maximum is a jump). Time per pose without penetration and gap (replay adds about the "
                    "same footprint pass to every variant).",
        "collision": "Every layout finds exactly the brute-force contacts (disagreement 0); they differ in work: "
                     "node-pair and leaf (triangle-pair) tests, and the share of triangle tests whose volumes "
                     "overlapped "
                     "but whose triangles do not touch. Peers are queried pose by pose from Python.",
        "internal": "The paper's two-plane projection against the exact cylinder test over a grid of turret "
                    "azimuths and gun elevations: the projection may raise false alarms, and must never miss.",
    }
    for stage in STAGES:
        recs = [r for r in res.records if r.stage == stage]
        if not recs:
            out += [f"## {stage}", "", "Skipped (the scene does not call for it).", ""]
            continue
        out += [f"## {stage}", "", notes[stage], "", f"Truth: {recs[0].truth}.", ""]
        cases = list(dict.fromkeys(r.case for r in recs))
        for case in cases:
            rows = [r for r in recs if r.case == case]
            measures = list(dict.fromkeys(r.measure for r in rows))
            variants = list(dict.fromkeys(r.variant for r in rows))
            out += [f"**{case}**", "", "| variant | " + " | ".join(measures) + " |",
                    "| --- |" + " --- |" * len(measures)]
            for v in variants:
                cells = []
                for ms in measures:
                    hit = [r for r in rows if r.variant == v and r.measure == ms]
                    if not hit:
                        cells.append("")
                        continue
                    r = hit[0]
                    text = fmt_value(r.value, r.unit)
                    if np.isfinite(r.spread_lo):
                        text += f" ({fmt_value(r.spread_lo, r.unit)}-{fmt_value(r.spread_hi, r.unit)})"
                    cells.append(text)
                out.append(f"| {v} | " + " | ".join(cells) + " |")
            out.append("")
    return "\n".join(out)


def pareto(points: list) -> list:
    """The points no other point beats on both time and error, fastest first."""
    front, best = [], np.inf
    for p in sorted(points, key=lambda p: (p.seconds, p.error)):
        if p.error < best:
            front.append(p)
            best = p.error
    return front


SHORT = {"AABB only": "AABB", "k-DOP 14 only": "k14", "k-DOP 18 only": "k18", "k-DOP 26 only": "k26",
         "hybrid 1 AABB level": "hyb1", "hybrid 2 AABB levels": "hyb2", "hybrid 3 AABB levels": "hyb3",
         "hybrid 4 AABB levels": "hyb4"}


def plot(res: Results, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    stages = [s for s in STAGES if any(p.stage == s for p in res.points)]
    panels = len(stages) + bool(res.rates)
    fig, axes = plt.subplots(1, max(panels, 1), figsize=(4.6 * max(panels, 1), 4.4), squeeze=False)
    if res.rates:
        _rate_panel(axes[0][-1], res.rates)
    for ax, stage in zip(axes[0], stages):
        pts = [p for p in res.points if p.stage == stage]
        positive = [p.error for p in pts if p.error > 0]
        floor = (min(positive) / 10) if positive else 1e-6
        shown = [max(p.error, floor) for p in pts]
        front = pareto(pts)
        fx = [p.seconds for p in front]
        fy = [max(p.error, floor) for p in front]
        ax.step(fx, fy, where="post", color="0.6", lw=1, zorder=1, label="Pareto front")
        for k, (p, y) in enumerate(zip(pts, shown)):
            on_front = p in front
            marker = "D" if p.error <= 0 else "o"
            ax.errorbar(p.seconds, y, xerr=[[p.seconds - p.seconds_lo], [p.seconds_hi - p.seconds]], fmt=marker,
                        color="C3" if on_front else "C0", ms=6, capsize=2, zorder=2)
            label = SHORT.get(p.variant, p.variant) + (" (truth)" if p.is_truth else (" (0)" if p.error <= 0 else ""))
            # alternate the labels above and below: variants of equal cost sit on top of each other
            ax.annotate(label, (p.seconds, y), textcoords="offset points", xytext=(5, 4 if k % 2 == 0 else -10),
                        fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):  # label the decades only: minor labels collide on short ranges
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        query, err = res.axes.get(stage, ("query", "error"))
        ax.set_xlabel(f"seconds per {query} (median, min-max)")
        ax.set_ylabel(err, fontsize=8)
        ax.set_title(stage)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7, loc="best")
    fig.suptitle("What accuracy costs in time (red: on the Pareto front; zero error drawn at the floor)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _rate_panel(ax, rates: list) -> None:
    """Contacts found and missed against the sampling rate; the continuous check's cost on a second axis."""
    hz = [r.hz for r in rates]
    found = [sum(r.contacts.values()) for r in rates]
    missed = [sum(r.missed.values()) for r in rates]
    ax.plot(hz, found, "o-", color="C0", label="contacts (continuous)")
    ax.plot(hz, missed, "s-", color="C3", label="missed by the rows alone")
    ax.set_xscale("log")
    ax.set_xticks(hz)
    ax.set_xticklabels([f"{h:g}" for h in hz])
    ax.minorticks_off()
    ax.set_xlabel("sampling rate, Hz")
    ax.set_ylabel("contacts", fontsize=8)
    ax.set_ylim(bottom=0)
    ax.set_title("sampling rate")
    ax.grid(True, alpha=0.25)
    cost = ax.twinx()
    ratio = np.array([r.ratio for r in rates])
    lo = np.array([r.ratio_lo for r in rates])
    hi = np.array([r.ratio_hi for r in rates])
    cost.errorbar(hz, ratio, yerr=[ratio - lo, hi - ratio], fmt="D", color="0.4", ms=4, capsize=2,
                  label="time, continuous / rows only (pairs' range)")
    cost.axhline(1.0, color="0.7", lw=0.8, ls=":")
    cost.set_ylabel("continuous / rows-only time", fontsize=8)
    cost.set_ylim(bottom=0)
    handles = ax.get_legend_handles_labels()
    more = cost.get_legend_handles_labels()
    ax.legend(handles[0] + more[0], handles[1] + more[1], fontsize=7, loc="center right")
