"""Matplotlib rendering of a search episode (after Fig. 2 of Hoffmann, Waslander & Tomlin 2006).

One frame shows, over the search domain box:

* the particles of one agent's belief, darker for heavier weights (grey level
  ``0.9 * (1 - w_k / max_k w_k)``); when the target state has an orientation coordinate (the
  beacon's ``psi``) each particle is a short line through its position along that orientation,
  as in the paper's Fig. 2, otherwise a dot;
* every vehicle's trail in its own colour (waypoints joined by a thin line), its current
  position and an arrow along its heading (airplanes) or velocity (quadrotors);
* the belief's MMSE estimate (black X) and the true target position (red square);
* a legend (below the axes) with an entry for every kind of mark drawn, axis labels, and a
  title with the step and the belief's posterior mass within the localisation radius of its
  estimate;
* once the belief has collapsed (90 % of its weight inside a box smaller than an eighth of the
  domain), an inset that zooms on it, with the estimate, the truth, the localisation radius
  (dashed circle) and a scale bar, in the corner of the axes that hides the fewest trail
  points, vehicles and markers; the legend then gains entries for the circle and the bar.

Every drawn artist carries a ``gid``: a phrase of the legend entry that explains it (``"frame"``
for the domain box), which ``tests/test_rendering.py`` uses to check that the legend names every
kind of mark. The axes always contain the domain box, every vehicle and every trail. The
figure and its artists are created once and updated in place between frames. ``rgb_array``
frames are drawn with the Agg canvas (no display, no global backend change), redrawing only the
artists that change over the kept pixels of the rest (the same pixels as drawing the whole
figure); ``human`` frames use pyplot's interactive figure. Matplotlib is imported only here,
and this module is imported only when an environment renders.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.targets import TargetSpace

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

FloatArray = NDArray[np.float64]

#: Fraction of the belief's weight that must fit in the zoom box for the inset to appear.
COLLAPSED_MASS = 0.9
#: Largest side of that box, as a fraction of the domain's largest side.
COLLAPSED_EXTENT = 1.0 / 8.0
#: Corners the zoom inset may take, as (x, y, width, height) in axes fractions, preferred first.
INSET_CORNERS = (
    (0.64, 0.6, 0.34, 0.34),
    (0.02, 0.6, 0.34, 0.34),
    (0.64, 0.02, 0.34, 0.34),
    (0.02, 0.02, 0.34, 0.34),
)
#: Lengths a scale bar may have (distance units).
SCALE_LENGTHS = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
#: Legend labels, and the phrase of each that tags (``gid``) the artists it explains.
PARTICLES_LABEL = "particles (darker = heavier)"
RADIUS_LABEL = "zoom: localisation radius around the estimate"
SCALE_LABEL = "zoom: scale bar (length beside it)"


def particle_colours(weights: FloatArray) -> FloatArray:
    """Opaque grey RGBA colours of particles, darker for heavier weights.

    Args:
        weights: ``(N,)`` particle weights (non-negative).

    Returns:
        ``(N, 4)`` colours of grey level ``0.9 * (1 - w_k / max_k w_k)``: black for the
        heaviest particle, light grey (0.9) for a weightless one; all 0.9 when every weight is 0.
    """
    w_max = float(np.max(weights)) if weights.size else 1.0
    grey = 0.9 * (1.0 - weights / (w_max if w_max > 0 else 1.0))
    return np.stack([grey, grey, grey, np.ones_like(grey)], axis=-1)


def frame_title(prefix: str, step: int, mass: float | None, radius: float | None) -> str:
    """The title of a frame: the step and, when known, the belief's posterior mass.

    Args:
        prefix: Title prefix (``""``: none).
        step: Step counter.
        mass: Posterior mass within ``radius`` of the estimate (``None``: not shown).
        radius: The localisation radius (``None``: not named).

    Returns:
        ``"<prefix>  t = <step>"`` (or ``"t = <step>"``), followed by a line with the mass.
    """
    title = f"{prefix}  t = {step}" if prefix else f"t = {step}"
    if mass is not None:
        within = "" if radius is None else f" within {radius:g}"
        title += f"\nposterior mass{within} of the estimate: {mass:.2f}"
    return title


def _new_figure(human: bool, size_inches: float, dpi: int) -> Figure:
    """A square figure: pyplot's interactive one (``human``) or an off-screen Agg one."""
    if human:
        import matplotlib.pyplot as plt

        plt.ion()
        return plt.figure(figsize=(size_inches, size_inches), dpi=dpi)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(size_inches, size_inches), dpi=dpi)
    FigureCanvasAgg(figure)
    return figure


