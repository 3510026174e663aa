"""Pictures a person would rather look at than read."""

from __future__ import annotations

import numpy as np

from tankcd_cli.names import CLASS_NAMES


def class_map_png(store, path: str) -> None:
    """Class map (left) and signed mean curvature (right) of a terrain store, as a PNG."""
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.tri import Triangulation

    v, f = store.vertices, store.faces
    origin = v[:, :2].min(axis=0)
    tri = Triangulation(v[:, 0] - origin[0], v[:, 1] - origin[1], f)
    fig = _figure(13, 5.6)
    axes = fig.subplots(1, 2)
    fig.subplots_adjust(left=0.05, right=0.92, bottom=0.1, top=0.9, wspace=0.32)
    cmap = ListedColormap(["#9ccc65", "#ffca28", "#e53935"])
    face_class = store.vertex_class[f].max(axis=1)
    pc = axes[0].tripcolor(tri, facecolors=face_class, cmap=cmap, norm=BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3))
    cb = fig.colorbar(pc, cax=_colourbar_axes(axes[0]), ticks=[0, 1, 2])
    cb.ax.set_yticklabels(list(CLASS_NAMES))
    a = store.attrs
    axes[0].set_title(f"region classes ({a.get('vehicle')} footprint; |H| < {a.get('threshold_flat'):.4f} flat, "
                      f">= {a.get('threshold_uneven'):.4f} uneven)", fontsize=9)
    H = store.mean_curvature
    lim = float(np.nanpercentile(np.abs(H), 99)) or 1e-6
    pc2 = axes[1].tripcolor(tri, H, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="gouraud")
    fig.colorbar(pc2, cax=_colourbar_axes(axes[1]), label="mean curvature H, 1/m (ridges +, valleys -)")
    axes[1].set_title(f"signed mean curvature ({a.get('curvature_method')})", fontsize=9)
    for ax in axes:
        ax.set_aspect("equal")
        _relative_axes(ax, origin)
    fig.suptitle(f"{a.get('source')}", fontsize=10)
    fig.savefig(path, dpi=110, format="png")


def envelope_png(vehicle, env, path: str) -> None:
    """Polar plot: turret azimuth around (forward up, counter-clockwise as the turret turns),
    radius the lowest safe elevation; the gun's own limit dashed, the drums' bite shaded."""
    az = np.radians(env["azimuth"])
    lim = env["min_elevation"]
    lo, hi = vehicle.gun_min_deg, vehicle.gun_max_deg
    fig = _figure(6.4, 6.4)
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(1)
    order = np.argsort(az)
    a, e = np.append(az[order], az[order][0] + 2 * np.pi), np.append(lim[order], lim[order][0])
    if vehicle.fuel_drums:
        ax.fill_between(a, lo, np.where(np.isfinite(e), e, hi), color="#e53935", alpha=0.35,
                        label="barrel meets a drum")
    ax.plot(a, np.where(np.isfinite(e), e, np.nan), color="#b71c1c", lw=2, label="lowest safe elevation")
    ax.plot(np.linspace(0, 2 * np.pi, 361), np.full(361, lo), "k--", lw=1, label=f"gun limit {lo:g} deg")
    ax.set_ylim(lo - 1, max(1.0, np.nanmax(np.where(np.isfinite(lim), lim, lo)) + 2))
    ax.set_rlabel_position(90)
    ax.set_xticks(np.radians([0, 90, 180, 270]))
    ax.set_xticklabels(["front", "left", "rear", "right"])
    drums = "" if vehicle.fuel_drums else " (no fuel drums: the gun's own limit)"
    ax.set_title(f"{vehicle.name}: gun depression limit by turret azimuth (deg){drums}", fontsize=10)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.12), fontsize=8)
    fig.savefig(path, dpi=110, format="png")


