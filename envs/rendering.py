"""Matplotlib rendering of a search episode (after Fig. 2 of Hoffmann, Waslander & Tomlin 2006).

One frame shows, over the search domain box:

* the particles of one agent's belief, darker for heavier weights (grey level
  ``0.9 * (1 - w_k / max_k w_k)``); when the target state has an orientation coordinate (the
  beacon's ``psi``) each particle is a short line through its position along that orientation,
  as in the paper's Fig. 2, otherwise a dot;
* every vehicle's waypoint history (red dots joined by a thin line, current position larger);
* the belief's MMSE estimate (black X) and the true target position (red square).

The figure and its artists are created once and updated in place between frames.
``rgb_array`` frames are drawn with the Agg canvas (no display, no global backend change);
``human`` frames use pyplot's interactive figure. Matplotlib is imported only here, and this
module is imported only when an environment renders.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.targets import TargetSpace

FloatArray = NDArray[np.float64]


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
    """

    def __init__(
        self,
        space: TargetSpace,
        *,
        human: bool = False,
        title: str = "",
        size_inches: float = 5.0,
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
        self._segment_half_length = 0.02 * float(np.max(self._high - self._low))

        from matplotlib.collections import LineCollection
        from matplotlib.patches import Rectangle

        if human:
            import matplotlib.pyplot as plt

            plt.ion()
            self.figure = plt.figure(figsize=(size_inches, size_inches), dpi=dpi)
        else:
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            self.figure = Figure(figsize=(size_inches, size_inches), dpi=dpi)
            FigureCanvasAgg(self.figure)
        ax = self.figure.add_subplot(1, 1, 1)
        self.axes = ax
        margin = 0.05 * (self._high - self._low)
        ax.set_xlim(self._low[0] - margin[0], self._high[0] + margin[0])
        ax.set_ylim(self._low[1] - margin[1], self._high[1] + margin[1])
        ax.set_aspect("equal")
        ax.add_patch(
            Rectangle(
                tuple(self._low),
                *(self._high - self._low),
                fill=False,
                edgecolor="black",
                linewidth=1.0,
            )
        )
        if self._angle_dim is not None:
            self._particles: Any = LineCollection([], linewidths=0.8)
            ax.add_collection(self._particles)
        else:
            self._particles = ax.scatter([], [], s=4, marker="o", linewidths=0)
        self._trail_lines: list[Any] = []
        self._heads = ax.scatter([], [], s=30, c="red", zorder=4)
        (self._estimate,) = ax.plot([], [], "kx", markersize=12, markeredgewidth=2.5, zorder=5)
        (self._target,) = ax.plot(
            [],
            [],
            "s",
            markersize=9,
            markerfacecolor="none",
            markeredgecolor="red",
            markeredgewidth=2.0,
            zorder=5,
        )
        self._title = ax.set_title(title)

    def draw(
        self,
        *,
        particles: FloatArray,
        weights: FloatArray,
        estimate: FloatArray,
        target: FloatArray,
        trails: FloatArray | None,
        step: int,
    ) -> NDArray[np.uint8] | None:
        """Update the artists and draw one frame.

        Args:
            particles: ``(N, d)`` particles of the belief to show.
            weights: ``(N,)`` their normalised weights.
            estimate: ``(d,)`` MMSE estimate of that belief.
            target: ``(d,)`` true target state.
            trails: ``(T, A, 2)`` vehicle positions so far (``None``: no trails).
            step: Step counter shown in the title.

        Returns:
            ``(H, W, 3)`` uint8 RGB frame off-screen; ``None`` in ``human`` mode.
        """
        w_max = float(np.max(weights)) if weights.size else 1.0
        grey = 0.9 * (1.0 - weights / (w_max if w_max > 0 else 1.0))
        colours = np.stack([grey, grey, grey, np.ones_like(grey)], axis=-1)
        order = np.argsort(weights, kind="stable")  # heaviest drawn last (on top)
        positions = particles[order, :2]
        if self._angle_dim is not None:
            angle = particles[order, self._angle_dim]
            half = self._segment_half_length * np.stack([np.cos(angle), np.sin(angle)], axis=-1)
            self._particles.set_segments(np.stack([positions - half, positions + half], axis=1))
            self._particles.set_color(colours[order])
        else:
            self._particles.set_offsets(positions)
            self._particles.set_facecolor(colours[order])

        if trails is not None and trails.size:
            n_agents = trails.shape[1]
            while len(self._trail_lines) < n_agents:
                (line,) = self.axes.plot(
                    [], [], ".-", color="red", markersize=3, linewidth=0.6, zorder=3
                )
                self._trail_lines.append(line)
            for a, line in enumerate(self._trail_lines[:n_agents]):
                line.set_data(trails[:, a, 0], trails[:, a, 1])
            self._heads.set_offsets(trails[-1])
        self._estimate.set_data([estimate[0]], [estimate[1]])
        self._target.set_data([target[0]], [target[1]])
        self._title.set_text(f"{self.title}  t = {step}" if self.title else f"t = {step}")

        if self.human:
            import matplotlib.pyplot as plt

            self.figure.canvas.draw_idle()
            plt.pause(1.0 / self.fps)
            return None
        canvas = self.figure.canvas
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()  # type: ignore[attr-defined]

    def close(self) -> None:
        """Close the figure (and its window in ``human`` mode)."""
        if self.human:
            import matplotlib.pyplot as plt

            plt.close(self.figure)
        self.figure = None  # type: ignore[assignment]
