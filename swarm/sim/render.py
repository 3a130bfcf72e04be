"""Pictures of a running mission: one RGB frame per call for `SwarmEnv.render()`, and animations
(GIF or MP4) of a whole `simulate` run.

```python
env = swarm.sim.parallel_env(mission="missions/landing.yaml", render_mode="rgb_array")
env.reset(seed=0)
frame = env.render()                       # (H, W, 3) uint8, W = FRAME_WIDTH_PX

with Animator("landing.gif") as anim:      # frames every K steps, written atomically at the end
    log = simulate(mission, seed=0, on_step=anim.on_step)
```

Speed: the map (terrain, contours, regions, true mine positions, relay nodes, the legend) is drawn
once into an Agg canvas and kept as a bitmap; each frame restores that bitmap and draws only what
moves (tracks, radio links, robots, losses, mine states, the header) with `draw_artist` (blitting).

Colours are the project's (`swarm.palette`, shared with the reports): terrain as on every map,
robots by role as in the plan report, losses by cause as `CAUSE_COLOURS`, all colour-blind safe
(Okabe-Ito).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.transforms import Bbox

from swarm.errors import InputError, SwarmError
from swarm.palette import REGION_STYLES, ROLE_COLOURS, terrain_colours

#: Every frame is this wide (pixels); its height follows the map's aspect ratio (even, for video).
FRAME_WIDTH_PX = 960
#: A tall map is drawn at most this high (pixels) and narrower than the frame.
MAX_MAP_HEIGHT_PX = 720
DPI = 100
#: Pixels around the map: left (y tick labels), right, top (two header lines), bottom (x tick
#: labels and axis label, then two legend rows).
MARGIN_PX = {"left": 46, "right": 10, "top": 40, "bottom": 78}
#: The bottom strip (pixels) that holds the loss legend.
FOOTER_PX = 25
#: Loss causes (`swarm.sim.hazards.CAUSES`) by colour: Okabe-Ito and Paul Tol's colour-blind-safe
#: sets, each chosen to stand out where that loss happens (orange wave impacts on the blue surf,
#: yellow sea timeouts on deep water, dark immobilized and blast marks on pale sand); every 'x'
#: also has a white halo.
CAUSE_COLOURS = {
    "failure": "#000000",
    "wave_impact": "#E69F00",
    "immobilized": "#332288",
    "rock": "#777777",
    "mine": "#D55E00",
    "battery": "#CC79A7",
    "cut_off": "#44AA99",
    "sea_timeout": "#F0E442",
    "surf_timeout": "#009E73",
    "blast": "#882255",
}
#: Causes the palette does not know (a policy's own), in order of first appearance.
CAUSE_FALLBACK = ("#56B4E9", "#999933", "#AA4499", "#CC6677")
#: End states that are not losses.
NOT_LOST = ("recovered", "expended", "time_limit")
#: Mine marks: truth faint, detected filled, marked ringed, set off / cleared as stars.
MINE_COLOUR = "#000000"
EXPLODED_FACE = "#F0E442"
#: The relay's fixed source and sinks (as `swarm.palette.REGION_STYLES` draws them).
RELAY_NODE_COLOUR = "#56B4E9"
#: Robot markers (points^2) and line widths (points).
ROBOT_SIZE = 30.0
TRACK_WIDTH = 0.6
LINK_WIDTH = 0.5
#: Above this many working links a frame draws a readable subset (`sparse_links`): a dense swarm
#: can have thousands, and drawing them all costs ~20 ms per thousand.
MAX_LINKS_DRAWN = 1500
LINKS_PER_NODE = 2
#: Animation defaults: frames per second, frames a full-length mission aims at, and the cap.
ANIMATION_FPS = 12
TARGET_FRAMES = 360
MAX_FRAMES = 600
#: A frame covers at least this much mission time (s): 60 times real time at 12 fps.
MIN_FRAME_INTERVAL_S = 5.0
ANIMATION_SUFFIXES = (".gif", ".mp4")


def cause_colour(cause: str, seen: dict[str, str] | None = None) -> str:
    """The colour of a loss cause; unknown causes take fallback colours in order (via `seen`)."""
    if cause in CAUSE_COLOURS:
        return CAUSE_COLOURS[cause]
    seen = {} if seen is None else seen
    if cause not in seen:
        seen[cause] = CAUSE_FALLBACK[len(seen) % len(CAUSE_FALLBACK)]
    return seen[cause]


def frame_layout(width_m: float, height_m: float) -> tuple[int, int, tuple[float, float, float, float]]:
    """(width px, height px, axes rect in figure fractions) for a map of this extent: the frame is
    `FRAME_WIDTH_PX` wide and its height even, the map keeps its aspect ratio."""
    m = MARGIN_PX
    avail_w = FRAME_WIDTH_PX - m["left"] - m["right"]
    map_w = float(avail_w)
    map_h = map_w * height_m / width_m
    if map_h > MAX_MAP_HEIGHT_PX:
        map_h = float(MAX_MAP_HEIGHT_PX)
        map_w = map_h * width_m / height_m
    height = math.ceil(m["top"] + map_h + m["bottom"])
    height += height % 2
    left = m["left"] + (avail_w - map_w) / 2.0
    bottom = height - m["top"] - map_h
    rect = (left / FRAME_WIDTH_PX, bottom / height, map_w / FRAME_WIDTH_PX, map_h / height)
    return FRAME_WIDTH_PX, height, rect


def sparse_links(a: np.ndarray, b: np.ndarray, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A readable subset of many links (a[k]-b[k] between `nodes`): the shortest-link spanning
    forest, which keeps exactly the same connected components, plus every node's
    `LINKS_PER_NODE` shortest links. Drawing thousands of long lines is both slow and unreadable."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import minimum_spanning_tree

    big_n = len(nodes)
    d = np.hypot(*(nodes[a] - nodes[b]).T) + 1e-9  # an explicit zero would be no edge
    forest = minimum_spanning_tree(coo_matrix((d, (a, b)), shape=(big_n, big_n))).tocoo()
    ends = np.concatenate([a, b])
    dist = np.concatenate([d, d])
    edge = np.concatenate([np.arange(len(a))] * 2)
    order = np.lexsort((dist, ends))  # by node, then shortest first
    first = np.searchsorted(ends[order], ends[order], side="left")
    nearest = edge[order][np.arange(len(order)) - first < LINKS_PER_NODE]
    lo = np.concatenate([np.minimum(forest.row, forest.col), a[nearest]])
    hi = np.concatenate([np.maximum(forest.row, forest.col), b[nearest]])
    key = np.unique(lo.astype(np.int64) * big_n + hi)
    return key // big_n, key % big_n


def _clock(t_s: float) -> str:
    t = round(t_s)
    return f"{t // 3600:d}:{t // 60 % 60:02d}:{t % 60:02d}"


def _interactive_backend() -> bool:
    """Is matplotlib's current backend one that opens windows?"""
    import matplotlib

    backend = matplotlib.get_backend().lower()
    try:
        from matplotlib.backends import BackendFilter, backend_registry

        names = backend_registry.list_builtin(BackendFilter.INTERACTIVE)
    except ImportError:  # matplotlib < 3.9
        from matplotlib import rcsetup

        names = rcsetup.interactive_bk
    return backend in {n.lower() for n in names}