def replay_map_png(store, path_xy, marks, path: str, footprints=(), matcher=None, counts=None, kinds=()) -> None:
    """The replayed path over the class map, obstacles' footprints, and events marked by kind.

    store : a MeshStore (the mesh layout), or the path of a grid store (drawn from its overview)
    path_xy : (N, 2) world x, y of the path; marks : [(kind, x, y)] events
    footprints : [(name, (k, 2) outline)] obstacles seen from above
    matcher : (N,) matcher codes to colour the path by (None: one colour)
    counts : events per kind for the legend (default: the marks counted)
    kinds : the kinds of event to mark, in the legend's order, each with ``name``, ``marker`` (None: not
        drawn), ``colour`` and ``label`` (replay.effects.EVENT_KIND_TABLE; the drawing sits below replay)
    """
    from matplotlib.colors import BoundaryNorm, ListedColormap

    fig = _figure(10, 7)
    ax = fig.subplots()
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.09, top=0.95)
    cmap = ListedColormap(["#dcedc8", "#fff3c4", "#ffcdd2"])
    norm = BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3)
    if isinstance(store, str):
        from tankcd_cli.terrain.grid.store import read_overview

        ov = read_overview(store)
        origin, extent = _overview_extent(ov)
        ax.imshow(np.ma.masked_equal(ov["classes"], 255), cmap=cmap, norm=norm, interpolation="nearest",
                  extent=extent)
    elif store is not None:
        from matplotlib.tri import Triangulation

        v, f = store.vertices, store.faces
        origin = v[:, :2].min(axis=0)
        tri = Triangulation(v[:, 0] - origin[0], v[:, 1] - origin[1], f)
        ax.tripcolor(tri, facecolors=store.vertex_class[f].max(axis=1), cmap=cmap, norm=norm)
    else:
        origin = np.nanmin(path_xy, axis=0) if len(path_xy) else np.zeros(2)
    origin = np.asarray(origin, dtype=float)
    px, py = path_xy[:, 0] - origin[0], path_xy[:, 1] - origin[1]
    if matcher is None:
        ax.plot(px, py, color="#1565c0", lw=1.5, label="path")
    else:
        from tankcd_cli.matching.match import PLACED_BY

        colours = ["#2e7d32", "#f9a825", "#c62828", "#1565c0", "#00838f", "#6d4c41", "#6a1b9a"]
        for code, name in enumerate(PLACED_BY):
            sel = matcher == code
            if sel.any():
                ax.scatter(px[sel], py[sel], s=3, color=colours[code % len(colours)], label=f"{name} ({sel.sum():,})",
                           zorder=2, linewidths=0)
    for i, (name, outline) in enumerate(footprints):
        if len(outline) >= 3:
            ax.fill(outline[:, 0] - origin[0], outline[:, 1] - origin[1], facecolor="#616161", alpha=0.45,
                    edgecolor="#212121", lw=1.0, label="obstacles" if i == 0 else None, zorder=2)
        ax.annotate(name, (float(np.mean(outline[:, 0]) - origin[0]), float(np.mean(outline[:, 1]) - origin[1])),
                    fontsize=7, ha="center", va="center", zorder=4)
    style = {k.name: (k.marker, k.colour, k.label) for k in kinds if k.marker is not None}
    for kind, (marker, colour, label) in style.items():
        pts = np.array([(x, y) for k, x, y in marks if k == kind])
        if len(pts):
            n = (counts or {}).get(kind, len(pts))
            ax.scatter(pts[:, 0] - origin[0], pts[:, 1] - origin[1], marker=marker, s=36, color=colour,
                       label=f"{label} ({n:,})", zorder=3)
    ax.set_aspect("equal")
    _relative_axes(ax, origin)
    ax.set_title("replay over the region classes (green flat, yellow general, red uneven)", fontsize=10)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    fig.savefig(path, dpi=110, format="png")


def _figure(width: float, height: float):
    """A figure (inches) drawn by Agg, without pyplot: its import and its figure manager cost a
    small job a fifth of a second, and a batch tool shows no windows. Laid out by fixed margins,
    not constrained layout (a quarter of a second more, to place a handful of axes)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    return fig


def _colourbar_axes(ax):
    """A colour bar's axes beside ``ax``, as tall as its drawn box (which an equal aspect shrinks)."""
    return ax.inset_axes([1.03, 0.0, 0.035, 1.0])


def _metres(value: float) -> str:
    return f"{value:,.3f}".rstrip("0").rstrip(".")


def _relative_axes(ax, origin) -> None:
    """Axis labels in metres east and north of ``origin``, which is stated once."""
    ax.set_xlabel(f"east of the origin, m   (origin: x = {_metres(origin[0])} m, y = {_metres(origin[1])} m)")
    ax.set_ylabel("north of the origin, m")


def _overview_extent(ov: dict):
    """The south-west post (world x, y) and the imshow extent, in metres from it, of an overview."""
    g = ov["grid"]
    top = (g.rows - 1) * g.dy
    origin = np.array([g.origin_x, g.origin_y - top])
    dx, dy = g.dx * ov["step"], g.dy * ov["step"]
    h, w = ov["classes"].shape
    return origin, (-dx / 2, (w - 0.5) * dx, top - (h - 0.5) * dy, top + dy / 2)


def grid_map_png(store_path: str, path: str, title: str | None = None) -> None:
    """Class map and footprint-averaged |H| of a grid store, from its overview rasters (a DEM
    of any size draws in the same time and memory)."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from tankcd_cli.terrain.grid.store import read_overview

    ov = read_overview(store_path)
    a = ov["attrs"]
    origin, extent = _overview_extent(ov)
    fig = _figure(13, 5.6)
    axes = fig.subplots(1, 2)
    fig.subplots_adjust(left=0.05, right=0.92, bottom=0.1, top=0.9, wspace=0.32)
    cls = np.ma.masked_equal(ov["classes"], 255)
    cmap = ListedColormap(["#9ccc65", "#ffca28", "#e53935"])
    im = axes[0].imshow(cls, cmap=cmap, norm=BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3), extent=extent,
                        interpolation="nearest")
    cb = fig.colorbar(im, cax=_colourbar_axes(axes[0]), ticks=[0, 1, 2])
    cb.ax.set_yticklabels(list(CLASS_NAMES))
    step = f", worst of {ov['step']} x {ov['step']} posts" if ov["step"] > 1 else ""
    axes[0].set_title(f"region classes ({a.get('vehicle')} footprint{step})", fontsize=9)
    curv = ov["curvature"]
    lim = float(np.nanpercentile(curv, 99)) if np.isfinite(curv).any() else 1e-6
    im2 = axes[1].imshow(curv, cmap="magma", vmin=0, vmax=lim or 1e-6, extent=extent, interpolation="nearest")
    fig.colorbar(im2, cax=_colourbar_axes(axes[1]), label="footprint-averaged |H|, 1/m")
    axes[1].set_title(f"curvature ({a.get('curvature_method')}); thresholds {a.get('threshold_flat'):.4f}, "
                      f"{a.get('threshold_uneven'):.4f}", fontsize=9)
    for ax in axes:
        _relative_axes(ax, origin)
    fig.suptitle(title or str(a.get("source")), fontsize=10)
    fig.savefig(path, dpi=110, format="png")