def _palette(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


class SearchRenderer:
    """Draws search frames into one reused matplotlib figure.

    Args:
        space: The target space (its position box is the drawn domain; its first periodic
            coordinate after the position, if any, orients the particle lines).
        human: Show the figure in a window (pyplot) instead of drawing off-screen.
        title: Figure title prefix.
        size_inches: Figure width and height in inches.
        dpi: Dots per inch (frame size is ``size_inches * dpi`` pixels).
        fps: Frames per second of the ``human`` window.

    Attributes:
        figure: The matplotlib figure (reused between frames). Off-screen, its changing
            artists are marked animated (drawn by each frame over the kept pixels):
            ``figure.savefig`` draws them, a bare ``figure.canvas.draw()`` leaves them out.
        axes: Its main axes (domain box, particles, trails, markers).
        legend: The legend (created with the first vehicles drawn).
        trail_lines: One line per vehicle, in that vehicle's colour.
        arrows: The quiver of heading arrows (one per vehicle).
        title_artist: The title text (step and posterior mass).
        inset: The zoom axes on a collapsed belief (``None`` until the belief first collapses;
            hidden while it is spread).
    """

    def __init__(
        self,
        space: TargetSpace,
        *,
        human: bool = False,
        title: str = "",
        size_inches: float = 6.0,
        dpi: int = 100,
        fps: float = 4.0,
    ) -> None:
        self.space = space
        self.human = human
        self.title = title
        self.fps = fps
        low = np.asarray(space.low, dtype=np.float64)
        high = np.asarray(space.high, dtype=np.float64)
        self._low, self._high = low[:2], high[:2]
        angle_dims = [k for k in range(2, space.dim) if space.periodic[k]]
        self._angle_dim: int | None = angle_dims[0] if angle_dims else None
        self._scale = float(np.max(self._high - self._low))
        self.figure = _new_figure(human, size_inches, dpi)
        self.axes = self._add_axes()
        self._particles = self._particle_artist(self.axes, self._scale * 0.02)
        self.trail_lines: list[Any] = []
        self._colours: list[Any] = []
        self._heads: Any = None
        self.arrows: Any = None
        (self._estimate,) = self.axes.plot([], [], **_estimate_style(12))
        (self._target,) = self.axes.plot([], [], **_target_style(9))
        self.title_artist = self.axes.set_title(title)
        self.legend: Any = None
        self.inset: Any = None
        self._corner = INSET_CORNERS[0]
        self._scale_bar: Any = None
        self._legend_version = 0  # counts the legends drawn (a new one changes the background)
        self._background: Any = None  # the Agg pixels of the artists that stay between frames
        self._background_key: tuple[Any, ...] | None = None
        self._fit_axes(np.empty((0, 2)))

    # -- artists
    def _add_axes(self) -> Axes:
        """The main axes (equal aspect, labelled, room below for the legend), with the domain
        box drawn."""
        from matplotlib.patches import Rectangle

        ax = self.figure.add_subplot(1, 1, 1)
        self.figure.subplots_adjust(left=0.1, right=0.97, top=0.9, bottom=0.22)
        ax.set_aspect("equal")
        ax.set_xlabel("x (units)")
        ax.set_ylabel("y (units)")
        ax.add_patch(
            Rectangle(
                tuple(self._low),
                *(self._high - self._low),
                fill=False,
                edgecolor="black",
                linewidth=1.0,
                gid="frame",
            )
        )
        return ax

    def _particle_artist(self, ax: Any, half_length: float) -> Any:
        from matplotlib.collections import LineCollection

        if self._angle_dim is not None:
            artist = LineCollection([], linewidths=0.8, zorder=2, gid="particles")
            artist.half_length = half_length  # type: ignore[attr-defined]
            ax.add_collection(artist)
            return artist
        return ax.scatter([], [], s=4, marker="o", linewidths=0, zorder=2, gid="particles")

    def _set_particles(
        self, artist: Any, positions: FloatArray, angles: FloatArray | None, colours: FloatArray
    ) -> None:
        if angles is not None:
            half = artist.half_length * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
            artist.set_segments(np.stack([positions - half, positions + half], axis=1))
            artist.set_color(colours)
        else:
            artist.set_offsets(positions)
            artist.set_facecolor(colours)

    def _vehicle_artists(self, n_agents: int) -> None:
        if len(self.trail_lines) == n_agents:
            return
        colours = _palette(n_agents)
        for a in range(len(self.trail_lines), n_agents):
            (line,) = self.axes.plot(
                [], [], ".-", color=colours[a], markersize=3, linewidth=0.8, zorder=3
            )
            line.set_gid("vehicle")
            self.trail_lines.append(line)
        self._heads = self.axes.scatter(
            np.zeros(n_agents), np.zeros(n_agents), s=40, c=colours, zorder=4, gid="vehicle"
        )
        self.arrows = self.axes.quiver(
            np.zeros(n_agents),
            np.zeros(n_agents),
            np.zeros(n_agents),
            np.zeros(n_agents),
            color=colours,
            angles="xy",
            scale_units="xy",
            scale=1.0,
            width=0.006,
            zorder=5,
            gid="vehicle",
        )
        self._colours = colours
        self._draw_legend()

    def _draw_legend(self) -> None:
        """The legend below the axes: particles, estimate, truth, the vehicles and, once the
        zoom inset exists, its radius circle and scale bar."""
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        colours = self._colours

        particle = Line2D(
            [],
            [],
            color="0.35",
            marker="|" if self._angle_dim is not None else "o",
            markersize=6,
            linestyle="none",
        )
        handles: list[Any] = [
            particle,
            Line2D([], [], **_estimate_style(8)),
            Line2D([], [], **_target_style(8)),
        ]
        labels = [PARTICLES_LABEL, "MMSE estimate", "true target"]
        if len(colours) <= 4:
            for a, colour in enumerate(colours):
                handles.append(Line2D([], [], color=colour, marker="o", markersize=5))
                labels.append(f"vehicle {a} (trail, heading)")
        else:
            handles.append(Line2D([], [], color=colours[0], marker="o", markersize=5))
            labels.append(f"{len(colours)} vehicles (trail, heading; one colour each)")
        if self.inset is not None:
            handles.append(Patch(facecolor="none", edgecolor="0.2", linestyle="--"))
            labels.append(RADIUS_LABEL)
            handles.append(Line2D([], [], color="black", linewidth=2.5))
            labels.append(SCALE_LABEL)
        if self.legend is not None:
            self.legend.remove()
        self._legend_version += 1
        # below the axes, so that it never hides particles or vehicles
        self.legend = self.axes.legend(
            handles,
            labels,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.09),
            ncol=2,
            fontsize=7,
            frameon=False,
        )

    def _fit_axes(self, points: FloatArray) -> None:
        """Limits that contain the domain box and every point, with a margin."""
        low = np.minimum(self._low, points.min(axis=0)) if points.size else self._low.copy()
        high = np.maximum(self._high, points.max(axis=0)) if points.size else self._high.copy()
        margin = 0.05 * float(np.max(high - low))
        self.axes.set_xlim(low[0] - margin, high[0] + margin)
        self.axes.set_ylim(low[1] - margin, high[1] + margin)

    # -- frame
    def draw(
        self,
        *,
        particles: FloatArray,
        weights: FloatArray,
        estimate: FloatArray,
        target: FloatArray,
        trails: FloatArray | None,
        step: int,
        headings: FloatArray | None = None,
        mass: float | None = None,
        radius: float | None = None,
    ) -> NDArray[np.uint8] | None:
        """Update the artists and draw one frame.

        Args:
            particles: ``(N, d)`` particles of the belief to show.
            weights: ``(N,)`` their normalised weights.
            estimate: ``(d,)`` MMSE estimate of that belief.
            target: ``(d,)`` true target state.
            trails: ``(T, A, 2)`` vehicle positions so far (``None``: no trails).
            step: Step counter shown in the title.
            headings: ``(A, 2)`` unit heading (or velocity) vectors of the vehicles, zero rows
                for a vehicle at rest (``None``: no arrows).
            mass: Posterior mass within ``radius`` of the estimate (shown in the title).
            radius: The localisation radius (drawn in the inset).

        Returns:
            ``(H, W, 3)`` uint8 RGB frame off-screen; ``None`` in ``human`` mode.
        """
        colours = particle_colours(weights)
        order = np.argsort(weights, kind="stable")  # heaviest drawn last (on top)
        angles = None if self._angle_dim is None else particles[order, self._angle_dim]
        self._set_particles(self._particles, particles[order, :2], angles, colours[order])
        points = [particles[:, :2], np.asarray(target[:2])[None, :]]
        points += self._update_vehicles(trails, headings)
        self._fit_axes(np.concatenate(points))
        self._estimate.set_data([estimate[0]], [estimate[1]])
        self._target.set_data([target[0]], [target[1]])
        self._marks = np.concatenate(points[1:] + [np.asarray(estimate[:2])[None, :]])
        self.title_artist.set_text(frame_title(self.title, step, mass, radius))
        self._update_inset(particles, weights, estimate, target, radius, colours, order)
        return self._show_frame()

    def _update_vehicles(
        self, trails: FloatArray | None, headings: FloatArray | None
    ) -> list[FloatArray]:
        """Move the trails, the vehicles and their heading arrows (see :meth:`draw`); returns
        the points they cover, trail points and arrow tips (none without trails)."""
        if trails is None or not trails.size:
            return []
        n_agents = trails.shape[1]
        self._vehicle_artists(n_agents)
        for a, line in enumerate(self.trail_lines[:n_agents]):
            line.set_data(trails[:, a, 0], trails[:, a, 1])
        self._heads.set_offsets(trails[-1])
        arrows = np.zeros((n_agents, 2)) if headings is None else np.asarray(headings)
        self.arrows.set_offsets(trails[-1])
        self.arrows.set_UVC(*(0.05 * self._scale * arrows).T)
        return [trails.reshape(-1, 2), trails[-1] + 0.05 * self._scale * arrows]

    def _show_frame(self) -> NDArray[np.uint8] | None:
        """Draw the figure: in its window (``human``; returns ``None``) or off-screen, returning
        the ``(H, W, 3)`` uint8 RGB pixels.

        Off-screen, the artists that stay between frames (axes, ticks, labels, domain box,
        legend) are drawn once and their pixels kept until the axes limits or the legend
        change; each frame restores them and draws the changing artists on top (matplotlib's
        blitting), in the order a full draw takes (z-order, then the axes' child order). No
        changing artist reaches the spines (the limits keep a margin around everything drawn),
        so the frames equal full draws.
        """
        if self.human:
            import matplotlib.pyplot as plt

            self.figure.canvas.draw_idle()
            plt.pause(1.0 / self.fps)
            return None
        canvas = self.figure.canvas
        changing = self._changing_artists()
        for artist in changing:
            artist.set_animated(True)  # left out of canvas.draw(), drawn below
        key = (self.axes.get_xlim(), self.axes.get_ylim(), self._legend_version)
        if key != self._background_key:
            canvas.draw()
            self._background = canvas.copy_from_bbox(self.figure.bbox)  # type: ignore[attr-defined]
            self._background_key = key
        else:
            canvas.restore_region(self._background)  # type: ignore[attr-defined]
        for artist in changing:
            self.axes.draw_artist(artist)
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()  # type: ignore[attr-defined]

    def _changing_artists(self) -> list[Any]:
        """The artists updated between frames (particles, trails, vehicles, arrows, estimate,
        truth, title, zoom inset), sorted as :meth:`Axes.draw` sorts the axes' children."""
        changing = [self._particles, *self.trail_lines, self._heads, self.arrows]
        changing += [self._estimate, self._target, self.title_artist, self.inset]
        ids = {id(artist) for artist in changing if artist is not None}
        children = [child for child in self.axes.get_children() if id(child) in ids]
        return sorted(children, key=lambda artist: artist.get_zorder())

    def _update_inset(
        self,
        particles: FloatArray,
        weights: FloatArray,
        estimate: FloatArray,
        target: FloatArray,
        radius: float | None,
        colours: FloatArray,
        order: NDArray[np.intp],
    ) -> None:
        """Show (or hide) the zoom on a collapsed belief."""
        half = _collapsed_half_width(particles[:, :2], weights, np.asarray(estimate[:2]))
        collapsed = half is not None and 2.0 * half < COLLAPSED_EXTENT * self._scale
        if not collapsed:
            if self.inset is not None:
                self.inset.set_visible(False)
            return
        assert half is not None
        corner = self._free_corner(np.asarray(estimate[:2]), half)
        if self.inset is None or corner != self._corner:
            self._create_inset(corner, half)
        self.inset.set_visible(True)
        view = max(1.5 * half, 1.2 * (radius or 0.0))
        centre = np.asarray(estimate[:2])
        self.inset.set_xlim(centre[0] - view, centre[0] + view)
        self.inset.set_ylim(centre[1] - view, centre[1] + view)
        angles = None if self._angle_dim is None else particles[order, self._angle_dim]
        if self._angle_dim is not None:
            self._inset_particles.half_length = 0.15 * view
        self._set_particles(self._inset_particles, particles[order, :2], angles, colours[order])
        self._inset_estimate.set_data([estimate[0]], [estimate[1]])
        self._inset_target.set_data([target[0]], [target[1]])
        self._inset_radius.set_center(tuple(centre))
        self._inset_radius.set_radius(radius if radius else 0.0)
        self._inset_radius.set_visible(bool(radius))
        self._set_scale_bar(view)

    def _create_inset(self, corner: tuple[float, float, float, float], half: float) -> None:
        """The zoom axes at ``corner`` (replacing the one elsewhere) and its artists."""
        from matplotlib import patheffects
        from matplotlib.patches import Circle

        first = self.inset is None
        if not first:
            self.inset.remove()
        self._corner = corner
        self.inset = self.axes.inset_axes(corner)
        self.inset.set_xticks([])
        self.inset.set_yticks([])
        self.inset.set_aspect("equal")
        self.inset.set_title("zoom on the belief", fontsize=7)
        self._inset_particles = self._particle_artist(self.inset, 0.15 * half)
        (self._inset_estimate,) = self.inset.plot([], [], **_estimate_style(9))
        (self._inset_target,) = self.inset.plot([], [], **_target_style(7))
        self._inset_radius = Circle(
            (0.0, 0.0),
            1.0,
            fill=False,
            linestyle="--",
            linewidth=1.2,
            edgecolor="0.2",
            zorder=7,  # above the particles, outlined in white to show on dark ones
            path_effects=[patheffects.withStroke(linewidth=3.0, foreground="white")],
            gid="localisation radius",
        )
        self.inset.add_patch(self._inset_radius)
        self._scale_bar = None
        if first and self._colours:
            self._draw_legend()  # now with the zoom's marks

    def _set_scale_bar(self, view: float) -> None:
        """A bar of a round length (at most 0.8 of the zoom's half width) in its lower left."""
        from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

        fitting = [length for length in SCALE_LENGTHS if length <= 0.8 * view]
        length = fitting[-1] if fitting else SCALE_LENGTHS[0]
        if self._scale_bar is not None:
            if self._scale_bar.length == length:
                return
            self._scale_bar.remove()
        unit = "unit" if length == 1.0 else "units"
        self._scale_bar = AnchoredSizeBar(
            self.inset.transData,
            length,
            f"{length:g} {unit}",
            "lower left",
            pad=0.2,
            borderpad=0.3,
            sep=2,
            frameon=True,
            size_vertical=0.03 * view,
            fontproperties={"size": 7},
        )
        self._scale_bar.patch.set_facecolor("white")  # readable over dark particles
        self._scale_bar.patch.set_alpha(0.85)
        self._scale_bar.patch.set_edgecolor("none")
        self._scale_bar.set_zorder(8)
        self._scale_bar.length = length
        self._scale_bar.set_gid("scale bar")
        self.inset.add_artist(self._scale_bar)

    def _free_corner(self, centre: FloatArray, half: float) -> tuple[float, float, float, float]:
        """The inset corner covering the fewest trail points, vehicles and markers (and not
        the collapsed belief itself); the current one while no other is strictly better."""
        x0, x1 = self.axes.get_xlim()
        y0, y1 = self.axes.get_ylim()
        box = np.array([[-half, -half], [half, half], [-half, half], [half, -half]]) + centre
        marks = np.concatenate([self._marks, box])
        fractions = (marks - [x0, y0]) / [x1 - x0, y1 - y0]

        def covered(corner: tuple[float, float, float, float]) -> int:
            x, y, w, h = corner
            inside = (
                (fractions[:, 0] >= x - 0.02)
                & (fractions[:, 0] <= x + w + 0.02)
                & (fractions[:, 1] >= y - 0.02)
                & (fractions[:, 1] <= y + h + 0.06)  # the inset's title above it
            )
            return int(np.count_nonzero(inside))

        counts = {corner: covered(corner) for corner in INSET_CORNERS}
        best = min(counts.values())
        if counts[self._corner] == best:
            return self._corner
        return next(corner for corner in INSET_CORNERS if counts[corner] == best)

    def close(self) -> None:
        """Close the figure (and its window in ``human`` mode)."""
        if self.human:
            import matplotlib.pyplot as plt

            plt.close(self.figure)
        self.figure = None  # type: ignore[assignment]