def draw_map(ax: Any, beach: Any) -> None:
    """The map under a frame: terrain in the project's colours, elevation contours every metre
    above the sea, region outlines by kind (the reports' `plot_map` without labels or legend)."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    classes = beach.terrain_classes
    x0, y0, x1, y1 = beach.bounds_m
    ax.imshow(
        beach.terrain,
        origin="lower",
        extent=(x0, x1, y0, y1),
        cmap=ListedColormap(terrain_colours(classes)),
        norm=BoundaryNorm(np.arange(-0.5, len(classes) + 0.5), len(classes)),
        interpolation="nearest",
        zorder=1,
    )
    top = float(np.nanmax(beach.elevation_m))
    if top >= 1.0:
        rows, cols = beach.shape
        xs = x0 + (np.arange(cols) + 0.5) * beach.cell_m
        ys = y0 + (np.arange(rows) + 0.5) * beach.cell_m
        levels = np.arange(1.0, top + 1e-9, max(1.0, math.ceil(top / 8)))
        ax.contour(xs, ys, beach.elevation_m, levels=levels, colors="#00000055", linewidths=0.4, zorder=2)
    for region in beach.regions.values():
        colour, style, marker = REGION_STYLES.get(region.kind, ("#000000", "-", "o"))
        geom = region.geometry
        if geom.geom_type == "Point":
            ax.plot(geom.x, geom.y, marker, ms=5, color=colour, mec="white", mew=0.6, zorder=4)
            continue
        for part in getattr(geom, "geoms", [geom]):
            ring = np.asarray(part.exterior.coords) if hasattr(part, "exterior") else np.asarray(part.coords)
            ax.plot(ring[:, 0], ring[:, 1], style, color=colour, lw=0.9, zorder=3)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")


class Renderer:
    """Draws a `SwarmEnv`'s current state into a fixed-size RGB frame (module docstring)."""

    def __init__(self, env: Any) -> None:
        import matplotlib

        # the user's backend (human mode only: it may start a GUI toolkit), before
        # swarm.report.style switches pyplot to Agg for files
        human = getattr(env, "render_mode", None) == "human"
        self._user_backend: str | None = matplotlib.get_backend() if human else None
        from swarm.sim.layout import ROLES

        self.env = env
        self.role_colours = np.array([ROLE_COLOURS.get(r, "#777777") for r in ROLES])
        self._extra_causes: dict[str, str] = {}
        self._window: Any = None
        self._window_closed = False
        self._build()

    def _build(self) -> None:
        """A new off-screen figure with the episode's map kept as a bitmap (again after a reset,
        which lays a new mine field)."""
        bm = self.env.beach
        self.width, self.height, rect = frame_layout(bm.width_m, bm.height_m)
        self.fig = Figure(figsize=(self.width / DPI, self.height / DPI), dpi=DPI)
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes(rect)
        self._causes_drawn: tuple[str, ...] = ()
        self.n_links = 0
        self._make_artists()
        self._draw_background()

    # static part --------------------------------------------------------------------------------
    def _draw_background(self) -> None:
        """Map, true mines, relay nodes and the legend, drawn once and kept as a bitmap."""
        env, ax = self.env, self.ax
        draw_map(ax, env.beach)
        ax.set_xlabel("x, east (m)", fontsize=7, labelpad=1)
        ax.set_ylabel("y, north (m)", fontsize=7, labelpad=1)
        ax.tick_params(labelsize=7, length=2, pad=1)
        mines = env.minefield.positions_m
        if len(mines):
            ax.scatter(
                mines[:, 0],
                mines[:, 1],
                s=10,
                facecolors="none",
                edgecolors=MINE_COLOUR,
                linewidths=0.5,
                alpha=0.35,
                zorder=10,
            )
        if env.fixed_m is not None:
            ax.scatter(
                env.fixed_m[:, 0],
                env.fixed_m[:, 1],
                s=40,
                marker="P",
                c=RELAY_NODE_COLOUR,
                edgecolors="black",
                linewidths=0.6,
                zorder=11,
            )
        self._minefield = env.minefield
        self._static_legend()
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        self._with_tracks = self._background  # the map with the tracks (and loss legend) so far
        self._tracks_drawn = 0
        # the bottom strip where the loss legend goes, bare, to wipe an old legend
        self._footer = self.canvas.copy_from_bbox(Bbox.from_extents(0, 0, self.width, FOOTER_PX))

    def _static_legend(self) -> None:
        from swarm.sim.layout import ROLES

        roles = sorted(set(self.env.role.tolist()))
        handles: list[Any] = [
            Line2D([], [], ls="", marker="o", ms=5, color=self.role_colours[r], mec="white", label=ROLES[r])
            for r in roles
        ]
        handles.append(Line2D([], [], ls="", marker="o", ms=5, mfc="white", mec="#555555", label="inverted"))
        handles.append(Line2D([], [], color="#333333", lw=0.6, label="radio link"))
        if self.env.fixed_m is not None:
            handles.append(
                Line2D(
                    [], [], ls="", marker="P", ms=6, color=RELAY_NODE_COLOUR, mec="black", label="relay node"
                )
            )
        if len(self.env.minefield):
            handles += [
                Line2D([], [], ls="", marker="o", ms=4, mfc="none", mec=MINE_COLOUR, alpha=0.4, label="mine"),
                Line2D([], [], ls="", marker="o", ms=4, color=MINE_COLOUR, label="detected"),
                Line2D([], [], ls="", marker="o", ms=8, mfc="none", mec=MINE_COLOUR, label="marked"),
                Line2D([], [], ls="", marker="*", ms=8, mfc=EXPLODED_FACE, mec=MINE_COLOUR, label="set off"),
                Line2D([], [], ls="", marker="*", ms=8, mfc="white", mec=MINE_COLOUR, label="cleared"),
            ]
        y = 20.0 / self.height
        self.fig.legend(
            handles=handles,
            loc="center",
            bbox_to_anchor=(0.5, y + 15.0 / self.height),
            ncol=len(handles),
            fontsize=7,
            frameon=False,
            handletextpad=0.3,
            columnspacing=1.0,
        )

    # moving part --------------------------------------------------------------------------------
    def _make_artists(self) -> None:
        ax = self.ax
        self.tracks = LineCollection(
            [],
            linewidths=TRACK_WIDTH,
            alpha=0.7,
            zorder=12,
            animated=True,
            capstyle="round",
            joinstyle="round",
        )
        self.links = LineCollection(
            [], linewidths=LINK_WIDTH, colors="#333333", alpha=0.45, zorder=13, animated=True
        )
        self.detected = ax.scatter([], [], s=12, c=MINE_COLOUR, zorder=14, animated=True)
        self.false_alarms = ax.scatter(
            [], [], s=16, marker="+", c="#555555", linewidths=0.8, zorder=14, animated=True
        )
        self.marked = ax.scatter(
            [], [], s=60, facecolors="none", edgecolors=MINE_COLOUR, linewidths=0.9, zorder=14, animated=True
        )
        self.exploded = ax.scatter(
            [],
            [],
            s=70,
            marker="*",
            facecolors=EXPLODED_FACE,
            edgecolors=MINE_COLOUR,
            linewidths=0.6,
            zorder=15,
            animated=True,
        )
        self.cleared = ax.scatter(
            [],
            [],
            s=70,
            marker="*",
            facecolors="white",
            edgecolors=MINE_COLOUR,
            linewidths=0.6,
            zorder=15,
            animated=True,
        )
        self.robots = ax.scatter([], [], s=ROBOT_SIZE, linewidths=0.7, zorder=17, animated=True)
        self.lost = ax.scatter([], [], s=30, marker="x", linewidths=1.4, zorder=16, animated=True)
        import matplotlib.patheffects as pe

        self.lost.set_path_effects([pe.withStroke(linewidth=3.0, foreground="white", alpha=0.8)])
        ax.add_collection(self.tracks)
        ax.add_collection(self.links)
        self.header = self.fig.text(
            6.0 / FRAME_WIDTH_PX,
            1.0 - 4.0 / self.height,
            "",
            ha="left",
            va="top",
            fontsize=8,
            linespacing=1.35,
            animated=True,
            family="DejaVu Sans",
        )
        self._moving = [
            self.tracks,
            self.links,
            self.false_alarms,
            self.detected,
            self.marked,
            self.exploded,
            self.cleared,
            self.lost,
            self.robots,
        ]

    def _draw_tracks(self, tracks: list[np.ndarray]) -> None:
        """Tracks only grow, so they are painted into the kept bitmap piece by piece: each frame
        draws only the samples added since the last one (cost independent of the mission's length)."""
        if len(tracks) < self._tracks_drawn:  # a new episode: start from the bare map
            self._tracks_drawn, self._with_tracks = 0, self._background
            self._causes_drawn = ()
        if len(tracks) - max(self._tracks_drawn - 1, 0) < 2:
            return
        xy = np.stack(tracks[max(self._tracks_drawn - 1, 0) :], axis=1)  # (n, new samples, 2)
        keep = np.isfinite(xy[..., 0]).sum(axis=1) >= 2
        self.tracks.set_segments(list(xy[keep]))
        self.tracks.set_color(self.role_colours[self.env.role[keep]])
        self.canvas.restore_region(self._with_tracks)
        self.ax.draw_artist(self.tracks)
        self._with_tracks = self.canvas.copy_from_bbox(self.fig.bbox)
        self._tracks_drawn = len(tracks)

    def _update_links(self) -> None:
        env = self.env
        n = env.n
        nodes = env.robot_state[:, :2]
        if env.fixed_m is not None:
            nodes = np.vstack([nodes, env.fixed_m])
        up = np.ones(len(nodes), bool)
        up[:n] = env.alive & env.on_map
        adj = env.links.adjacency.tocoo()
        keep = (adj.row < adj.col) & up[adj.row] & up[adj.col]
        a, b = adj.row[keep], adj.col[keep]
        self.n_links = len(a)
        if len(a) > MAX_LINKS_DRAWN:
            a, b = sparse_links(a, b, nodes)
        self.links.set_segments(np.stack([nodes[a], nodes[b]], axis=1) if len(a) else [])

    def _update_robots(self) -> None:
        env = self.env
        show = np.flatnonzero(env.alive & env.on_map)
        colours = self.role_colours[env.role[show]]
        faces = np.where(env.inverted[show], "white", colours)
        edges = np.where(env.inverted[show], colours, "white")
        self.robots.set_offsets(env.robot_state[show, :2] if len(show) else np.empty((0, 2)))
        self.robots.set_facecolors(faces)
        self.robots.set_edgecolors(edges)
        self.robots.set_linewidths(np.where(env.inverted[show], 1.6, 0.6))

    def colours(self) -> list[str]:
        """Every colour the moving artists draw in (for a fixed GIF palette)."""
        fixed = ["#000000", "#FFFFFF", "#333333", "#555555", MINE_COLOUR, EXPLODED_FACE]
        return fixed + list(self.role_colours) + list(CAUSE_COLOURS.values()) + list(CAUSE_FALLBACK)

    def lost_count(self) -> int:
        """Robots lost so far (not recovered, expended or stopped by the time limit)."""
        return sum(1 for r in self.env.end_reason if r is not None and r not in NOT_LOST)

    def _lost(self) -> tuple[np.ndarray, list[str]]:
        env = self.env
        idx = [i for i, r in enumerate(env.end_reason) if r is not None and r not in NOT_LOST]
        idx = [i for i in idx if np.isfinite(env.lost_at[i, 1:]).all()]
        return np.array(idx, dtype=np.intp), [env.end_reason[i] for i in idx]

    def _update_lost(self) -> list[str]:
        idx, causes = self._lost()
        self.lost.set_offsets(self.env.lost_at[idx, 1:] if len(idx) else np.empty((0, 2)))
        self.lost.set_color([cause_colour(c, self._extra_causes) for c in causes])
        return sorted(set(causes))

    def _update_mines(self) -> None:
        env = self.env
        mf = env.minefield
        pos = mf.positions_m

        def put(artist, mask):
            artist.set_offsets(pos[mask] if mask.any() else np.empty((0, 2)))

        if len(pos):
            gone = mf.exploded | mf.cleared
            put(self.detected, mf.detected & ~gone)
            put(self.marked, mf.marked & ~gone)
            put(self.exploded, mf.exploded)
            put(self.cleared, mf.cleared & ~mf.exploded)
        false = env.object_mine < 0
        self.false_alarms.set_offsets(env.objects_m[false] if false.any() else np.empty((0, 2)))

    def _update_cause_legend(self, causes: list[str]) -> None:
        """The loss legend ("lost: x cause ...") changes only when a new cause appears: it is painted
        into the kept bitmap then, in the bottom strip that tracks (clipped to the map) never touch."""
        if tuple(causes) == self._causes_drawn:
            return
        self._causes_drawn = tuple(causes)
        self.canvas.restore_region(self._with_tracks)
        self.canvas.restore_region(self._footer)
        if causes:
            handles = [Line2D([], [], ls="", label="lost:")]
            handles += [
                Line2D(
                    [],
                    [],
                    ls="",
                    marker="x",
                    ms=6,
                    mew=1.4,
                    color=cause_colour(c, self._extra_causes),
                    label=c.replace("_", " "),
                )
                for c in causes
            ]
            legend = self.fig.legend(
                handles=handles,
                loc="center",
                bbox_to_anchor=(0.5, 12.0 / self.height),
                ncol=len(handles),
                fontsize=7,
                frameon=False,
                handletextpad=0.3,
                handlelength=1.0,
                columnspacing=1.0,
            )
            legend.set_animated(True)
            self.fig.draw_artist(legend)
            legend.remove()
        self._with_tracks = self.canvas.copy_from_bbox(self.fig.bbox)

    def _header_text(self, lost: int) -> str:
        env = self.env
        ends = env.end_reason
        mission = getattr(env.mission, "name", None) or "mission"
        alive = int(env.alive.sum())
        ashore = int((env.alive & env.on_map).sum())
        recovered = sum(1 for r in ends if r == "recovered")
        expended = sum(1 for r in ends if r == "expended")
        line1 = (
            f"{mission} on {env.beach.name}   seed {env.seed}   t = {_clock(env.t_s)} / "
            f"{_clock(env.time_limit_s)}"
        )
        line2 = f"robots: {alive} alive ({ashore} on the map), {lost} lost"
        if recovered:
            line2 += f", {recovered} recovered"
        if expended:
            line2 += f", {expended} expended"
        mf = env.minefield
        if len(mf):
            line2 += (
                f"   mines: {int(mf.detected.sum())}/{len(mf)} detected, {int(mf.marked.sum())} marked, "
                f"{int(mf.exploded.sum())} set off, {int(mf.cleared.sum())} cleared"
            )
        thinned = "" if self.n_links <= MAX_LINKS_DRAWN else " (thinned)"
        line2 += f"   radio links: {self.n_links}{thinned}"
        relay_up = getattr(env, "relay_up", None)
        if relay_up is not None:
            line2 += f"   relay {'up' if relay_up else 'down'}"
        return f"{line1}\n{line2}"

    def frame(self, tracks: list[np.ndarray] | None = None) -> np.ndarray:
        """The current state as an (H, W, 3) uint8 RGB array; `tracks` (samples of (n, 2) positions,
        NaN off the map) default to `env.tracks`."""
        if self.env.minefield is not self._minefield:  # reset() laid a new mine field
            self._build()
        self._draw_tracks(self.env.tracks if tracks is None else tracks)
        self._update_links()
        self._update_mines()
        causes = self._update_lost()
        self._update_robots()
        self._update_cause_legend(causes)
        self.header.set_text(self._header_text(self.lost_count()))
        self.canvas.restore_region(self._with_tracks)
        for artist in self._moving:
            self.ax.draw_artist(artist)
        self.fig.draw_artist(self.header)
        rgba = np.asarray(self.canvas.buffer_rgba())
        return np.ascontiguousarray(rgba[: self.height, : self.width, :3])

    # human mode ----------------------------------------------------------------------------------
    def show(self, frame: np.ndarray) -> None:
        """Show the frame in a matplotlib window without blocking; nothing without a display
        (a non-interactive backend such as Agg) or once the user has closed the window."""
        import matplotlib.pyplot as plt

        if self._window_closed:
            return
        if self._window is None:
            if self._user_backend is not None and plt.get_backend() != self._user_backend:
                with contextlib.suppress(Exception):  # the display may be gone
                    plt.switch_backend(self._user_backend)
            if not _interactive_backend():
                self._window_closed = True
                return
            fig = plt.figure(figsize=(self.width / DPI, self.height / DPI), dpi=DPI)
            fig.canvas.manager.set_window_title("surf-swarm")
            ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
            ax.set_axis_off()
            self._window = (fig, ax.imshow(frame, interpolation="nearest"))
            plt.show(block=False)
        fig, image = self._window
        if not plt.fignum_exists(fig.number):
            self._window, self._window_closed = None, True
            return
        image.set_data(frame)
        fps = self.env.metadata.get("render_fps", 10)
        plt.pause(1.0 / fps)

    def close(self) -> None:
        """Close the window, if any; the off-screen figure needs no closing (no pyplot)."""
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window[0])
            self._window = None


# --- animation ------------------------------------------------------------------------------------------
def check_animation_path(path: str | Path, will_create: Path | None = None) -> Path:
    """Refuse an animation we could not write, before any simulation runs: the suffix must be
    .gif or .mp4, the folder must exist (or be `will_create`, the output folder the command
    makes), and .mp4 needs ffmpeg."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in ANIMATION_SUFFIXES:
        raise InputError("command line", "--animate", str(path), "a file name ending in .gif or .mp4")
    parent = path.parent if str(path.parent) else Path(".")
    planned = will_create is not None and parent.resolve() == Path(will_create).resolve()
    if not parent.is_dir() and not planned:
        raise InputError(
            "command line", "--animate", str(path), f"a file in an existing folder ({parent} is not one)"
        )
    if path.is_dir():
        raise InputError("command line", "--animate", str(path), "a file name (this is a folder)")
    if suffix == ".mp4" and not _ffmpeg_available():
        raise InputError(
            "command line", "--animate", str(path), "ffmpeg on the PATH for .mp4 (install ffmpeg), or a .gif"
        )
    return path


def _ffmpeg_available() -> bool:
    from matplotlib.animation import FFMpegWriter

    return bool(FFMpegWriter.isAvailable())


def frame_stride(max_steps: int, dt_s: float, target_frames: int = TARGET_FRAMES) -> int:
    """Steps between frames: a full-length run gives about `target_frames` frames, and a frame
    covers at least `MIN_FRAME_INTERVAL_S` of mission (a short mission is not slowed to a crawl)."""
    by_count = math.ceil(max_steps / max(target_frames, 1))
    by_time = math.ceil(MIN_FRAME_INTERVAL_S / dt_s - 1e-9)
    return max(1, by_count, by_time)


class _GifSink:
    """Frames mapped to one 256-colour palette as they come (a third of the memory of RGB, and
    unchanged pixels stay identical from frame to frame, so the GIF compresses well).

    The palette holds every colour the moving artists use (`Renderer.colours`) exactly, and the
    rest of its entries are fitted to the first frame (the map)."""

    def __init__(self, fps: float) -> None:
        self.fps = fps
        self.frames: list[Any] = []
        self.palette: Any = None

    def _make_palette(self, frame: np.ndarray, colours: list[str]) -> Any:
        from matplotlib.colors import to_rgb
        from PIL import Image

        fixed = sorted({tuple(round(255 * c) for c in to_rgb(col)) for col in colours})
        fitted = Image.fromarray(frame, "RGB").quantize(
            256 - len(fixed), method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
        )
        rest = fitted.getpalette()[: 3 * (256 - len(fixed))]
        entries = [v for rgb in fixed for v in rgb] + rest
        palette = Image.new("P", (1, 1))
        palette.putpalette(entries + [0] * (768 - len(entries)))
        return palette

    def add(self, frame: np.ndarray, colours: Sequence[str] = ()) -> None:
        from PIL import Image

        if self.palette is None:
            self.palette = self._make_palette(frame, list(colours))
        img = Image.fromarray(frame, "RGB")
        self.frames.append(img.quantize(palette=self.palette, dither=Image.Dither.NONE))

    def finish(self, tmp: Path) -> None:
        first, *rest = self.frames
        first.save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=rest,
            duration=round(1000.0 / self.fps),
            loop=0,
            optimize=False,
            disposal=1,
        )


class _Mp4Sink:
    """Frames streamed to ffmpeg (matplotlib's FFMpegWriter) as they come: no frames in memory."""

    def __init__(self, fps: float, tmp: Path) -> None:
        self.fps, self.tmp = fps, tmp
        self.writer: Any = None

    def add(self, frame: np.ndarray, colours: Sequence[str] = ()) -> None:
        from matplotlib.animation import FFMpegWriter

        if self.writer is None:
            h, w = frame.shape[:2]
            self.fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
            FigureCanvasAgg(self.fig)
            ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0))
            ax.set_axis_off()
            self.image = ax.imshow(frame, interpolation="nearest")
            self.writer = FFMpegWriter(fps=self.fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
            self.writer.setup(self.fig, str(self.tmp), dpi=DPI)
        self.image.set_data(frame)
        self.writer.grab_frame()

    def finish(self, tmp: Path) -> None:
        if self.writer is not None:
            self.writer.finish()

    def abort(self) -> None:
        if self.writer is not None:
            with contextlib.suppress(Exception):
                self.writer.finish()


class Animator:
    """Collects a frame every K steps of a run (`on_step`) and writes a GIF or MP4 atomically when
    the `with` block ends without an error (on an error nothing is left behind).

    K is chosen from the run's length so a full-length mission gives about `target_frames` frames
    (a 2-hour mission at 0.5 s steps: one frame every 20 s of mission, 30 s of animation at 12 fps),
    and a frame covers at least `MIN_FRAME_INTERVAL_S` of mission; at most `max_frames` are kept.
    The last step is always a frame. Tracks are sampled here every `swarm.sim.env.TRACK_SAMPLE_S`
    when the environment keeps none (no render_mode, as in `simulate`)."""

    def __init__(
        self,
        path: str | Path,
        *,
        fps: float = ANIMATION_FPS,
        target_frames: int = TARGET_FRAMES,
        max_frames: int = MAX_FRAMES,
    ) -> None:
        self.path = check_animation_path(path)
        self.fps = fps
        self.target_frames = target_frames
        self.max_frames = max_frames
        self.frames = 0
        self.stride: int | None = None
        self.renderer: Renderer | None = None
        self._tracks: list[np.ndarray] = []
        self._next_track_s = 0.0
        self._atomic: Any = None
        self._tmp: Path | None = None
        self._sink: Any = None

    def __enter__(self) -> Animator:
        from swarm.files import atomic_path

        self._atomic = atomic_path(self.path)
        self._tmp = self._atomic.__enter__()
        is_gif = self.path.suffix.lower() == ".gif"
        self._sink = _GifSink(self.fps) if is_gif else _Mp4Sink(self.fps, self._tmp)
        return self

    def on_step(self, env: Any) -> None:
        """Call after every env step (`simulate(on_step=...)`)."""
        if self._sink is None:
            raise RuntimeError("Animator.on_step outside its `with` block")
        if self.renderer is None:
            self.renderer = Renderer(env)
            self.stride = frame_stride(env.max_steps, env.config.dt_s, self.target_frames)
        self._sample_tracks(env)
        last = not env.agents
        if self.frames < self.max_frames and (last or env.steps % self.stride == 0):
            frame = self.renderer.frame(env.tracks if env.tracks else self._tracks)
            self._sink.add(frame, self.renderer.colours())
            self.frames += 1

    def _sample_tracks(self, env: Any) -> None:
        from swarm.sim.env import TRACK_SAMPLE_S

        if env.tracks or env.t_s + 1e-9 < self._next_track_s:
            return
        self._next_track_s = env.t_s + TRACK_SAMPLE_S
        on = env.alive & env.on_map
        self._tracks.append(np.where(on[:, None], env.robot_state[:, :2], np.nan).astype(np.float32))

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        atomic, self._atomic = self._atomic, None
        sink, self._sink = self._sink, None
        if kind is None and self.frames == 0:
            err = SwarmError(f"animation {self.path}: no frames (the run took no steps)")
            atomic.__exit__(SwarmError, err, None)
            raise err
        if kind is None:
            try:
                sink.finish(self._tmp)
            except BaseException as err:
                atomic.__exit__(type(err), err, err.__traceback__)
                raise
            atomic.__exit__(None, None, None)
            return
        if isinstance(sink, _Mp4Sink):
            sink.abort()
        atomic.__exit__(kind, exc, tb)