def _estimate_style(size: float) -> dict[str, Any]:
    from matplotlib import patheffects

    return {
        "gid": "MMSE estimate",
        "marker": "x",
        "markersize": size,
        "markeredgecolor": "black",
        "markeredgewidth": 2.5,
        "zorder": 6,
        "linestyle": "none",
        "path_effects": [patheffects.withStroke(linewidth=4.5, foreground="white")],
    }


def _target_style(size: float) -> dict[str, Any]:
    return {
        "gid": "true target",
        "marker": "s",
        "markersize": size,
        "markerfacecolor": "none",
        "markeredgecolor": "red",
        "markeredgewidth": 2.0,
        "zorder": 6,
        "linestyle": "none",
    }


def _collapsed_half_width(
    positions: FloatArray, weights: FloatArray, centre: FloatArray
) -> float | None:
    """Half width of the smallest square around ``centre`` holding COLLAPSED_MASS of the
    weight (``None`` without weight)."""
    total = float(np.sum(weights))
    if not positions.size or not total > 0:
        return None
    distance = np.max(np.abs(positions - centre), axis=1)  # Chebyshev distance
    order = np.argsort(distance)
    cumulative = np.cumsum(weights[order]) / total
    index = int(np.searchsorted(cumulative, COLLAPSED_MASS))
    return float(distance[order][min(index, distance.size - 1)])
